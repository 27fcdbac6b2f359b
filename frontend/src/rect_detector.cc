#include "fsp/frontend/rect_detector.h"

#include "fsp/frontend/edge_refine.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "fsp/common/error.h"
#include "fsp/frontend/rect_geometry.h"

namespace fsp::frontend {

bool RectDetectorOptions::Check(std::string* why) const {
  std::ostringstream os;
  auto positive = [&](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) os << name << " must be positive (got " << v << "); ";
  };
  positive(canny_noise_multiple, "canny_noise_multiple");
  positive(min_edge_contrast, "min_edge_contrast");
  if (!(canny_low_ratio > 0.0 && canny_low_ratio <= 1.0))
    os << "canny_low_ratio must be in (0, 1]; ";
  positive(min_segment_frac, "min_segment_frac");
  positive(segment_fit_px, "segment_fit_px");
  positive(merge_angle_deg, "merge_angle_deg");
  positive(merge_line_px, "merge_line_px");
  if (merge_gap_frac < 0.0) os << "merge_gap_frac must be >= 0; ";
  positive(min_side_frac, "min_side_frac");
  if (!(min_corner_angle_deg > 0.0 && min_corner_angle_deg < 90.0))
    os << "min_corner_angle_deg must be in (0, 90); ";
  if (junction_gap_frac < 0.0 || junction_overshoot_frac < 0.0 || junction_slack_px < 0.0)
    os << "junction tolerances must be >= 0; ";
  if (max_hypotheses < 1) os << "max_hypotheses must be >= 1; ";
  positive(search_px, "search_px");
  if (!(search_step_px > 0.0 && search_step_px <= search_px))
    os << "search_step_px must be in (0, search_px]; ";
  if (samples_per_side < 4) os << "samples_per_side must be >= 4; ";
  if (!(corner_margin_frac >= 0.0 && corner_margin_frac < 0.4))
    os << "corner_margin_frac must be in [0, 0.4); ";
  positive(ransac_inlier_px, "ransac_inlier_px");
  if (ransac_iterations < 1) os << "ransac_iterations must be >= 1; ";
  if (!(min_side_support >= 0.0 && min_side_support <= 1.0))
    os << "min_side_support must be in [0, 1]; ";
  if (!(max_side_continuation >= 0.0 && max_side_continuation <= 1.0))
    os << "max_side_continuation must be in [0, 1]; ";
  if (!(continuation_start_px >= 0.0)) os << "continuation_start_px must be >= 0; ";
  positive(continuation_frac, "continuation_frac");
  if (!(continuation_step_px >= 0.0)) os << "continuation_step_px must be >= 0; ";
  if (!(max_abs_cos > 0.0 && max_abs_cos <= 1.0)) os << "max_abs_cos must be in (0, 1]; ";
  if (!(max_aspect >= 1.0)) os << "max_aspect must be >= 1; ";
  if (!(assumed_hfov_deg > 1.0 && assumed_hfov_deg < 179.0))
    os << "assumed_hfov_deg must be in (1, 179); ";
  positive(margin_min_contrast, "margin_min_contrast");
  if (!(margin_max_texture >= 0.0)) os << "margin_max_texture must be >= 0; ";
  positive(margin_min_width_px, "margin_min_width_px");
  if (!(max_corner_outside_px >= 0.0)) os << "max_corner_outside_px must be >= 0; ";
  if (!(margin_probe_frac > 0.0 && margin_probe_frac <= 1.0))
    os << "margin_probe_frac must be in (0, 1]; ";
  if (duplicate_corner_frac < 0.0 || nest_corner_frac < 0.0)
    os << "suppression fractions must be >= 0; ";
  if (max_detections < 0) os << "max_detections must be >= 0; ";
  if (why) *why = os.str();
  return os.str().empty();
}

RectDetector::RectDetector(Options options) : options_(std::move(options)) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
}

