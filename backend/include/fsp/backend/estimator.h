// The visual-inertial estimator: keyframe states (pose, velocity, IMU biases) and rectangle
// landmarks (FSP, or the FHP baseline) in one Ceres problem, fed with IMU samples and per-frame
// object observations (undistorted corners). The README's "How it works" and docs/conventions.md
// give the frames.
//
// Modes:
//  - kWindow (online): keyframes every keyframe_interval_s (default 0.1 s), the newest frame
//    always solved with them; the problem holds the last `window_size` keyframes
//    and the objects they see. When a keyframe leaves the window, the objects anchored at it are
//    re-anchored exactly at the newest keyframe that sees s1 in front (reanchor.h); its inertial
//    information (IMU factor to the next keyframe, the previous prior) is marginalised into a
//    linear prior on the next keyframe by Schur complement; and its object observations stay as
//    "past views" with its pose held constant (as a local bundle adjustment with fixed keyframes
//    does), so objects keep what older views told about them without putting them in the dense
//    prior. Why not marginalise the object observations too: objects live for the whole sequence,
//    and a linear prior on their parameters, linearised while their depth is still poorly known
//    (class prior, little parallax), pulled later solutions away (measured: ATE 15 cm vs 2 cm on
//    the default scene's first 20 s). The cost per frame is bounded by the window and
//    max_past_views, not the sequence length. Objects out of view stay in the map and are re-used
//    when seen again. Beside the window, the global step (GlobalOptions) solves every keyframe and
//    object together, closes the loop of a returning object and ends the sequence with a final
//    global solve.
//  - kBatch (offline, the accuracy reference): every keyframe stays a variable; the growing problem
//    is re-solved every `batch_solve_every` keyframes (IMU prediction in between) to keep the
//    values near the optimum, and at the end one full problem over every keyframe and observation
//    is solved to convergence. By default every frame is a keyframe (the paper's experiment); with
//    batch_keyframe_interval_s > 0 keyframes are chosen as in the window and the frames between
//    them are predicted through the IMU from the keyframe before them after the final solve: ~10x
//    faster, less accurate (the corners seen between keyframes are not used).
//
// Gauge: the world frame is fixed at the first keyframe by a prior on its position and yaw (and on
// the biases from the static initialisation); the remaining 4-DoF freedom (x, y, z, yaw) of the VIO
// problem is otherwise unobservable.
//
// Single-threaded and deterministic: the same inputs give the same outputs.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fsp/backend/fsp_factor.h"
#include "fsp/backend/imu_preintegration.h"
#include "fsp/backend/motion_init.h"
#include "fsp/backend/point_init.h"
#include "fsp/backend/single_view_init.h"
#include "fsp/backend/state.h"
#include "fsp/backend/static_init.h"
#include "fsp/common/calibration.h"
#include "fsp/common/types.h"

