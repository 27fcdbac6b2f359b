// Stage 5 of the rectangle detector: verification of the refined quads (rectangle test, corners in
// view), the L-corner tests (T-junction, corner reach), grey-level statistics of margins and rings,
// and the class guess of the detections.
#include <algorithm>
#include <cmath>

#include "fsp/frontend/rect_geometry.h"
#include "rect_internal.h"

namespace fsp::frontend::rect_internal {
namespace {

// What a side's edge looks like at p (searched along the side's normal n): found on the side's
// line (polarity `sign`, at least half the side's median gradient, within ransac_inlier_px + 0.5
// px of p along n), found off it, not found, or p too close to the image border to tell.
enum class EdgeAt { kOnLine, kOffLine, kNone, kUnsearchable };

EdgeAt FindEdgeAt(const EdgeProbe& probe, const Vec2& p, const Vec2& n, const SideEdge& edge,
                  int sign) {
  Vec2 e;
  double gradient;
  int sg;
  if (!probe.Peak(p, n, 0.5 * edge.gradient, &e, &gradient, &sg, sign))
    return probe.Searchable(p) ? EdgeAt::kNone : EdgeAt::kUnsearchable;
  return std::abs(n.dot(e - p)) <= probe.o.ransac_inlier_px + 0.5 ? EdgeAt::kOnLine
                                                                  : EdgeAt::kOffLine;
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
    return FindEdgeAt(probe, corner + t * u, n_side, edge, edge.sign) == EdgeAt::kOnLine;
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
    // Outside the image is not evidence either way; no edge inside is evidence against.
    const EdgeAt at = FindEdgeAt(probe, corner + t * u, n_side, edge, edge.sign);
    if (at == EdgeAt::kUnsearchable) continue;
    ++valid;
    if (at != EdgeAt::kOnLine) {
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
    // The side's polarity first; with `reach_either_polarity` the opposite one too (the
    // background changes along the side: a panel before a bright wall above, a dark radiator
    // below).
    bool searchable = false, on_edge = false;
    for (const int sign : {edge.sign, -edge.sign}) {
      const EdgeAt at = FindEdgeAt(probe, p, n_side, edge, sign);
      searchable = searchable || at != EdgeAt::kUnsearchable;
      on_edge = at == EdgeAt::kOnLine;
      if (on_edge || !o.reach_either_polarity) break;
    }
    valid += searchable;
    support += on_edge;
  }
  if (valid < 3) return 1.0;
  return static_cast<double>(support) / valid;
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

// Class cues (frontend/README.md, "Class guess"): metric aspect h/w from Zhang-He, brightness
// against the surroundings, interior texture. Statistics on the smoothed image at the distorted
// corners `px`.
ObjectClass GuessClass(const cv::Mat& smooth, const Corners& px, double aspect_w_h) {
  double in_mean, in_std, out_mean, out_std;
  QuadStats(smooth, px, 0.8, &in_mean, &in_std);
  QuadStats(smooth, px, 1.25, &out_mean, &out_std);
  const double h_over_w = 1.0 / aspect_w_h;
  // The first rule that applies:
  //  - tag (a fiducial without its id: use the AprilTag front end for ids): square-ish, a
  //    plain dark ring just inside the outline (the black border, 1/8 of the side: sampled at
  //    scale 0.875) inside a plain bright ring just outside it (the white margin, scale
  //    1.125), > 60 grey levels apart, and a patterned interior;
  //  - door: tall (metric h/w 1.8..3.2: a standard door is 1.9-3.4; a tall cabinet of 1.7 voted
  //    door and cabinet about evenly with 1.7), not strongly textured;
  //  - window: brighter than its surroundings (> 15 grey levels) with a frame (the ring just
  //    inside the outline, scale 0.95, darker than the interior by > 20 on every side) that is
  //    at most half as bright as the interior on every side (daylight through glass; mullions
  //    allowed);
  //  - cabinet: a frame round a plain interior (grey-level std < 20) that is not door-shaped
  //    (a panelled front; a wall panel with a frame is called a cabinet too);
  //  - poster: brighter than its surroundings otherwise (a print on the wall: a white
  //    calibration board is one), or a strongly textured interior (std > 30);
  //  - otherwise unknown.
  double ring_in, ring_in_std, ring_out, ring_out_std, frame, frame_std, frame_max;
  RingStats(smooth, px, 0.875, &ring_in, &ring_in_std);
  RingStats(smooth, px, 1.125, &ring_out, &ring_out_std);
  RingStats(smooth, px, 0.95, &frame, &frame_std, &frame_max);
  const double tag_contrast = ring_out - ring_in;
  const bool tag_like = ring_in >= 0.0 && ring_out >= 0.0 && tag_contrast > 60.0 &&
                        ring_in_std < 0.25 * tag_contrast && ring_out_std < 0.25 * tag_contrast &&
                        in_std > 30.0 && h_over_w >= 0.67 && h_over_w <= 1.5;
  if (tag_like) return ObjectClass::kTag;
  if (h_over_w >= 1.8 && h_over_w <= 3.2 && in_std < 40.0) return ObjectClass::kDoor;
  if (h_over_w < 0.4 || h_over_w > 2.5) return ObjectClass::kUnknown;
  const bool framed = frame >= 0.0 && frame_max < in_mean - 20.0;
  const bool brighter = out_mean >= 0.0 && in_mean - out_mean > 30.0;
  if (out_mean >= 0.0 && in_mean - out_mean > 15.0 && framed && in_mean >= 2.0 * frame_max)
    return ObjectClass::kWindow;
  if (framed && in_std < 20.0) return ObjectClass::kCabinet;
  if (brighter || in_std > 30.0) return ObjectClass::kPoster;
  return ObjectClass::kUnknown;
}

}  // namespace

bool IsDoorShaped(const RectDetectorOptions& o, const Quad& q) {
  const double h_over_w = 1.0 / q.aspect_w_h;
  return o.door_min_aspect > 0.0 && h_over_w >= o.door_min_aspect && h_over_w <= o.door_max_aspect;
}

double CornerOutside(const Corners& c, const PinholeRadtan* cam, int cols, int rows) {
  double outside = 0.0;
  for (const Vec2& x : c) {
    const Vec2 d = cam ? cam->DistortPixel(x) : x;
    outside = std::max({outside, -d.x(), -d.y(), d.x() - (cols - 1), d.y() - (rows - 1)});
  }
  return outside;
}

// True when some corner of the refined quad is not an L-corner: a side continues past it (see
// SideContinuation; a T-junction, where the object runs on and another line such as a panel
// groove, a mullion or texture crosses it), or a side's edge stops short of it (see CornerReach; a
// quad closed by a line a little beyond the object, such as the outer edge of a tag's white
// margin with the black square's other three sides).
bool HasTJunction(const EdgeProbe& probe, const Corners& c, const std::array<SideEdge, 4>& edges,
                  bool door_shaped, bool* relaxed, bool texture) {
  const RectDetectorOptions& o = probe.o;
  // The ends at the lowest corner in the image (a door's bottom in shadow, on the floor) may fail
  // the reach test, at most `reach_failures_allowed` of them, and besides those at most
  // `reach_failures_any_corner` ends at any corner; a door-shaped quad may have up to
  // `door_reach_failures_allowed` short ends at any corner (`relaxed` then tells whether it
  // needed either).
  const bool door = door_shaped && o.door_reach_failures_allowed > o.reach_failures_allowed;
  bool needs_door_rule = false;
  int lowest = 0, second = -1;  // the two lowest corners in the image
  for (int i = 1; i < 4; ++i)
    if (c[i].y() > c[lowest].y()) lowest = i;
  for (int i = 0; i < 4; ++i)
    if (i != lowest && (second < 0 || c[i].y() > c[second].y())) second = i;
  // Continuation past each side's start (P) and end (Q) corner, kept for the door rule.
  std::array<std::array<double, 2>, 4> cont{};
  int short_ends = 0;  // side ends whose edge does not reach the corner
  int short_low = 0;   // ... of them at the lowest corner
  bool used_any_corner = false;
  // Short ends at any corner only for a quad with sides of at least `any_corner_min_side_frac` of
  // the image diagonal (on a small quad the reach test's few pixels next to the corner are all a
  // variant closed by a line a little beyond the object differs by: a tag's margin mixed with its
  // black square, a radiator closed by the lower edge of its shadow) that is clear of the image
  // border by `continuation_frac` x its shortest side (near the border quads are closed by lines
  // of what runs out of view: a window cut off by the border, closed by its frame's inner edge).
  // A texture hypothesis (a patterned rectangle, see RectDetectorOptions::texture_level) of any
  // size may have `texture_reach_failures_any_corner` short ends: where a dark square of a
  // checkerboard meets its thin white margin at a corner, the strongest edge next to the corner is
  // the square's, ~2 px inside the outline. Such a hypothesis is the outline of one bright block of
  // the averaged gradient, not a line a little beyond the object that closes it.
  int any_corner = o.reach_failures_any_corner;
  const double shortest = ShortestSide(c);
  if (texture)
    any_corner = std::max(any_corner, o.texture_reach_failures_any_corner);
  else if (shortest < o.any_corner_min_side_frac * std::hypot(probe.smooth.cols, probe.smooth.rows))
    any_corner = 0;
  if (any_corner > 0) {
    const double clear = o.continuation_frac * shortest;
    for (const Vec2& x : c) {
      const Vec2 d = probe.cam ? probe.cam->DistortPixel(x) : x;
      if (std::min({d.x(), d.y(), probe.smooth.cols - 1 - d.x(), probe.smooth.rows - 1 - d.y()}) <
          clear)
        any_corner = 0;
    }
  }
  for (int side = 0; side < 4; ++side) {
    const Vec2 P = c[(side + 3) % 4], Q = c[side];
    const double L = (Q - P).norm();
    const Vec2 u = (Q - P) / L;
    const Vec2 us = edges[side].curved ? edges[side].dir_start : u;
    const Vec2 ue = edges[side].curved ? edges[side].dir_end : u;
    if (edges[side].weak) {
      // No edge along this side (a door hypothesis' bottom): only the door rule accepts it.
      if (!door) return true;
      needs_door_rule = true;
      continue;
    }
    if (o.min_corner_reach > 0.0) {
      const bool q_short = CornerReach(probe, Q, -ue, true, L, edges[side]) < o.min_corner_reach;
      const bool p_short = CornerReach(probe, P, us, false, L, edges[side]) < o.min_corner_reach;

      short_ends += q_short + p_short;
      short_low += (q_short && side == lowest) + (p_short && (side + 3) % 4 == lowest);
      const int short_elsewhere =
          short_ends - std::min(short_low, o.reach_failures_allowed);  // beyond the lowest's
      used_any_corner = short_elsewhere > 0;
      needs_door_rule = needs_door_rule || short_elsewhere > any_corner;
      if (needs_door_rule && (!door || short_ends > o.door_reach_failures_allowed)) return true;
    }
    cont[side] = {SideContinuation(probe, P, -us, true, L, edges[side]),
                  SideContinuation(probe, Q, ue, false, L, edges[side])};
    if (!door && std::max(cont[side][0], cont[side][1]) > o.max_side_continuation) return true;
  }

  // The door rule for sides running on past a corner of a door-shaped quad: at its two lowest
  // corners (the jambs of the frame run on to the floor below the leaf, the floor line or skirting
  // on past the door's bottom corners), and at a top corner where only the more horizontal side
  // runs on (a lintel or beam running on past the jamb that ends under it), at one top corner only
  // (a grille's bars closed by a cross bar that runs on at both).
  int top_run_ons = 0;
  for (int i = 0; door && i < 4; ++i) {
    const bool a_runs = cont[i][1] > o.max_side_continuation;            // side i, ending at c[i]
    const bool b_runs = cont[(i + 1) % 4][0] > o.max_side_continuation;  // side i + 1, from c[i]
    if (!a_runs && !b_runs) continue;
    needs_door_rule = true;
    if (i == lowest || i == second) continue;
    if (a_runs && b_runs) return true;
    const Vec2 d = a_runs ? Vec2(c[i] - c[(i + 3) % 4]) : Vec2(c[(i + 1) % 4] - c[i]);
    if (std::abs(d.x()) <= std::abs(d.y()) || ++top_run_ons > 1) return true;
  }
  if (relaxed) *relaxed = needs_door_rule || used_any_corner;
  return false;
}

bool SpansTwoObjects(const EdgeProbe& probe, const Quad& q) {
  const RectDetectorOptions& o = probe.o;
  // A patterned rectangle (a checkerboard) has its sides' polarity flip with its squares.
  if (!(o.union_gap_frac > 0.0) || q.texture) return false;
  const Corners& c = q.c_grouping;
  // Sides as homogeneous lines (n.x, n.y, -c): side i joins c[i-1] and c[i].
  std::array<Vec3, 4> line;
  for (int i = 0; i < 4; ++i) {
    const Line l = LineOf(MakeSeg(c[(i + 3) % 4], c[i]));
    line[i] = Vec3(l.n.x(), l.n.y(), -l.c);
  }
  // Whether side `side`'s edge is found on its line at p; a point outside the searchable image
  // counts as found (no evidence of a gap).
  std::array<Vec2, 4> normal;  // left normal of side i's direction c[i-1] -> c[i]
  for (int i = 0; i < 4; ++i) {
    const Vec2 u = (c[i] - c[(i + 3) % 4]).normalized();
    normal[i] = Vec2(-u.y(), u.x());
  }
  auto on_edge = [&](int side, const Vec2& p) {
    const EdgeAt at = FindEdgeAt(probe, p, normal[side], q.edges[side], q.edges[side].sign);
    return at == EdgeAt::kOnLine || at == EdgeAt::kUnsearchable;
  };
  for (int i = 0; i < 2; ++i) {
    const int j = i + 2;  // the opposite side
    if (q.edges[i].weak || q.edges[j].weak || q.edges[i].curved || q.edges[j].curved) continue;
    // The point of side j that faces p on side i: on the line through p and the vanishing point
    // of the two other sides (the same position across the object's plane).
    const Vec3 vanishing = line[(i + 1) % 4].cross(line[(i + 3) % 4]);
    const Vec2 P = c[(i + 3) % 4], Q = c[i];
    const double L = std::max((Q - P).norm(), (c[(j + 3) % 4] - c[j]).norm());
    const int k_samples = std::clamp(static_cast<int>(L / 2.0), 12, 64);
    int run = 0, longest = 0;
    bool edge_before = false;
    for (int k = 0; k < k_samples; ++k) {
      const Vec2 p = P + (0.05 + 0.9 * (k + 0.5) / k_samples) * (Q - P);
      const Vec3 facing = Vec3(p.x(), p.y(), 1.0).cross(vanishing).cross(line[j]);
      if (std::abs(facing.z()) < 1e-12) return false;
      const bool gap = !on_edge(i, p) && !on_edge(j, facing.head<2>() / facing.z());
      if (!gap) {
        // A gap counts between stretches with an edge (one at a corner is the reach test's).
        if (edge_before) longest = std::max(longest, run);
        edge_before = true;
        run = 0;
      } else {
        ++run;
      }
    }
    if (longest >= std::max(2.0, o.union_gap_frac * k_samples)) return true;
  }
  return false;
}

bool IsLCornered(const EdgeProbe& probe, const Quad& q, bool* relaxed) {
  if (relaxed) *relaxed = false;
  return !(probe.o.max_side_continuation < 1.0 || probe.o.min_corner_reach > 0.0) ||
         !HasTJunction(probe, q.c_grouping, q.edges, IsDoorShaped(probe.o, q), relaxed, q.texture);
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

void VerifyQuads(std::vector<Quad>& refined, const EdgeProbe& probe, const std::vector<Mat3>& Ks,
                 const Vec3* gravity_C, double probe_side, std::vector<Quad>* good,
                 std::vector<Quad>* cut_off) {
  const RectDetectorOptions& o = probe.o;
  const Mat3& K = Ks[Ks.size() / 2];
  for (Quad& q : refined) {
    if (ShortestSide(q.c) < probe_side) continue;
    q.c_grouping = q.c;
    q.c = CanonicalOrder(q.c, &K, gravity_C);
    double plain_abs_cos = 1.0;
    const RectangleTest t = BestRectangleTest(q.c, Ks, o.rectangle_corner_px, &plain_abs_cos);
    if (!t.valid || t.abs_cos > o.max_abs_cos) continue;
    q.aspect_w_h = t.aspect_12_14;
    if (q.aspect_w_h > o.max_aspect || q.aspect_w_h < 1.0 / o.max_aspect) continue;
    // The score keeps the plain |cos| (a quad that passes only within its corner error scores as
    // one at the tolerance): which of two nested outlines wins stays as it was (a synthetic
    // cabinet's low-contrast outer outline lost to its panel when scored by the lowered |cos|).
    q.abs_cos = std::min(plain_abs_cos, o.max_abs_cos);
    q.score *= 1.0 - 0.5 * q.abs_cos / o.max_abs_cos;
    q.area = std::abs(SignedArea(q.c));
    // Every corner must be seen: a corner outside the image is an extrapolation of sides that run
    // out of the view (the object is cut off; its fourth side is some other line).
    const double outside = CornerOutside(q.c, probe.cam, probe.smooth.cols, probe.smooth.rows);
    if (outside > o.max_corner_outside_px) {
      // A rectangle cut off by the image border by a little (a door whose bottom corners are just
      // out of view) is not reported, but what lies inside it (the door leaf, its panels) is part
      // of it: kept to suppress those.
      if (outside <= o.container_outside_frac * ShortestSide(q.c)) cut_off->push_back(q);
      continue;
    }
    // The costliest test (every corner an L-corner) is left to the suppression stage, which runs
    // it only on quads that would be kept or would replace a kept one, and on margin probes only
    // when one would mark a margin.
    good->push_back(q);
  }
}

RectangleTest BestRectangleTest(const Corners& undistorted_px, const std::vector<Mat3>& Ks,
                                double corner_px, double* plain_abs_cos) {
  RectangleTest best;
  const Mat3* best_K = nullptr;
  for (const Mat3& K : Ks) {
    const RectangleTest t = ZhangHeTest(undistorted_px, K);
    if (t.valid && (!best.valid || t.abs_cos < best.abs_cos)) {
      best = t;
      best_K = &K;
    }
  }
  if (plain_abs_cos) *plain_abs_cos = best.abs_cos;
  if (!best.valid || !(corner_px > 0.0) || best.abs_cos == 0.0) return best;
  // The 3-D angle of a small quad is ill-conditioned: its sides are nearly parallel in the image,
  // and a pixel of corner error moves their vanishing points, and so the angle, a lot (the
  // DM-VIO walk's hand labels, accurate to 2-3 px: |cos| up to 0.46 on 30-45 px switch plates,
  // at most 0.05 on the 170-500 px monitors). |cos| is lowered by its first-order change when each
  // corner moves by up to `corner_px` against it: the rectangle test asks whether some rectangle
  // lies within the corners' error, which for a large quad is the old test (the change is ~0.01
  // for a 100 px quad).
  constexpr double kStep = 0.05;  // [px] central differences
  double slope = 0.0;             // sum over corners of |d|cos| / d corner|
  for (int i = 0; i < 4; ++i) {
    Vec2 g;
    for (int axis = 0; axis < 2; ++axis) {
      Corners p = undistorted_px, m = undistorted_px;
      p[i][axis] += kStep;
      m[i][axis] -= kStep;
      const RectangleTest tp = ZhangHeTest(p, *best_K), tm = ZhangHeTest(m, *best_K);
      if (!tp.valid || !tm.valid) return best;
      g[axis] = (tp.abs_cos - tm.abs_cos) / (2.0 * kStep);
    }
    slope += g.norm();
  }
  best.abs_cos = std::max(0.0, best.abs_cos - corner_px * slope);
  return best;
}

std::vector<Mat3> CandidateIntrinsics(const RectDetectorOptions& o, int cols, int rows,
                                      const PinholeRadtan* camera) {
  if (camera) return {camera->K()};
  if (o.focal_prior_steps < 1) return {DefaultK(cols, rows, o.assumed_hfov_deg)};
  std::vector<Mat3> Ks;
  const double long_side = std::max(cols, rows);
  for (int k = 0; k < o.focal_prior_steps; ++k) {
    const double t = o.focal_prior_steps == 1 ? 0.5 : k / (o.focal_prior_steps - 1.0);
    const double f =
        long_side * o.focal_prior_min * std::pow(o.focal_prior_max / o.focal_prior_min, t);
    Mat3 K;
    K << f, 0.0, 0.5 * (cols - 1), 0.0, f, 0.5 * (rows - 1), 0.0, 0.0, 1.0;
    Ks.push_back(K);
  }
  return Ks;
}

namespace {

// The refinement's side polarities (grouping order) for the canonical corners: canonical side j
// (c[j-1] to c[j]) is the grouping side between the same two corners, its sign flipped when it runs
// the other way (its left normal turns round). 0 for a side taken without an edge.
std::array<int, 4> CanonicalSideSigns(const Quad& q) {
  std::array<int, 4> at{};  // index in c_grouping of canonical corner i
  for (int i = 0; i < 4; ++i) {
    at[i] = 0;
    for (int k = 1; k < 4; ++k)
      if ((q.c_grouping[k] - q.c[i]).squaredNorm() < (q.c_grouping[at[i]] - q.c[i]).squaredNorm())
        at[i] = k;
  }
  std::array<int, 4> sign = {0, 0, 0, 0};
  for (int j = 0; j < 4; ++j) {
    const int a = at[(j + 3) % 4], b = at[j];
    const bool along = b == (a + 1) % 4;
    if (!along && a != (b + 1) % 4) return {0, 0, 0, 0};  // not a permutation of the corners
    const SideEdge& e = q.edges[along ? b : a];
    sign[j] = e.weak ? 0 : (along ? e.sign : -e.sign);
  }
  return sign;
}

}  // namespace

std::vector<Detection> MakeDetections(const std::vector<Quad>& quads, const EdgeProbe& probe) {
  const PinholeRadtan* cam = probe.cam;
  std::vector<Detection> dets;
  for (const Quad& q : quads) {
    Detection det;
    det.corners_undistorted = q.c;
    CorrectSides(probe, &det.corners_undistorted);
    for (int i = 0; i < 4; ++i)
      det.corners_px[i] =
          cam ? cam->DistortPixel(det.corners_undistorted[i]) : det.corners_undistorted[i];
    det.score = q.score;
    det.side_sign = CanonicalSideSigns(q);
    if (probe.o.guess_class)
      det.object_class = GuessClass(probe.smooth, det.corners_px, q.aspect_w_h);
    dets.push_back(det);
  }
  return dets;
}

}  // namespace fsp::frontend::rect_internal
