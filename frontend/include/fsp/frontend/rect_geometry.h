// Small geometry of image quadrilaterals: the single-view rectangle test (Zhang & He), corner
// ordering in s1..s4, polygon helpers. Independent of the back end (which has its own initialiser).
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/types.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::frontend {

// Zhang & He ("Whiteboard scanning and image enhancement", 2007), the single-view rectangle test.
// With homogeneous undistorted pixel corners m1..m4 in cyclic order (m1, m3 diagonal) and m̃ = K⁻¹
// m:
//   c2 = ((m̃1 × m̃3)·m̃4) / ((m̃2 × m̃3)·m̃4),   c4 = ((m̃1 × m̃3)·m̃2) / ((m̃4 × m̃3)·m̃2)
//   n2 = c2 m̃2 − m̃1  (∝ the 3-D edge s1→s2),   n4 = c4 m̃4 − m̃1  (∝ the 3-D edge s1→s4)
// (c2, c4 are the depths of corners 2 and 4 relative to corner 1.) A planar parallelogram's image
// gives c2, c4 > 0; it is a rectangle when n2 ⊥ n4, so |cos∠(n2, n4)| measures how far it is from
// one.
struct RectangleTest {
  bool valid =
      false;  // false: degenerate (collinear corners) or a corner behind the camera (c ≤ 0)
  double c2 = 0.0, c4 = 0.0;
  Vec3 n2 = Vec3::Zero(), n4 = Vec3::Zero();  // 3-D edge directions at unit depth of corner 1
  double abs_cos = 1.0;                       // |cos∠(n2, n4)|, 0 for a perfect rectangle
  double aspect_12_14 = 0.0;  // ‖n2‖/‖n4‖: metric length ratio of edge s1s2 to edge s1s4
};
RectangleTest ZhangHeTest(const Corners& undistorted_px, const Mat3& K);

// A pinhole K for an uncalibrated image: principal point at the centre, focal length from an
// assumed horizontal field of view [deg].
Mat3 DefaultK(int width, int height, double hfov_deg);

// Signed area (shoelace) in pixel coordinates (x right, y down). s1..s4 of an object seen from the
// front goes counter-clockwise on screen, which is a NEGATIVE value here.
double SignedArea(const Corners& c);
bool IsConvex(const Corners& c);
// True when p is inside the convex quad (any orientation).
bool InsideConvex(const Corners& c, const Vec2& p);
// Each corner of C moved PX away from the centroid (negative: towards it, a smaller quad).
Corners MovedFromCentroid(const Corners& c, double px);
// True when every corner of `inner` is inside `outer` grown by `margin_px` (each corner moved that
// far away from the centroid): "inside" that tolerates shared sides and corners.
bool ContainsWithMargin(const Corners& outer, const Corners& inner, double margin_px);

// Puts four corners of a convex quad (any start, either orientation) into s1..s4 order.
//  - Orientation: counter-clockwise on screen (negative SignedArea), the order of a front view.
//  - Start corner: with gravity_C (gravity direction in the camera frame, any length) the image
//    direction of "down" at the quad's centre is the projection of gravity there (undistorted
//    pixels, K needed); without it, "down" is +v (image y). s1 is chosen so that the two "height"
//    edges s4→s1 and s3→s2 point along "down" as well as possible, i.e. s1 is bottom-left and s2
//    bottom-right. When gravity is nearly along the viewing ray at the quad (a floor or ceiling
//    object seen from above/below) the projected direction is too short to decide and the image
//    rule is used.
Corners CanonicalOrder(const Corners& undistorted_px, const Mat3* K = nullptr,
                       const Vec3* gravity_C = nullptr);

// Image direction (unit, undistorted pixels) of gravity at pixel m, or nullopt when gravity points
// (nearly) along the viewing ray through m. Derivation: x = X/Z; d x / d t along X + t g is
// (g_xy − x g_z) / Z, so the pixel direction is diag(fx, fy)(g_xy − x_n g_z) with x_n = K⁻¹ m.
std::optional<Vec2> GravityImageDirection(const Vec2& m, const Mat3& K, const Vec3& gravity_C);

// Largest distance between corresponding corners after the best cyclic shift (orientation kept).
double CornerDistanceBestShift(const Corners& a, const Corners& b, int* best_shift = nullptr);
// Mean distance between corresponding corners after the best cyclic shift: 1/4 sum ||a_j -
// b_{(j+s) mod 4}||, minimised over s (orientation kept).
double MeanCornerDistanceBestShift(const Corners& a, const Corners& b, int* best_shift = nullptr);
// Largest distance between corresponding corners (same order).
double MaxCornerDistance(const Corners& a, const Corners& b);
// How much two quads differ in shape: the largest distance between corresponding corners (b
// cyclically shifted as MeanCornerDistanceBestShift matches them) once their mean offset is
// removed. 0 for a translated copy; a quad with one side moved by d differs by about d / 2.
double ShapeDifference(const Corners& a, const Corners& b);

// Shortest side length in pixels.
double ShortestSide(const Corners& c);

// Axis-aligned bounding box of the corners.
Eigen::AlignedBox2d BoundingBox(const Corners& c);

// The convex hull of a quadrilateral's corners (OpenCV points, for its polygon functions).
std::vector<cv::Point2f> QuadHull(const Corners& c);
// Intersection over union of two convex polygons, 0 when both are empty.
double ConvexIou(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b);
// Intersection over union of two quadrilaterals (their convex hulls).
double QuadIou(const Corners& a, const Corners& b);

// Intersection over union of two boxes (0 when both are empty).
double BoxIou(const Eigen::AlignedBox2d& a, const Eigen::AlignedBox2d& b);

// The pixels covering BOX grown by MARGIN on every side (outwards to whole pixels), clipped to a
// COLS x ROWS image.
cv::Rect PixelBox(const Eigen::AlignedBox2d& box, double margin, int cols, int rows);

}  // namespace fsp::frontend
