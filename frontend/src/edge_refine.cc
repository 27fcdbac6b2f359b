// Stage 4 of the rectangle detector, sub-pixel refinement of the sides on the image's edges, and
// the public form of it (edge_refine.h) for quads from elsewhere.
#include "fsp/frontend/edge_refine.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <opencv2/imgproc.hpp>

#include "fsp/common/error.h"
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
    // The hypothesis' corners come from segments (about a pixel off): twice the corner error.
    const RectangleTest pre = BestRectangleTest(q.c, Ks, 2.0 * o.rectangle_corner_px);
    if (!pre.valid || pre.abs_cos > std::min(1.0, 2.0 * o.max_abs_cos)) continue;
    // A corner so far out of view that refinement (which moves corners by at most 0.2 x the
    // shortest side + 2 search_px) cannot bring it within the cut-off container limit: neither a
    // detection nor a container.
    const double side = ShortestSide(q.c);
    const double reach_out = (std::max(o.container_outside_frac, 0.0) + 0.2) * side +
                             2.0 * o.search_px + o.max_corner_outside_px;
    if (CornerOutside(q.c, probe.cam, probe.smooth.cols, probe.smooth.rows) > reach_out) continue;
    const Quad hypothesis = q;
    // Each hypothesis draws its own RANSAC samples: with one generator for all, a hypothesis more
    // or less anywhere in the image changed the draws of every later one (the in-flight EuRoC
    // mattress came and went with a 32 px quad elsewhere).
    rng.seed(o.seed);
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
  rect_internal::CorrectSides(probe, &q.c);
  out.corners_undistorted = q.c;
  out.support = q.score;
  for (int i = 0; i < 4; ++i) {
    out.side_sign[i] = edges[i].sign;
    out.side_gradient[i] = edges[i].gradient;
  }
  return out;
}

}  // namespace fsp::frontend
