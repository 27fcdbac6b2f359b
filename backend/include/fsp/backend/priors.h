// Simple priors that fix the gauge and regularise the start of the estimation.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/sized_cost_function.h>

#include "fsp/backend/state.h"
#include "fsp/common/geometry.h"

namespace fsp::backend {

// Prior on a body pose block (backend/README.md, "Gauge"): r = [ (p − p0) / σ_p ;  S · Log(R R0ᵀ) ]
// with the rotation error in the WORLD frame (left), so its z component is the yaw error and x, y
// are roll and pitch about world axes: S = diag(1/σ_rp, 1/σ_rp, 1/σ_yaw). Block: pose[7]. Ambient
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

// The same prior on an FHP object's metric width, w = (|s2 − s1| + |s3 − s4|) / 2 as
// FhpLandmark::Width (invariant to re-anchoring): r = (log w − log w_prior) / σ. Blocks: the four
// corners' fhp[3] (fsp_landmark.h). Automatic derivatives.
ceres::CostFunction* MakeFhpLogWidthPrior(double width_prior_m, double sigma_log);

// Stands in for the IMU factor between two keyframes when the IMU stream has a hole between them
// (a driver gap: preintegration over missing samples is unusable). A constant-velocity motion
// model with an inflated covariance, the 15 residuals of the IMU factor's blocks:
//   r_θ = Log(R_iᵀ R_j) / (ω_max Δt),       r_v = (v_j − v_i) / (a_max Δt),
//   r_p = (p_j − p_i − ½ (v_i + v_j) Δt) / (a_max Δt²),
//   r_bg = (b_g,j − b_g,i) / (σ_gw √Δt),    r_ba = (b_a,j − b_a,i) / (σ_aw √Δt)
// (a constant acceleration a leaves r_p = 0 and r_v = a Δt: the prior says "accelerations and
// turn rates up to a_max, ω_max"; the bias random walk is the IMU's own). It keeps the problem well
// posed across the gap while visual factors, where objects are in view, determine the motion.
// Blocks: pose_i[7], speed_bias_i[9], pose_j[7], speed_bias_j[9] (state.h). Automatic
// derivatives in the ambient parameters. Requires dt_s > 0 and positive sigmas (checked).
struct ImuGapPriorOptions {
  double max_acc = 2.0;       // a_max [m/s^2]
  double max_rate = 1.0;      // ω_max [rad/s]
  double gyro_walk = 1.9e-5;  // σ_gw [rad/s^2/√Hz]
  double acc_walk = 3.0e-3;   // σ_aw [m/s^3/√Hz]
};
ceres::CostFunction* MakeImuGapPrior(double dt_s, const ImuGapPriorOptions& options);

// Ties two body poses to a relative pose T_i_j measured earlier (the window's estimate, where the
// global step holds no points; backend/README.md, "Points"):
//   r_p = (R_iᵀ (p_j − p_i) − t_ij) / σ_p,   r_θ = 2 vec(q_ijᵀ q_iᵀ q_j) / σ_θ   (q_ij's
//   conjugate).
// Blocks: pose_i[7], pose_j[7] (state.h). Automatic derivatives in the ambient parameters.
// Requires positive sigmas (checked). FREE_LENGTH: the position residual's component along t_ij
// is dropped (its row is 0): only the direction of the translation is held, not its length.
ceres::CostFunction* MakeRelativePosePrior(const Rigid3& T_i_j, double sigma_p, double sigma_rot,
                                           bool free_length = false);

}  // namespace fsp::backend
