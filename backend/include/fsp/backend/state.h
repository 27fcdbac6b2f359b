// Parameter blocks of the back end's Ceres problem. Every factor of fsp_backend (IMU, FSP, FHP,
// marginalisation prior) reads these layouts; the manifolds that go with them are in manifolds.h.
//
//   pose[7]        = (p_W_B x, y, z,  q_W_B x, y, z, w)      T_W_B: body (IMU) frame B -> world W.
//                    Manifold: PoseManifold (manifolds.h) =
//                      ProductManifold<EuclideanManifold<3>, EigenQuaternionManifold>, i.e.
//                      pose ⊞ (δp, δθ) = (p + δp,  Exp(2δθ) ⊗ q):
//                      δp in the WORLD frame (not p + R δp as fsp::Rigid3::Plus); δθ is Ceres'
//                      quaternion tangent: a LEFT (world-frame) rotation by the rotation vector
//                      2δθ. Factors are written in the right tangent and lifted (see manifolds.h).
//                    Tangent size 6, order (δp, δθ).
//   speed_bias[9]  = (v_W x, y, z,  b_g x, y, z,  b_a x, y, z)
//                    velocity of B in W [m/s], gyroscope bias [rad/s], accelerometer bias [m/s^2],
//                    both biases in B (measured = true + bias + noise). Euclidean (no manifold).
#pragma once

#include <cstdint>

#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::backend {

constexpr int kPoseSize = 7;         // ambient size of a pose block
constexpr int kPoseTangentSize = 6;  // (δp_W, δθ_B)
constexpr int kSpeedBiasSize = 9;    // (v_W, b_g, b_a)

// Gravity in the world frame (z up): g_W = (0, 0, -magnitude) [m/s^2].
inline Vec3 GravityW(double magnitude = 9.81) {
  return Vec3(0.0, 0.0, -magnitude);
}

// Pose block <-> Rigid3 (T_W_B).
inline void PoseToBlock(const Rigid3& T_W_B, double* pose) {
  Eigen::Map<Vec3> p(pose);
  Eigen::Map<Eigen::Vector4d> q(pose + 3);
  p = T_W_B.translation();
  q = T_W_B.rotation().coeffs();  // x, y, z, w
}
inline Rigid3 PoseFromBlock(const double* pose) {
  return Rigid3(Quat(pose[6], pose[3], pose[4], pose[5]), Vec3(pose[0], pose[1], pose[2]));
}

// Views of a speed_bias block.
inline Eigen::Map<Vec3> VelocityOf(double* sb) {
  return Eigen::Map<Vec3>(sb);
}
inline Eigen::Map<Vec3> GyroBiasOf(double* sb) {
  return Eigen::Map<Vec3>(sb + 3);
}
inline Eigen::Map<Vec3> AccBiasOf(double* sb) {
  return Eigen::Map<Vec3>(sb + 6);
}
inline Eigen::Map<const Vec3> VelocityOf(const double* sb) {
  return Eigen::Map<const Vec3>(sb);
}
inline Eigen::Map<const Vec3> GyroBiasOf(const double* sb) {
  return Eigen::Map<const Vec3>(sb + 3);
}
inline Eigen::Map<const Vec3> AccBiasOf(const double* sb) {
  return Eigen::Map<const Vec3>(sb + 6);
}

// The state of one keyframe as the solver sees it: raw parameter blocks (stable addresses when the
// struct itself does not move, e.g. held in a std::deque or by unique_ptr).
struct KeyframeState {
  int64_t t_ns = 0;
  double pose[kPoseSize] = {0, 0, 0, 0, 0, 0, 1};
  double speed_bias[kSpeedBiasSize] = {0, 0, 0, 0, 0, 0, 0, 0, 0};

  Rigid3 T_W_B() const { return PoseFromBlock(pose); }
  void SetT_W_B(const Rigid3& T) { PoseToBlock(T, pose); }
  Vec3 v_W() const { return VelocityOf(speed_bias); }
  Vec3 gyro_bias() const { return GyroBiasOf(speed_bias); }
  Vec3 acc_bias() const { return AccBiasOf(speed_bias); }
  // To/from the shared StateSample type (trajectory output, ground truth).
  StateSample ToStateSample() const {
    StateSample s;
    s.t_ns = t_ns;
    s.T_W_B = T_W_B();
    s.v_W = v_W();
    s.gyro_bias = gyro_bias();
    s.acc_bias = acc_bias();
    return s;
  }
  static KeyframeState FromStateSample(const StateSample& s) {
    KeyframeState k;
    k.t_ns = s.t_ns;
    k.SetT_W_B(s.T_W_B);
    VelocityOf(k.speed_bias) = s.v_W;
    GyroBiasOf(k.speed_bias) = s.gyro_bias;
    AccBiasOf(k.speed_bias) = s.acc_bias;
    return k;
  }
};

}  // namespace fsp::backend