namespace {

// A segment in undistorted pixels.
struct Seg {
  Vec2 a, b;
  Vec2 dir;  // unit, a → b
  double len = 0.0;
  // A slowly bending edge (curled paper): the polyline a = path[0], ..., path.back() = b through
  // the straight pieces it was built from; empty for a straight segment. Its corners come from the
  // first and last pieces (see CurvedChains).
  std::vector<Vec2> path;
  // Line of the piece at end 0 (a) or 1 (b).
  Vec2 EndDir(int end) const {
    if (path.size() < 2) return dir;
    const Vec2 d = end == 0 ? Vec2(path[1] - path[0]) : Vec2(path.back() - path[path.size() - 2]);
    return d.normalized();
  }
};

Seg MakeSeg(const Vec2& a, const Vec2& b) {
  Seg s;
  s.a = a;
  s.b = b;
  s.len = (b - a).norm();
  s.dir = s.len > 0 ? Vec2((b - a) / s.len) : Vec2(1.0, 0.0);
  return s;
}

// Line n·x = c with unit normal n.
struct Line {
  Vec2 n = Vec2(0.0, 1.0);
  double c = 0.0;
  double Dist(const Vec2& p) const { return n.dot(p) - c; }
};

Line LineOf(const Seg& s) {
  Line l;
  l.n = Vec2(-s.dir.y(), s.dir.x());
  l.c = l.n.dot(s.a);
  return l;
}

// Line of the piece at end 0 (a) or 1 (b) of a segment (its own line when straight).
Line EndLine(const Seg& s, int end) {
  const Vec2 d = s.EndDir(end);
  Line l;
  l.n = Vec2(-d.y(), d.x());
  l.c = l.n.dot(end == 0 ? s.a : s.b);
  return l;
}

bool Intersect(const Line& l1, const Line& l2, Vec2* x) {
  // [n1ᵀ; n2ᵀ] x = [c1; c2]
  const double det = l1.n.x() * l2.n.y() - l1.n.y() * l2.n.x();
  if (std::abs(det) < 1e-9) return false;
  *x = Vec2((l1.c * l2.n.y() - l1.n.y() * l2.c) / det, (l1.n.x() * l2.c - l1.c * l2.n.x()) / det);
  return true;
}

// Unit eigenvector of the larger eigenvalue of a symmetric 2x2 matrix S = [a b; b c] (the major
// axis of a scatter matrix), in closed form: the axis makes the angle θ = atan2(2b, a − c) / 2 with
// x (an iterative eigen solver cost ~2 % of the detector's time).
inline Vec2 MajorAxis(const Mat2& S) {
  const double theta = 0.5 * std::atan2(2.0 * S(0, 1), S(0, 0) - S(1, 1));
  return Vec2(std::cos(theta), std::sin(theta));
}

// Weighted total least squares line: the normal is the eigenvector of the smallest eigenvalue of
// the weighted scatter matrix about the weighted centroid.
bool FitLineTls(const std::vector<Vec2>& pts, const std::vector<double>& w,
                const std::vector<int>& idx, Line* line) {
  if (idx.size() < 2) return false;
  double sw = 0.0;
  Vec2 mu = Vec2::Zero();
  for (int i : idx) {
    sw += w[i];
    mu += w[i] * pts[i];
  }
  if (!(sw > 0.0)) return false;
  mu /= sw;
  Mat2 S = Mat2::Zero();
  for (int i : idx) {
    const Vec2 d = pts[i] - mu;
    S += w[i] * d * d.transpose();
  }
  const Vec2 dir = MajorAxis(S);
  line->n = Vec2(-dir.y(), dir.x());
  line->c = line->n.dot(mu);
  return true;
}

// Bilinear interpolation of an 8-bit image; false outside [0, W-1] x [0, H-1].
inline bool Bilinear(const cv::Mat& img, double x, double y, double* v) {
  if (!(x >= 0.0 && y >= 0.0 && x < img.cols - 1 && y < img.rows - 1)) return false;
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const double fx = x - x0, fy = y - y0;
  const uint8_t* r0 = img.ptr<uint8_t>(y0) + x0;
  const uint8_t* r1 = img.ptr<uint8_t>(y0 + 1) + x0;
  *v = (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
  return true;
}

// Canny thresholds from the gradient statistics. The median Sobel magnitude over (a subsample of)
// the image is dominated by flat regions, where the magnitude of Gaussian noise is
// Rayleigh-distributed: median = 1.177 σ_r. High threshold = max(multiple · σ_r, 4 · min_contrast)
// (Sobel's response to a sharp step of C grey levels is 4C); low = ratio · high.
void CannyThresholds(const cv::Mat& dx, const cv::Mat& dy, const RectDetectorOptions& o,
                     double* low, double* high) {
  constexpr int kBins = 2048;
  std::array<int, kBins> hist{};
  int n = 0;
  // Sobel magnitude (dx, dy: CV_16S, the gradients Canny uses) at every 3rd pixel of every 3rd row
  // (~34k samples at 640x480, plenty for a median).
  for (int y = 1; y < dx.rows - 1; y += 3) {
    const int16_t* gx_row = dx.ptr<int16_t>(y);
    const int16_t* gy_row = dy.ptr<int16_t>(y);
    for (int x = 1; x < dx.cols - 1; x += 3) {
      const int gx = gx_row[x], gy = gy_row[x];
      const double m = std::sqrt(static_cast<double>(gx * gx + gy * gy));
      ++hist[std::min(kBins - 1, static_cast<int>(m))];
      ++n;
    }
  }
  int acc = 0, median = 0;
  for (int b = 0; b < kBins; ++b) {
    acc += hist[b];
    if (2 * acc >= n) {
      median = b;
      break;
    }
  }
  const double sigma_r = (median + 0.5) / 1.177;
  *high = std::max(o.canny_noise_multiple * sigma_r, 4.0 * o.min_edge_contrast);
  *low = o.canny_low_ratio * *high;
}

// Merges collinear pieces (union of compatible pairs, then one TLS line through all endpoints).
std::vector<Seg> MergeCollinear(const std::vector<Seg>& in, double angle_deg, double line_px,
                                double gap_px) {
  const int n = static_cast<int>(in.size());
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  std::vector<double> theta(n);
  for (int i = 0; i < n; ++i)
    theta[i] = std::atan2(in[i].dir.y(), in[i].dir.x()) + M_PI;  // [0, 2π]
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int i, int j) { return theta[i] < theta[j]; });
  const double tol = angle_deg * M_PI / 180.0;
  const double cos_tol = std::cos(tol);
  auto compatible = [&](const Seg& s, const Seg& t) {
    if (s.dir.dot(t.dir) < cos_tol) return false;  // same polarity only (see orientation above)
    const Seg& lng = s.len >= t.len ? s : t;
    const Seg& sht = s.len >= t.len ? t : s;
    const Line l = LineOf(lng);
    if (std::abs(l.Dist(sht.a)) > line_px || std::abs(l.Dist(sht.b)) > line_px) return false;
    // Gap between the two intervals along the long segment's direction.
    const double ta = (sht.a - lng.a).dot(lng.dir), tb = (sht.b - lng.a).dot(lng.dir);
    const double lo = std::min(ta, tb), hi = std::max(ta, tb);
    const double gap = std::max(lo - lng.len, -hi);
    return gap <= gap_px;
  };
  // A smoothly bending edge (bent paper, residual distortion) splits into pieces that are not
  // collinear within line_px but continue each other: the end of one touches the start of the next.
  auto continues = [&](const Seg& s, const Seg& t) {
    if (s.dir.dot(t.dir) < cos_tol) return false;
    return (s.b - t.a).squaredNorm() <= line_px * line_px ||
           (t.b - s.a).squaredNorm() <= line_px * line_px;
  };
  for (int oi = 0; oi < n; ++oi) {
    const int i = order[oi];
    // Neighbours in angle (with wrap-around at π).
    for (int k = 1, ok = oi + 1; k < n; ++k, ++ok) {
      if (ok == n) ok = 0;  // (oi + k) mod n without a division per step
      const int j = order[ok];
      double d = theta[j] - theta[i];
      if (d < 0) d += 2 * M_PI;
      if (d > tol) break;
      if (compatible(in[i], in[j]) || continues(in[i], in[j])) parent[find(i)] = find(j);
    }
  }
  std::vector<std::vector<int>> groups(n);
  for (int i = 0; i < n; ++i) groups[find(i)].push_back(i);
  std::vector<Seg> out;
  for (const auto& g : groups) {
    if (g.empty()) continue;
    if (g.size() == 1) {
      out.push_back(in[g[0]]);
      continue;
    }
    std::vector<Vec2> pts;
    std::vector<double> w;
    std::vector<int> idx;
    for (int i : g) {
      idx.push_back(static_cast<int>(pts.size()));
      pts.push_back(in[i].a);
      idx.push_back(static_cast<int>(pts.size()));
      pts.push_back(in[i].b);
      w.push_back(in[i].len);
      w.push_back(in[i].len);
    }
    Line l;
    if (!FitLineTls(pts, w, idx, &l)) continue;
    Vec2 dir(l.n.y(), -l.n.x());
    if (dir.dot(in[g[0]].dir) < 0.0) dir = -dir;  // keep the polarity orientation
    const Vec2 p0 = l.c * l.n;
    // Guard against chains of continuations that bend too far (an arc): keep the pieces then.
    double worst = 0.0, extent = 0.0;
    for (const auto& p : pts) worst = std::max(worst, std::abs(l.Dist(p)));
    for (int i : g) extent += in[i].len;
    if (worst > std::max(line_px, 0.01 * extent)) {
      for (int i : g) out.push_back(in[i]);
      continue;
    }
    double lo = 1e300, hi = -1e300;
    for (const auto& p : pts) {
      const double t = (p - p0).dot(dir);
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
    out.push_back(MakeSeg(p0 + lo * dir, p0 + hi * dir));
  }
  return out;
}

// Slowly bending edges (curled paper, a page's edge near the binding): straight pieces where the
// end of one touches the start of the next (within `touch_px`), with the same polarity and
// directions within `step_deg`, are chained; a chain of at least two pieces whose first and last
// directions differ by at most `total_deg` and whose chord is at least `min_len` long becomes one
// curved segment (the chord, with the pieces' polyline). The pieces stay segments of their own.
std::vector<Seg> CurvedChains(const std::vector<Seg>& segs, double touch_px, double step_deg,
                              double total_deg, double min_len) {
  const int n = static_cast<int>(segs.size());
  const double cos_step = std::cos(step_deg * M_PI / 180.0);
  const double cos_total = std::cos(total_deg * M_PI / 180.0);
  std::vector<int> next(n, -1), prev_count(n, 0);
  // Candidates j for "i's end b touches j's start a", found by start x (sorted).
  std::vector<int> by_ax(n);
  std::iota(by_ax.begin(), by_ax.end(), 0);
  std::sort(by_ax.begin(), by_ax.end(),
            [&](int x, int y) { return segs[x].a.x() < segs[y].a.x(); });
  std::vector<double> ax(n);
  for (int k = 0; k < n; ++k) ax[k] = segs[by_ax[k]].a.x();
  for (int i = 0; i < n; ++i) {
    double best = touch_px * touch_px;
    const auto lo = std::lower_bound(ax.begin(), ax.end(), segs[i].b.x() - touch_px);
    const auto hi = std::upper_bound(ax.begin(), ax.end(), segs[i].b.x() + touch_px);
    for (auto it = lo; it != hi; ++it) {
      const int j = by_ax[it - ax.begin()];
      if (j == i || segs[i].dir.dot(segs[j].dir) < cos_step) continue;
      const double d2 = (segs[i].b - segs[j].a).squaredNorm();
      if (d2 <= best) {
        best = d2;
        next[i] = j;
      }
    }
    if (next[i] >= 0) ++prev_count[next[i]];
  }
  std::vector<Seg> out;
  std::vector<char> used(n, 0);
  for (int head = 0; head < n; ++head) {
    if (prev_count[head] != 0) continue;  // chains start at a piece nothing leads into
    std::vector<int> chain = {head};
    used[head] = 1;
    for (int k = next[head]; k >= 0 && !used[k]; k = next[k]) {
      if (segs[head].dir.dot(segs[k].dir) < cos_total) break;
      chain.push_back(k);
      used[k] = 1;
    }
    if (chain.size() < 2) continue;
    Seg c = MakeSeg(segs[chain.front()].a, segs[chain.back()].b);
    if (c.len < min_len) continue;
    c.path.push_back(segs[chain.front()].a);
    for (size_t k = 0; k + 1 < chain.size(); ++k)
      c.path.push_back(0.5 * (segs[chain[k]].b + segs[chain[k + 1]].a));
    c.path.push_back(segs[chain.back()].b);
    out.push_back(std::move(c));
  }
  return out;
}

// Edge linking: traces 8-connected chains of Canny pixels (consumes `edges`). At each step the
// unvisited neighbour that best continues the current direction is taken; branches become chains of
// their own. Each chain is traced from its seed in both directions and handed to `on_chain` (a
// buffer reused for every chain).
template <class OnChain>
void TraceChains(cv::Mat& edges, int min_len, OnChain&& on_chain) {
  static const int kDx[8] = {1, 1, 0, -1, -1, -1, 0, 1};
  static const int kDy[8] = {0, 1, 1, 1, 0, -1, -1, -1};
  static const float kInvLen[8] = {1.f, 0.70710678f, 1.f, 0.70710678f,
                                   1.f, 0.70710678f, 1.f, 0.70710678f};
  const int W = edges.cols, H = edges.rows;
  // Border pixels are cleared so neighbour lookups stay inside the image.
  edges.row(0).setTo(0);
  edges.row(H - 1).setTo(0);
  edges.col(0).setTo(0);
  edges.col(W - 1).setTo(0);
  // The walk's heading is the direction over the last few steps (a digital line of slope 1/2
  // alternates between two 8-neighbour steps; a single-step heading would follow any branch at a
  // junction).
  auto walk = [&](cv::Point p, int dir, std::vector<cv::Point>* out) {
    constexpr int kMemory = 4;
    for (;;) {
      cv::Point heading(dir >= 0 ? kDx[dir] : 0, dir >= 0 ? kDy[dir] : 0);
      const int n = static_cast<int>(out->size());
      if (n >= kMemory) heading = p - (*out)[n - kMemory];
      // Score: cosine between step k and the heading (up to the heading's positive length).
      int best = -1;
      float best_score = -1e30f;
      const uint8_t* row_m = edges.ptr<uint8_t>(p.y - 1) + p.x;
      const uint8_t* row_0 = edges.ptr<uint8_t>(p.y) + p.x;
      const uint8_t* row_p = edges.ptr<uint8_t>(p.y + 1) + p.x;
      const uint8_t* rows[3] = {row_m, row_0, row_p};
      for (int k = 0; k < 8; ++k) {
        if (!rows[kDy[k] + 1][kDx[k]]) continue;
        const float score = (dir < 0 && n == 0)
                                ? -static_cast<float>(k)
                                : (kDx[k] * heading.x + kDy[k] * heading.y) * kInvLen[k];
        if (score > best_score) {
          best_score = score;
          best = k;
        }
      }
      if (best < 0 || (dir >= 0 && best_score < 0.0f)) return;  // stop at turns sharper than 90 deg
      p = cv::Point(p.x + kDx[best], p.y + kDy[best]);
      edges.at<uint8_t>(p) = 0;
      out->push_back(p);
      dir = best;
    }
  };
  std::vector<cv::Point> fwd, bwd, chain;  // reused: no allocation per chain
  for (int y = 1; y < H - 1; ++y) {
    const uint8_t* row = edges.ptr<uint8_t>(y);
    for (int x = 1; x < W - 1; ++x) {
      // Skip empty stretches 8 bytes at a time (most of an edge map is empty; the byte-wise scan
      // was ~40 % of the linking time).
      while (x + 8 <= W - 1) {
        uint64_t word;
        std::memcpy(&word, row + x, sizeof(word));
        if (word) break;
        x += 8;
      }
      if (!row[x]) continue;
      const cv::Point seed(x, y);
      edges.at<uint8_t>(seed) = 0;
      fwd.clear();
      bwd.clear();
      walk(seed, -1, &fwd);
      if (!fwd.empty()) {
        // Walk the other way, starting opposite to the first step.
        const cv::Point d = fwd[0] - seed;
        int back = -1;
        for (int k = 0; k < 8; ++k)
          if (kDx[k] == -d.x && kDy[k] == -d.y) back = k;
        walk(seed, back, &bwd);
      }
      if (static_cast<int>(fwd.size() + bwd.size()) + 1 < min_len) continue;
      chain.assign(bwd.rbegin(), bwd.rend());
      chain.push_back(seed);
      chain.insert(chain.end(), fwd.begin(), fwd.end());
      on_chain(chain);
    }
  }
}

// Splits a pixel chain into straight pieces (recursive split at the farthest point from the chord
// while it is farther than tol_px) and fits each piece of at least min_len pixels by total least
// squares.
void SplitChain(const std::vector<cv::Point>& c, int i0, int i1, double tol_px, int min_len,
                std::vector<std::pair<Vec2, Vec2>>* out) {
  if (i1 - i0 + 1 < min_len) return;
  const Vec2 a(c[i0].x, c[i0].y), b(c[i1].x, c[i1].y);
  const Vec2 d = b - a;
  const double L = d.norm();
  int worst = -1;
  double worst_dist = 0.0;
  if (L > 0) {
    const Vec2 n(-d.y() / L, d.x() / L);
    for (int i = i0 + 1; i < i1; ++i) {
      const double dist = std::abs(n.dot(Vec2(c[i].x, c[i].y) - a));
      if (dist > worst_dist) {
        worst_dist = dist;
        worst = i;
      }
    }
  }
  if (worst >= 0 && worst_dist > tol_px) {
    SplitChain(c, i0, worst, tol_px, min_len, out);
    SplitChain(c, worst, i1, tol_px, min_len, out);
    return;
  }
  // Total least squares on the piece's pixels; endpoints = projections of the first and last pixel.
  Vec2 mu = Vec2::Zero();
  for (int i = i0; i <= i1; ++i) mu += Vec2(c[i].x, c[i].y);
  mu /= (i1 - i0 + 1);
  Mat2 S = Mat2::Zero();
  for (int i = i0; i <= i1; ++i) {
    const Vec2 e = Vec2(c[i].x, c[i].y) - mu;
    S += e * e.transpose();
  }
  const Vec2 dir = MajorAxis(S);
  out->emplace_back(mu + dir * dir.dot(a - mu), mu + dir * dir.dot(b - mu));
}

struct Junction {
  int seg = -1;  // the other segment
  int end = 0;   // the other segment's end at the junction (0 = a, 1 = b)
  Vec2 x;        // intersection point
};

// Which end of s the point x (on s's line) is a corner for, or -1. Beyond the end by up to gap,
// inside the segment by up to overshoot.
int JunctionEnd(const Seg& s, const Vec2& x, const RectDetectorOptions& o) {
  const double t = (x - s.a).dot(s.dir);
  const double beyond = t < 0.5 * s.len ? -t : t - s.len;  // > 0: x lies past that end
  const int end = t < 0.5 * s.len ? 0 : 1;
  if (beyond >= 0.0) return beyond <= o.junction_gap_frac * s.len + o.junction_slack_px ? end : -1;
  return -beyond <= o.junction_overshoot_frac * s.len + o.junction_slack_px ? end : -1;
}

// What refinement learns about one side besides its line: the polarity of its edge (+1: brighter
// towards the side's left normal) and the median gradient of its inlier edge points.
struct SideEdge {
  int sign = 1;
  double gradient = 0.0;
  // A curved side (see CurvedChains): its unit directions at c[i-1] and c[i] (towards c[i]).
  bool curved = false;
  Vec2 dir_start = Vec2(1.0, 0.0), dir_end = Vec2(1.0, 0.0);
};

struct Quad {
  Corners c;  // undistorted px, grouping order (a∩b, b∩c, c∩d, d∩a)
  std::array<SideEdge, 4>
      edges;  // side i joins c[i-1] and c[i] (grouping order, set by refinement)
  std::array<int, 4> seg = {-1, -1, -1, -1};  // segment of side i (grouping)
  Corners c_grouping;  // refined corners in grouping order (the order of `edges`)
  double score = 0.0;
  double abs_cos = 1.0;
  double aspect_w_h = 1.0;  // metric width / height after canonical ordering
  double area = 0.0;
};

// RANSAC over two-point lines (most inliers wins), then weighted TLS on the inliers, twice. Returns
// the number of final inliers (0 on failure).
int RansacLine(const std::vector<Vec2>& pts, const std::vector<double>& w,
               const std::vector<int>& subset, double inlier_px, int iterations, std::mt19937* rng,
               Line* line) {
  const int np = static_cast<int>(subset.size());
  if (np < 2) return 0;
  std::uniform_int_distribution<int> pick(0, np - 1);
  int best_count = -1;
  Line best_line;
  for (int it = 0; it < iterations; ++it) {
    const int i = subset[pick(*rng)];
    int j = subset[pick(*rng)];
    if (j == i) j = subset[(pick(*rng) + 1) % np];
    const Vec2 d = pts[j] - pts[i];
    if (d.norm() < 1e-9) continue;
    Line l;
    l.n = Vec2(-d.y(), d.x()).normalized();
    l.c = l.n.dot(pts[i]);
    int count = 0;
    for (int k : subset) count += std::abs(l.Dist(pts[k])) <= inlier_px;
    if (count > best_count) {
      best_count = count;
      best_line = l;
    }
  }
  if (best_count < 2) return 0;
  Line l = best_line;
  std::vector<int> inl;
  for (int pass = 0; pass < 3; ++pass) {
    inl.clear();
    for (int k : subset)
      if (std::abs(l.Dist(pts[k])) <= inlier_px) inl.push_back(k);
    if (pass == 2) break;
    if (static_cast<int>(inl.size()) < 2 || !FitLineTls(pts, w, inl, &l)) return 0;
  }
  *line = l;
  return static_cast<int>(inl.size());
}

// One sub-pixel edge point: the 1-D gradient peak on the (smoothed, distorted) image along the
// normal `n` through `p` (undistorted px), within +-search_px. Returns false when the peak is at
// the window's end (no edge inside), below `min_gradient` [grey levels / px] or the profile leaves
// the image. With `want_sign` != 0 only edges of that polarity are considered (a groove's two
// edges). `edge` (undistorted px), `gradient` [grey levels / px] and `sign` (+1: brighter towards
// +n) describe the peak.
struct EdgeProbe {
  const cv::Mat& smooth;
  const PinholeRadtan* cam;  // non-null only with distortion
  const RectDetectorOptions& o;
  int m;  // samples each side of p
  mutable std::vector<double> prof;
  EdgeProbe(const cv::Mat& s, const PinholeRadtan* c, const RectDetectorOptions& opt)
      : smooth(s),
        cam(c && c->HasDistortion() ? c : nullptr),
        o(opt),
        m(static_cast<int>(std::lround(opt.search_px / opt.search_step_px))),
        prof(2 * m + 1) {}

