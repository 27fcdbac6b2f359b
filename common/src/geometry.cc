#include "fsp/common/geometry.h"

#include <Eigen/SVD>
#include <cmath>
#include <stdexcept>

namespace fsp {

Mat3 Skew(const Vec3& v) {
  Mat3 S;
  S << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return S;
}

Mat3 ExpSO3(const Vec3& phi) {
  return ExpQuat(phi).toRotationMatrix();
}

Quat ExpQuat(const Vec3& phi) {
  const double theta = phi.norm();
  const double half = 0.5 * theta;
  // sin(x)/x with a Taylor series below 1e-4 rad: exact to double precision.
  const double k = theta < 1e-4 ? 0.5 - theta * theta / 48.0 : std::sin(half) / theta;
  return Quat(std::cos(half), k * phi.x(), k * phi.y(), k * phi.z());
}

Vec3 LogQuat(const Quat& q_in) {
  Quat q = q_in.normalized();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // shortest rotation, angle in [0, pi]
  const Vec3 v = q.vec();
  const double s = v.norm();
  if (s < 1e-10) return 2.0 * v / q.w();
  const double theta = 2.0 * std::atan2(s, q.w());
  return theta / s * v;
}

Vec3 LogSO3(const Mat3& R) {
  return LogQuat(Quat(R));
}

Mat3 RightJacobianSO3(const Vec3& phi) {
  const double theta = phi.norm();
  const Mat3 W = Skew(phi);
  if (theta < 1e-5) return Mat3::Identity() - 0.5 * W + W * W / 6.0;
  const double t2 = theta * theta;
  return Mat3::Identity() - (1.0 - std::cos(theta)) / t2 * W +
         (theta - std::sin(theta)) / (t2 * theta) * W * W;
}

Mat3 RightJacobianInvSO3(const Vec3& phi) {
  const double theta = phi.norm();
  const Mat3 W = Skew(phi);
  if (theta < 1e-5) return Mat3::Identity() + 0.5 * W + W * W / 12.0;
  const double t2 = theta * theta;
  return Mat3::Identity() + 0.5 * W +
         (1.0 / t2 - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta))) * W * W;
}

Mat3 RotX(double rad) {
  return Eigen::AngleAxisd(rad, Vec3::UnitX()).toRotationMatrix();
}
Mat3 RotY(double rad) {
  return Eigen::AngleAxisd(rad, Vec3::UnitY()).toRotationMatrix();
}
Mat3 RotZ(double rad) {
  return Eigen::AngleAxisd(rad, Vec3::UnitZ()).toRotationMatrix();
}
Mat3 RotFromRpy(double roll, double pitch, double yaw) {
  return RotZ(yaw) * RotY(pitch) * RotX(roll);
}

Mat3 Orthonormalize(const Mat3& M) {
  Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

Rigid3 Rigid3::FromMatrix(const Mat4& M) {
  const Mat3 A = M.topLeftCorner<3, 3>();
  const Mat3 R = Orthonormalize(A);
  if (!A.allFinite() || (R - A).norm() > 1e-3 ||
      (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
    throw std::invalid_argument("matrix is not a rigid transform (rotation block not orthonormal)");
  }
  return Rigid3(R, M.topRightCorner<3, 1>());
}

Mat4 Rigid3::Matrix() const {
  Mat4 M = Mat4::Identity();
  M.topLeftCorner<3, 3>() = R();
  M.topRightCorner<3, 1>() = translation_;
  return M;
}

Rigid3 Rigid3::Inverse() const {
  const Quat q_inv = rotation_.conjugate();
  return Rigid3(q_inv, -(q_inv * translation_));
}

Rigid3 Rigid3::operator*(const Rigid3& other) const {
  return Rigid3(rotation_ * other.rotation_, rotation_ * other.translation_ + translation_);
}

Rigid3 Rigid3::Plus(const Eigen::Matrix<double, 6, 1>& delta) const {
  return Rigid3(rotation_ * ExpQuat(delta.tail<3>()), translation_ + rotation_ * delta.head<3>());
}

Eigen::Matrix<double, 6, 1> Rigid3::Minus(const Rigid3& other) const {
  Eigen::Matrix<double, 6, 1> d;
  d.head<3>() = rotation_.conjugate() * (other.translation_ - translation_);
  d.tail<3>() = LogQuat(rotation_.conjugate() * other.rotation_);
  return d;
}

Vec3 Rigid3::Transform(const Vec3& p, Mat36* d_out_d_T, Mat3* d_out_d_p) const {
  const Mat3 R = this->R();
  if (d_out_d_T) {
    d_out_d_T->leftCols<3>() = R;
    d_out_d_T->rightCols<3>() = -R * Skew(p);
  }
  if (d_out_d_p) *d_out_d_p = R;
  return R * p + translation_;
}

Rigid3 Interpolate(const Rigid3& a, const Rigid3& b, double alpha) {
  return Rigid3(a.rotation().slerp(alpha, b.rotation()),
                (1.0 - alpha) * a.translation() + alpha * b.translation());
}

}  // namespace fsp
