#include "fsp/common/camera.h"

#include <cmath>
#include <sstream>

namespace fsp {

bool PinholeRadtan::Check(std::string* why) const {
  std::ostringstream os;
  if (width <= 0 || height <= 0)
    os << "image size " << width << "x" << height << " is not positive";
  else if (!(fx > 0.0) || !(fy > 0.0) || !std::isfinite(fx) || !std::isfinite(fy))
    os << "focal length (" << fx << ", " << fy << ") is not positive and finite";
  else if (!std::isfinite(cx) || !std::isfinite(cy) || cx < 0.0 || cy < 0.0 || cx > width ||
           cy > height)
    os << "principal point (" << cx << ", " << cy << ") lies outside the " << width << "x" << height
       << " image";
  else
    for (double d : distortion)
      if (!std::isfinite(d)) os << "distortion coefficient is not finite";
  if (why) *why = os.str();
  return os.str().empty();
}

bool PinholeRadtan::HasDistortion() const {
  return distortion[0] != 0.0 || distortion[1] != 0.0 || distortion[2] != 0.0 ||
         distortion[3] != 0.0;
}

Mat3 PinholeRadtan::K() const {
  Mat3 K;
  K << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return K;
}

Vec2 PinholeRadtan::Distort(const Vec2& xn, Mat2* d_xd_d_xn) const {
  const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3];
  const double x = xn.x(), y = xn.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
  const Vec2 xd(x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y);
  if (d_xd_d_xn) {
    const double d_radial_d_r2 = k1 + 2.0 * k2 * r2;
    // d r2 / dx = 2x, d r2 / dy = 2y
    (*d_xd_d_xn)(0, 0) = radial + x * d_radial_d_r2 * 2.0 * x + 2.0 * p1 * y + p2 * 6.0 * x;
    (*d_xd_d_xn)(0, 1) = x * d_radial_d_r2 * 2.0 * y + 2.0 * p1 * x + p2 * 2.0 * y;
    (*d_xd_d_xn)(1, 0) = y * d_radial_d_r2 * 2.0 * x + p1 * 2.0 * x + 2.0 * p2 * y;
    (*d_xd_d_xn)(1, 1) = radial + y * d_radial_d_r2 * 2.0 * y + p1 * 6.0 * y + 2.0 * p2 * x;
  }
  return xd;
}

Vec2 PinholeRadtan::Undistort(const Vec2& xd) const {
  if (!HasDistortion()) return xd;
  Vec2 xn = xd;
  for (int it = 0; it < 30; ++it) {
    Mat2 J;
    const Vec2 err = Distort(xn, &J) - xd;
    if (err.squaredNorm() < 1e-26) break;
    xn -= J.lu().solve(err);
  }
  return xn;
}

Vec2 PinholeRadtan::Project(const Vec3& p_C, Mat23* d_uv_d_p) const {
  const double inv_z = 1.0 / p_C.z();
  const Vec2 xn(p_C.x() * inv_z, p_C.y() * inv_z);
  Mat2 d_xd_d_xn;
  const Vec2 xd = Distort(xn, d_uv_d_p ? &d_xd_d_xn : nullptr);
  if (d_uv_d_p) {
    Mat23 d_xn_d_p;
    d_xn_d_p << inv_z, 0.0, -xn.x() * inv_z, 0.0, inv_z, -xn.y() * inv_z;
    const Mat2 F = Eigen::Vector2d(fx, fy).asDiagonal();
    *d_uv_d_p = F * d_xd_d_xn * d_xn_d_p;
  }
  return Vec2(fx * xd.x() + cx, fy * xd.y() + cy);
}

Vec2 PinholeRadtan::ProjectIdeal(const Vec3& p_C, Mat23* d_uv_d_p) const {
  const double inv_z = 1.0 / p_C.z();
  if (d_uv_d_p) {
    *d_uv_d_p << fx * inv_z, 0.0, -fx * p_C.x() * inv_z * inv_z, 0.0, fy * inv_z,
        -fy * p_C.y() * inv_z * inv_z;
  }
  return Vec2(fx * p_C.x() * inv_z + cx, fy * p_C.y() * inv_z + cy);
}

Vec3 PinholeRadtan::Unproject(const Vec2& uv) const {
  const Vec2 xn = Undistort(Vec2((uv.x() - cx) / fx, (uv.y() - cy) / fy));
  return Vec3(xn.x(), xn.y(), 1.0);
}

Vec2 PinholeRadtan::UndistortPixel(const Vec2& uv) const {
  const Vec3 ray = Unproject(uv);
  return Vec2(fx * ray.x() + cx, fy * ray.y() + cy);
}

Vec2 PinholeRadtan::DistortPixel(const Vec2& uv_undistorted) const {
  const Vec2 xn((uv_undistorted.x() - cx) / fx, (uv_undistorted.y() - cy) / fy);
  const Vec2 xd = Distort(xn);
  return Vec2(fx * xd.x() + cx, fy * xd.y() + cy);
}

bool PinholeRadtan::InImage(const Vec2& uv, double margin) const {
  return uv.x() >= -0.5 + margin && uv.y() >= -0.5 + margin && uv.x() <= width - 0.5 - margin &&
         uv.y() <= height - 0.5 - margin;
}

}  // namespace fsp