  // Whether a search at undistorted p lies wholly inside the image (an edge could have been found).
  bool Searchable(const Vec2& p) const {
    const Vec2 d = cam ? cam->DistortPixel(p) : p;
    const double r = o.search_px + 1.0;
    return d.x() >= r && d.y() >= r && d.x() < smooth.cols - 1 - r && d.y() < smooth.rows - 1 - r;
  }

  bool Peak(const Vec2& p, const Vec2& n, double min_gradient, Vec2* edge, double* gradient,
            int* sign, int want_sign = 0) const {
    // With distortion the search runs along the image of the normal, nd = J n / |J n| (J: the
    // Jacobian of the distortion at p, by a 1 px finite difference); an offset s along nd maps
    // back to p + (s / |J n|) n to first order (the error is second order in s <= search_px:
    // negligible, and it saves an iterative undistortion per edge point).
    Vec2 qd = p, nd = n;
    double jn = 1.0;
    if (cam) {
      qd = cam->DistortPixel(p);
      nd = cam->DistortPixel(p + n) - qd;
      jn = nd.norm();
      nd /= jn;
    }
    for (int i = -m; i <= m; ++i) {
      const Vec2 sp = qd + (i * o.search_step_px) * nd;
      if (!Bilinear(smooth, sp.x(), sp.y(), &prof[i + m])) return false;
    }
    // Derivative by central differences over one pixel (2 steps of 0.5 px): grey levels per px.
    int best = -1;
    double best_abs = 0.0;
    for (int i = 1; i < 2 * m; ++i) {
      const double diff = prof[i + 1] - prof[i - 1];
      const double d = want_sign == 0 ? std::abs(diff) : want_sign * diff;
      if (d > best_abs) {
        best_abs = d;
        best = i;
      }
    }
    if (best <= 1 || best >= 2 * m - 1) return false;  // peak at the window's end: no edge inside
    *gradient = best_abs / (2.0 * o.search_step_px);
    if (*gradient < min_gradient) return false;
    // Parabola through the derivative magnitudes at best-1, best, best+1: vertex offset in steps.
    const double sgn = want_sign == 0 ? (prof[best + 1] > prof[best - 1] ? 1.0 : -1.0) : want_sign;
    const double dm = sgn * (prof[best] - prof[best - 2]);
    const double dp = sgn * (prof[best + 2] - prof[best]);
    const double den = dm - 2.0 * best_abs + dp;
    const double delta = den < 0.0 ? 0.5 * (dm - dp) / den : 0.0;
    const double s_star = (best - m + std::clamp(delta, -0.5, 0.5)) * o.search_step_px;
    *edge = p + (s_star / jn) * n;
    *sign = prof[best + 1] > prof[best - 1] ? 1 : -1;
    return true;
  }
};

// Sub-pixel refinement of one quad. Side i joins corners c[i-1] and c[i]; its edge points come from
// 1-D gradient peaks along the side's normal in the (smoothed, distorted) image. Each side gets one
// RANSAC line; when the lines fitted to its two halves disagree with it by more than `bend_px` at
// the corners (a bent side: paper, residual distortion), each corner is taken from the half-lines
// next to it.
// `side_want` gives the polarity of sides without a segment (0: either).
bool RefineQuad(const EdgeProbe& probe, const std::vector<Seg>& segs, double min_gradient,
                std::mt19937* rng, Quad* q, std::array<SideEdge, 4>* side_edges,
                const std::array<int, 4>& side_want = {0, 0, 0, 0}) {
  const RectDetectorOptions& o = probe.o;
  std::array<Line, 4> start_line, end_line;  // line used at the side's first / last corner
  double support_sum = 0.0;
  std::vector<Vec2> pts, poly;
  std::vector<double> w, ts, cum, t_list;
  std::vector<int> first_inl, second_inl;
  std::vector<int> sign;
  for (int side = 0; side < 4; ++side) {
    const Vec2 P = q->c[(side + 3) % 4], Q = q->c[side];
    // The side is sampled along its segment's polyline when curved (P, the pieces' joints, Q),
    // else along the straight line P → Q.
    poly.assign({P, Q});
    const Seg* sg_side = q->seg[side] >= 0 ? &segs[q->seg[side]] : nullptr;
    const bool curved = sg_side && sg_side->path.size() > 2;
    if (curved) {
      const auto& path = sg_side->path;
      const bool forward = (path.front() - P).squaredNorm() <= (path.back() - P).squaredNorm();
      poly.assign(1, P);
      for (size_t k = 1; k + 1 < path.size(); ++k)
        poly.push_back(forward ? path[k] : path[path.size() - 1 - k]);
      poly.push_back(Q);
    }
    cum.assign(1, 0.0);
    for (size_t k = 1; k < poly.size(); ++k)
      cum.push_back(cum.back() + (poly[k] - poly[k - 1]).norm());
    const double L = cum.back();
    if (!(L > 1.0)) return false;
    const Vec2 u = (Q - P).normalized();
    // The segment's polarity fixes the side's: only edges of that polarity are searched (a thin
    // line's other edge, a groove's, is not the side). Segments are brighter towards (dy, -dx)
    // (see the segments stage), the opposite of n = (-u.y, u.x) here when they run along u.
    const int want_sign = !sg_side                 ? side_want[side]
                          : o.polarity_from_segment ? (sg_side->dir.dot(u) > 0.0 ? -1 : 1)
                                                    : 0;
    // A curved side is sampled every 3 px from close to its corners, and each corner comes from
    // the stretch of its end piece nearest to it (`curved_corner_frac`): the rest of a curled
    // page's edge wanders by a pixel or more.
    const double margin = curved ? std::max(o.search_px + 1.0, 0.01 * L)
                                 : std::max(o.corner_margin_frac * (Q - P).norm(), 1.0);
    // Sample positions along the side: evenly spaced on a straight side; on a curved one every
    // 3 px in the stretch next to each corner and `samples_per_side` / 2 in between.
    const double corner_stretch = margin + std::max(30.0, o.curved_corner_frac * L);
    t_list.clear();
    if (!curved) {
      const int k = std::max(8, std::min(o.samples_per_side, static_cast<int>(L - 2 * margin)));
      for (int i = 0; i < k; ++i) t_list.push_back(margin + (L - 2 * margin) * (i + 0.5) / k);
    } else {
      const double stretch = std::min(corner_stretch, 0.5 * L) - margin;
      const int k_end = std::max(3, static_cast<int>(stretch / 3.0));
      for (int i = 0; i < k_end; ++i) t_list.push_back(margin + stretch * (i + 0.5) / k_end);
      const double mid = L - 2 * (margin + stretch);
      const int k_mid = mid > 0.0 ? o.samples_per_side / 2 : 0;
      for (int i = 0; i < k_mid; ++i) t_list.push_back(margin + stretch + mid * (i + 0.5) / k_mid);
      for (int i = 0; i < k_end; ++i)
        t_list.push_back(L - margin - stretch + stretch * (i + 0.5) / k_end);
    }
    const int k_samples = static_cast<int>(t_list.size());
    pts.clear();
    w.clear();
    ts.clear();
    sign.clear();
    int pos = 0, neg = 0, on_path = 0;
    size_t piece = 0;
    for (const double t : t_list) {
      while (piece + 2 < poly.size() && t > cum[piece + 1]) ++piece;
      const Vec2 ue = (poly[piece + 1] - poly[piece]).normalized(), n(-ue.y(), ue.x());
      const Vec2 p = poly[piece] + (t - cum[piece]) * ue;
      Vec2 e;
      double gradient;
      int sg;
      if (!probe.Peak(p, n, min_gradient, &e, &gradient, &sg, want_sign)) continue;
      (sg > 0 ? pos : neg)++;
      on_path += std::abs(n.dot(e - p)) <= 1.0;
      pts.push_back(e);
      w.push_back(gradient);
      ts.push_back(t);
      sign.push_back(sg);
    }
    // Keep the majority polarity: a side's edge has one polarity; the other is a neighbouring edge.
    const int keep = pos >= neg ? 1 : -1;
    std::vector<int> all, first, second;
    std::vector<double> grads;
    // Halves of a straight side; the end pieces of a curved one.
    const double first_end = curved ? std::min(cum[1], corner_stretch) : 0.5 * L;
    const double second_start =
        curved ? std::max(cum[cum.size() - 2], L - corner_stretch) : 0.5 * L;
    for (size_t i = 0; i < pts.size(); ++i) {
      if (sign[i] != keep) continue;
      all.push_back(static_cast<int>(i));
      grads.push_back(w[i]);
      if (ts[i] < first_end) first.push_back(static_cast<int>(i));
      if (ts[i] >= second_start) second.push_back(static_cast<int>(i));
    }
    const int need = static_cast<int>(std::ceil(o.min_side_support * k_samples));
    if (static_cast<int>(all.size()) < std::max(need, 2)) return false;
    std::nth_element(grads.begin(), grads.begin() + grads.size() / 2, grads.end());
    (*side_edges)[side].sign = keep;
    (*side_edges)[side].gradient = grads[grads.size() / 2];
    (*side_edges)[side].curved = curved;
    if (curved) {
      Line l1, l2;
      const int n1 = RansacLine(pts, w, first, o.ransac_inlier_px, o.ransac_iterations, rng, &l1);
      const int n2 = RansacLine(pts, w, second, o.ransac_inlier_px, o.ransac_iterations, rng, &l2);
      if (n1 < 3 || n2 < 3 || on_path < need) return false;
      start_line[side] = l1;
      end_line[side] = l2;
      // Directions along the end lines, pointing from P towards Q.
      for (const auto& [line, dir] : {std::make_pair(&l1, &(*side_edges)[side].dir_start),
                                      std::make_pair(&l2, &(*side_edges)[side].dir_end)}) {
        *dir = Vec2(line->n.y(), -line->n.x());
        if (dir->dot(u) < 0.0) *dir = -*dir;
      }
      support_sum += static_cast<double>(on_path) / k_samples;
      continue;
    }
    Line global;
    const int n_global =
        RansacLine(pts, w, all, o.ransac_inlier_px, o.ransac_iterations, rng, &global);
    // Disagreement of a half-line with the global line at the corner it serves.
    auto bend_at = [&](const Line& half, const Vec2& corner) {
      const Vec2 on_half =
          corner - half.Dist(corner) * half.n;  // foot of the corner on the half-line
      return std::abs(global.Dist(on_half));
    };
    // Cheap check first: lines through the global line's inliers in each half. Only when they
    // disagree with it (or too few points are inliers) are the halves fitted on their own (RANSAC).
    Line l1, l2;
    int n1 = 0, n2 = 0;
    bool maybe_bent = n_global < static_cast<int>(0.9 * all.size());
    if (!maybe_bent) {
      std::vector<int>& in1 = first_inl;
      std::vector<int>& in2 = second_inl;
      in1.clear();
      in2.clear();
      for (int i : first)
        if (std::abs(global.Dist(pts[i])) <= o.ransac_inlier_px) in1.push_back(i);
      for (int i : second)
        if (std::abs(global.Dist(pts[i])) <= o.ransac_inlier_px) in2.push_back(i);
      maybe_bent = in1.size() >= 2 && in2.size() >= 2 && FitLineTls(pts, w, in1, &l1) &&
                   FitLineTls(pts, w, in2, &l2) &&
                   (bend_at(l1, P) > 0.5 * o.bend_px || bend_at(l2, Q) > 0.5 * o.bend_px);
    }
    if (maybe_bent) {
      n1 = RansacLine(pts, w, first, o.ransac_inlier_px, o.ransac_iterations, rng, &l1);
      n2 = RansacLine(pts, w, second, o.ransac_inlier_px, o.ransac_iterations, rng, &l2);
    }
    const bool halves_ok = n1 >= std::max(2, need / 2) && n2 >= std::max(2, need / 2);
    const bool bent =
        maybe_bent && halves_ok && (bend_at(l1, P) > o.bend_px || bend_at(l2, Q) > o.bend_px);
    if (!bent) {
      if (n_global < need) return false;
      start_line[side] = end_line[side] = global;
      support_sum += static_cast<double>(n_global) / k_samples;
    } else {
      start_line[side] = l1;
      end_line[side] = l2;
      support_sum += static_cast<double>(n1 + n2) / k_samples;
    }
  }
  // Corner i joins side i (ending there) and side i+1 (starting there).
  Corners c;
  for (int i = 0; i < 4; ++i)
    if (!Intersect(end_line[i], start_line[(i + 1) % 4], &c[i])) return false;
  const double tol = 0.2 * ShortestSide(q->c) + 2.0 * o.search_px;
  for (int i = 0; i < 4; ++i)
    if ((c[i] - q->c[i]).norm() > tol) return false;
  if (!IsConvex(c)) return false;
  q->c = c;
  q->score = std::min(1.0, support_sum / 4.0);
  return true;
}

// T-junction test (RectDetectorOptions::max_side_continuation): does the edge of a side run on past
// the corner `corner`? `u` is the side's direction pointing out of the quad at that corner, `edge`
// its polarity and strength along the side (polarity relative to the left normal of u_side, where
// u_side is the side's own direction from its first to its last corner; `flip` says whether u is
// -u_side). Edge points are searched on the side's line extended beyond the corner, from
// `continuation_start_px` over `continuation_frac` x the side's length; a point supports the
// continuation when the gradient peak has the side's polarity, at least half its median gradient,
// and lies within ransac_inlier_px + 0.5 px of the extended line. Returns the supported fraction of
// the samples inside the image (0 when fewer than 3 are).
double SideContinuation(const EdgeProbe& probe, const Vec2& corner, const Vec2& u, bool flip,
                        double length, const SideEdge& edge) {
  const RectDetectorOptions& o = probe.o;
  const Vec2 n_side = flip ? Vec2(u.y(), -u.x()) : Vec2(-u.y(), u.x());  // left normal of u_side
  const double span = o.continuation_frac * length;
  // One sample per 2 px (at least 4, at most 12): a corner a few pixels from the image border still
  // gets samples in view.
  const int kSamples = std::clamp(static_cast<int>(span / 2.0), 4, 12);
  // Support counts in runs of consecutive samples (the longest run): an edge that runs on is
  // continuous, scattered hits (text, texture beyond the corner) are not.
  // The edge point at distance t beyond the corner along u, on the extended line.
  auto on_line = [&](double t) {
    const Vec2 p = corner + t * u;
    Vec2 e;
    double gradient;
    int sg;
    return probe.Peak(p, n_side, 0.5 * edge.gradient, &e, &gradient, &sg, edge.sign) &&
           std::abs(n_side.dot(e - p)) <= o.ransac_inlier_px + 0.5;
  };
  // Two consecutive hits extend a run only when the edge is also found between them at least every
  // `continuation_step_px`: an edge that runs on is continuous, while the ends of text strokes or
  // texture that happen to line up with the side leave gaps between the (sparse) samples.
  const double step = span / kSamples;
  const int n_between = o.continuation_step_px > 0.0
                            ? static_cast<int>(std::ceil(step / o.continuation_step_px)) - 1
                            : 0;
  int valid = 0, run = 0, longest = 0;
  for (int k = 0; k < kSamples; ++k) {
    const double t = o.continuation_start_px + span * (k + 0.5) / kSamples;
    const Vec2 p = corner + t * u;
    Vec2 e;
    double gradient;
    int sg;
    if (!probe.Peak(p, n_side, 0.5 * edge.gradient, &e, &gradient, &sg, edge.sign)) {
      // Outside the image is not evidence either way; no edge inside is evidence against.
      if (probe.Searchable(p)) {
        ++valid;
        run = 0;
      }
      continue;
    }
    ++valid;
    if (std::abs(n_side.dot(e - p)) > o.ransac_inlier_px + 0.5) {
      run = 0;
      continue;
    }
    bool continuous = run > 0;
    for (int j = 1; continuous && j <= n_between; ++j)
      continuous = on_line(t - step + step * j / (n_between + 1));
    run = continuous ? run + 1 : 1;
    longest = std::max(longest, run);
  }
  return valid >= 3 ? static_cast<double>(longest) / valid : 0.0;
}

// Corner reach test (RectDetectorOptions::min_corner_reach): the fraction of points on a side's
// line between `reach_start_px` and max(reach_min_px, reach_frac x length) from the corner
// `corner` (u points from the corner into the side) where the side's edge is found (same criteria
// as SideContinuation). 1 when fewer than 3 points are inside the image.
double CornerReach(const EdgeProbe& probe, const Vec2& corner, const Vec2& u, bool flip,
                   double length, const SideEdge& edge) {
  const RectDetectorOptions& o = probe.o;
  const Vec2 n_side = flip ? Vec2(u.y(), -u.x()) : Vec2(-u.y(), u.x());
  const double t0 = o.reach_start_px, t1 = std::max(o.reach_min_px, o.reach_frac * length);
  constexpr int kSamples = 6;
  int valid = 0, support = 0;
  for (int k = 0; k < kSamples; ++k) {
    const Vec2 p = corner + (t0 + (t1 - t0) * k / (kSamples - 1)) * u;
    Vec2 e;
    double gradient;
    int sg;
    if (!probe.Peak(p, n_side, 0.5 * edge.gradient, &e, &gradient, &sg, edge.sign)) {
      valid += probe.Searchable(p) ? 1 : 0;
      continue;
    }
    ++valid;
    support += std::abs(n_side.dot(e - p)) <= o.ransac_inlier_px + 0.5;
  }
  if (valid < 3) return 1.0;
  return static_cast<double>(support) / valid;
}

// True when some corner of the refined quad is not an L-corner: a side continues past it (see
// SideContinuation; a T-junction, where the object runs on and another line such as a panel
// groove, a mullion or texture crosses it), or a side's edge stops short of it (see CornerReach; a
// quad closed by a line a little beyond the object, such as the outer edge of a tag's white
// margin with the black square's other three sides).
bool HasTJunction(const EdgeProbe& probe, const Corners& c, const std::array<SideEdge, 4>& edges) {
  for (int side = 0; side < 4; ++side) {
    const Vec2 P = c[(side + 3) % 4], Q = c[side];
    const double L = (Q - P).norm();
    const Vec2 u = (Q - P) / L;
    const Vec2 us = edges[side].curved ? edges[side].dir_start : u;
    const Vec2 ue = edges[side].curved ? edges[side].dir_end : u;
    if (probe.o.min_corner_reach > 0.0 &&
        (CornerReach(probe, Q, -ue, true, L, edges[side]) < probe.o.min_corner_reach ||
         CornerReach(probe, P, us, false, L, edges[side]) < probe.o.min_corner_reach))
      return true;
    if (SideContinuation(probe, Q, ue, false, L, edges[side]) > probe.o.max_side_continuation ||
        SideContinuation(probe, P, -us, true, L, edges[side]) > probe.o.max_side_continuation)
      return true;
  }
  return false;
}

// Mean and standard deviation of the grey values on an n x n grid of the quad's interior (bilinear
// map of the unit square, shrunk by `shrink` towards the centre) or of a ring just outside it
// (scale > 1).
void QuadStats(const cv::Mat& img, const Corners& px, double scale, double* mean, double* stddev) {
  const Vec2 centre = 0.25 * (px[0] + px[1] + px[2] + px[3]);
  double s = 0.0, s2 = 0.0;
  int n = 0;
  const int g = 8;
  for (int i = 0; i < g; ++i)
    for (int j = 0; j < g; ++j) {
      if (scale > 1.0 && i > 0 && i < g - 1 && j > 0 && j < g - 1)
        continue;  // ring: border cells only
      const double a = (i + 0.5) / g, b = (j + 0.5) / g;
      const Vec2 p =
          (1 - a) * (1 - b) * px[0] + a * (1 - b) * px[1] + a * b * px[2] + (1 - a) * b * px[3];
      const Vec2 ps = centre + scale * (p - centre);
      double v;
      if (!Bilinear(img, ps.x(), ps.y(), &v)) continue;
      s += v;
      s2 += v * v;
      ++n;
    }
  if (n == 0) {
    *mean = *stddev = -1.0;
    return;
  }
  *mean = s / n;
  *stddev = std::sqrt(std::max(0.0, s2 / n - *mean * *mean));
}

// Mean and standard deviation of the grey values along the outline of the quad scaled by `scale`
// about its centre (< 1: a ring inside it, > 1: outside), 8 points per side; optionally the
// largest of the four sides' means.
void RingStats(const cv::Mat& img, const Corners& px, double scale, double* mean, double* stddev,
               double* max_side_mean = nullptr) {
  const Vec2 centre = 0.25 * (px[0] + px[1] + px[2] + px[3]);
  double s = 0.0, s2 = 0.0;
  int n = 0;
  if (max_side_mean) *max_side_mean = -1.0;
  for (int i = 0; i < 4; ++i) {
    double side_sum = 0.0;
    int side_n = 0;
    for (int k = 0; k < 8; ++k) {
      const Vec2 p = px[i] + ((k + 0.5) / 8.0) * (px[(i + 1) % 4] - px[i]);
      const Vec2 ps = centre + scale * (p - centre);
      double v;
      if (!Bilinear(img, ps.x(), ps.y(), &v)) continue;
      s += v;
      s2 += v * v;
      ++n;
      side_sum += v;
      ++side_n;
    }
    if (max_side_mean && side_n > 0) *max_side_mean = std::max(*max_side_mean, side_sum / side_n);
  }
  if (n == 0) {
    *mean = *stddev = -1.0;
    return;
  }
  *mean = s / n;
  *stddev = std::sqrt(std::max(0.0, s2 / n - *mean * *mean));
}

// Bright margin test (RectDetectorOptions::prefer_inner_of_bright_margin) for an outer quad and a
// nested inner one (undistorted px, any start corner, same orientation). Per side, at points p
// along the inner side (t in [0.15, 0.85], away from the corners), the ring's width h is the
// distance from p along the side's outward normal n to the matching outer side's line; the ring is
// sampled at p + n h/2, the strip inside the inner outline at p − n h/2 (for a tag the black border
// is as wide as the white margin) and the surroundings at p + 1.5 n h. Sides where the outlines
// coincide (h < `margin_min_width_px`: a variant closed by lines of both outlines, a margin cut off
// by the image border) and samples outside the image are skipped; at least one side's worth must
// remain. Grey values on the smoothed image at the distorted positions.
bool IsBrightMargin(const cv::Mat& smooth, const PinholeRadtan* cam, const Corners& outer,
                    const Corners& inner, const RectDetectorOptions& o) {
  int shift = 0;
  CornerDistanceBestShift(outer, inner, &shift);
  const Vec2 centre = 0.25 * (inner[0] + inner[1] + inner[2] + inner[3]);
  constexpr int kPerSide = 12;
  double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
  int n = 0;
  for (int i = 0; i < 4; ++i) {
    const Vec2 &i0 = inner[(i + shift) % 4], &i1 = inner[(i + 1 + shift) % 4];
    const Line outer_line = LineOf(MakeSeg(outer[i], outer[(i + 1) % 4]));
    const Vec2 u = (i1 - i0).normalized();
    Vec2 nrm(-u.y(), u.x());
    if (nrm.dot(i0 - centre) < 0.0) nrm = -nrm;  // outward
    const double cos_n = outer_line.n.dot(nrm);
    if (std::abs(cos_n) < 0.5) continue;  // sides not roughly parallel: not matching sides
    for (int k = 0; k < kPerSide; ++k) {
      const double t = 0.15 + 0.7 * (k + 0.5) / kPerSide;
      const Vec2 p = i0 + t * (i1 - i0);
      // p + h nrm lies on the outer line: outer_line.n · (p + h nrm) = outer_line.c.
      const double h = (outer_line.c - outer_line.n.dot(p)) / cos_n;
      if (h < o.margin_min_width_px) continue;
      const Vec2 at[3] = {p - 0.5 * h * nrm, p + 0.5 * h * nrm, p + 1.5 * h * nrm};
      double v[3];
      bool ok = true;
      for (int j = 0; j < 3 && ok; ++j) {
        const Vec2 q = cam ? cam->DistortPixel(at[j]) : at[j];
        ok = Bilinear(smooth, q.x(), q.y(), &v[j]);
      }
      if (!ok) continue;
      for (int j = 0; j < 3; ++j) {
        sum[j] += v[j];
        sum2[j] += v[j] * v[j];
      }
      ++n;
    }
  }
  if (n < kPerSide) return false;  // less than one side's worth of ring
  double mean[3], sd[3];
  for (int j = 0; j < 3; ++j) {
    mean[j] = sum[j] / n;
    sd[j] = std::sqrt(std::max(0.0, sum2[j] / n - mean[j] * mean[j]));
  }
  // The ring is brighter than the inner strip (clearly) and than the surroundings (an edge), and
  // both the ring and the inner strip are plain.
  const double contrast = mean[1] - mean[0];
  return contrast >= o.margin_min_contrast && mean[1] - mean[2] >= o.min_edge_contrast &&
         sd[1] <= o.margin_max_texture * contrast && sd[0] <= o.margin_max_texture * contrast;
}

}  // namespace

