// The IMU factor: 15 whitened residuals between two consecutive keyframes from one preintegration.
//
// Residual (Forster et al., TRO 2017, eq. 45, with the bias random walk of eq. 48 appended),
// frames: R_i = R_W_Bi, p_i = p_W_Bi, v_i = v_W of keyframe i, g = (0, 0, −|g|), Δt = t_j − t_i,
// and the preintegrated deltas first-order corrected to the current bias b_i (eq. 44):
//   r_φ  = Log( ΔR̃(b_i)ᵀ R_iᵀ R_j )
//   r_v  = R_iᵀ (v_j − v_i − g Δt) − Δṽ(b_i)
//   r_p  = R_iᵀ (p_j − p_i − v_i Δt − ½ g Δt²) − Δp̃(b_i)
//   r_bg = b_g,j − b_g,i,   r_ba = b_a,j − b_a,i
// whitened r_w = S r with S = Lᵀ, Σ15⁻¹ = L Lᵀ (ImuPreintegration::sqrt_information).
//
// Jacobians are ANALYTIC. They are derived in the right tangent of each pose (δp in world,
// R ← R Exp(δθ)) and of the Euclidean speed_bias, e.g. ∂r_φ/∂δθ_j = Jr⁻¹(r_φ),
// ∂r_φ/∂δθ_i = −Jr⁻¹(r_φ) R_jᵀ R_i, ∂r_φ/∂b_g,i = −Jr⁻¹(r_φ) Exp(r_φ)ᵀ Jr(J_R δb_g) J_R (Forster
// eq. 45 derivatives, Appendix), then lifted to the ambient pose parameters with PoseRightLift
// (manifolds.h): J_ambient = J_tangent · 4P_rᵀ, which satisfies J_ambient · P = J for the pose's
// Ceres manifold. Parameter blocks: pose_i[7], speed_bias_i[9], pose_j[7], speed_bias_j[9]
// (state.h).
#pragma once

#include <memory>

#include <ceres/sized_cost_function.h>

#include "fsp/backend/imu_preintegration.h"

namespace fsp::backend {

using Vec15 = Eigen::Matrix<double, 15, 1>;

class ImuFactor : public ceres::SizedCostFunction<15, 7, 9, 7, 9> {
 public:
  // The preintegration is shared: the estimator may re-integrate it between solves
  // (ImuPreintegration::ReintegrateIfNeeded) and the factor reads the current values.
  explicit ImuFactor(std::shared_ptr<const ImuPreintegration> preintegration);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // Unwhitened residual (φ, v, p, b_g, b_a) for diagnostics and tests.
  Vec15 UnwhitenedResidual(const double* pose_i, const double* speed_bias_i, const double* pose_j,
                           const double* speed_bias_j) const;

  const ImuPreintegration& preintegration() const { return *pre_; }

 private:
  std::shared_ptr<const ImuPreintegration> pre_;
};

}  // namespace fsp::backend
