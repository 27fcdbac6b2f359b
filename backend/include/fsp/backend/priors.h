// Simple priors that fix the gauge and regularise the start of the estimation.
#pragma once

#include <ceres/sized_cost_function.h>

#include "fsp/backend/state.h"
#include "fsp/common/geometry.h"

namespace fsp::backend {

// Prior on a body pose block (DESIGN.md §4, gauge): r = [ (p − p0) / σ_p ;  S · Log(R R0ᵀ) ] with
// the rotation error in the WORLD frame (left), so its z component is the yaw error and x, y are
// roll and pitch about world axes: S = diag(1/σ_rp, 1/σ_rp, 1/σ_yaw). Block: pose[7]. Ambient
// Jacobian through LeftRotationJacobianWrtQuat (fsp_landmark.h), consistent with any quaternion
// manifold.
class PosePrior final : public ceres::SizedCostFunction<6, 7> {
 public:
  PosePrior(const Rigid3& T_W_B0, double sigma_p, double sigma_roll_pitch, double sigma_yaw);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Rigid3 T0_;
  Vec3 inv_sigma_p_, inv_sigma_rot_;
};

// Prior on a speed_bias block: r = diag(1/σ) (sb − sb0), σ per entry (v, b_g, b_a). Linear.
class SpeedBiasPrior final : public ceres::SizedCostFunction<9, 9> {
 public:
  SpeedBiasPrior(const Eigen::Matrix<double, 9, 1>& sb0, const Eigen::Matrix<double, 9, 1>& sigma);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Matrix<double, 9, 1> sb0_, inv_sigma_;
};

// Weak prior on an FSP object's metric width in log space, invariant to re-anchoring:
//   log w = log w̄ − log ω,   r = (log w̄ − log ω − log w_prior) / σ.   Block: x[5] (fsp_landmark.h).
class LogWidthPrior final : public ceres::SizedCostFunction<1, 5> {
 public:
  LogWidthPrior(double width_prior_m, double sigma_log);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double log_w0_, inv_sigma_;
};

}  // namespace fsp::backend
