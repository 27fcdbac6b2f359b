// Stage 2 of the rectangle detector: segments from the straight pieces of the edge chains
// (polarity, undistortion, collinear merge, curved chains).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "rect_internal.h"

namespace fsp::frontend::rect_internal {

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

namespace {

// One group of compatible pieces `g` (indices into `in`) becomes one segment: the length-weighted
// TLS line through all their endpoints, spanning their projections onto it. A group that bends
// too far from that line (an arc of continuations) stays as its pieces.
// Returns whether the group became one segment.
bool MergeGroup(const std::vector<Seg>& in, const std::vector<int>& g, double line_px,
                std::vector<Seg>* out) {
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
  if (!FitLineTls(pts, w, idx, &l)) return false;
  Vec2 dir(l.n.y(), -l.n.x());
  if (dir.dot(in[g[0]].dir) < 0.0) dir = -dir;  // keep the polarity orientation
  const Vec2 p0 = l.c * l.n;
  // Guard against chains of continuations that bend too far (an arc): keep the pieces then.
  double worst = 0.0, extent = 0.0;
  for (const auto& p : pts) worst = std::max(worst, std::abs(l.Dist(p)));
  for (int i : g) extent += in[i].len;
  if (worst > std::max(line_px, 0.01 * extent)) {
    for (int i : g) out->push_back(in[i]);
    return false;
  }
  double lo = 1e300, hi = -1e300;
  for (const auto& p : pts) {
    const double t = (p - p0).dot(dir);
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  Seg merged = MakeSeg(p0 + lo * dir, p0 + hi * dir);
  for (int i : g) merged.mixed = merged.mixed || in[i].mixed || in[i].dir.dot(dir) < 0.0;
  out->push_back(std::move(merged));
  return true;
}

}  // namespace

// Merges collinear pieces (union of compatible pairs, then one TLS line through all endpoints).
std::vector<Seg> MergeCollinear(const std::vector<Seg>& in, double angle_deg, double line_px,
                                double gap_px, bool any_polarity, bool only_joined) {
  const int n = static_cast<int>(in.size());
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  // Directions as angles in [0, 2π) (with `any_polarity`, of the undirected line: [0, π)).
  const double period = any_polarity ? M_PI : 2 * M_PI;
  std::vector<double> theta(n);
  for (int i = 0; i < n; ++i)
    theta[i] = std::fmod(std::atan2(in[i].dir.y(), in[i].dir.x()) + 2 * M_PI, period);
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int i, int j) { return theta[i] < theta[j]; });
  const double tol = angle_deg * M_PI / 180.0;
  const double cos_tol = std::cos(tol);
  auto aligned = [&](const Seg& s, const Seg& t) {
    const double c = s.dir.dot(t.dir);
    return (any_polarity ? std::abs(c) : c) >= cos_tol;
  };
  auto compatible = [&](const Seg& s, const Seg& t) {
    if (!aligned(s, t)) return false;  // same polarity only unless any_polarity
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
    if (any_polarity || s.dir.dot(t.dir) < cos_tol) return false;
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
      if (d < 0) d += period;
      if (d > tol) break;
      if (compatible(in[i], in[j]) || continues(in[i], in[j])) parent[find(i)] = find(j);
    }
  }
  std::vector<std::vector<int>> groups(n);
  for (int i = 0; i < n; ++i) groups[find(i)].push_back(i);
  std::vector<Seg> out;
  for (const auto& g : groups) {
    if (g.empty()) continue;
    if (only_joined) {
      std::vector<Seg> joined;
      if (g.size() > 1 && MergeGroup(in, g, line_px, &joined)) out.push_back(std::move(joined[0]));
      continue;
    }
    if (g.size() == 1) {
      out.push_back(in[g[0]]);
      continue;
    }
    MergeGroup(in, g, line_px, &out);
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

namespace {

// Orients a piece by polarity: brighter side on the left of a → b (image x right, y down: left
// normal is (dy, -dx) for direction (dx, dy)), from the smoothed image at five points along it.
void OrientByPolarity(const cv::Mat& smooth, Vec2* a, Vec2* b) {
  const Vec2 d = *b - *a;
  const Vec2 left = Vec2(d.y(), -d.x()).normalized();
  double sum = 0.0;
  for (int k = 1; k <= 5; ++k) {
    const Vec2 p = *a + (k / 6.0) * d;
    double vl = 0.0, vr = 0.0;
    if (Bilinear(smooth, p.x() + 1.5 * left.x(), p.y() + 1.5 * left.y(), &vl) &&
        Bilinear(smooth, p.x() - 1.5 * left.x(), p.y() - 1.5 * left.y(), &vr))
      sum += vl - vr;
  }
  if (sum < 0.0) std::swap(*a, *b);
}

}  // namespace

std::vector<Seg> BuildSegments(const std::vector<std::pair<Vec2, Vec2>>& pieces,
                               const cv::Mat& smooth, const PinholeRadtan* cam,
                               const RectDetectorOptions& o, double diag, int min_seg) {
  std::vector<Seg> segs;
  segs.reserve(pieces.size());
  for (const auto& r : pieces) {
    Vec2 a = r.first, b = r.second;
    OrientByPolarity(smooth, &a, &b);
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
  if (o.bridge_gap_frac > 0.0) {
    // Bridged sides (grouping only): segments of either polarity on one line with gaps of up to
    // `bridge_gap_frac` of the diagonal, from segments of at least `bridge_min_piece_frac` of it,
    // appended as segments of their own when at least
    // `bridge_min_frac` of the diagonal long (a side whose background changes along it, a side
    // broken by clutter crossing it); the pieces stay as they are.
    std::vector<Seg> long_segs;
    for (const Seg& sg : segs)
      if (sg.len >= o.bridge_min_piece_frac * diag) long_segs.push_back(sg);
    for (Seg& b : MergeCollinear(long_segs, o.merge_angle_deg, o.merge_line_px,
                                 o.bridge_gap_frac * diag, true, true))
      if (b.len >= o.bridge_min_frac * diag) segs.push_back(std::move(b));
  }
  if (o.curved_step_deg > 0.0)
    for (Seg& c : CurvedChains(segs, o.merge_line_px, o.curved_step_deg, o.curved_total_deg,
                               o.curved_min_frac * diag))
      segs.push_back(std::move(c));
  return segs;
}

}  // namespace fsp::frontend::rect_internal
