// Initialisation in motion from tracked points and the IMU (VINS-Mono, Qin et al., TRO 2018,
// section V; read from its initial_sfm.cpp / initial_aligment.cpp and OpenVINS's dynamic
// initializer): for a start that is neither still nor shows a whole rectangle (a hand-held walk).
//
// 1. Up-to-scale structure from motion over the buffered frames (visual_sfm.h): keyframes by
//    parallax, the camera poses T_S_C(k) in the first keyframe's camera frame S.
// 2. Gyroscope bias: the preintegrated rotations between consecutive keyframes against the
//    visual ones R_S_B(k) = R_S_C(k) R_C_B (vi_alignment.h, EstimateGyroBias); the IMU is then
//    re-integrated at that bias.
// 3. Velocities, gravity g_S and the scale s from the preintegrated Δp, Δv (vi_alignment.h); then
//    |g| is fixed and the system re-solved on gravity's direction.
// 4. W: z up (g_W = (0, 0, −gravity)), yaw that of S (a gauge freedom), p_W_B = 0 at the first
//    keyframe.
// It REFUSES (success = false, reason) when the structure from motion does (too little parallax,
// too few points), when the gyroscope bias is implausibly large, when gravity's magnitude comes out
// off by more than max_gravity_error_frac before it is fixed, when the scale is not positive, or
// when the result moves faster than max_speed or puts the points closer than min_depth_m or
// further than max_depth_m. The estimator then tries again on a later window.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fsp/backend/imu_preintegration.h"
#include "fsp/backend/visual_sfm.h"
#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::backend {

struct PointInitOptions {
  // Try it when the static initialisation refuses because the start moves, and the frames carry
  // points (frontend.points.enabled). It is tried before the rectangle in motion (motion_init.h),
  // which is tried first only when a rectangle is seen throughout.
  bool enabled = true;
  // Frames buffered for one attempt [s]. Longer: more parallax and acceleration (scale), but the
  // tracks must survive and the bias hold; VINS-Mono uses 10 keyframes (~1-2 s). Measured on the
  // rendered start (test_point_init, render seeds 1-10, 0.5 px): the scale -3.8..+2.4 % off with
  // 1.5 s, -1.1..+2.0 % with 2 s.
  double window_s = 2.0;
  // After a refusal the next attempt starts this much later (the buffer's oldest frames dropped)
  // [s]. Smaller: found sooner, more CPU while refusing (an attempt costs ~10-50 ms).
  double retry_step_s = 0.25;
  // Give up after this long since the first frame [s]; 0: never (a moving recording keeps trying
  // until it succeeds).
  double max_wait_s = 0.0;
  VisualSfmOptions sfm;
  // Plausibility. A gyroscope bias above this is refused [rad/s] (MEMS: ~0.01).
  double max_gyro_bias = 0.1;
  // The rotations after the bias fit must agree with the gyroscope's within this, RMS per
  // keyframe interval [deg].
  double max_rotation_rms_deg = 1.0;
  // The accelerometer bias is estimated with the alignment when this is > 0: its prior σ relative
  // to the alignment's unweighted equations (vi_alignment.h; 0: b_a = 0 as in VINS-Mono). A bias
  // constant in B looks like gravity until the body turns; unmodelled, what gravity's fixed
  // magnitude cannot take goes into the scale. Measured: the rendered start (bias 0.027 m/s^2) the
  // same either way (seeds 1-10: -1.8..+1.5 % with 10, -1.1..+2.0 % with 0); the DM-VIO walk (bias
  // ~0.34 m/s^2) 1.27 -> 1.20 times the reference's baseline with 10.
  double acc_bias_sigma = 0.0;
  // An estimated accelerometer bias above this is refused [m/s^2].
  double max_acc_bias = 1.0;
  // | |g| − gravity | / gravity of the free solution at most (before |g| is fixed).
  double max_gravity_error_frac = 0.1;
  // The velocities at most [m/s], and the points' median depth within [min_depth_m, max_depth_m]
  // [m] (a wrong scale shows as an impossible speed or room).
  double max_speed = 10.0;
  double min_depth_m = 0.2;
  double max_depth_m = 100.0;
  // The camera must have moved this far from the first keyframe at some keyframe [m]: the scale
  // is the visual displacement matched to the accelerometer's double integral, and an
  // accelerometer error of 0.025 m/s^2 (a bias the alignment does not take out) integrates to 5
  // cm over 2 s. A wrong start on the DM-VIO walk (sfm.min_points 20 instead of 30) had moved 2.6
  // cm, and the run then diverged 32 times; its right start moved 11 cm or more, the rendered
  // starts 0.3-1 m.
  double min_motion_m = 0.05;
  bool Check(std::string* why) const;
};

struct PointInitSummary {
  bool success = false;
  std::string reason;  // why it refused; empty on success
  size_t first = 0;    // index of the frame whose state this is (the first keyframe)
  Rigid3 T_W_B;        // at that frame
  Vec3 v_W = Vec3::Zero();
  Vec3 gyro_bias = Vec3::Zero();
  Vec3 acc_bias = Vec3::Zero();   // 0 unless acc_bias_sigma > 0
  double scale = 0.0;             // metres per unit of the structure from motion
  double baseline_m = 0.0;        // metric distance of the first to the last keyframe's camera [m]
  int64_t t_last_ns = 0;          // the last keyframe's time
  double gravity_error = 0.0;     // | |g_S| − gravity | of the free solution [m/s^2]
  double rotation_rms_deg = 0.0;  // rotations vs the gyroscope after the bias fit [deg]
  double alignment_rms = 0.0;     // residual RMS of the alignment's equations
  double median_depth_m = 0.0;
  int keyframes = 0;  // posed keyframes
  int points = 0;     // triangulated points
  VisualSfmSummary sfm;
};

// FRAMES in time order with their points (undistorted pixels), IMU covering them, K the ideal
// pinhole, T_B_C the camera mount.
PointInitSummary InitializeFromPoints(const std::vector<SfmFrame>& frames,
                                      const std::vector<ImuSample>& imu, const Mat3& K,
                                      const Rigid3& T_B_C, const PreintegrationOptions& preint,
                                      const PointInitOptions& options);

}  // namespace fsp::backend