cv::Mat EdgeRefineImage(const cv::Mat& gray) {
  FSP_CHECK(gray.type() == CV_8UC1 && !gray.empty());
  cv::Mat smooth;
  cv::GaussianBlur(gray, smooth, cv::Size(5, 5), 1.0, 1.0, cv::BORDER_REPLICATE);
  return smooth;
}

EdgeRefinement RefineCornersOnEdges(const cv::Mat& smooth, const PinholeRadtan* camera,
                                    const Corners& corners_undistorted, double min_gradient,
                                    const RectDetectorOptions& options,
                                    const std::array<int, 4>& want_sign) {
  FSP_CHECK(smooth.type() == CV_8UC1 && !smooth.empty());
  if (camera) FSP_CHECK(camera->width == smooth.cols && camera->height == smooth.rows);
  EdgeRefinement out;
  if (!IsConvex(corners_undistorted)) return out;
  const EdgeProbe probe(smooth, camera, options);
  std::mt19937 rng(options.seed);
  Quad q;
  q.c = corners_undistorted;
  std::array<SideEdge, 4> edges;
  if (!RefineQuad(probe, {}, min_gradient, &rng, &q, &edges, want_sign)) return out;
  out.ok = true;
  out.corners_undistorted = q.c;
  out.support = q.score;
  for (int i = 0; i < 4; ++i) {
    out.side_sign[i] = edges[i].sign;
    out.side_gradient[i] = edges[i].gradient;
  }
  return out;
}

