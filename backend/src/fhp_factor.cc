#include "fsp/backend/fhp_factor.h"

#include <cmath>

#include "fsp/common/error.h"

namespace fsp::backend {

CornerPrediction PredictFhpCorners(const Mat3& K, const Rigid3& T_W_C, const Rigid3& T_W_F,
                                   const FhpLandmark& landmark) {
  CornerPrediction out;
  out.in_front = true;
  for (int j = 0; j < 4; ++j) {
    const Vec3 h = AnchoredHomogeneousPoint(T_W_C, T_W_F, Rigid3::Identity(), landmark.Ray(j),
                                            landmark.Omega(j));
    out.h_z[j] = h.z();
    out.in_front = out.in_front && h.z() > 0.0;
    out.uv[j] = ProjectHomogeneous(K, h);
  }
  return out;
}

namespace {
using Mat23R = Eigen::Matrix<double, 2, 3, Eigen::RowMajor>;
}  // namespace

FhpFactor::FhpFactor(const Vec2& corner_px, const Mat3& K, const Rigid3& T_B_C,
                     const FspFactorOptions& options)
    : obs_(corner_px), K_(K), T_B_C_(T_B_C), options_(options) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
  FSP_CHECK(K_.row(2).isApprox(Eigen::RowVector3d(0.0, 0.0, 1.0)));
}

// FHP observation (the FSP paper's baseline): a = (u, v, 1), h = R_C_W(ω(p_W_F − p_W_C) + R_W_F a).
bool FhpFactor::Evaluate(double const* const* parameters, double* residuals,
                         double** jacobians) const {
  const Rigid3 T_W_Bc = PoseFromBlock(parameters[0]);
  const Rigid3 T_W_Ba = PoseFromBlock(parameters[1]);
  const double* c = parameters[2];
  const Vec3 a(c[0], c[1], 1.0);
  const double omega = std::exp(c[2]);
  Mat23 D;
  AnchoredPointJacobians Jh;
  if (!AnchoredReprojection(T_W_Bc, T_W_Ba, T_B_C_, K_, a, omega, obs_, options_.sigma_px,
                            options_.min_h_z, residuals, jacobians, &D, &Jh))
    return false;
  if (jacobians == nullptr) return true;
  if (jacobians[2] != nullptr) {
    Eigen::Map<Mat23R> J(jacobians[2]);
    J.leftCols<2>() = D * Jh.d_a.leftCols<2>();  // da/du = e_x, da/dv = e_y
    J.col(2) = omega * (D * Jh.d_omega);         // dh/dlog ω = ω dh/dω
  }
  return true;
}

FhpAnchorFactor::FhpAnchorFactor(const Vec2& corner_px, const Mat3& K,
                                 const FspFactorOptions& options)
    : obs_(corner_px), K_(K), options_(options) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
  FSP_CHECK(K_.row(2).isApprox(Eigen::RowVector3d(0.0, 0.0, 1.0)));
}

// C = F: h = (u, v, 1), z = π(K h).
bool FhpAnchorFactor::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  const Vec3 h(parameters[0][0], parameters[0][1], 1.0);
  Mat23 D;
  const bool want = jacobians != nullptr && jacobians[0] != nullptr;
  const Vec2 z = ProjectHomogeneous(K_, h, want ? &D : nullptr);
  const double inv_sigma = 1.0 / options_.sigma_px;
  residuals[0] = (z.x() - obs_.x()) * inv_sigma;
  residuals[1] = (z.y() - obs_.y()) * inv_sigma;
  if (want) {
    Eigen::Map<Mat23R> J(jacobians[0]);
    J.leftCols<2>() = inv_sigma * D.leftCols<2>();
    J.col(2).setZero();
  }
  return true;
}

}  // namespace fsp::backend
