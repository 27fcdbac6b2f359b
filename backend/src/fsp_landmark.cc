#include "fsp/backend/fsp_landmark.h"

#include <algorithm>
#include <cmath>

#include "fsp/common/error.h"

namespace fsp::backend {

// φ = 2 vec(dq ⊗ q*) for R(q + dq) = Exp(φ) R(q), unit q. With p = dq, q* = (−q_v, q_w):
// vec(p ⊗ q*) = p_w (−q_v) + q_w p_v + p_v × (−q_v) = q_w p_v + q_v × p_v − p_w q_v.
Mat34 LeftRotationJacobianWrtQuat(const Quat& q) {
  Mat34 J;
  J.leftCols<3>() = q.w() * Mat3::Identity() + Skew(q.vec());
  J.col(3) = -q.vec();
  return 2.0 * J;
}

FspLandmark FspLandmark::Make(const Mat3& R_F_O, const Vec3& ray_s1, double omega, double wbar,
                              double form) {
  FSP_CHECK(omega > 0.0 && wbar > 0.0 && form > 0.0);
  FspLandmark l;
  const Quat q = Quat(R_F_O).normalized();
  l.q_F_O[0] = q.x();
  l.q_F_O[1] = q.y();
  l.q_F_O[2] = q.z();
  l.q_F_O[3] = q.w();
  l.x[kFspU] = ray_s1.x() / ray_s1.z();
  l.x[kFspV] = ray_s1.y() / ray_s1.z();
  l.x[kFspLogOmega] = std::log(omega);
  l.x[kFspLogWbar] = std::log(wbar);
  l.x[kFspLogForm] = std::log(form);
  return l;
}

// s1 at p_F = T_F_O.translation(): ω = 1/p_F.z, r = p_F ω, w̄ = w ω, f = w/h.
FspLandmark FspLandmark::FromObject(const Rigid3& T_F_O, double width, double height) {
  const Vec3& s1 = T_F_O.translation();
  FSP_CHECK(s1.z() > 0.0 && width > 0.0 && height > 0.0);
  const double omega = 1.0 / s1.z();
  return Make(T_F_O.R(), s1 * omega, omega, width * omega, width / height);
}

Quat FspLandmark::QuatFO() const {
  return Quat(q_F_O[3], q_F_O[0], q_F_O[1], q_F_O[2]).normalized();
}
Mat3 FspLandmark::R_F_O() const {
  return QuatFO().toRotationMatrix();
}
double FspLandmark::Omega() const {
  return std::exp(x[kFspLogOmega]);
}
double FspLandmark::Wbar() const {
  return std::exp(x[kFspLogWbar]);
}
double FspLandmark::Form() const {
  return std::exp(x[kFspLogForm]);
}

Eigen::Matrix<double, 2, 5> FspLandmark::SizeJacobian() const {
  Eigen::Matrix<double, 2, 5> J;
  J << 0.0, 0.0, -1.0, 1.0, 0.0, 0.0, 0.0, -1.0, 1.0, -1.0;
  J.row(0) *= Width();
  J.row(1) *= Height();
  return J;
}

Eigen::Vector2d FspLandmark::SizeSigma(const Eigen::Matrix<double, 5, 5>& cov_x) const {
  const Eigen::Matrix<double, 2, 5> J = SizeJacobian();
  const Eigen::Matrix2d cov = J * cov_x * J.transpose();
  return Eigen::Vector2d(std::sqrt(std::max(cov(0, 0), 0.0)), std::sqrt(std::max(cov(1, 1), 0.0)));
}

Vec3 FspLandmark::SBar(int j) const {
  FSP_CHECK(j >= 0 && j < 4);
  const double wbar = Wbar();
  return Vec3(wbar * kCornerXi[j], wbar * kCornerEta[j] / Form(), 0.0);
}

Vec3 FspLandmark::CornerDirF(int j) const {
  return Ray() + R_F_O() * SBar(j);
}

std::array<Vec3, 4> FspLandmark::CornersF() const {
  std::array<Vec3, 4> p;
  const double inv_omega = 1.0 / Omega();
  for (int j = 0; j < 4; ++j) p[j] = CornerDirF(j) * inv_omega;
  return p;
}

std::array<Vec3, 4> FspLandmark::CornersW(const Rigid3& T_W_F) const {
  std::array<Vec3, 4> p = CornersF();
  for (Vec3& pj : p) pj = T_W_F * pj;
  return p;
}

Rigid3 FspLandmark::T_F_O() const {
  return Rigid3(QuatFO(), Ray() / Omega());
}
Rigid3 FspLandmark::T_W_O(const Rigid3& T_W_F) const {
  return T_W_F * T_F_O();
}

FhpLandmark FhpLandmark::FromCornersF(const std::array<Vec3, 4>& p_F) {
  FhpLandmark l;
  for (int j = 0; j < 4; ++j) {
    FSP_CHECK(p_F[j].z() > 0.0);
    l.corner[j][0] = p_F[j].x() / p_F[j].z();
    l.corner[j][1] = p_F[j].y() / p_F[j].z();
    l.corner[j][2] = -std::log(p_F[j].z());  // log ω = log(1/z)
  }
  return l;
}

FhpLandmark FhpLandmark::FromFsp(const FspLandmark& fsp) {
  return FromCornersF(fsp.CornersF());
}

double FhpLandmark::Omega(int j) const {
  return std::exp(corner[j][2]);
}

std::array<Vec3, 4> FhpLandmark::CornersF() const {
  std::array<Vec3, 4> p;
  for (int j = 0; j < 4; ++j) p[j] = CornerF(j);
  return p;
}

std::array<Vec3, 4> FhpLandmark::CornersW(const Rigid3& T_W_F) const {
  std::array<Vec3, 4> p = CornersF();
  for (Vec3& pj : p) pj = T_W_F * pj;
  return p;
}

double FhpLandmark::Width() const {
  const std::array<Vec3, 4> p = CornersF();
  return 0.5 * ((p[1] - p[0]).norm() + (p[2] - p[3]).norm());
}

double FhpLandmark::Height() const {
  const std::array<Vec3, 4> p = CornersF();
  return 0.5 * ((p[3] - p[0]).norm() + (p[2] - p[1]).norm());
}

Rigid3 FhpLandmark::T_F_O() const {
  const std::array<Vec3, 4> p = CornersF();
  const Vec3 ex = ((p[1] - p[0]) + (p[2] - p[3])).normalized();
  const Vec3 ey = ((p[3] - p[0]) + (p[2] - p[1])).normalized();
  Mat3 M;
  M.col(0) = ex;
  M.col(1) = ey;
  M.col(2) = ex.cross(ey).normalized();
  const Mat3 R = Orthonormalize(M);
  const Vec3 centroid = 0.25 * (p[0] + p[1] + p[2] + p[3]);
  return Rigid3(R, centroid - R * Vec3(0.5 * Width(), 0.5 * Height(), 0.0));
}

Rigid3 FhpLandmark::T_W_O(const Rigid3& T_W_F) const {
  return T_W_F * T_F_O();
}

}  // namespace fsp::backend