RectDetector::Result RectDetector::Detect(const cv::Mat& gray, const PinholeRadtan* camera,
                                          const Vec3* gravity_C) const {
  FSP_CHECK(gray.type() == CV_8UC1 && !gray.empty());
  if (camera) FSP_CHECK(camera->width == gray.cols && camera->height == gray.rows);
  const Options& o = options_;
  Result res;
  Stopwatch sw;
  const double diag = std::hypot(gray.cols, gray.rows);
  const Mat3 K = camera ? camera->K() : DefaultK(gray.cols, gray.rows, o.assumed_hfov_deg);
  const PinholeRadtan* cam = camera && camera->HasDistortion() ? camera : nullptr;

  // 1. edges: light smoothing (σ = 1 px) against pixel noise, Sobel, Canny with data-driven
  // thresholds.
  // The Sobel gradients are computed once (what cv::Canny would compute inside: 3x3, replicated
  // border) and serve both the threshold statistics and Canny.
  cv::Mat edges, dx, dy;
  const cv::Mat smooth = EdgeRefineImage(gray);
  cv::spatialGradient(smooth, dx, dy, 3, cv::BORDER_REPLICATE);
  CannyThresholds(dx, dy, o, &res.canny_low, &res.canny_high);
  cv::Canny(dx, dy, edges, res.canny_low, res.canny_high, true);
  res.times.Add("edges", sw.Lap());

  // 2. segments: edge chains split into straight pieces, each fitted by least squares.
  const int min_seg = std::max(4, static_cast<int>(std::lround(o.min_segment_frac * diag)));
  std::vector<std::pair<Vec2, Vec2>> raw;
  // Pieces down to a third of the minimum length are kept for merging: a chain that runs into
  // another edge takes a stretch of it, leaving short pieces of a long side that merging joins
  // again.
  const int min_piece = std::max(6, min_seg / 3);
  TraceChains(edges, min_piece, [&](const std::vector<cv::Point>& chain) {
    SplitChain(chain, 0, static_cast<int>(chain.size()) - 1, o.segment_fit_px, min_piece, &raw);
  });
  std::vector<Seg> segs;
  segs.reserve(raw.size());
  for (const auto& r : raw) {
    Vec2 a = r.first, b = r.second;
    // Orient by polarity: brighter side on the left of a → b (image x right, y down: left normal is
    // (dy, -dx) for direction (dx, dy)), from the Sobel gradient at five points along the segment.
    {
      const Vec2 d = b - a;
      const Vec2 left = Vec2(d.y(), -d.x()).normalized();
      double sum = 0.0;
      for (int k = 1; k <= 5; ++k) {
        const Vec2 p = a + (k / 6.0) * d;
        double vl = 0.0, vr = 0.0;
        if (Bilinear(smooth, p.x() + 1.5 * left.x(), p.y() + 1.5 * left.y(), &vl) &&
            Bilinear(smooth, p.x() - 1.5 * left.x(), p.y() - 1.5 * left.y(), &vr))
          sum += vl - vr;
      }
      if (sum < 0.0) std::swap(a, b);
    }
    if (cam) {
      a = cam->UndistortPixel(a);
      b = cam->UndistortPixel(b);
    }
    segs.push_back(MakeSeg(a, b));
  }
  segs = MergeCollinear(segs, o.merge_angle_deg, o.merge_line_px, o.merge_gap_frac * diag);
  segs.erase(
      std::remove_if(segs.begin(), segs.end(), [&](const Seg& sg) { return sg.len < min_seg; }),
      segs.end());
  if (o.curved_step_deg > 0.0)
    for (Seg& c : CurvedChains(segs, o.merge_line_px, o.curved_step_deg, o.curved_total_deg,
                               o.curved_min_frac * diag))
      segs.push_back(std::move(c));
  res.segments = static_cast<int>(segs.size());
  for (const Seg& sg : segs) res.segment_ends.emplace_back(sg.a, sg.b);
  res.times.Add("segments", sw.Lap());

  // 3. grouping: junctions at segment ends, then 4-cycles a → b → c → d → a.
  const int ns = static_cast<int>(segs.size());
  std::vector<std::array<std::vector<Junction>, 2>> ends(ns);
  std::vector<Line> seg_lines(ns);
  for (int i = 0; i < ns; ++i) seg_lines[i] = LineOf(segs[i]);
  const double min_sin = std::sin(o.min_corner_angle_deg * M_PI / 180.0);
  // Compact copies of what the pair loop's cheap rejections read (the segments themselves carry
  // their polylines: a cache miss per pair).
  struct SegEnds {
    Vec2 a, b, dir;
    double len;
  };
  std::vector<SegEnds> se(ns);
  for (int i = 0; i < ns; ++i) se[i] = {segs[i].a, segs[i].b, segs[i].dir, segs[i].len};
  for (int i = 0; i < ns; ++i)
    for (int j = i + 1; j < ns; ++j) {
      const SegEnds &si = se[i], &sj = se[j];
      const double s = std::abs(si.dir.x() * sj.dir.y() - si.dir.y() * sj.dir.x());
      if (s < min_sin) continue;
      // Cheap rejection: the nearest endpoints must be within reach of both junction tolerances.
      const double reach = (o.junction_gap_frac + o.junction_overshoot_frac) * (si.len + sj.len) +
                           2.0 * o.junction_slack_px;
      const double dmin2 = std::min({(si.a - sj.a).squaredNorm(), (si.a - sj.b).squaredNorm(),
                                     (si.b - sj.a).squaredNorm(), (si.b - sj.b).squaredNorm()});
      if (dmin2 > reach * reach) continue;
      // A curved segment meets the other one with the piece at its nearer end.
      auto near_end = [](const Seg& s1, const Seg& s2) {
        const double da = std::min((s1.a - s2.a).squaredNorm(), (s1.a - s2.b).squaredNorm());
        const double db = std::min((s1.b - s2.a).squaredNorm(), (s1.b - s2.b).squaredNorm());
        return da <= db ? 0 : 1;
      };
      const int ni = segs[i].path.empty() ? -1 : near_end(segs[i], segs[j]);
      const int nj = segs[j].path.empty() ? -1 : near_end(segs[j], segs[i]);
      Vec2 x;
      if (!Intersect(ni < 0 ? seg_lines[i] : EndLine(segs[i], ni),
                     nj < 0 ? seg_lines[j] : EndLine(segs[j], nj), &x))
        continue;
      const int ei = JunctionEnd(segs[i], x, o);
      if (ei < 0 || (ni >= 0 && ei != ni)) continue;
      const int ej = JunctionEnd(segs[j], x, o);
      if (ej < 0 || (nj >= 0 && ej != nj)) continue;
      ends[i][ei].push_back({j, ej, x});
      ends[j][ej].push_back({i, ei, x});
    }
  const double min_side = o.min_side_frac * diag;
  // Quads down to `margin_probe_frac` x min_side are found only to recognise the margins of
  // objects too small to report (see the bright margin rule below); they are never reported.
  const double probe_side =
      o.prefer_inner_of_bright_margin ? o.margin_probe_frac * min_side : min_side;
  std::vector<Quad> quads;
  for (int a = 0; a < ns && static_cast<int>(quads.size()) < o.max_hypotheses; ++a)
    for (const Junction& jb : ends[a][1]) {
      const int b = jb.seg;
      if (b <= a) continue;
      for (const Junction& jc : ends[b][1 - jb.end]) {
        const int c = jc.seg;
        if (c <= a || c == b) continue;
        for (const Junction& jd : ends[c][1 - jc.end]) {
          const int d = jd.seg;
          if (d <= a || d == b || d == c) continue;
          for (const Junction& ja : ends[d][1 - jd.end]) {
            if (ja.seg != a || ja.end != 0) continue;
            Quad q;
            q.c = {jb.x, jc.x, jd.x, ja.x};
            q.seg = {a, b, c, d};
            if (!IsConvex(q.c) || ShortestSide(q.c) < probe_side) continue;
            quads.push_back(q);
          }
        }
      }
    }
  res.hypotheses = static_cast<int>(quads.size());
  for (const Quad& q : quads) res.hypothesis_quads.push_back(q.c);
  res.times.Add("group", sw.Lap());

  // 4. refinement (with a cheap rectangle pre-test at twice the tolerance on the hypothesis
  // corners).
  std::mt19937 rng(o.seed);
  const double min_gradient = res.canny_low / 8.0;  // Sobel magnitude ≈ 8 x (grey levels per px)
  std::vector<Quad> refined;
  const EdgeProbe probe(smooth, cam, o);
  auto LCornered = [&](const Quad& q) {
    return !(o.max_side_continuation < 1.0 || o.min_corner_reach > 0.0) ||
           !HasTJunction(probe, q.c_grouping, q.edges);
  };
  for (Quad& q : quads) {
    const RectangleTest pre = ZhangHeTest(q.c, K);
    if (!pre.valid || pre.abs_cos > std::min(1.0, 2.0 * o.max_abs_cos)) continue;
    // A corner so far out of view that refinement (which moves corners by at most 0.2 x the
    // shortest side + 2 search_px) cannot bring it within the cut-off container limit: neither a
    // detection nor a container.
    {
      const double side = ShortestSide(q.c);
      const double reach_out = (std::max(o.container_outside_frac, 0.0) + 0.2) * side +
                               2.0 * o.search_px + o.max_corner_outside_px;
      double outside = 0.0;
      for (const Vec2& c : q.c) {
        const Vec2 d = cam ? cam->DistortPixel(c) : c;
        outside =
            std::max({outside, -d.x(), -d.y(), d.x() - (gray.cols - 1), d.y() - (gray.rows - 1)});
      }
      if (outside > reach_out) continue;
    }
    if (RefineQuad(probe, segs, min_gradient, &rng, &q, &q.edges)) refined.push_back(q);
  }
  res.refined = static_cast<int>(refined.size());
  res.times.Add("refine", sw.Lap());

  // 5. verification on the refined corners, canonical order.
  std::vector<Quad> good, cut_off;
  for (Quad& q : refined) {
    if (ShortestSide(q.c) < probe_side) continue;
    q.c_grouping = q.c;
    q.c = CanonicalOrder(q.c, &K, gravity_C);
    const RectangleTest t = ZhangHeTest(q.c, K);
    if (!t.valid || t.abs_cos > o.max_abs_cos) continue;
    q.aspect_w_h = t.aspect_12_14;
    if (q.aspect_w_h > o.max_aspect || q.aspect_w_h < 1.0 / o.max_aspect) continue;
    q.abs_cos = t.abs_cos;
    q.score *= 1.0 - 0.5 * t.abs_cos / o.max_abs_cos;
    q.area = std::abs(SignedArea(q.c));
    // Every corner must be seen: a corner outside the image is an extrapolation of sides that run
    // out of the view (the object is cut off; its fourth side is some other line).
    bool in_view = true;
    double outside = 0.0;  // farthest distance of a corner outside the image [px, distorted]
    for (const Vec2& c : q.c) {
      const Vec2 d = cam ? cam->DistortPixel(c) : c;
      outside =
          std::max({outside, -d.x(), -d.y(), d.x() - (gray.cols - 1), d.y() - (gray.rows - 1)});
    }
    in_view = outside <= o.max_corner_outside_px;
    if (!in_view) {
      // A rectangle cut off by the image border by a little (a door whose bottom corners are just
      // out of view) is not reported, but what lies inside it (the door leaf, its panels) is part
      // of it: kept to suppress those.
      if (outside <= o.container_outside_frac * ShortestSide(q.c)) cut_off.push_back(q);
      continue;
    }
    // The costliest test (every corner an L-corner) is left to the suppression stage, which runs
    // it only on quads that would be kept or would replace a kept one, and on margin probes only
    // when one would mark a margin.
    good.push_back(q);
  }
  for (const Quad& q : good) res.verified_quads.emplace_back(q.c, q.score);
  res.times.Add("verify", sw.Lap());

  // 6. suppression: duplicates keep the best score, concentric nesting keeps the outer outline.
  // Undersized quads (probes) take no part in it; see the end of the loop.
  std::vector<Quad> probes, full;
  for (const Quad& q : good) (ShortestSide(q.c) < min_side ? probes : full).push_back(q);
  good.swap(full);
  std::stable_sort(good.begin(), good.end(),
                   [](const Quad& x, const Quad& y) { return x.score > y.score; });
  std::vector<Quad> kept;
  for (const Quad& q : good) {
    bool drop = false;
    Quad* replace = nullptr;  // the kept quad q would replace
    for (Quad& k : kept) {
      const double d = CornerDistanceBestShift(q.c, k.c);
      const double small_side = std::min(ShortestSide(q.c), ShortestSide(k.c));
      if (d <= std::max(2.0, o.duplicate_corner_frac * small_side)) {
        // Duplicate: the kept one scores at least as high. But when the new one is the outer of
        // two near-identical outlines (it contains the kept one, within 1 px of corner precision:
        // the outer edges of a thick border line against its inner edges) and is not clearly worse
        // supported, it replaces the kept one, as for concentric nesting below.
        if (q.area > k.area && q.score >= k.score - o.nest_score_margin && ContainsWithMargin(q.c, k.c, 1.0))
          replace = &k;
        drop = true;
        break;
      }
      const Quad& outer = q.area > k.area ? q : k;
      const Quad& inner = q.area > k.area ? k : q;
      // "Inside" with a margin: shared corners lie on the outer outline, not strictly inside it.
      const double dup_tol = std::max(2.0, o.duplicate_corner_frac * small_side);
      const bool inside = ContainsWithMargin(outer.c, inner.c, dup_tol);
      const bool concentric = d <= o.nest_corner_frac * ShortestSide(outer.c);
      if (!inside) {
        // Near-concentric but crossing (the left side from one outline, the right from the other):
        // another variant of the same object; the kept one scores at least as high.
        if (concentric) {
          drop = true;
          break;
        }
        continue;
      }
      if (concentric) {
        // A plain bright ring between the outlines is a margin (a tag's white border): the inner
        // outline is the object, whichever scores higher.
        if (o.prefer_inner_of_bright_margin && IsBrightMargin(smooth, cam, outer.c, inner.c, o)) {
          if (&inner == &q) replace = &k;
          drop = true;
          break;
        }
        // The new one is the outer outline: it replaces the kept inner one unless clearly worse
        // supported (a box's side face seen at an angle gives a weaker outer edge than its front).
        if (&outer == &q && q.score >= k.score - o.nest_score_margin) replace = &k;
        drop = true;
        break;
      }
      // Alternatives for one object: nested quads sharing two adjacent corners differ only in which
      // parallel line closes them (a board's top edge or the row of tags below it): best score
      // wins.
      int shift = 0;
      CornerDistanceBestShift(q.c, k.c, &shift);
      int shared_adjacent = 0;
      for (int i = 0; i < 4; ++i)
        shared_adjacent = std::max(
            shared_adjacent,
            static_cast<int>((q.c[i] - k.c[(i + shift) % 4]).norm() <= dup_tol &&
                             (q.c[(i + 1) % 4] - k.c[(i + 1 + shift) % 4]).norm() <= dup_tol));
      if (shared_adjacent) {
        drop = true;  // k scores at least as high (processing in score order)
        break;
      }
    }
    if (drop && !replace) continue;
    if (!LCornered(q)) continue;  // as if it had never been found
    if (replace)
      *replace = q;
    else
      kept.push_back(q);
  }
  // Replacing may have created duplicates among kept ones; remove exact repeats. (A second pass
  // that drops every quad nested in a kept outer one was tried: on the rendered default room it
  // lowered precision from 0.57 to 0.52, because the rendered tags' ground truth is the black
  // square inside the white margin, and on the EuRoC board it picked the board's side face.)
  // A bright margin around an object smaller than the minimum side (a small tag's white border):
  // the margin outline is not an object and the object is too small to report, so neither is.
  if (o.prefer_inner_of_bright_margin && !probes.empty()) {
    std::vector<Quad> not_margin;
    for (const Quad& k : kept) {
      bool margin = false;
      for (const Quad& p : probes) {
        if (margin || p.area >= k.area) continue;
        if (CornerDistanceBestShift(k.c, p.c) > o.nest_corner_frac * ShortestSide(k.c)) continue;
        // 2 px margin: variants of the outline share sides with the probe.
        margin = ContainsWithMargin(k.c, p.c, 2.0) && IsBrightMargin(smooth, cam, k.c, p.c, o) && LCornered(p);
      }
      if (!margin) not_margin.push_back(k);
    }
    kept.swap(not_margin);
  }
  std::vector<Quad> unique;
  for (const Quad& q : kept) {
    bool dup = false;
    for (const Quad& u : unique) dup = dup || CornerDistanceBestShift(q.c, u.c) < 1e-9;
    if (!dup) unique.push_back(q);
  }
  if (o.drop_contained) {
    // One object per outer rectangle: drop quads lying inside another kept quad (panes, door
    // panels, the pattern squares of a tag), with a 2 px margin for shared sides.
    std::vector<Quad> outer_only;
    for (const Quad& q : unique) {
      bool contained = false;
      for (const Quad& u : unique)
        contained = contained || (&u != &q && u.area > q.area && ContainsWithMargin(u.c, q.c, 2.0));
      for (const Quad& u : cut_off) {
        if (contained || u.area <= q.area) continue;
        contained = ContainsWithMargin(u.c, q.c, 2.0) &&
                    !(o.prefer_inner_of_bright_margin && IsBrightMargin(smooth, cam, u.c, q.c, o));
      }
      if (!contained) outer_only.push_back(q);
    }
    unique.swap(outer_only);
  }
  if (o.max_detections > 0 && static_cast<int>(unique.size()) > o.max_detections)
    unique.resize(o.max_detections);

  for (const Quad& q : unique) {
    Detection det;
    det.corners_undistorted = q.c;
    for (int i = 0; i < 4; ++i) det.corners_px[i] = cam ? cam->DistortPixel(q.c[i]) : q.c[i];
    det.score = q.score;
    if (o.guess_class) {
      // Class cues (see README of the front end): metric aspect h/w from Zhang-He, brightness
      // against the surroundings, interior texture. Statistics on the smoothed image at the
      // distorted corners.
      double in_mean, in_std, out_mean, out_std;
      QuadStats(smooth, det.corners_px, 0.8, &in_mean, &in_std);
      QuadStats(smooth, det.corners_px, 1.25, &out_mean, &out_std);
      const double h_over_w = 1.0 / q.aspect_w_h;
      //  - door: tall (metric h/w 1.7..3.2), not strongly textured;
      //  - window: much brighter than its surroundings (> 30 grey levels: daylight; mullions
      //  allowed);
      //  - poster: otherwise a strongly textured interior (grey-level std > 30: print, pattern);
      //    (a white calibration board on a dark background is therefore called a window);
      //  - cabinet is never guessed from one image (a cabinet front looks like a wall panel);
      //  - otherwise unknown.
      //  - tag (a fiducial without its id: use the AprilTag front end for ids): square-ish, a
      //    plain dark ring just inside the outline (the black border, 1/8 of the side: sampled at
      //    scale 0.875) inside a plain bright ring just outside it (the white margin, scale
      //    1.125), > 60 grey levels apart, and a patterned interior;
      //  - window: brighter than its surroundings (> 30 grey levels) with a frame: the ring just
      //    inside the outline (scale 0.95) darker than the interior on every side;
      //  - a bright interior without such a frame is a poster (a print on the wall).
      double ring_in, ring_in_std, ring_out, ring_out_std, frame, frame_std, frame_max;
      RingStats(smooth, det.corners_px, 0.875, &ring_in, &ring_in_std);
      RingStats(smooth, det.corners_px, 1.125, &ring_out, &ring_out_std);
      RingStats(smooth, det.corners_px, 0.95, &frame, &frame_std, &frame_max);
      const double tag_contrast = ring_out - ring_in;
      const bool tag_like = ring_in >= 0.0 && ring_out >= 0.0 && tag_contrast > 60.0 &&
                            ring_in_std < 0.25 * tag_contrast &&
                            ring_out_std < 0.25 * tag_contrast && in_std > 30.0 &&
                            h_over_w >= 0.67 && h_over_w <= 1.5;
      if (tag_like) {
        det.object_class = ObjectClass::kTag;
      } else if (h_over_w >= 1.7 && h_over_w <= 3.2 && in_std < 40.0) {
        det.object_class = ObjectClass::kDoor;
      } else if (out_mean >= 0.0 && in_mean - out_mean > 30.0 && h_over_w >= 0.4 &&
                 h_over_w <= 2.5) {
        det.object_class = frame >= 0.0 && frame_max < in_mean - 20.0 ? ObjectClass::kWindow
                                                                      : ObjectClass::kPoster;
      } else if (in_std > 30.0 && h_over_w >= 0.4 && h_over_w <= 2.5) {
        det.object_class = ObjectClass::kPoster;
      }
    }
    res.detections.push_back(det);
  }
  res.times.Add("nms", sw.Lap());
  return res;
}

}  // namespace fsp::frontend
