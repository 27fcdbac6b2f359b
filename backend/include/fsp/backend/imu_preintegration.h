// On-manifold IMU preintegration between two keyframes (Forster, Carlone, Dellaert, Scaramuzza,
// "On-Manifold Preintegration for Real-Time Visual-Inertial Odometry", IEEE TRO 2017), double
// precision.
//
// Between keyframe times t_i < t_j it accumulates, from raw body-frame samples (ω̃, ã) and a bias
// linearisation point (b̄_g, b̄_a):
//   ΔR_ij = R_iᵀ R_j,   Δv_ij = R_iᵀ (v_j − v_i − g Δt),   Δp_ij = R_iᵀ (p_j − p_i − v_i Δt − ½ g
//   Δt²)
// (Forster eq. 33), their Jacobians w.r.t. the biases (eq. 44, first-order bias correction) and the
// 9x9 covariance of the preintegration noise (δφ, δv, δp) (eq. 38-40), with ΔR̃ = ΔR Exp(δφ)
// (right).
//
// Discretisation (midpoint, real timestamps): the boundary samples are interpolated linearly to t_i
// and t_j, so the integration knots are t_i, every sample strictly inside (t_i, t_j), t_j. On an
// interval [t_k, t_k+1] of length dt_k:
//   ω   = ½(ω̃_k + ω̃_k+1) − b_g,  dR = Exp(ω dt_k),  ΔR_k+1 = ΔR_k dR
//   a_W = ½(ΔR_k (ã_k − b_a) + ΔR_k+1 (ã_k+1 − b_a))          (acceleration in frame i)
//   Δp_k+1 = Δp_k + Δv_k dt_k + ½ a_W dt_k²,  Δv_k+1 = Δv_k + a_W dt_k
// The error-state transition A_k (9x9) and noise input B_k (9x6) are the exact linearisation of
// this scheme (see the .cc); Σ_k+1 = A Σ Aᵀ + B diag(σ_g² I, σ_a² I) Bᵀ with the discrete
// white-noise σ = density / √dt_k, and the bias Jacobians follow J_k+1 = A J_k − B. Outside the
// sample coverage the nearest sample is held (counted in extrapolated_s()).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fsp/common/calibration.h"
#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::backend {

using Mat9 = Eigen::Matrix<double, 9, 9>;
using Mat15 = Eigen::Matrix<double, 15, 15>;

struct PreintegrationOptions {
  ImuNoise noise;  // continuous white-noise and random-walk densities (Kalibr names and units)
  double gravity = 9.81;  // |g| [m/s^2]; g_W = (0, 0, −gravity)
  // Re-integrate from the stored samples when the bias estimate has moved further than this from
  // the linearisation point [rad/s] / [m/s^2]. Smaller: more exact, more CPU; first-order
  // correction is accurate to ~1e-5 relative for a 1 s interval at these defaults.
  double reintegrate_gyro_bias_threshold = 0.01;
  double reintegrate_acc_bias_threshold = 0.1;
  bool Check(std::string* why) const;
};

// Corrected (bias-updated) preintegrated measurement.
struct PreintegratedDelta {
  Quat dR = Quat::Identity();
  Vec3 dv = Vec3::Zero();
  Vec3 dp = Vec3::Zero();
};

// The samples a preintegration over [t0, t1] needs from time-ordered SAMPLES: those inside plus
// one before t0 and one after t1, so that it can interpolate the boundaries.
std::vector<ImuSample> ImuSamplesFor(const std::vector<ImuSample>& samples, int64_t t0, int64_t t1);

class ImuPreintegration {
 public:
  // Integrates `samples` (time-ordered, any spacing) between t_i_ns < t_j_ns with the bias
  // linearisation point (bg, ba). Only the samples that matter (one before t_i .. one after t_j)
  // are kept, for re-integration. Throws InputError when samples is empty or out of order.
  ImuPreintegration(const PreintegrationOptions& options, const std::vector<ImuSample>& samples,
                    int64_t t_i_ns, int64_t t_j_ns, const Vec3& bg, const Vec3& ba);

