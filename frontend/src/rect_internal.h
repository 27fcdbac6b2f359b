// Internal to the rectangle detector (not installed): the types its stages share and small
// geometric helpers. The stages, in the order RectDetector::Detect runs them:
//   rect_edges.cc     1. Canny thresholds from the gradient statistics, chain tracing and splitting
//   rect_segments.cc  2. segment fitting, polarity, collinear merge, curved chains
//   rect_grouping.cc  3. junctions at segment ends, 4-cycles of segments
//   edge_refine.cc    4. sub-pixel refinement of the sides (also the public edge_refine.h)
//   rect_verify.cc    5. rectangle test, view test; L-corner tests, margin and ring statistics,
//                        class guess
//   rect_suppress.cc  6. duplicates, nesting, bright margins, containment
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/types.h"
#include "fsp/frontend/detection.h"
#include "fsp/frontend/rect_detector.h"
#include "fsp/frontend/rect_geometry.h"

namespace fsp::frontend::rect_internal {

// A segment in undistorted pixels.
struct Seg {
  Vec2 a, b;
  Vec2 dir;  // unit, a → b
  double len = 0.0;
  // A slowly bending edge (curled paper): the polyline a = path[0], ..., path.back() = b through
  // the straight pieces it was built from; empty for a straight segment. Its corners come from the
  // first and last pieces (see CurvedChains).
  std::vector<Vec2> path;
  // Bridged from pieces of both polarities (a side whose background changes along it): `dir` is
  // no polarity, and refinement searches edges of either.
  bool mixed = false;
  // Line of the piece at end 0 (a) or 1 (b).
  Vec2 EndDir(int end) const {
    if (path.size() < 2) return dir;
    const Vec2 d = end == 0 ? Vec2(path[1] - path[0]) : Vec2(path.back() - path[path.size() - 2]);
    return d.normalized();
  }
};

inline Seg MakeSeg(const Vec2& a, const Vec2& b) {
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

inline Line LineOf(const Seg& s) {
  Line l;
  l.n = Vec2(-s.dir.y(), s.dir.x());
  l.c = l.n.dot(s.a);
  return l;
}

// Line of the piece at end 0 (a) or 1 (b) of a segment (its own line when straight).
inline Line EndLine(const Seg& s, int end) {
  const Vec2 d = s.EndDir(end);
  Line l;
  l.n = Vec2(-d.y(), d.x());
  l.c = l.n.dot(end == 0 ? s.a : s.b);
  return l;
}

inline bool Intersect(const Line& l1, const Line& l2, Vec2* x) {
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
// the weighted scatter matrix about the weighted centroid (points pts[idx], weights w[idx]).
bool FitLineTls(const std::vector<Vec2>& pts, const std::vector<double>& w,
                const std::vector<int>& idx, Line* line);

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

struct Junction {
  int seg = -1;  // the other segment
  int end = 0;   // the other segment's end at the junction (0 = a, 1 = b)
  Vec2 x;        // intersection point
};

// What refinement learns about one side besides its line: the polarity of its edge (+1: brighter
// towards the side's left normal) and the median gradient of its inlier edge points.
struct SideEdge {
  int sign = 1;
  double gradient = 0.0;
  // A curved side (see CurvedChains): its unit directions at c[i-1] and c[i] (towards c[i]).
  bool curved = false;
  Vec2 dir_start = Vec2(1.0, 0.0), dir_end = Vec2(1.0, 0.0);
  // No edge was found along the side (a quad's `weak_side`): its line is the hypothesis' and it
  // takes no part in the L-corner tests.
  bool weak = false;
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
  // Passed the L-corner tests only by a relaxed rule: the door rule
  // (RectDetectorOptions::door_reach_failures_*) or a short side end at a corner other than the
  // lowest (reach_failures_any_corner).
  bool relaxed = false;
  // A side that may lack edge support (a door hypothesis' bottom, see FindDoorQuads); -1: none.
  int weak_side = -1;
  // A texture hypothesis (RectDetectorOptions::texture_level): a coarse refinement when the usual
  // one fails; texture_reach_failures_any_corner in the L-corner tests.
  bool texture = false;
};

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

// The side corrections after the sub-pixel refinement of quad C (undistorted px, cyclic order),
// edge_corrections.cc: RectDetectorOptions::frame_band_max_frac moves the side that lies on a
// frame's inner edge out onto the frame's outline, or a bright object's side found on its shadow's
// outer edge in onto the object; then band_max_px moves each (other) side that has an edge of the
// opposite polarity close by from its gradient peak to the edge of a two-edge model fitted across
// it.
void CorrectSides(const EdgeProbe& probe, Corners* c);

// ---- 1. edges (rect_edges.cc) ----

// Canny thresholds (Sobel magnitude units) from the median gradient magnitude; see the definition.
void CannyThresholds(const cv::Mat& dx, const cv::Mat& dy, const RectDetectorOptions& o,
                     double* low, double* high);

// What the edge stage hands on: the smoothed image (σ = 1 px, also the image every later stage
// samples), its Sobel gradients (CV_16S), the Canny edge map and the thresholds used.
struct EdgeImages {
  cv::Mat smooth, dx, dy, edges;
  double canny_low = 0.0, canny_high = 0.0;
};
EdgeImages DetectEdges(const cv::Mat& gray, const RectDetectorOptions& o);

// Shortest segment kept after merging [px] (RectDetectorOptions::min_segment_frac of the diagonal).
int MinSegmentPx(const RectDetectorOptions& o, double diag);

// Straight pieces (distorted px, not yet oriented) of the edge chains: chains of at least
// `min_piece` pixels split while farther than `fit_px` from their chord. Consumes `edges`.
std::vector<std::pair<Vec2, Vec2>> TracePieces(cv::Mat& edges, int min_piece, double fit_px);

// ---- 2. segments (rect_segments.cc) ----

// The rectangle test over candidate intrinsics: the calibration's K alone, or without one the
// focal-length prior (RectDetectorOptions::focal_prior_*): the result with the smallest |cos|,
// that |cos| lowered by its first-order change when each corner moves by up to `corner_px` (see
// RectDetectorOptions::rectangle_corner_px; 0: the plain test). `plain_abs_cos` (optional)
// receives the |cos| before lowering.
RectangleTest BestRectangleTest(const Corners& undistorted_px, const std::vector<Mat3>& Ks,
                                double corner_px = 0.0, double* plain_abs_cos = nullptr);

// Candidate intrinsics for the rectangle test: {camera K} with a calibration, else
// `focal_prior_steps` focal lengths spaced geometrically over [focal_prior_min, focal_prior_max] x
// the longer image side, principal point at the centre.
std::vector<Mat3> CandidateIntrinsics(const RectDetectorOptions& o, int cols, int rows,
                                      const PinholeRadtan* camera);

// Collinear pieces (directions within `angle_deg`, endpoints within `line_px` of the longer one's
// line, at most `gap_px` apart along it) merged into one segment each, through union of
// compatible pairs; pieces that continue each other end to start also join. Only pieces of the
// same polarity, unless `any_polarity` (then the merged segment is `mixed` when its pieces'
// polarities differ; continuations are not joined). With `only_joined` only the segments merged
// from two or more pieces are returned.
std::vector<Seg> MergeCollinear(const std::vector<Seg>& in, double angle_deg, double line_px,
                                double gap_px, bool any_polarity = false, bool only_joined = false);
std::vector<Seg> CurvedChains(const std::vector<Seg>& segs, double touch_px, double step_deg,
                              double total_deg, double min_len);

// Pieces → segments (undistorted px): oriented by polarity, merged, short ones dropped (below
// `min_seg` px), curved chains added.
std::vector<Seg> BuildSegments(const std::vector<std::pair<Vec2, Vec2>>& pieces,
                               const cv::Mat& smooth, const PinholeRadtan* cam,
                               const RectDetectorOptions& o, double diag, int min_seg);

// ---- 3. grouping (rect_grouping.cc) ----

// Junctions at each segment's two ends: ends[i][e] lists the segments meeting end e of segment i.
using SegmentJunctions = std::vector<std::array<std::vector<Junction>, 2>>;
// With `known` (the junctions of the first known->size() segments), only the junctions of the
// segments appended since are added to a copy of it.
SegmentJunctions FindJunctions(const std::vector<Seg>& segs, const RectDetectorOptions& o,
                               const SegmentJunctions* known = nullptr);

// 4-cycles a → b → c → d → a of junctions: convex quads with a shortest side of at least
// `min_side` px, at most `max_quads` (the cap is checked per first segment).
std::vector<Quad> FindQuads(const SegmentJunctions& ends, double min_side, int max_quads);

// Door hypotheses (RectDetectorOptions::door_hypotheses): a near-horizontal lintel segment with a
// long near-vertical jamb segment hanging down from each of its ends, closed by the line through
// the jambs' lower ends; that bottom side is the quad's `weak_side` (refinement keeps the line
// when it finds no edge there: a door's bottom in shadow or on a dark floor).
// None on three sides of a quad in `closed` (the grouping's 4-cycles). A lintel broken by an
// occluder may be two collinear pieces with a gap of up to `door_jamb_gap_frac` of the image
// diagonal (cols x rows) between them.
std::vector<Quad> FindDoorQuads(const std::vector<Seg>& segs, const SegmentJunctions& ends,
                                const std::vector<Quad>& closed, const RectDetectorOptions& o,
                                int cols, int rows, double min_side);

// ---- 4. refinement (edge_refine.cc) ----

int RansacLine(const std::vector<Vec2>& pts, const std::vector<double>& w,
               const std::vector<int>& subset, double inlier_px, int iterations, std::mt19937* rng,
               Line* line);
bool RefineQuad(const EdgeProbe& probe, const std::vector<Seg>& segs, double min_gradient,
                std::mt19937* rng, Quad* q, std::array<SideEdge, 4>* side_edges,
                const std::array<int, 4>& side_want = {0, 0, 0, 0});

// The refinement stage: a cheap rectangle pre-test (twice the tolerance) on the hypothesis
// corners, a reach test for corners out of view, then RefineQuad; returns the refined quads.
std::vector<Quad> RefineHypotheses(std::vector<Quad>& quads, const std::vector<Seg>& segs,
                                   const EdgeProbe& probe, const std::vector<Mat3>& Ks,
                                   double min_gradient);

// ---- 5. verification (rect_verify.cc) ----

// Farthest distance of a corner (undistorted px) outside the image [px, distorted]; 0 inside.
double CornerOutside(const Corners& c, const PinholeRadtan* cam, int cols, int rows);

// Whether a verified quad (canonical order, metric aspect set) has a door's shape: metric height /
// width in [door_min_aspect, door_max_aspect].
bool IsDoorShaped(const RectDetectorOptions& o, const Quad& q);
// Some corner is not an L-corner. `door_shaped` allows the door rule (door_reach_failures_allowed);
// `relaxed` (optional) tells whether the quad passed only by it or by a short end at a corner
// other than the lowest (reach_failures_any_corner); `texture` (a texture hypothesis) allows
// texture_reach_failures_any_corner short ends whatever the quad's size.
bool HasTJunction(const EdgeProbe& probe, const Corners& c, const std::array<SideEdge, 4>& edges,
                  bool door_shaped = false, bool* relaxed = nullptr, bool texture = false);
// Every corner an L-corner (true when the L-corner tests are switched off).
bool IsLCornered(const EdgeProbe& probe, const Quad& q, bool* relaxed = nullptr);
bool IsBrightMargin(const cv::Mat& smooth, const PinholeRadtan* cam, const Corners& outer,
                    const Corners& inner, const RectDetectorOptions& o);
// Two opposite sides both lack their edge over the same stretch across the object (facing points
// through the other sides' vanishing point), of at least `union_gap_frac` of their samples,
// between stretches where both have it: the quad joins two objects with background between them
// by their collinear sides (two posters side by side).
bool SpansTwoObjects(const EdgeProbe& probe, const Quad& q);

// The verification stage on the refined quads: canonical corner order, rectangle and aspect tests,
// every corner in view. Quads cut off by the border by a little go to `cut_off` (containers for
// the suppression stage), the others to `good`.
void VerifyQuads(std::vector<Quad>& refined, const EdgeProbe& probe, const std::vector<Mat3>& Ks,
                 const Vec3* gravity_C, double probe_side, std::vector<Quad>* good,
                 std::vector<Quad>* cut_off);

// Detections (distorted and undistorted corners, score, class guess when asked for) of the
// surviving quads.
std::vector<Detection> MakeDetections(const std::vector<Quad>& quads, const EdgeProbe& probe);

// ---- 6. suppression (rect_suppress.cc) ----

// Duplicates, nesting, bright margins and containment among the verified quads `good`; quads with
// a shortest side below `min_side` are only margin probes. Best score first.
std::vector<Quad> Suppress(const std::vector<Quad>& good, const std::vector<Quad>& cut_off,
                           const EdgeProbe& probe, double min_side);

}  // namespace fsp::frontend::rect_internal