namespace fsp::backend {

enum class EstimatorMode { kWindow, kBatch };
enum class LandmarkType { kFsp, kFhp };

// What real drivers do to the input, and how the estimator detects that its state went wrong
// (backend/README.md, "Gaps and faults"). Nothing here changes a run without such faults.
struct FaultOptions {
  // The IMU stream has a hole longer than this between two keyframes: the preintegration across it
  // is replaced by a constant-velocity motion prior (priors.h, MakeImuGapPrior) [s]. Shorter holes
  // are interpolated by the preintegration (dropped samples).
  double max_imu_gap_s = 0.1;
  // The motion prior's bounds: accelerations [m/s^2] and turn rates [rad/s] it allows per second
  // of gap.
  double gap_max_acc = 2.0;
  double gap_max_rate = 1.0;
  // Consecutive frames further apart than this are a frame gap (counted and warned; the IMU
  // preintegration bridges it) [s].
  double frame_gap_s = 0.5;
  // A stretch of at least this long with no object observation is counted and warned [s].
  double blind_s = 2.0;
  // Divergence: a solve that fails, leaves a non-finite state, a speed above max_speed [m/s], a
  // bias above max_gyro_bias [rad/s] / max_acc_bias [m/s^2], or moves a keyframe further than
  // max_jump_m [m] (or max_view_error_px, below) is rejected (the states before it are restored)
  // and the estimator restarts a new session at the newest frame.
  double max_speed = 30.0;
  double max_gyro_bias = 1.0;
  double max_acc_bias = 2.0;
  double max_jump_m = 5.0;
  // ...or leaves every object in view of the newest frame (at least two, whole views of objects in
  // the map) further than this from where it puts them [RMS px]: the solve follows the IMU against
  // the camera (a corrupted IMU burst, whose speed the robust loss lets the views not contradict).
  double max_view_error_px = 50.0;
  // A restarted session's priors: velocity σ around the last plausible velocity [m/s], roll and
  // pitch σ [rad].
  double restart_velocity_sigma = 1.0;
  double restart_roll_pitch_sigma = 0.1;
  bool Check(std::string* why) const;
};

// Window mode's global step (backend/README.md, "Global step and loops"): a visual-inertial bundle
// adjustment over every keyframe and object, beside the window, so that an object that returns
// closes a loop (it keeps its identity) and scale and biases come from the whole history.
enum class WindowBoundary {
  kPrior,  // the window's dense marginalisation prior, re-centred at every global solve
  kFixed,  // no prior: the keyframe before the window is held at its estimate (ORB-SLAM3 style)
};

struct GlobalOptions {
  bool enabled = true;
  // A global solve every this many keyframes (and whenever a loop closes) [keyframes].
  int every_keyframes = 5;
  // Solver iterations of a global solve during the run, and of the final one (Finish).
  int max_iterations = 10;
  int final_iterations = 50;
  // A global solve during the run stops once an iteration lowers the cost by less than this
  // fraction (Ceres' function_tolerance). Its first step takes most of the way (the cost falls
  // 10-1000x: the window's first keyframe has moved away from the marginalised one before it);
  // 1e-4 saves a quarter of the CPU from pixels but costs the causal estimate 0.2-0.45 cm on
  // gt-corners (backend/README.md, "Cost").
  double function_tolerance = 1e-8;
  // A global solve started at keyframe k works on a copy of the states and objects and is applied
  // when keyframe k + apply_after_keyframes arrives (earlier when a loop needs the map): keyframes
  // in the solve take its values, the ones added since move rigidly with the newest of them
  // (OKVIS2's synchronisation). With `background` the solve runs on its own thread meanwhile;
  // without, inside AddFrame of keyframe k. Both give the same output, byte for byte. 1 (against
  // 5): the window takes the global solution one keyframe later instead of five, and waits
  // for it when it is not done (backend/README.md, "Schedule")...
  int apply_after_keyframes = 1;
  // ...plus one keyframe per this many keyframes in the solve: a solve's cost grows with the
  // keyframes it holds, and the window should not wait for it (a 10-minute flight's per-frame time
  // grew 1.65x with a fixed lag of 1). Deterministic: a function of the problem, not of the clock.
  // 0: the lag is apply_after_keyframes alone.
  int apply_after_per_keyframes = 500;
  bool background = true;
  // The global solves during the run hold every keyframe older than the newest
  // max_free_keyframes at its estimate, except the keyframes since a loop's object was last seen
  // (they are free): so their cost stops growing with the run. 0: every keyframe is free. The final
  // solve frees every keyframe. With keyframes every 0.1 s (default room, render seeds 1 / 3,
  // gt-corners): 150 (15 s) -> causal ATE 4.3 / 5.7 cm; 100 (10 s) -> 4.1 / 5.4 cm at 27 % less
  // global CPU; 60 -> 4.8 / 5.9 cm; 40 -> 25 / 19 cm (the final map the same within 0.05 mm).
  int max_free_keyframes = 150;
  WindowBoundary boundary = WindowBoundary::kPrior;
  // A returning object (no window keyframe saw it) predicted within this RMS error of its corners
  // closes its loop as it is; further, the window is first pre-aligned onto the object's map
  // estimate (the camera pose the object's corners give, spread over the keyframes since it was
  // last seen) [px].
  double loop_direct_px = 8.0;
  // After the pre-alignment, the loop is accepted when the object's corners are within this RMS of
  // their prediction; otherwise it is rejected and the object starts afresh as a new instance
  // [px].
  double loop_accept_px = 15.0;
  // Plausibility budget of a pre-alignment: position correction <= budget_m + budget_per_m x the
  // distance travelled since the object was last seen + ½ budget_blind_acc T² (T: the time since
  // then with no object in view, pure IMU dead reckoning, whose drift an accelerometer bias error
  // of budget_blind_acc [m/s²] grows with T²), yaw <= budget_yaw_deg + budget_yaw_per_m x that
  // distance.
  double budget_m = 0.3;
  double budget_per_m = 0.1;
  double budget_blind_acc = 0.02;
  double budget_yaw_deg = 3.0;
  double budget_yaw_per_m = 0.5;
  bool Check(std::string* why) const;
};

// Zero-velocity detection (backend/README.md, "Standing still"): a keyframe whose IMU agrees with
// standing still since the previous keyframe and whose objects did not move in the image gets a
// zero-velocity prior and a still link to the previous keyframe, so that a vehicle standing still
// does not drift on the IMU's noise and its gyroscope bias is the mean rate it stood still with.
struct ZeroVelocityOptions {
  bool enabled = true;
  // The IMU since the previous keyframe agrees with standing still: its mean turn rate is the
  // estimated gyroscope bias, its mean specific force gravity's plus the accelerometer bias, each
  // to the samples' own scatter (a vehicle vibrating on the ground, EuRoC V1_01: accelerometer std
  // 0.6-2 m/s^2, has no mean motion) and at least turn_rate_sigma, velocity_sigma / Δt; one χ²(6)
  // accepted below this quantile (zero_velocity.h). It tells what the image cannot: a hover that
  // turns at 0.01 rad/s, a take-off's first 0.2 s.
  double imu_confidence = 0.99;
  // The corners of the objects seen by both keyframes moved no more than their noise (the
  // observation σ, FspFactorOptions::sigma_px) explains: two chi-square tests (zero_velocity.h),
  // each accepted below this quantile. Lower: a slow motion is found sooner, a still keyframe is
  // more often missed (harmless: its neighbours keep the prior). Measured (hall flight, seed 1,
  // gt-corners, FSP): 0.95 takes its slow take-off for still, ATE 2.93 cm at 0.2 s keyframes and
  // 5.7 cm at 0.1 s; 0.75: 2.80 cm and 1.38 cm (backend/README.md, "Standing still"). A keyframe
  // that shares no object with the reference is never taken as still (a smooth flight at constant
  // velocity has a still IMU too).
  double confidence = 0.75;
  double velocity_sigma = 0.01;  // σ of the zero-velocity prior [m/s]
  // Standing still, the camera does not turn either: between a still keyframe and the one before
  // it a relative-pose prior holds the rotation to turn_rate_sigma Δt (and the position to
  // velocity_sigma Δt). Through the IMU factor it gives the gyroscope bias the whole stand-still's
  // mean rate, not only the still start's first second (backend/README.md, "Standing still").
  double turn_rate_sigma = 1e-3;  // [rad/s]
  // With points in use and no object both keyframes see, at least this many tracked points both
  // see stand in (the same two tests, each point in its noise; zero_velocity.h): a start standing
  // in front of a blank or textured wall is held still too. 0: objects only.
  int min_points = 10;
  bool Check(std::string* why) const;
};

// Point features beside the objects (backend/README.md, "Points"): each point is one inverse depth
// ρ anchored at the keyframe of its first view in the window, along that view's bearing
// (point_factor.h, as VINS-Mono), in the window only (not in the global step, not in the map).
// They only act when AddFrame is given points (the pixel front ends' frontend.points); with none
// (gt-corners, external corners) nothing changes.
struct PointOptions {
  bool enabled = true;
  // Pixel noise of a tracked point [px] (the front end's LK drift: median 0.3, p90 0.8 px on the
  // room), and its robust loss (k_sigma in σ units, per coordinate, as RobustLossOptions).
  double sigma_px = 1.0;
  RobustLossOptions robust{RobustLossOptions::Type::kHuber, 1.5};
  // Live points a keyframe sees at most; new ones enter longest-tracked first. More: more
  // constraints, more CPU per keyframe (each point a parameter and ~2 residuals per keyframe).
  int max_points = 150;
  // A point enters once seen by at least min_views keyframes whose rays (first and newest view,
  // rotation removed) are at least min_parallax_deg apart: less parallax gives depths too
  // uncertain to linearise [deg]...
  int min_views = 2;
  double min_parallax_deg = 1.0;
  // ...triangulated (linear, over every window view) in front of every view, at a depth in the
  // anchor within [min_depth_m, max_depth_m] (also the bounds of ρ in the solve) [m], and
  // reprojected within max_triangulation_px of every view [px].
  double min_depth_m = 0.1;
  double max_depth_m = 50.0;
  double max_triangulation_px = 3.0;
  // After each window solve a point with a view further than this from its prediction is dropped
  // (counted in points_rejected) [px].
  double outlier_px = 3.0;
  // Objects on probation. In a run with points, an object constrains the poses only from its
  // object_probation_views-th view on; before, it is refined alone against the poses that the
  // points and the IMU give (held), and once it has 3 views in the window it is dropped for good
  // (objects_moving, warned) when they lie further than object_gate_px (RMS) from it: it moves
  // with the camera (the recording laptop's screen), swings (a door) or is no rectangle. So such an
  // object cannot bend the trajectory and have the points dropped as the outliers instead. A
  // mature object whose window views lie further than object_gate_px from it (median, 5 views or
  // more: a quad across four doors that no rectangle explains once the camera moves) is rejected
  // (objects_rejected): it leaves the estimate and the map (backend/README.md, "Objects on
  // probation").
  // 0 views: no probation.
  int object_probation_views = 5;
  double object_gate_px = 3.0;
  // When the anchor keyframe leaves the window, its views of the points anchored at it go into the
  // marginalisation prior with their inverse depths (VINS-Mono); false: they are dropped with it.
  // Without them the window's position and yaw keep only the IMU chain's prior and wander where no
  // object holds them (a 14 s flight through random points: the last window slid 31 cm).
  bool marginalize = true;
  // ...and each such point is dropped (false; still tracked, it enters again as a new landmark
  // from its later keyframes' views, as Basalt's), or moves into the next keyframe that sees it,
  // its bearing from that view, its depth from the estimate (true; VINS-Mono's, whose later views
  // then count twice: once in the prior, once as factors). Measured (backend/README.md, "Points"),
  // the room without objects from pixels: re-anchored 47 cm ATE, dropped 7.3 cm; the room: 0.225 /
  // 0.224 cm.
  bool reanchor = false;
  // The global step holds no points: a keyframe that saw points but no object, in a stretch
  // without objects of at least faults.blind_s, is tied there to the keyframe before it (and the
  // stretch's last to the keyframe after it) by the window's estimate of their relative pose, taken
  // when the earlier of the two left the window: σ = global_sigma_m + global_sigma_per_m × their
  // distance in position [m], global_sigma_deg in rotation [deg] (backend/README.md, "Points").
  double global_sigma_m = 0.002;
  double global_sigma_per_m = 0.01;
  double global_sigma_deg = 0.1;
  // Elsewhere, two consecutive keyframes that both saw live points are tied by the shape of that
  // relative pose alone: its rotation and the direction of its translation (the same σ across it),
  // its length free, so that the objects and the IMU keep the scale and one poor object in view
  // (a track that slides) cannot bend the trajectory against the points (backend/README.md,
  // "Points"). False: only the stretches without objects are tied.
  bool global_shape_links = true;
  bool Check(std::string* why) const;
};

struct EstimatorOptions {
  EstimatorMode mode = EstimatorMode::kWindow;
  LandmarkType landmarks = LandmarkType::kFsp;
  // Keyframes in the sliding window. Longer: more parallax for inverse depth and better scale, more
  // CPU per frame (roughly linear). 45 (4.5 s at keyframe_interval_s 0.1): a handheld walk's slow
  // motion needs that long to hold the metric scale on points alone (backend/README.md, "Window
  // length").
  int window_size = 45;
  // Window mode: a frame becomes a keyframe when this much time passed since the last keyframe, or
  // when it sees an object that is new (or back after leaving the window) [s]. Other frames are
  // solved with the window (their pose is reported) and then dropped. Longer: the window spans more
  // time (better scale and velocity before marginalisation) for the same CPU; too long: less visual
  // information per second. 0 = every frame is a keyframe. Measured (default room 60 s, render
  // seeds 1/2/3, noise seed 1; backend/README.md, "Cost"), 0.2 s -> 0.1 s: gt-corners FSP ATE
  // 0.47/0.29/0.55 -> 0.29/0.24/0.37 cm, causal 2.9/2.4/2.9 -> 2.6/2.1/2.7 cm; FHP causal
  // 4.1/3.8/4.1 -> 3.0/2.6/3.2 cm; from pixels causal 4.0/3.8/4.7 -> 2.6/2.8/3.1 cm at the same
  // tracking success; the hall flight FSP ATE 2.3 -> 1.3 cm.
  double keyframe_interval_s = 0.1;
  // Window: and at least this many frames after the last keyframe (a new object still makes one at
  // once). 0 = 1 (the application resolves it by its front end: `fsp run` takes 2 from pixels,
  // whose tracked corners share their errors between consecutive frames, and 1 with ground-truth
  // or external corners). Only a camera whose frame period reaches keyframe_interval_s (10 Hz or
  // slower at 0.1 s) is affected. Measured on the 135 s hall flight (10 Hz camera) from pixels: 1
  // -> 2 frames, ATE 3.04 -> 1.63 cm, causal 16.0 -> 12.6 cm, CPU 68 -> 29 s; with ground-truth
  // corners (1 px, independent per frame) 2 frames instead is worse, 1.39 -> 2.39 cm.
  int keyframe_min_frames = 0;
  // Batch mode: the same for the batch (and a keyframe on every new object); the other frames are
  // predicted through the IMU, not solved [s]. 0 = every frame is a keyframe. Measured (1 px, seed
  // 1): default room 60 s: 0 -> ATE 0.42 cm at 0.4x real time, 0.2 -> 0.67 cm at 4.2x; its first
  // 20 s: 2.0 cm against 4.1 cm; the 135 s hall flight: 0.2 -> 2.2 cm (Sim3 1.4 cm) at 1.3x, 0 ->
  // not finished after 12 minutes.
  double batch_keyframe_interval_s = 0.0;
  // Solver iterations per frame in the window (Levenberg-Marquardt). The window is re-solved every
  // frame, so a few iterations suffice.
  int window_max_iterations = 6;
  // Window mode: a frame that is no keyframe is solved for its own pose, velocity and biases alone
  // (the window's keyframes and objects held), as a tracking step; false: the whole window is
  // re-solved with it (its information is dropped with it either way).
  bool frame_motion_only = true;
  // Batch mode re-solves the growing problem every this many keyframes.
  int batch_solve_every = 5;
  // Iteration cap of every batch solve (the periodic ones and the final one); they stop earlier
  // when converged.
  int batch_max_iterations = 60;
  // Corner noise [px] and robust loss on each observation.
  FspFactorOptions factor;
  RobustLossOptions robust;
  PreintegrationOptions imu;
  SingleViewInitOptions init;
  // Static initialisation: the IMU over the first window_s seconds after the first frame must be
  // still; it gives gravity (roll, pitch), the gyroscope bias and zero velocity.
  StaticInitOptions static_init;
  // When the static initialisation refuses (the start moves): the initialisation in motion from
  // the most-seen rectangle and the IMU (motion_init.h). Its first state's velocity gets this
  // prior σ [m/s].
  MotionInitOptions motion_init;
  double motion_init_velocity_sigma = 0.1;
  // ...and from the tracked points (point_init.h: structure from motion aligned with the IMU),
  // when the frames carry points (AddFrame's POINTS): a hand-held start without a whole rectangle.
  // Its first state's velocity gets the same prior σ, its gyroscope bias prior_gyro_bias_sigma.
  PointInitOptions point_init;
  // Prior on the initial biases: the accelerometer bias is only known to be small; the gyro bias
  // from a start in motion to prior_gyro_bias_sigma, from a still start to what its mean rate
  // measured (the scatter of its block means, at least the noise density over window_s; at most
  // prior_gyro_bias_sigma).
  double prior_gyro_bias_sigma = 0.01;  // [rad/s]
  double prior_acc_bias_sigma = 0.2;    // [m/s^2]
  // Weak prior on each object's log inverse depth around its single-view (class prior) value, as a
  // prior on its metric width at the class's typical width (priors.h: FSP's log w̄ − log ω, FHP's
  // mean of its two width edges). Keeps the problem well posed before parallax exists (hover);
  // 1.0 = "within a factor e".
  double prior_log_omega_sigma = 1.0;
  // Views of an object from keyframes that left the window, kept as factors with the keyframe pose
  // held constant (newest kept). They carry the object's accumulated information; more: better
  // maps, more CPU per frame. The cost per frame stays bounded by window_size + max_past_views x
  // objects in view. 20 against 40: the same final map and trajectory on the default room (seeds
  // 1-3) and the hall flight (now that the global step holds every view), 27 % less CPU with ten
  // objects in view (assets/scenes/ten_objects.yaml).
  int max_past_views = 20;
  // An object constrains the poses only once it has been seen this many times; before that it is
  // refined alone with the poses held constant (a wrong single-view guess cannot pull the
  // trajectory). Measured (window, default scene, 1 px): 1 -> ATE 9.7 cm on the first 20 s, 10 ->
  // 55 cm: objects held out for 10 frames leave the window to the IMU alone whenever objects
  // change.
  int mature_views = 1;
  // Box on each object's depth (through its log inverse depth) [m]. Indoors objects are seen from
  // 0.3..30 m; the box only matters for objects without parallax yet, which would otherwise drift.
  double min_depth_m = 0.3;
  double max_depth_m = 30.0;
  // Window mode: an object seen again after it left the window, with its corners further than this
  // (RMS) from their prediction, is re-initialised as a new object (its past views hold poses from
  // before a drift the window cannot undo) [px]. Smaller: fewer stale constraints, fewer small
  // loops closed. 0 = always re-initialise. Measured (default scene, 1 px, mature_views 1, seeds
  // 1/2/3): 0 -> ATE 0.20/0.18/0.18 m; 20 -> 0.41/0.35/0.24 m; no gate (large) -> diverges. The map
  // reports the better-observed instance of a re-initialised object.
  double reinit_gate_px = 0.0;
  // An object enters the map from two whole views that agree: the first view's single-view
  // rectangle, moved into the second view's camera at its best scale (one view does not give it),
  // lies within this of the second view's corners (RMS) [px]. A view that disagrees is replaced by
  // the newer one (counted in starts_rejected). A front end that closes an object entering the view
  // with an inner edge (a window's pane) reports wrong corners for a frame or two; started from
  // such a view, the default room's window from pixels was 10-38 cm off for 4 s. 0: an object
  // starts from its first whole view.
  double start_agree_px = 4.0;
  // ...the second view at least this long after the first [s]: consecutive frames share a front
  // end's error (the pane's edge above held for 3 frames).
  double start_agree_gap_s = 0.1;
  // Objects (instances) seen by fewer keyframes than this are not reported in the map.
  int min_observations = 3;
  // ...nor are objects whose width or height σ (known after Finish()) exceeds this fraction of it:
  // the views added next to nothing to the class-size prior (alone it gives σ ≈ the size with
  // prior_log_omega_sigma 1), their depth was not observable. On the blur clip (render seed 2) a
  // poster seen in the clip's last 1.5 s was 0.57 +- 0.55 m wide with its corners 50 cm off; EuRoC
  // V1_01's still start keeps its board at 1.15 +- 0.68 m. 0: all.
  double max_size_sigma_frac = 0.8;
  // The final solve's consistency (EstimatorSummary::variance_factor): a run whose residuals exceed
  // their noise model by more than this factor in χ² (σ0² above it: the IMU noise or the corner σ
  // is too small for the data, or the data disagree) says so in a warning; its σs are scaled by σ0
  // whatever this is. 4: σ0 = 2, a model twice too optimistic (rendered runs are at 0.9-1.2).
  double warn_variance_factor = 4.0;
  // A run whose map scale σ (after the σ0 scaling) exceeds this fraction says that its metric scale
  // is weakly observable (little acceleration, objects seen from one side, ...).
  double warn_scale_sigma = 0.02;
  FaultOptions faults;
  GlobalOptions global;
  ZeroVelocityOptions zero_velocity;
  // Window mode only (batch mode ignores points).
  PointOptions points;
  bool Check(std::string* why) const;
};

// An object as reported in map.json (docs/outputs.md).
struct MapObject {
  int id = -1;
  ObjectClass object_class = ObjectClass::kUnknown;
  std::array<Vec3, 4> corners_W;
  double width = 0.0, height = 0.0;  // [m]
  double width_sigma = 0.0,
         height_sigma = 0.0;  // 1-σ from the estimator's covariance [m]; <0 unknown
  Rigid3 T_W_O;
  int observations = 0;
};

struct EstimatorSummary {
  bool initialized = false;
  std::string init_failure;     // why the initialisation refused (empty when fine)
  bool init_in_motion = false;  // initialised in motion (MotionInitOptions), not from a still start
  double init_t_s = 0.0;        // time of the first state since the first frame [s]
  // Which initialisation started the estimator: "static", "rectangle" (motion_init.h), "points"
  // (point_init.h); empty before.
  std::string init_method;
  // What it estimated: the gyroscope bias [rad/s], the first state's speed [m/s], | |g| − gravity |
  // before gravity's magnitude was fixed [m/s^2] (in motion), and the scale: the metric width of
  // the reference object (rectangle) or metres per unit of the structure from motion (points).
  Vec3 init_gyro_bias = Vec3::Zero();
  Vec3 init_acc_bias = Vec3::Zero();  // [m/s^2]; estimated by the points' init on request, else 0
  double init_speed = 0.0;
  double init_gravity_error = 0.0;
  double init_scale = 0.0;
  // Points: the metric distance between the first and last keyframe of the structure from motion
  // [m] and the time of the last [s since the first frame] (compare with a reference trajectory).
  double init_baseline_m = 0.0;
  double init_baseline_end_t_s = 0.0;
  // Attempts in motion that refused before the one that succeeded (or before giving up), and the
  // last refusal's reason.
  int init_attempts_refused = 0;
  std::string init_last_refusal;
  // The refusals by kind (their reason up to its first number or parenthesis) and count.
  std::map<std::string, int> init_refusals;
  int frames = 0;                // frames given to AddFrame
  int keyframes = 0;             // keyframes created
  int observations_used = 0;     // observations of objects in the map (they become factors)
  int observations_partial = 0;  // ...of them, objects partly in view (some corners not seen)
  int partial_dropped = 0;  // partial observations of objects the window did not track (unused)
  int observations_rejected = 0;  // first views whose single-view initialisation failed
  int starts_rejected = 0;        // first views of objects that the next whole view disagreed with
  // Objects the points disagreed with (PointOptions::object_gate_px): dropped on probation,
  // rejected when mature.
  int objects_moving = 0;
  int objects_rejected = 0;
  int reanchors = 0;
  int objects_reinitialized =
      0;  // window: objects seen again after leaving the window, started afresh
  int marginalizations = 0;
  int marginalization_failures = 0;  // Schur complement failed: the prior was dropped
  int zero_velocity_keyframes = 0;   // keyframes found standing still (ZeroVelocityOptions)
  int motion_only_frames = 0;        // frames solved for their own state alone (frame_motion_only)
  // Point features (PointOptions; all 0 when no frame had points): frames given points, points
  // that entered the window, of them dropped as outliers after a solve, dropped because their
  // anchor left (no later view, or reanchor false), moved to a new anchor; the keyframes that saw
  // each entered point, summed when it left the window (mean track length = that / points_used).
  int point_frames = 0;
  int points_used = 0;
  int points_rejected = 0;
  int points_dropped = 0;
  int points_reanchored = 0;
  int64_t point_track_keyframes = 0;
  // The stretches found standing still, [from, to] keyframe times as in trajectory.tum [s]: the
  // keyframes of each stretch and the one before them.
  std::vector<std::pair<double, double>> zero_velocity_stretches;
  std::vector<double>
      backend_ms;               // wall time of each frame's update (solve + marginalisation) [ms]
  double batch_solve_ms = 0.0;  // the final full solve (batch mode) [ms]
  double final_cost = 0.0;
  // How well the map's metric scale is determined (after Finish, FSP landmarks): the σ of the
  // precision-weighted combination of the mapped objects' log sizes ½ (log w + log h), from the
  // final solve's covariance with every cross-covariance between objects (1 / (1ᵀ C⁻¹ 1)). A
  // relative σ: 0.01 = the map's sizes and the trajectory's scale are known to about 1 %. −1:
  // unknown (FHP, no objects, or the covariance failed).
  double scale_sigma = -1.0;
  // The final solve's a-posteriori variance factor σ0² (after Finish): the χ² of its residuals
  // (whitened, without the robust loss) over their redundancy (residuals minus free parameters).
  // About 1 when the noise model (IMU noise densities, corner σ) fits the data; when it is above 1
  // every σ above (scale_sigma, the map's width/height σ) is multiplied by σ0, so that they stay
  // honest about a model that is too optimistic. Per factor type, χ² per residual of the IMU
  // factors and of the corners (a type's own share, not corrected for the parameters). −1: not
  // computed (no final solve).
  double variance_factor = -1.0;
  double imu_chi2_per_residual = -1.0;
  double corner_chi2_per_residual = -1.0;
  // Faults (FaultOptions): holes in the IMU stream bridged by the motion prior, frame gaps,
  // stretches without any object in view, rejected solves (divergences) and session restarts.
  int imu_gaps = 0;
  double imu_gap_max_s = 0.0;
  int imu_gap_links = 0;  // keyframe links bridged by the motion prior
  int frame_gaps = 0;
  double frame_gap_max_s = 0.0;
  int blind_stretches = 0;
  double blind_max_s = 0.0;
  // With points: stretches of at least faults.blind_s without an object or a live point (the IMU
  // alone).
  int dead_reckoning_stretches = 0;
  double dead_reckoning_max_s = 0.0;
  int divergences = 0;
  int resets = 0;
  // Global step (window mode, GlobalOptions): solves, their time and iterations, the keyframes of
  // the last one, loops closed (a returning object kept its identity; pre-aligned: the window was
  // moved onto the map first) and rejected (the object started afresh).
  int global_solves = 0;
  int global_rejected = 0;  // global solves whose result was implausible (not applied)
  int global_iterations = 0;
  std::vector<double> global_ms;
  std::vector<int> global_keyframes;
  int loops_closed = 0;
  int loops_prealigned = 0;
  int loops_rejected = 0;
  // One line per fault, "t=12.35 s: what happened, what was done" (the first kMaxWarnings).
  static constexpr int kMaxWarnings = 50;
  std::vector<std::string> warnings;
};

class Estimator {
 public:
  Estimator(const Calibration& calibration, const EstimatorOptions& options);
  ~Estimator();
  Estimator(const Estimator&) = delete;
  Estimator& operator=(const Estimator&) = delete;

