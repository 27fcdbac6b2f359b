// Initialisation in motion from one rectangle and the IMU (a start that is not still): the
// visual-inertial alignment of VINS-Mono (Qin et al., TRO 2018, section V-B) with a rectangle in
// place of the structure from motion.
//
// 1. The reference object: the one seen in most of the buffered frames. Its shape (form factor
//    f = w/h) and, per frame, the camera pose relative to it at UNIT WIDTH come from the
//    single-view initialisation (single_view_init.h): T_O_C(k) = (R_O_C, s ĉ_k) with the unknown
//    metric width s. Views whose rotation disagrees with the gyroscope's (a planar pose's normal
//    flip near fronto-parallel views) are dropped.
// 2. The rotations: the largest view's, carried to the others by the gyroscope (its bias left at 0
//    for the estimator's prior to refine): a rectangle's orientation from one view is uncertain by
//    degrees (measured 3-8 deg on a rendered 1.4 m window at 4.6 m with 1 px noise; a bias fitted
//    to them came out 0.09 rad/s wrong), while its position in the camera is well determined.
// 3. Velocities (in O), gravity g_O and the scale s from the preintegrated Δp, Δv between
//    consecutive views (Forster et al. 2017, eq. 33), with p_O_B(k) = s ĉ_k − R_O_B(k) p_B_C:
//      s (ĉ_j − ĉ_i) − v_i Δt − ½ g Δt² = R_i Δp_ij + (R_j − R_i) p_B_C
//      v_j − v_i − g Δt                 = R_i Δv_ij
//    linear in (v_0..v_m, g_O, s); then |g_O| is fixed to gravity and the system re-solved on the
//    gravity direction's tangent (VINS-Mono's RefineGravity).
// 4. W: z up (g_W = (0, 0, −gravity)), yaw that of O (the yaw is a gauge freedom), p_W_B = 0 at the
//    first view.
// It REFUSES (success = false, reason) when no object is seen often enough, when the scale is not
// positive or gravity comes out far from its magnitude (wrong data). What the estimator takes from
// it: gravity's direction (roll, pitch) and the velocity. The scale it finds over a 1 s window is
// weak (measured: 0.033 m for a 0.088 m tag of the EuRoC calibration run, 0.038 m for a rendered
// 1.4 m window) and is not used: objects start from their class priors, as after a still start,
// and the estimator finds the scale from parallax and the IMU (the EuRoC tags end within 0.4 mm
// on average).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "fsp/backend/imu_preintegration.h"
#include "fsp/backend/single_view_init.h"
#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::backend {

struct MotionInitOptions {
  // Try it when the static initialisation refuses because the start moves.
  bool enabled = true;
  // Frames buffered for one attempt [s]. Longer: more acceleration seen (scale), but the gyroscope
  // bias and the single-view poses must hold over it.
  double window_s = 1.0;
  // An attempt that refuses is repeated on later frames for this long after the first frame, then
  // the initialisation gives up [s].
  double max_wait_s = 10.0;
  // Views of the reference object used at least this far apart [s]: the camera must move by more
  // than the single-view poses' noise between two of them (with consecutive frames, the noise
  // dominated and pulled the scale towards 0: errors in the variables).
  double min_view_spacing_s = 0.2;
  // The reference object must be seen (all four corners) in at least this many frames (before the
  // spacing).
  int min_views = 8;
  // Views whose camera rotation differs from the gyroscope's prediction by more than this are
  // dropped [deg].
  double max_rotation_error_deg = 10.0;
  // Refuse when the unconstrained gravity estimate's magnitude is off by more than this [m/s^2].
  double max_gravity_error = 2.0;
  // Refuse when the reference object's metric width (the alignment's scale) is outside this range
  // [m]. The scale over 1 s is weak: EuRoC's calibration run starts from its 0.088 m tags at
  // 0.033 m (the window then finds the size), so the range only catches gross failures (the DM-VIO
  // walk with small rectangles detected started from a 30-45 px object 0.15 mm wide and diverged).
  double min_width_m = 0.01;
  double max_width_m = 10.0;
  bool Check(std::string* why) const;
};

struct MotionInitSummary {
  bool success = false;
  std::string reason;  // why it refused; empty on success
  size_t first = 0;    // index of the frame whose state this is (the reference object's first view)
  Rigid3 T_W_B;        // at that frame
  Vec3 v_W = Vec3::Zero();
  Vec3 gyro_bias = Vec3::Zero();  // 0 (see 2.)
  int object_id = -1;             // the reference object
  int views = 0;                  // its views used
  double width = 0.0;             // its metric width (the scale) [m]
  double gravity_error = 0.0;     // | |g_O| − gravity | before the magnitude was fixed [m/s^2]
};

using BufferedFrame = std::pair<int64_t, std::vector<ObjectObservation>>;

// FRAMES in time order (undistorted corners), IMU covering them, K the ideal pinhole, T_B_C the
// camera mount.
MotionInitSummary InitializeInMotion(const std::vector<BufferedFrame>& frames,
                                     const std::vector<ImuSample>& imu, const Mat3& K,
                                     const Rigid3& T_B_C, const PreintegrationOptions& preint,
                                     const SingleViewInitOptions& single_view,
                                     const MotionInitOptions& options);

}  // namespace fsp::backend