  // Re-integrates from the stored knots with a new bias linearisation point.
  void Reintegrate(const Vec3& bg, const Vec3& ba);
  // Re-integrates when (bg, ba) moved beyond the Options thresholds; returns whether it did.
  bool ReintegrateIfNeeded(const Vec3& bg, const Vec3& ba);

  // First-order bias correction (Forster eq. 44) to the biases (bg, ba).
  PreintegratedDelta Corrected(const Vec3& bg, const Vec3& ba) const;

  // Predicts the state at t_j from the state at t_i (eq. 33 solved for j) with biases (bg, ba).
  void Predict(const Rigid3& T_W_Bi, const Vec3& v_i, const Vec3& bg, const Vec3& ba,
               Rigid3* T_W_Bj, Vec3* v_j) const;

  // Uncorrected quantities at the linearisation point.
  const Quat& delta_R() const { return dR_; }
  const Vec3& delta_v() const { return dv_; }
  const Vec3& delta_p() const { return dp_; }
  double dt() const { return dt_; }  // t_j − t_i [s]
  int64_t t_i_ns() const { return t_i_ns_; }
  int64_t t_j_ns() const { return t_j_ns_; }
  const Vec3& bg_lin() const { return bg_lin_; }
  const Vec3& ba_lin() const { return ba_lin_; }
  double extrapolated_s() const { return extrapolated_s_; }  // time outside the sample coverage [s]
  int num_intervals() const { return static_cast<int>(knots_.size()) - 1; }
  int num_reintegrations() const { return num_reintegrations_; }

  // Bias Jacobians (right-perturbation form for the rotation: ΔR(b̄+δ) ≈ ΔR Exp(dR_dbg δ)).
  const Mat3& dR_dbg() const { return dR_dbg_; }
  const Mat3& dv_dbg() const { return dv_dbg_; }
  const Mat3& dv_dba() const { return dv_dba_; }
  const Mat3& dp_dbg() const { return dp_dbg_; }
  const Mat3& dp_dba() const { return dp_dba_; }

  // Covariance of (δφ, δv, δp) [rad, m/s, m].
  const Mat9& covariance() const { return cov_; }
  // 15x15 covariance of the IMU factor residual (φ, v, p, b_g, b_a): blockdiag(Σ9, σ_bg² Δt I,
  // σ_ba² Δt I) with the continuous random-walk densities, and the upper-triangular square root of
  // its inverse (information = Lᵀ... : whitened r_w = sqrt_information() * r, r_wᵀr_w = rᵀ Σ⁻¹ r).
  const Mat15& covariance15() const { return cov15_; }
  const Mat15& sqrt_information() const { return sqrt_info_; }
  const PreintegrationOptions& options() const { return options_; }

 private:
  struct Knot {
    int64_t t_ns;
    Vec3 gyro, acc;
  };
  void Integrate();

  PreintegrationOptions options_;
  std::vector<Knot> knots_;
  int64_t t_i_ns_ = 0, t_j_ns_ = 0;
  double dt_ = 0.0, extrapolated_s_ = 0.0;
  Vec3 bg_lin_ = Vec3::Zero(), ba_lin_ = Vec3::Zero();
  int num_reintegrations_ = 0;

  Quat dR_ = Quat::Identity();
  Vec3 dv_ = Vec3::Zero(), dp_ = Vec3::Zero();
  Mat3 dR_dbg_ = Mat3::Zero(), dv_dbg_ = Mat3::Zero(), dv_dba_ = Mat3::Zero(),
       dp_dbg_ = Mat3::Zero(), dp_dba_ = Mat3::Zero();
  Mat9 cov_ = Mat9::Zero();
  Mat15 cov15_ = Mat15::Zero(), sqrt_info_ = Mat15::Identity();
};

}  // namespace fsp::backend