  // IMU samples in time order (a sample older than the last one throws InputError).
  void AddImu(const ImuSample& sample);
  // One frame's observations (corners undistorted, s1..s4; an object partly in view with the
  // corners it shows, ObjectObservation::seen: backend/README.md, "Objects partly in view"; one
  // without any is ignored). Frames in time order, after the IMU that covers them. Returns false
  // while the estimator is not initialised (the frame is buffered until the static interval is
  // complete) or after the initialisation refused (summary().init_failure). POINTS: the frame's
  // tracked point features (undistorted pixels, by id): landmarks in the window (PointOptions) and
  // the initialisation in motion from points (EstimatorOptions::point_init).
  bool AddFrame(int64_t t_ns, const std::vector<ObjectObservation>& observations,
                const std::vector<PointObservation>& points = {});
  // Ends the sequence: final window solve, or the full batch solve.
  void Finish();

  // Body pose per frame: in window mode a keyframe's estimate when it left the window (or the final
  // one for the last window), a frame that was not kept as a keyframe relative to the keyframe
  // before it (its own solve gave the relative pose); in batch mode the batch solution.
  std::vector<StampedPose> Trajectory() const;
  std::vector<StateSample> States() const;
  // Per frame, the estimate the frame had right after its own update (what a live user had at that
  // moment); Trajectory() is the final estimate after every later window and global solve.
  std::vector<StampedPose> CausalTrajectory() const;
  // The estimate of the newest frame given to AddFrame (as Trajectory() reports it), or nullopt
  // before the first. O(1): what a caller predicting the next frame needs.
  std::optional<StateSample> Latest() const;
  // Objects with >= min_observations whose depth is not on the min/max_depth_m box (unconstrained)
  // and, after Finish(), whose size is known (max_size_sigma_frac), with width/height σ from the
  // covariance (after Finish()).
  std::vector<MapObject> Map() const;
  const EstimatorSummary& summary() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fsp::backend
