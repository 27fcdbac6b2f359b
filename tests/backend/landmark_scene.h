// Small deterministic scenes for the landmark tests: a rectangle (T_W_O, w, h) and cameras that
// look at it from its front side (+z_O), with a seeded generator.
#pragma once

#include <array>
#include <cmath>
#include <iostream>
#include <random>
#include <vector>

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include "backend/jacobian_check.h"
#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::test {

inline Mat3 TestK() {
  Mat3 K;
  K << 458.0, 0.0, 320.0, 0.0, 457.0, 240.0, 0.0, 0.0, 1.0;
  return K;
}

inline Vec3 RandomVec3(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return Vec3(n(rng), n(rng), n(rng));
}

inline double Uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

struct TestObject {
  Rigid3 T_W_O;
  double width = 1.0;
  double height = 1.0;
  Vec3 Corner(int j) const {
    const double xi[4] = {0.0, 1.0, 1.0, 0.0};
    const double eta[4] = {0.0, 0.0, 1.0, 1.0};
    return T_W_O * Vec3(xi[j] * width, eta[j] * height, 0.0);
  }
  Vec3 Centre() const { return T_W_O * Vec3(0.5 * width, 0.5 * height, 0.0); }
};

// A vertical object (y up, z horizontal) at a random place and heading.
inline TestObject RandomObject(std::mt19937& rng, double w_lo = 0.3, double w_hi = 1.5) {
  TestObject o;
  o.width = Uniform(rng, w_lo, w_hi);
  o.height = o.width * Uniform(rng, 0.5, 2.0);
  // O axes in W: x horizontal, y = world up, z = x × y horizontal (towards the viewer).
  const double yaw = Uniform(rng, -M_PI, M_PI);
  Mat3 R;
  R.col(0) = Vec3(std::cos(yaw), std::sin(yaw), 0.0);
  R.col(1) = Vec3::UnitZ();
  R.col(2) = R.col(0).cross(R.col(1));
  o.T_W_O = Rigid3(R, RandomVec3(rng, 2.0));
  return o;
}

// Camera (x right, y down, z forward) at `distance` from the object's centre, in a direction tilted
// by up to `max_tilt_rad` away from the object's normal, looking at the centre with a roll of up to
// `roll_rad`. CameraAtTilt: the same with the tilt exactly `tilt_rad` (random azimuth).
inline Rigid3 CameraAtTilt(std::mt19937& rng, const TestObject& o, double distance, double tilt,
                           double roll_rad = 0.1) {
  const Mat3 R_W_O = o.T_W_O.R();
  const double az = Uniform(rng, -M_PI, M_PI);
  const Vec3 dir_O(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), std::cos(tilt));
  const Vec3 centre = o.Centre();
  const Vec3 p_W_C = centre + distance * (R_W_O * dir_O);
  const Vec3 z = (centre - p_W_C).normalized();
  const Vec3 down = -R_W_O.col(1);
  const Vec3 x = down.cross(z).normalized();
  const Vec3 y = z.cross(x);
  Mat3 R_W_C;
  R_W_C.col(0) = x;
  R_W_C.col(1) = y;
  R_W_C.col(2) = z;
  R_W_C = R_W_C * RotZ(Uniform(rng, -roll_rad, roll_rad));
  return Rigid3(R_W_C, p_W_C);
}

inline Rigid3 CameraLookingAt(std::mt19937& rng, const TestObject& o, double distance,
                              double max_tilt_rad, double roll_rad = 0.1) {
  const double tilt = Uniform(rng, 0.0, max_tilt_rad);
  return CameraAtTilt(rng, o, distance, tilt, roll_rad);
}

// Ideal pinhole projection of the object's corners (undistorted pixels).
inline Corners ProjectCorners(const Mat3& K, const Rigid3& T_W_C, const TestObject& o) {
  Corners c;
  const Rigid3 T_C_W = T_W_C.Inverse();
  for (int j = 0; j < 4; ++j) {
    const Vec3 p = K * (T_C_W * o.Corner(j));
    c[j] = Vec2(p.x() / p.z(), p.y() / p.z());
  }
  return c;
}

inline Corners AddNoise(std::mt19937& rng, const Corners& c, double sigma_px) {
  std::normal_distribution<double> n(0.0, sigma_px);
  Corners out = c;
  for (Vec2& v : out) v += Vec2(n(rng), n(rng));
  return out;
}

// A non-trivial camera-to-body calibration (rotation of tens of degrees, lever arm of centimetres).
inline Rigid3 TestT_B_C() {
  return Rigid3(RotFromRpy(-1.50, 0.05, -1.55), Vec3(0.065, -0.021, 0.009));
}

// CheckJacobians (jacobian_check.h: central differences in the tangent space) plus
// ceres::GradientChecker. GradientChecker differentiates with Ridders' method, whose first step is
// ridders_relative_initial_step_size · |x| (default 1e-2, NOT relative_step_size); at 1e-2 the
// extrapolation on quaternion blocks stops early with errors ~1e-3 even for exact Jacobians, so it
// is set to 1e-5 here.
inline ::testing::AssertionResult ExpectFactorJacobiansOk(
    const ceres::CostFunction& cost, const std::vector<double*>& params,
    const std::vector<const ceres::Manifold*>& manifolds, double tolerance,
    double gc_precision = 1e-6) {
  const JacobianCheckResult res = CheckJacobians(cost, params, manifolds, 1e-6);
  if (!res.evaluated) return ::testing::AssertionFailure() << "cost function failed to evaluate";
  if (!(res.worst_error <= tolerance)) return ::testing::AssertionFailure() << res.Describe();
  ceres::NumericDiffOptions nd;
  nd.ridders_relative_initial_step_size = 1e-5;
  ceres::GradientChecker checker(&cost, &manifolds, nd);
  ceres::GradientChecker::ProbeResults probe;
  if (!checker.Probe(params.data(), gc_precision, &probe)) {
    return ::testing::AssertionFailure() << "ceres::GradientChecker: " << probe.error_log;
  }
  std::cout << "[jacobians] " << res.Describe() << "; GradientChecker max rel. err "
            << probe.maximum_relative_error << "\n";
  return ::testing::AssertionSuccess();
}

}  // namespace fsp::test
