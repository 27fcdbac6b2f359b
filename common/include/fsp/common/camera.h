// Pinhole camera with radial-tangential (OpenCV "plumb bob", k1 k2 p1 p2) distortion.
//
// Pixels follow OpenCV: the integer coordinate is the pixel centre. Camera frame C: x right, y
// down, z forward. "Normalised" coordinates are (x/z, y/z) before distortion; "undistorted pixels"
// are K * normalised, the ideal pinhole image the back end works in.
#pragma once

#include <array>
#include <string>

#include "fsp/common/geometry.h"

namespace fsp {

struct PinholeRadtan {
  int width = 0;  // image size in pixels
  int height = 0;
  double fx = 0.0, fy = 0.0;                             // focal lengths in pixels
  double cx = 0.0, cy = 0.0;                             // principal point in pixels
  std::array<double, 4> distortion{0.0, 0.0, 0.0, 0.0};  // k1, k2, p1, p2 (OpenCV order)

  // False with a reason when the intrinsics are unusable (non-positive size or focal length, NaN,
  // principal point outside the image).
  bool Check(std::string* why) const;
  bool HasDistortion() const;
  Mat3 K() const;

  // Distortion of normalised coordinates, with optional 2x2 Jacobian.
  Vec2 Distort(const Vec2& xn, Mat2* d_xd_d_xn = nullptr) const;
  // Inverse of Distort by Gauss-Newton (converges to < 1e-12 within the image for real lenses).
  Vec2 Undistort(const Vec2& xd) const;

  // Project a point in C to distorted pixels; optional Jacobian w.r.t. p_C. Requires p_C.z() > 0.
  Vec2 Project(const Vec3& p_C, Mat23* d_uv_d_p = nullptr) const;
  // Ideal pinhole projection (no distortion) to undistorted pixels; optional Jacobian.
  Vec2 ProjectIdeal(const Vec3& p_C, Mat23* d_uv_d_p = nullptr) const;
  // Bearing (x, y, 1) in C of a distorted pixel.
  Vec3 Unproject(const Vec2& uv) const;
  // Distorted pixel -> undistorted pixel (same K, no distortion).
  Vec2 UndistortPixel(const Vec2& uv) const;
  // Undistorted pixel -> distorted pixel.
  Vec2 DistortPixel(const Vec2& uv_undistorted) const;
  // True when the pixel lies inside the image (with a margin in pixels).
  bool InImage(const Vec2& uv, double margin = 0.0) const;
};

}  // namespace fsp
