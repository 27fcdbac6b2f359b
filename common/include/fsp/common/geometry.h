// Rotations and rigid transforms as value types.
//
// Conventions (docs/conventions.md):
//  - T_A_B maps coordinates in frame B into frame A: p_A = T_A_B * p_B.
//  - Quaternions are Eigen's (Hamilton, stored x, y, z, w). Never mix orders; EuRoC csv files store
//    w, x, y, z and are converted at the reader.
//  - Rigid3::Plus perturbs on the right: T ⊞ (δp, δθ) = (p + R δp, R Exp(δθ)). This is NOT Ceres'
//    convention: ceres::EigenQuaternionManifold::Plus(q, δ) = Exp(2δ) ⊗ q (left, half-angle
//    tangent); the back end's factors bridge the two explicitly
//    (backend/include/fsp/backend/manifolds.h).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace fsp {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;
using Mat4 = Eigen::Matrix4d;
using Mat23 = Eigen::Matrix<double, 2, 3>;
using Mat36 = Eigen::Matrix<double, 3, 6>;
using Quat = Eigen::Quaterniond;

// Skew-symmetric matrix: Skew(a) * b == a.cross(b).
Mat3 Skew(const Vec3& v);

// SO(3) exponential map (Rodrigues), exact near zero.
Mat3 ExpSO3(const Vec3& phi);
Quat ExpQuat(const Vec3& phi);
// SO(3) logarithm, angle in [0, pi]. Input must be a rotation matrix (orthonormal, det +1).
Vec3 LogSO3(const Mat3& R);
Vec3 LogQuat(const Quat& q);

// Right Jacobian of SO(3): Exp(phi + d) ≈ Exp(phi) Exp(Jr(phi) d) (Forster et al. 2017, eq. 8).
Mat3 RightJacobianSO3(const Vec3& phi);
// Inverse of the right Jacobian: Log(Exp(phi) Exp(d)) ≈ phi + Jr^-1(phi) d.
Mat3 RightJacobianInvSO3(const Vec3& phi);

// Rotation about a world axis, angle in radians.
Mat3 RotX(double rad);
Mat3 RotY(double rad);
Mat3 RotZ(double rad);
// R = Rz(yaw) Ry(pitch) Rx(roll) (the scene file's rpy_deg convention, in radians here).
Mat3 RotFromRpy(double roll, double pitch, double yaw);

// Nearest rotation (Frobenius norm) to an arbitrary 3x3 matrix, via SVD, with det +1.
Mat3 Orthonormalize(const Mat3& M);

// A rigid transform T_A_B = (R_A_B, p_A_B): p_A = R_A_B p_B + p_A_B.
class Rigid3 {
 public:
  Rigid3() = default;
  Rigid3(const Quat& q, const Vec3& t) : rotation_(q.normalized()), translation_(t) {}
  Rigid3(const Mat3& R, const Vec3& t) : rotation_(Quat(R).normalized()), translation_(t) {}

  static Rigid3 Identity() { return Rigid3(); }
  // From a homogeneous 4x4 matrix; the rotation block is re-orthonormalised (calibration files
  // carry ~1e-9 rounding). Throws std::invalid_argument when the block is far from a rotation (>
  // 1e-3).
  static Rigid3 FromMatrix(const Mat4& M);

  const Quat& rotation() const { return rotation_; }
  const Vec3& translation() const { return translation_; }
  Mat3 R() const { return rotation_.toRotationMatrix(); }
  Mat4 Matrix() const;

  Rigid3 Inverse() const;
  Rigid3 operator*(const Rigid3& other) const;
  Vec3 operator*(const Vec3& p) const { return rotation_ * p + translation_; }

  // Right perturbation: (p + R dp, R Exp(dtheta)), delta = (dp, dtheta).
  Rigid3 Plus(const Eigen::Matrix<double, 6, 1>& delta) const;
  // Inverse of Plus: other = this->Plus(this->Minus(other)).
  Eigen::Matrix<double, 6, 1> Minus(const Rigid3& other) const;

  // Apply to a point with optional Jacobians w.r.t. the right perturbation (dp, dtheta) and the
  // point.
  Vec3 Transform(const Vec3& p, Mat36* d_out_d_T = nullptr, Mat3* d_out_d_p = nullptr) const;

 private:
  Quat rotation_ = Quat::Identity();
  Vec3 translation_ = Vec3::Zero();
};

// Linear interpolation in translation and slerp in rotation, alpha in [0, 1].
Rigid3 Interpolate(const Rigid3& a, const Rigid3& b, double alpha);

}  // namespace fsp
