// Stage 4 of the rectangle detector, sub-pixel refinement of the sides on the image's edges, and
// the public form of it (edge_refine.h) for quads from elsewhere.
#include "fsp/frontend/edge_refine.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "fsp/common/error.h"
#include "fsp/common/median.h"
#include "fsp/frontend/rect_geometry.h"
#include "rect_internal.h"

namespace fsp::frontend {
namespace rect_internal {

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

namespace {

// Edge points found along one side of a quad, with buffers reused for every side.
struct SideSamples {
  bool curved = false;
  double L = 0.0;               // length along the side's polyline [px]
  double corner_stretch = 0.0;  // curved: the stretch next to each corner its end piece serves
  int k_samples = 0;            // positions searched
  int pos = 0, neg = 0;         // edge points of either polarity
  int on_path = 0;              // edge points within 1 px of the polyline
  std::vector<Vec2> poly, pts;  // polyline P, ..., Q; edge points (undistorted px)
  std::vector<double> cum, t_list, w, ts;  // arc length at poly; sample positions; gradient, t
  std::vector<int> sign;                   // per edge point
  std::vector<int> first_inl, second_inl;  // scratch of the bend check
};

// Searches edge points along side P → Q (its segment `sg_side` if any: its polyline when curved,
// else the straight line). False when the side is too short.
bool SampleSide(const EdgeProbe& probe, const Seg* sg_side, const Vec2& P, const Vec2& Q,
                int want_sign, double min_gradient, SideSamples* s) {
  const RectDetectorOptions& o = probe.o;
  // The side is sampled along its segment's polyline when curved (P, the pieces' joints, Q),
  // else along the straight line P → Q.
  s->poly.assign({P, Q});
  s->curved = sg_side && sg_side->path.size() > 2;
  const bool curved = s->curved;
  if (curved) {
    const auto& path = sg_side->path;
    const bool forward = (path.front() - P).squaredNorm() <= (path.back() - P).squaredNorm();
    s->poly.assign(1, P);
    for (size_t k = 1; k + 1 < path.size(); ++k)
      s->poly.push_back(forward ? path[k] : path[path.size() - 1 - k]);
    s->poly.push_back(Q);
  }
  const std::vector<Vec2>& poly = s->poly;
  std::vector<double>& cum = s->cum;
  cum.assign(1, 0.0);
  for (size_t k = 1; k < poly.size(); ++k)
    cum.push_back(cum.back() + (poly[k] - poly[k - 1]).norm());
  const double L = s->L = cum.back();
  if (!(L > 1.0)) return false;
  // A curved side is sampled every 3 px from close to its corners, and each corner comes from
  // the stretch of its end piece nearest to it (`curved_corner_frac`): the rest of a curled
  // page's edge wanders by a pixel or more.
  const double margin = curved ? std::max(o.search_px + 1.0, 0.01 * L)
                               : std::max(o.corner_margin_frac * (Q - P).norm(), 1.0);
  // Sample positions along the side: evenly spaced on a straight side; on a curved one every
  // 3 px in the stretch next to each corner and `samples_per_side` / 2 in between.
  const double corner_stretch = s->corner_stretch =
      margin + std::max(30.0, o.curved_corner_frac * L);
  std::vector<double>& t_list = s->t_list;
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
  s->k_samples = static_cast<int>(t_list.size());
  s->pts.clear();
  s->w.clear();
  s->ts.clear();
  s->sign.clear();
  s->pos = s->neg = s->on_path = 0;
  size_t piece = 0;
  for (const double t : t_list) {
    while (piece + 2 < poly.size() && t > cum[piece + 1]) ++piece;
    const Vec2 ue = (poly[piece + 1] - poly[piece]).normalized(), n(-ue.y(), ue.x());
    const Vec2 p = poly[piece] + (t - cum[piece]) * ue;
    Vec2 e;
    double gradient;
    int sg;
    if (!probe.Peak(p, n, min_gradient, &e, &gradient, &sg, want_sign)) continue;
    (sg > 0 ? s->pos : s->neg)++;
    s->on_path += std::abs(n.dot(e - p)) <= 1.0;
    s->pts.push_back(e);
    s->w.push_back(gradient);
    s->ts.push_back(t);
    s->sign.push_back(sg);
  }
  return true;
}

// The line(s) of a straight side P → Q from its edge points (indices `all`, and those of its two
// halves): one RANSAC line, or a line per half when the side is bent by more than `bend_px` at the
// corners. Adds the side's support to `support_sum`; false when it is too weak.
bool FitStraightSide(const EdgeProbe& probe, SideSamples* s, const std::vector<int>& all,
                     const std::vector<int>& first, const std::vector<int>& second, int need,
                     const Vec2& P, const Vec2& Q, std::mt19937* rng, Line* start_line,
                     Line* end_line, double* support_sum) {
  const RectDetectorOptions& o = probe.o;
  const std::vector<Vec2>& pts = s->pts;
  const std::vector<double>& w = s->w;
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
    std::vector<int>& in1 = s->first_inl;
    std::vector<int>& in2 = s->second_inl;
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
    *start_line = *end_line = global;
    *support_sum += static_cast<double>(n_global) / s->k_samples;
  } else {
    *start_line = l1;
    *end_line = l2;
    *support_sum += static_cast<double>(n1 + n2) / s->k_samples;
  }
  return true;
}

// Fits side P → Q (direction u) from its samples: the majority polarity's edge points, the side's
// edge description, then the end lines (a curved side: one line per end piece).
bool FitSide(const EdgeProbe& probe, SideSamples* s, const Vec2& P, const Vec2& Q, const Vec2& u,
             std::mt19937* rng, Line* start_line, Line* end_line, SideEdge* side_edge,
             double* support_sum) {
  const RectDetectorOptions& o = probe.o;
  const bool curved = s->curved;
  const double L = s->L;
  const std::vector<double>& cum = s->cum;
  // Keep the majority polarity: a side's edge has one polarity; the other is a neighbouring edge.
  const int keep = s->pos >= s->neg ? 1 : -1;
  std::vector<int> all, first, second;
  std::vector<double> grads;
  // Halves of a straight side; the end pieces of a curved one.
  const double first_end = curved ? std::min(cum[1], s->corner_stretch) : 0.5 * L;
  const double second_start =
      curved ? std::max(cum[cum.size() - 2], L - s->corner_stretch) : 0.5 * L;
  for (size_t i = 0; i < s->pts.size(); ++i) {
    if (s->sign[i] != keep) continue;
    all.push_back(static_cast<int>(i));
    grads.push_back(s->w[i]);
    if (s->ts[i] < first_end) first.push_back(static_cast<int>(i));
    if (s->ts[i] >= second_start) second.push_back(static_cast<int>(i));
  }
  const int need = static_cast<int>(std::ceil(o.min_side_support * s->k_samples));
  if (static_cast<int>(all.size()) < std::max(need, 2)) return false;
  std::nth_element(grads.begin(), grads.begin() + grads.size() / 2, grads.end());
  side_edge->sign = keep;
  side_edge->gradient = grads[grads.size() / 2];
  side_edge->curved = curved;
  if (!curved)
    return FitStraightSide(probe, s, all, first, second, need, P, Q, rng, start_line, end_line,
                           support_sum);
  Line l1, l2;
  const int n1 = RansacLine(s->pts, s->w, first, o.ransac_inlier_px, o.ransac_iterations, rng, &l1);
  const int n2 =
      RansacLine(s->pts, s->w, second, o.ransac_inlier_px, o.ransac_iterations, rng, &l2);
  if (n1 < 3 || n2 < 3 || s->on_path < need) return false;
  *start_line = l1;
  *end_line = l2;
  // Directions along the end lines, pointing from P towards Q.
  for (const auto& [line, dir] :
       {std::make_pair(&l1, &side_edge->dir_start), std::make_pair(&l2, &side_edge->dir_end)}) {
    *dir = Vec2(line->n.y(), -line->n.x());
    if (dir->dot(u) < 0.0) *dir = -*dir;
  }
  *support_sum += static_cast<double>(s->on_path) / s->k_samples;
  return true;
}

}  // namespace

// Sub-pixel refinement of one quad. Side i joins corners c[i-1] and c[i]; its edge points come from
// 1-D gradient peaks along the side's normal in the (smoothed, distorted) image. Each side gets one
// RANSAC line; when the lines fitted to its two halves disagree with it by more than `bend_px` at
// the corners (a bent side: paper, residual distortion), each corner is taken from the half-lines
// next to it.
// `side_want` gives the polarity of sides without a segment (0: either).
bool RefineQuad(const EdgeProbe& probe, const std::vector<Seg>& segs, double min_gradient,
                std::mt19937* rng, Quad* q, std::array<SideEdge, 4>* side_edges,
                const std::array<int, 4>& side_want) {
  const RectDetectorOptions& o = probe.o;
  std::array<Line, 4> start_line, end_line;  // line used at the side's first / last corner
  double support_sum = 0.0;
  SideSamples s;
  for (int side = 0; side < 4; ++side) {
    const Vec2 P = q->c[(side + 3) % 4], Q = q->c[side];
    const Seg* sg_side = q->seg[side] >= 0 ? &segs[q->seg[side]] : nullptr;
    const Vec2 u = (Q - P).normalized();
    // The segment's polarity fixes the side's: only edges of that polarity are searched (a thin
    // line's other edge, a groove's, is not the side). Segments are brighter towards (dy, -dx)
    // (see the segments stage), the opposite of n = (-u.y, u.x) here when they run along u.
    const int want_sign = !sg_side ? side_want[side]
                          : o.polarity_from_segment && !sg_side->mixed
                              ? (sg_side->dir.dot(u) > 0.0 ? -1 : 1)
                              : 0;
    if (!SampleSide(probe, sg_side, P, Q, want_sign, min_gradient, &s)) return false;
    (*side_edges)[side] = SideEdge();
    if (!FitSide(probe, &s, P, Q, u, rng, &start_line[side], &end_line[side], &(*side_edges)[side],
                 &support_sum)) {
      if (side != q->weak_side) return false;
      // A weak side without edge support keeps the hypothesis' line (and adds no support).
      start_line[side] = end_line[side] = LineOf(MakeSeg(P, Q));
      (*side_edges)[side] = SideEdge();
      (*side_edges)[side].weak = true;
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

// Frame outline (RectDetectorOptions::frame_band_max_frac). Along each side, at kPositions points
// of its middle 70 %, the grey 1.5 px inside and outside; a side's contrast is the median of inside
// - outside. The band on the opposite side: the 1-D profile inward from its outline, the strongest
// step of the odd side's polarity from 1 px on (a parabola through the steps for its sub-pixel
// place). All on the smoothed image the refinement reads (distorted), at undistorted points.
namespace {

constexpr int kPositions = 12;

// Grey of the smoothed image at undistorted point p; false outside.
bool GreyAt(const EdgeProbe& probe, const Vec2& p, double* v) {
  const Vec2 d = probe.cam ? probe.cam->DistortPixel(p) : p;
  return Bilinear(probe.smooth, d.x(), d.y(), v);
}

// The unit normal of side P -> Q pointing into the quad (towards `centre`).
Vec2 InwardNormal(const Vec2& P, const Vec2& Q, const Vec2& centre) {
  const Vec2 u = (Q - P).normalized();
  Vec2 n(-u.y(), u.x());
  if (n.dot(centre - 0.5 * (P + Q)) < 0.0) n = -n;
  return n;
}

// The k-th sample position along a side, as a fraction of it from P.
double PositionT(int k) {
  return 0.15 + 0.7 * (k + 0.5) / kPositions;
}

}  // namespace

bool MoveOntoFrameOutline(const EdgeProbe& probe, Corners* corners) {
  const RectDetectorOptions& o = probe.o;
  if (!(o.frame_band_max_frac > 0.0)) return false;
  Corners& c = *corners;
  const Vec2 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  std::array<double, 4> contrast{};
  std::array<int, 4> pol{};
  for (int i = 0; i < 4; ++i) {
    const Vec2 P = c[(i + 3) % 4], Q = c[i], n = InwardNormal(P, Q, centre);
    std::vector<double> diffs;
    for (int k = 0; k < kPositions; ++k) {
      const Vec2 b = P + PositionT(k) * (Q - P);
      double vin, vout;
      if (GreyAt(probe, b + 1.5 * n, &vin) && GreyAt(probe, b - 1.5 * n, &vout))
        diffs.push_back(vin - vout);
    }
    if (static_cast<int>(diffs.size()) < kPositions / 2) return false;
    contrast[i] = Median(diffs);
    pol[i] = contrast[i] > 0.0 ? 1 : -1;
  }
  // The odd side: its inside brighter (darker) where the three others' is darker (brighter).
  int j = -1;
  for (int i = 0; i < 4; ++i)
    if (pol[i] != pol[(i + 1) % 4] && pol[i] != pol[(i + 3) % 4]) j = i;
  if (j < 0) return false;
  const int opp = (j + 2) % 4;
  // The band on the opposite side: from its outline inward to a step of side j's polarity.
  const Vec2 Po = c[(opp + 3) % 4], Qo = c[opp], no = InwardNormal(Po, Qo, centre);
  const double step = 0.5;
  const double max_d = o.frame_band_max_frac * ShortestSide(c);
  const int K = static_cast<int>(max_d / step);
  if (K < 4) return false;
  std::vector<double> widths, band, panel, prof(static_cast<size_t>(K + 2));
  for (int k = 0; k < kPositions; ++k) {
    const Vec2 b = Po + PositionT(k) * (Qo - Po);
    bool ok = true;
    for (int s = 0; s <= K + 1 && ok; ++s) ok = GreyAt(probe, b + (s * step) * no, &prof[s]);
    if (!ok) continue;
    int best = -1;
    double best_d = 0.0;
    for (int s = 2; s < K; ++s) {
      const double d = pol[j] * (prof[s + 1] - prof[s - 1]);  // grey levels per px
      if (d > best_d) {
        best_d = d;
        best = s;
      }
    }
    if (best < 0 || best_d < 0.25 * std::abs(contrast[j])) continue;
    const double dm = pol[j] * (prof[best] - prof[best - 2]);
    const double dp = best + 2 <= K + 1 ? pol[j] * (prof[best + 2] - prof[best]) : best_d;
    const double den = dm - 2.0 * best_d + dp;
    const double delta = den < 0.0 ? std::clamp(0.5 * (dm - dp) / den, -0.5, 0.5) : 0.0;
    widths.push_back((best + delta) * step);
    band.push_back(prof[static_cast<size_t>(best / 2)]);
    panel.push_back(prof[static_cast<size_t>(std::min(best + 3, K + 1))]);
  }
  if (static_cast<int>(widths.size()) < 2 * kPositions / 3) return false;
  const double w_opp = Median(widths), grey_band = Median(band);
  const double frame_contrast = std::abs(Median(panel) - grey_band);
  int consistent = 0;
  for (double w : widths) consistent += std::abs(w - w_opp) <= 1.0;
  if (consistent < 2 * kPositions / 3) return false;
  // Side j is a frame's inner edge: its contrast is the frame's, not a faint outline's.
  if (std::abs(contrast[j]) < 0.5 * frame_contrast || frame_contrast < 16.0) return false;
  // The band's width at side j and its grey outside side j (not inside it: there is the panel).
  const Vec2 P = c[(j + 3) % 4], Q = c[j], n = InwardNormal(P, Q, centre);
  const double w_j = w_opp * (Q - P).norm() / (Qo - Po).norm();
  if (w_j < 1.0 || w_j > max_d) return false;
  std::vector<double> outside, inside;
  for (int k = 0; k < kPositions; ++k) {
    const Vec2 b = P + PositionT(k) * (Q - P);
    double v1, v2, v3;
    if (GreyAt(probe, b - 0.3 * w_j * n, &v1) && GreyAt(probe, b - 0.7 * w_j * n, &v2) &&
        GreyAt(probe, b + 0.5 * w_j * n, &v3)) {
      outside.push_back(std::max(std::abs(v1 - grey_band), std::abs(v2 - grey_band)));
      inside.push_back(std::abs(v3 - grey_band));
    }
  }
  if (static_cast<int>(outside.size()) < kPositions / 2 || Median(outside) > 0.4 * frame_contrast ||
      Median(inside) < 0.5 * frame_contrast)
    return false;
  // The outline: side j's line moved out by w_j, onto an edge found within 1.5 px of it.
  Line line;
  line.n = n;
  line.c = n.dot(P) - w_j;
  std::vector<Vec2> pts;
  std::vector<double> wts;
  for (int k = 0; k < kPositions; ++k) {
    const Vec2 b = P + PositionT(k) * (Q - P) - w_j * n;
    std::array<double, 9> v{};  // -2 .. +2 px along n, 0.5 px apart
    bool ok = true;
    for (int s = 0; s < 9 && ok; ++s) ok = GreyAt(probe, b + (0.5 * (s - 4)) * n, &v[s]);
    if (!ok) continue;
    int best = -1;
    double best_d = 0.0;
    for (int s = 1; s < 8; ++s) {
      const double d = std::abs(v[s + 1] - v[s - 1]);
      if (d > best_d) {
        best_d = d;
        best = s;
      }
    }
    if (best <= 1 || best >= 7 || best_d < 2.0) continue;
    pts.push_back(b + (0.5 * (best - 4)) * n);
    wts.push_back(best_d);
  }
  if (static_cast<int>(pts.size()) >= 2 * kPositions / 3) {
    std::vector<int> idx(pts.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<int>(i);
    Line found;
    if (FitLineTls(pts, wts, idx, &found)) {
      if (found.n.dot(n) < 0.0) {
        found.n = -found.n;
        found.c = -found.c;
      }
      const double shift = std::abs(found.c - line.c);
      if (found.n.dot(n) > std::cos(3.0 * M_PI / 180.0) && shift <= 1.5) line = found;
    }
  }
  // New corners: the moved line with the two neighbouring sides' lines.
  const int a = (j + 3) % 4, b = j;
  const Line before = LineOf(MakeSeg(c[(j + 2) % 4], c[a]));
  const Line after = LineOf(MakeSeg(c[b], c[(j + 1) % 4]));
  Vec2 ca, cb;
  if (!Intersect(before, line, &ca) || !Intersect(line, after, &cb)) return false;
  Corners moved = c;
  moved[a] = ca;
  moved[b] = cb;
  if (!IsConvex(moved)) return false;
  c = moved;
  return true;
}

// Thin bands (RectDetectorOptions::band_max_px). Across each side, at kPositions points of its
// middle 70 %, the profile of the smoothed image from -R to +R px along the side's normal; their
// median per offset is the side's profile. Where an edge of the opposite polarity lies within
// band_max_px of the side's gradient peak on one side of it (a frame's inner edge), the profile is
// fitted with a blurred step per edge, y(s) = B + c1 Phi((s - a1) / sg) + c2 Phi((s - a2) / sg)
// (Levenberg-Marquardt, all six free), and the side moves from the peak to its step's a: blurred
// edges' gradients overlap and push each other's peaks apart, by ~w exp(-w^2 / 2 sg^2) for a band
// of width w. For bands thinner than the blur the profile fixes the band's centre better than its
// width, so a part of the push remains (tests/frontend/test_edge_refine.cc: 1-3 px frames).
namespace {

constexpr double kBandStep = 0.5;  // profile sample spacing [px]

// Fits theta = {B, c_1..c_m, a_1..a_m, log sg} (initial values in, fit out) to samples (s, y);
// RMS: the fit's RMS residual [grey levels].
bool FitEdges(const std::vector<double>& s, const std::vector<double>& y, Eigen::VectorXd* theta,
              double* rms) {
  const int m = static_cast<int>((theta->size() - 2) / 2);
  const int np = static_cast<int>(theta->size());
  const double kInvSqrt2 = 1.0 / std::sqrt(2.0), kInvSqrt2Pi = 1.0 / std::sqrt(2.0 * M_PI);
  Eigen::VectorXd J(np);
  auto evaluate = [&](const Eigen::VectorXd& t, Eigen::MatrixXd* H, Eigen::VectorXd* g) {
    const double sg = std::exp(t[np - 1]);
    double cost = 0.0;
    if (H) H->setZero(np, np);
    if (g) g->setZero(np);
    for (size_t k = 0; k < s.size(); ++k) {
      double r = t[0] - y[k];
      J.setZero();
      J[0] = 1.0;
      for (int e = 0; e < m; ++e) {
        const double z = (s[k] - t[1 + m + e]) / sg;
        const double P = 0.5 * std::erfc(-z * kInvSqrt2);
        r += t[1 + e] * P;
        if (!H) continue;
        const double f = kInvSqrt2Pi * std::exp(-0.5 * z * z);
        J[1 + e] = P;
        J[1 + m + e] = -t[1 + e] * f / sg;
        J[np - 1] -= t[1 + e] * f * z;
      }
      cost += r * r;
      if (!H) continue;
      H->selfadjointView<Eigen::Lower>().rankUpdate(J);
      *g += J * r;
    }
    if (H) *H = H->selfadjointView<Eigen::Lower>();
    return cost;
  };
  Eigen::VectorXd t = *theta, g;
  Eigen::MatrixXd H;
  double cost = evaluate(t, &H, &g), lambda = 1e-3;
  bool converged = false;
  for (int it = 0; it < 20 && !converged; ++it) {
    Eigen::MatrixXd A = H;
    A.diagonal() += lambda * H.diagonal() + Eigen::VectorXd::Constant(np, 1e-12);
    const Eigen::VectorXd dx = A.ldlt().solve(-g);
    if (!dx.allFinite()) return false;
    const Eigen::VectorXd tn = t + dx;
    const double cn = evaluate(tn, nullptr, nullptr);
    if (cn < cost) {
      converged = dx.tail(m + 1).cwiseAbs().maxCoeff() < 1e-4;
      t = tn;
      cost = evaluate(t, &H, &g);
      lambda = std::max(lambda / 3.0, 1e-9);
    } else {
      lambda *= 4.0;
      converged = lambda > 1e6;
    }
  }
  *theta = t;
  *rms = std::sqrt(cost / static_cast<double>(s.size()));
  return t.allFinite();
}

// The offset [px, along n] from side P -> Q's gradient peak to the edge of the model, when an edge
// of the opposite polarity lies within band_max_px; false (no move) otherwise.
bool BandOffset(const EdgeProbe& probe, const Vec2& P, const Vec2& Q, const Vec2& n,
                double* offset) {
  const RectDetectorOptions& o = probe.o;
  const int K = static_cast<int>(std::ceil((o.band_max_px + 2.5) / kBandStep));
  const int N = 2 * K + 1;
  std::vector<std::vector<double>> at(N);  // grey per offset, over the positions
  std::vector<double> v(N);
  for (int k = 0; k < kPositions; ++k) {
    const Vec2 b = P + PositionT(k) * (Q - P);
    bool ok = true;
    for (int i = 0; i < N && ok; ++i) ok = GreyAt(probe, b + ((i - K) * kBandStep) * n, &v[i]);
    if (!ok) continue;
    for (int i = 0; i < N; ++i) at[i].push_back(v[i]);
  }
  if (static_cast<int>(at[0].size()) < 2 * kPositions / 3) return false;
  std::vector<double> s(N), y(N), grad(N, 0.0);
  for (int i = 0; i < N; ++i) {
    s[i] = (i - K) * kBandStep;
    y[i] = Median(at[i]);
  }
  const int d = static_cast<int>(std::lround(0.5 / kBandStep));  // central difference over 1 px
  for (int i = d; i < N - d; ++i) grad[i] = y[i + d] - y[i - d];
  // The side's peak: the strongest gradient within 1 px of the line.
  const int one_px = static_cast<int>(std::lround(1.0 / kBandStep));
  int pk = -1;
  for (int i = K - one_px; i <= K + one_px; ++i)
    if (pk < 0 || std::abs(grad[i]) > std::abs(grad[pk])) pk = i;
  const double pol = grad[pk] > 0.0 ? 1.0 : -1.0;
  if (std::abs(grad[pk]) < 2.0) return false;
  auto vertex = [&](int i, double sign) {  // parabola through sign * grad at i-1, i, i+1
    const double gm = sign * grad[i - 1], g0 = sign * grad[i], gp = sign * grad[i + 1];
    const double den = gm - 2.0 * g0 + gp;
    return s[i] + (den < 0.0 ? std::clamp(0.5 * (gm - gp) / den, -0.5, 0.5) : 0.0) * kBandStep;
  };
  const double s_pk = vertex(pk, pol);
  // The nearest strong opposite edge (a local maximum of -pol * grad) within band_max_px on
  // either side.
  std::array<int, 2> nb = {-1, -1};  // before, after the peak
  for (int i = d + 1; i < N - d - 1; ++i) {
    const double gi = -pol * grad[i];
    const double dist = std::abs(s[i] - s_pk);
    if (dist < 0.75 || dist > o.band_max_px || gi < 0.25 * std::abs(grad[pk])) continue;
    if (gi < -pol * grad[i - 1] || gi < -pol * grad[i + 1]) continue;
    int& slot = nb[s[i] > s_pk ? 1 : 0];
    if (slot < 0 || dist < std::abs(s[slot] - s_pk)) slot = i;
  }
  // None: no band. One on either side (a tag's black border between its white margin and its
  // white cells): their pushes oppose and the mix of cells along the side makes the profile no
  // model of it (the rendered room's small tags came out 0.1-0.2 px too large with it).
  if ((nb[0] < 0) == (nb[1] < 0)) return false;
  // The two edges in order of s, each step initialised from the grey halfway to its neighbours.
  const int main_edge = nb[0] >= 0 ? 1 : 0;
  const std::array<int, 2> idx = {main_edge == 1 ? nb[0] : pk, main_edge == 1 ? pk : nb[1]};
  constexpr int m = 2;
  Eigen::VectorXd th(2 * m + 2);
  th[0] = y[0];
  double prev = y[0];
  for (int e = 0; e < m; ++e) {
    const double next = e + 1 < m ? y[(idx[e] + idx[e + 1]) / 2] : y[N - 1];
    th[1 + e] = next - prev;
    th[1 + m + e] = idx[e] == pk ? s_pk : vertex(idx[e], -pol);
    prev = next;
  }
  th[2 * m + 1] = std::log(1.2);
  double rms = 0.0;
  if (!FitEdges(s, y, &th, &rms)) return false;
  const double sg = std::exp(th[2 * m + 1]);
  // A plausible fit: two clean steps (RMS residual within 5 % of the smaller step), a blur of
  // 0.85-1.5 px (the refinement's own smoothing is 1 px; a wider fitted blur means the profile is
  // something else, such as a cabinet's frame beside a faint inset line: moved 0.7 px inwards
  // without this), the edges keeping their polarities and order, and the side's edge moving by at
  // most 1.5 px.
  if (!(sg >= 0.85 && sg <= 1.5) || !(rms <= 0.05 * std::min(std::abs(th[1]), std::abs(th[2]))))
    return false;
  for (int e = 0; e < m; ++e) {
    if ((e == main_edge ? pol : -pol) * th[1 + e] <= 0.0) return false;
    if (e > 0 && th[1 + m + e] <= th[m + e]) return false;
  }
  const double move = th[1 + m + main_edge] - s_pk;
  if (std::abs(move) > 1.5) return false;
  *offset = move;
  return true;
}

}  // namespace

void CorrectBandOffsets(const EdgeProbe& probe, Corners* corners) {
  if (!(probe.o.band_max_px > 0.0)) return;
  const Corners& c = *corners;
  std::array<Line, 4> lines;
  bool moved = false;
  for (int i = 0; i < 4; ++i) {
    const Vec2 P = c[(i + 3) % 4], Q = c[i];
    lines[i] = LineOf(MakeSeg(P, Q));
    double offset = 0.0;
    if (BandOffset(probe, P, Q, lines[i].n, &offset)) {
      lines[i].c += offset;
      moved = true;
    }
  }
  if (!moved) return;
  Corners out;
  for (int i = 0; i < 4; ++i)
    if (!Intersect(lines[i], lines[(i + 1) % 4], &out[i])) return;
  if (IsConvex(out)) *corners = out;
}

std::vector<Quad> RefineHypotheses(std::vector<Quad>& quads, const std::vector<Seg>& segs,
                                   const EdgeProbe& probe, const std::vector<Mat3>& Ks,
                                   double min_gradient) {
  const RectDetectorOptions& o = probe.o;
  std::mt19937 rng(o.seed);
  std::vector<Quad> refined;
  // The coarse pass of the texture hypotheses: the same probe with a wider search.
  RectDetectorOptions wide = o;
  wide.search_px = std::max(o.search_px, o.texture_search_px);
  const EdgeProbe wide_probe(probe.smooth, probe.cam, wide);
  for (Quad& q : quads) {
    const RectangleTest pre = BestRectangleTest(q.c, Ks);
    if (!pre.valid || pre.abs_cos > std::min(1.0, 2.0 * o.max_abs_cos)) continue;
    // A corner so far out of view that refinement (which moves corners by at most 0.2 x the
    // shortest side + 2 search_px) cannot bring it within the cut-off container limit: neither a
    // detection nor a container.
    const double side = ShortestSide(q.c);
    const double reach_out = (std::max(o.container_outside_frac, 0.0) + 0.2) * side +
                             2.0 * o.search_px + o.max_corner_outside_px;
    if (CornerOutside(q.c, probe.cam, probe.smooth.cols, probe.smooth.rows) > reach_out) continue;
    const Quad hypothesis = q;
    if (RefineQuad(probe, segs, min_gradient, &rng, &q, &q.edges)) {
      refined.push_back(q);
      continue;
    }
    // A texture hypothesis the usual search does not refine (its corners, scaled up from the
    // averaged map, are up to ~4 px off): a coarse pass, then the usual one. Only as a fallback:
    // where the usual pass refines a checkerboard's outline, a coarse pass before it reaches the
    // pattern's own edges next to the outline and loses it.
    q = hypothesis;
    if (q.texture && o.texture_search_px > o.search_px &&
        RefineQuad(wide_probe, segs, min_gradient, &rng, &q, &q.edges) &&
        RefineQuad(probe, segs, min_gradient, &rng, &q, &q.edges))
      refined.push_back(q);
  }
  return refined;
}

}  // namespace rect_internal

using rect_internal::EdgeProbe;
using rect_internal::Quad;
using rect_internal::SideEdge;

cv::Mat EdgeRefineImage(const cv::Mat& gray) {
  FSP_CHECK(gray.type() == CV_8UC1 && !gray.empty());
  cv::Mat smooth;
  cv::GaussianBlur(gray, smooth, cv::Size(5, 5), 1.0, 1.0, cv::BORDER_REPLICATE);
  return smooth;
}

bool SmoothForEdgeRefine(const cv::Mat& gray, cv::Rect region, cv::Mat* smooth) {
  FSP_CHECK(gray.type() == CV_8UC1 && !gray.empty());
  if (smooth->size() != gray.size() || smooth->type() != CV_8UC1)
    smooth->create(gray.size(), CV_8UC1);
  region &= cv::Rect(0, 0, gray.cols, gray.rows);
  if (region.area() <= 0) return false;
  cv::GaussianBlur(gray(region), (*smooth)(region), cv::Size(5, 5), 1.0, 1.0, cv::BORDER_REPLICATE);
  return true;
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
  rect_internal::MoveOntoFrameOutline(probe, &q.c);
  rect_internal::CorrectBandOffsets(probe, &q.c);
  out.corners_undistorted = q.c;
  out.support = q.score;
  for (int i = 0; i < 4; ++i) {
    out.side_sign[i] = edges[i].sign;
    out.side_gradient[i] = edges[i].gradient;
  }
  return out;
}

}  // namespace fsp::frontend
