// Visual-inertial alignment (VINS-Mono, Qin et al., TRO 2018, section V-B; Forster et al. 2017,
// eq. 33): given the body rotations R_S_B(k) and the camera positions ĉ_k of views k in a frame S
// at an unknown scale s (metric p_S_C = s ĉ_k), and the IMU preintegrated between consecutive
// views, find the velocities, gravity in S and the scale. With p_S_B(k) = s ĉ_k − R_S_B(k) p_B_C:
//   s (ĉ_j − ĉ_i) − v_i Δt − ½ g Δt² = R_i Δp_ij + (R_j − R_i) p_B_C
//   v_j − v_i − g Δt                 = R_i Δv_ij
// linear in (v_0..v_m [in S], g_S, s). Optionally also in the accelerometer bias b_a, through the
// preintegration's first-order bias Jacobians (Δp + J_p^a b_a, Δv + J_v^a b_a), with a prior
// b_a ~ N(0, acc_bias_sigma²) relative to the equations' unit weight: a bias constant in B is told
// from gravity only as far as the body turns. Used by the initialisation in motion from a rectangle
// (motion_init.h: S = the object's frame) and from points (point_init.h: S = the first keyframe's
// camera of the structure from motion).
#pragma once

#include <memory>
#include <vector>

#include "fsp/backend/imu_preintegration.h"
#include "fsp/common/geometry.h"

namespace fsp::backend {

// One view: the body rotation and the camera position at unit scale, in S.
struct AlignmentView {
  Mat3 R_S_B = Mat3::Identity();
  Vec3 c_hat = Vec3::Zero();
};

struct Alignment {
  std::vector<Vec3> v;      // per view, in S [m/s]
  Vec3 g = Vec3::Zero();    // gravity in S [m/s^2]
  double s = 0.0;           // metric length of one unit of ĉ [m]
  double residual_rms = 0;  // RMS of the equations' residuals (positions [m] and velocities [m/s])
  Vec3 acc_bias = Vec3::Zero();  // [m/s^2]; 0 unless estimated
};

// The accelerometer bias as an unknown: ACC_BIAS_SIGMA > 0 is its prior σ in units of the
// equations' residuals per m/s^2 (the equations are unweighted); 0: not estimated (b_a = 0).
struct AlignmentOptions {
  double acc_bias_sigma = 0.0;
};

// PRE[k] is the preintegration between views k and k + 1. With G_DIR (unit), gravity is
// g_mag G_DIR + B δ (δ on the tangent of the direction, VINS-Mono's RefineGravity step) instead of
// free.
Alignment AlignVisualInertial(const std::vector<AlignmentView>& views,
                              const std::vector<std::unique_ptr<ImuPreintegration>>& pre,
                              const Vec3& p_B_C, const Vec3* g_dir, double g_mag,
                              const AlignmentOptions& options = AlignmentOptions());

// The free solution, then gravity's magnitude fixed to G_MAG and the system re-solved on its
// direction ITERATIONS times. GRAVITY_ERROR (optional): | |g| − g_mag | of the free solution.
Alignment AlignWithGravityMagnitude(const std::vector<AlignmentView>& views,
                                    const std::vector<std::unique_ptr<ImuPreintegration>>& pre,
                                    const Vec3& p_B_C, double g_mag, int iterations,
                                    double* gravity_error,
                                    const AlignmentOptions& options = AlignmentOptions());

// The gyroscope bias that makes the preintegrated rotations agree with the views' (VINS-Mono's
// solveGyroscopeBias): Σ_k ‖Log(ΔR_k(b)ᵀ R_S_Bkᵀ R_S_Bk+1)‖² with ΔR(b̄ + δ) ≈ ΔR Exp(J δ),
// linear in δ, solved ITERATIONS times with re-integration at the new bias (PRE is re-integrated
// at the result). ROTATION_RMS (optional): the residual rotation after it, RMS per view pair [rad].
Vec3 EstimateGyroBias(const std::vector<AlignmentView>& views,
                      const std::vector<std::unique_ptr<ImuPreintegration>>& pre, int iterations,
                      double* rotation_rms);

}  // namespace fsp::backend
