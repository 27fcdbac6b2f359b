#include "fsp/backend/point_factor.h"

#include <string>

#include "fsp/backend/fsp_landmark.h"  // LeftRotationJacobianWrtQuat, PoseFromBlock
#include "fsp/common/error.h"

namespace fsp::backend {

PointPrediction PredictPoint(const Mat3& K, const Rigid3& T_W_C, const Rigid3& T_W_F,
                             const Vec3& bearing_F, double rho) {
  // With T_B_C = identity the "body" poses are the camera poses.
  const Vec3 h = AnchoredHomogeneousPoint(T_W_C, T_W_F, Rigid3::Identity(), bearing_F, rho);
  PointPrediction p;
  p.h_z = h.z();
  p.in_front = h.z() > 0.0;
  p.uv = ProjectHomogeneous(K, h);
  return p;
}

PointFactor::PointFactor(const Vec2& uv_px, const Vec3& bearing_F, const Mat3& K,
                         const Rigid3& T_B_C, const FspFactorOptions& options)
    : obs_(uv_px), a_(bearing_F), K_(K), T_B_C_(T_B_C), options_(options) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
  FSP_CHECK(K_.row(2).isApprox(Eigen::RowVector3d(0.0, 0.0, 1.0)));
  FSP_CHECK(a_.z() == 1.0);
}

// h = R_C_W (ρ (p_W_F − p_W_C) + R_W_F a): AnchoredHomogeneousPoint with ω = ρ; dh/dρ = R_C_W
// (p_W_F − p_W_C) (fsp_factor.h has the pose columns' derivation).
bool PointFactor::Evaluate(double const* const* parameters, double* residuals,
                           double** jacobians) const {
  const Rigid3 T_W_Bc = PoseFromBlock(parameters[0]);
  const Rigid3 T_W_Ba = PoseFromBlock(parameters[1]);
  const double rho = parameters[2][0];
  Mat23 D;
  AnchoredPointJacobians Jh;
  if (!AnchoredReprojection(T_W_Bc, T_W_Ba, T_B_C_, K_, a_, rho, obs_, options_.sigma_px,
                            options_.min_h_z, residuals, jacobians, &D, &Jh))
    return false;
  if (jacobians == nullptr) return true;
  if (jacobians[2] != nullptr) {
    Eigen::Map<Vec2> J(jacobians[2]);
    J = D * Jh.d_omega;
  }
  return true;
}

}  // namespace fsp::backend
