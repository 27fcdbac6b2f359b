// The estimator's state and its parts (the per-keyframe, object and point-track structs in
// estimator_state.h), shared by the files that implement it (estimator.cc:
// keyframes, the batch, faults and the map; estimator_window.cc: the window's solve and
// marginalisation; estimator_global.cc: the global step and loop closure). Internal: not installed,
// included by those files only.
#pragma once

#include "fsp/backend/estimator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <functional>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <thread>
#include <tuple>
#include <unordered_map>

#include <ceres/ceres.h>

#include "estimator_state.h"
#include "fsp/backend/imu_factor.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/marginalization.h"
#include "fsp/backend/priors.h"
#include "fsp/backend/static_init.h"
#include "fsp/common/error.h"
#include "fsp/common/time.h"
#include "landmark_model.h"

namespace fsp::backend {

using namespace internal;

struct Estimator::Impl {
  Impl(const Calibration& calib, const EstimatorOptions& opts) : calibration(calib), options(opts) {
    K = calibration.camera.K();
    T_B_C = calibration.T_B_C;
    options.imu.noise = calibration.imu;
    landmark_context = {K,
                        T_B_C,
                        options.factor,
                        options.robust,
                        options.min_depth_m,
                        options.max_depth_m,
                        options.prior_log_omega_sigma,
                        &quat_manifold};
  }
  ~Impl() { DiscardGlobal(); }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  Calibration calibration;
  EstimatorOptions options;
  Mat3 K;
  Rigid3 T_B_C;
  EstimatorSummary summary;

  std::vector<ImuSample> imu;  // all samples (pruned behind the oldest needed time)
  std::vector<std::pair<int64_t, std::vector<ObjectObservation>>> pending;  // frames before init
  std::map<int64_t, std::vector<PointObservation>> pending_points;          // their points, by time
  std::deque<std::unique_ptr<Keyframe>>
      keyframes;  // every keyframe (window = the last window_size)
  std::map<int, std::unique_ptr<Object>> objects;
  // Window mode: the best-observed earlier instance of each re-initialised object (the map reports
  // whichever instance of an id has more observations).
  std::map<int, std::unique_ptr<Object>> retired;
  // The first whole view of each object not in the map yet, waiting for a second one to agree
  // (options.start_agree_px).
  std::map<int, StartView> start_views;
  // Objects dropped on probation (PointOptions::object_probation_views): their ids never start.
  std::set<int> moving;
  std::vector<StateSample> output;  // per frame, the state reported for it
  std::vector<StateSample> causal;  // per frame, its state right after its own update
  // Frames that were not kept as keyframes: their pose and velocity relative to the keyframe before
  // them, from their own solve. They are reported relative to that keyframe's final estimate (as
  // keyframe-based systems write trajectories): reporting their own solve next to keyframes refined
  // over the whole window made the trajectory jump at every keyframe (0.8 deg, measured).
  struct Dropped {
    int frame;
    const Keyframe* ref;
    Rigid3 T_ref_B;
    Vec3 v_ref;  // velocity in the ref body frame
  };
  std::vector<Dropped> dropped;

  // A dropped frame's state: its keyframe's estimate moved by the relative pose of the frame's
  // solve.
  StateSample Resolve(const Dropped& d) const {
    const StateSample& ref = output[d.ref->frame];
    StateSample s = output[d.frame];
    s.T_W_B = ref.T_W_B * d.T_ref_B;
    s.v_W = ref.T_W_B.rotation() * d.v_ref;
    s.gyro_bias = ref.gyro_bias;
    s.acc_bias = ref.acc_bias;
    return s;
  }
  std::vector<StateSample> Reported() const {
    std::vector<StateSample> out = output;
    for (const Dropped& d : dropped) out[d.frame] = Resolve(d);
    return out;
  }
  size_t window_begin = 0;  // index of the oldest keyframe in the window
  // Window mode: index of the first keyframe of the current session (the start, the last restart).
  // The global solves and the final solve hold the keyframes before it: nothing links the sessions
  // (the restart's gauge replaces the IMU link, its objects start again), and the states that led
  // to a divergence would fail every later solve's checks.
  size_t session_begin = 0;
  Rigid3 T_W_B0;  // gauge prior of the first keyframe
  Eigen::Matrix<double, 9, 1> sb0 = Eigen::Matrix<double, 9, 1>::Zero();
  std::shared_ptr<const LinearPrior> prior;  // from the marginalised keyframes
  // Global step: keyframes added since the last global solve was started; a loop closed since (the
  // next global solve starts as soon as none is in flight) and the oldest keyframe it reaches.
  int keyframes_since_global = 0;
  bool loop_pending = false;
  int loop_from =
      std::numeric_limits<int>::max();  // oldest keyframe a pending loop reaches back to
  bool finished = false;
  // Fault bookkeeping: the start of the IMU hole last counted, the previous frame's time, the time
  // of the last frame with an observation (or of the first frame).
  int64_t counted_imu_hole_from = -1;
  std::optional<int64_t> last_frame_t, last_seen_t;
  // With points: the first keyframe of the current stretch that saw neither an object nor a
  // live point (none: the last keyframe saw something).
  std::optional<int64_t> unseen_since_t;
  bool seen_once = false;  // a keyframe saw an object or a live point

  PoseManifold pose_manifold;
  ceres::EigenQuaternionManifold quat_manifold;
  LandmarkContext landmark_context;  // the landmarks' view of the above

  // --- IMU -------------------------------------------------------------------------------------
  std::vector<ImuSample> ImuBetween(int64_t t0, int64_t t1) const {
    return ImuSamplesFor(imu, t0, t1);
  }

  // The longest stretch without an IMU sample that the interval [t0, t1] needs: from the last
  // sample at or before t0 (t0 if none) through the samples inside to the first sample at or after
  // t1 (t1 when none has arrived yet). [from, to] in ns.
  std::pair<int64_t, int64_t> LongestImuHole(int64_t t0, int64_t t1) const;

  // Frame gaps and stretches without any object in view (counted and warned; `end`: the sequence
  // ended at t_ns, only the trailing stretch is examined).
  void NoteFrame(int64_t t_ns, bool sees_objects, bool end = false);
  // With points: stretches of keyframes that saw neither an object nor a live point, the IMU
  // alone (counted and warned as dead reckoning; `end`: the sequence ended at t_ns).
  void NoteSight(int64_t t_ns, bool sees, bool end = false);

  void Warn(int64_t t_ns, const std::string& what) {
    if (static_cast<int>(summary.warnings.size()) >= EstimatorSummary::kMaxWarnings) return;
    char t[32];
    std::snprintf(t, sizeof(t), "t=%.2f s: ", NsToSeconds(t_ns));
    summary.warnings.push_back(t + what);
  }

  // --- Initialisation ----------------------------------------------------------------------------
  // Returns true once initialised; false while waiting for IMU or after a refusal.
  bool TryInitialize();
  // The static initialisation refused with STATIC_REASON: tries the initialisation in motion on the
  // pending frames (dropping the oldest when it refuses, until max_wait_s).
  bool TryInitializeInMotion(const std::string& static_reason);
  // The initialisation in motion from the pending frames' points (point_init.h); sets *REASON when
  // it refused, and drops the oldest retry_step_s of frames for the next attempt.
  bool TryInitializeFromPoints(std::string* reason);
  // Starts the first session in motion at pending frame FIRST_INDEX with that state, warning WHAT.
  void StartInMotion(size_t first_index, const Rigid3& T_W_B, const Vec3& v_W,
                     const Vec3& gyro_bias, const Vec3& acc_bias, const std::string& what);
  // Refusals of the initialisation from points listed in the warnings at most.
  static constexpr int kMaxInitWarnings = 10;
  // Drops the N oldest pending frames.
  void DropPending(size_t n);
  // The rectangle in motion already refused on the window starting at this frame time.
  std::optional<int64_t> rect_tried_t0;
  // Starts the first session at FRAMES[0] with state FIRST and its gauge priors, then adds the
  // other frames.
  void StartSession(std::vector<std::pair<int64_t, std::vector<ObjectObservation>>> frames,
                    const KeyframeState& first, const Gauge& gauge);
  std::optional<int64_t> first_frame_t;  // the first frame given (initialisation's clock)

  // --- Keyframes ---------------------------------------------------------------------------------
  void AddKeyframe(int64_t t_ns, std::vector<ObjectObservation> obs, const KeyframeState* initial,
                   const std::optional<Gauge>& gauge = std::nullopt,
                   std::vector<PointObservation> points = {});

  // --- Points (estimator_points.cc; PointOptions) ------------------------------------------------
  std::map<int64_t, PointTrack> point_tracks;  // by point id
  bool UsePoints() const {
    return options.points.enabled && options.mode == EstimatorMode::kWindow;
  }
  // The views of keyframe `kf` join their tracks; tracks seen by it with parallax enough enter the
  // window (triangulated, longest-tracked first, up to max_points live).
  void AddPointViews(Keyframe* kf);
  bool TriangulatePoint(PointTrack* t) const;
  // A point's pixel noise σ: points.sigma_px times its PointObservation::sigma_scale (at least 1).
  double PointSigmaPx(double sigma_scale) const {
    return options.points.sigma_px * std::max(1.0, sigma_scale);
  }
  // The factor options of a point's views (σ: PointSigmaPx of its first view's scale).
  FspFactorOptions PointFactorOptions(const PointTrack& t) const;
  // Factors of every live point's views (not the anchor's) into a window problem, with ρ bounded
  // to the depth range.
  void AddPointFactors(ceres::Problem* problem);
  // ...of the points keyframe `kf` (no keyframe, solved alone) sees: anchors and ρ held.
  void AddPointFactorsOf(ceres::Problem* problem, Keyframe* kf);
  // The factors of the points anchored at `old` for its marginalisation (owned by COSTS, LOSSES).
  std::vector<ResidualBlockInput> AddPointFactorsOf(
      Keyframe* old, std::vector<std::unique_ptr<ceres::CostFunction>>* costs,
      std::vector<std::unique_ptr<ceres::LossFunction>>* losses);
  // After a window solve: drops points with a view further than outlier_px from their prediction
  // or with a depth on the range's bounds.
  void RemovePointOutliers();
  // Keyframe `old` leaves the window: its views leave their tracks; points anchored at it move into
  // their next view's keyframe (or are dropped; still tracked, they enter again as new landmarks).
  void ReanchorPointsOf(Keyframe* old);
  void StopPoint(PointTrack* t) {
    t->live = false;
    t->dead = true;
    if (t->used && !t->accounted) {
      summary.point_track_keyframes += t->keyframes_seen;
      t->accounted = true;
    }
  }
  // The global step holds no points: without any object it would be the IMU alone, and its result
  // would overwrite what the window's points gave the keyframes (measured: a flight through random
  // points ended exactly as dead reckoning). Then the window's estimates stand.
  bool GlobalHasObjects() const {
    return summary.points_used == 0 || !objects.empty() || !retired.empty();
  }
  void ClearPoints() {
    for (auto& [id, t] : point_tracks) StopPoint(&t);
    point_tracks.clear();
  }

  // Whether a frame is kept as a keyframe (both modes). Kept: every keyframe_interval_s
  // (batch: batch_keyframe_interval_s), and any
  // frame that sees an object not in the map or (window mode) back after leaving the window (it may
  // become the object's anchor, and only keyframes can be anchors).
  bool IsKeyframe(int64_t t_ns, int frame, const std::vector<ObjectObservation>& obs) const;
  // The first whole view of an object not in the map that waits for a second (in the window),
  // nullptr if none.
  const StartView* WaitingStart(int object_id) const;

  // Whether the vehicle stood still between keyframes `prev` and `kf` (ZeroVelocityOptions): no
  // mean turn since `prev`, and the objects `kf` shares with still_reference where they were then
  // (without one, its points where still_point_reference had them).
  bool Still(const Keyframe& prev, const Keyframe& kf) const;
  // The observations of the newest keyframe not found standing still: a stand-still is tested
  // against where it began, not against the previous keyframe, so that a slow motion (a take-off)
  // cannot pass as a series of steps each below the corner noise.
  std::vector<ObjectObservation> still_reference;
  std::vector<PointObservation> still_point_reference;  // its points

  // A standing-still keyframe's prior: zero velocity, the biases free.
  ceres::CostFunction* MakeZeroVelocityPrior(const Keyframe& kf) const;
  // A standing-still keyframe's link to the keyframe before it: neither moved nor turned
  // (ZeroVelocityOptions::turn_rate_sigma). Blocks: prev's pose, kf's pose.
  ceres::CostFunction* MakeStillLink(const Keyframe& prev, const Keyframe& kf) const;

  // Removes the newest frame (not a keyframe) from the window: its pose was reported, its
  // observations are forgotten, and the next frame's IMU factor starts at the last keyframe.
  void DropNewest();

  void PruneImu() {
    const int64_t keep_from = keyframes[window_begin]->state.t_ns;
    if (options.mode == EstimatorMode::kBatch) return;  // batch re-integrates nothing, but keep all
    auto it = std::lower_bound(imu.begin(), imu.end(), keep_from,
                               [](const ImuSample& s, int64_t t) { return s.t_ns < t; });
    if (it - imu.begin() > 4000) imu.erase(imu.begin(), it - 2);
  }

  Rigid3 CameraPose(const Keyframe& kf) const { return kf.state.T_W_B() * T_B_C; }

  // Single-view initialisation of objects seen for the first time in `kf`, anchored at it.
  // Window mode: an object seen again after it left the window (no window keyframe sees it) whose
  // corners are further than options.reinit_gate_px (RMS) from their prediction in `kf` starts
  // afresh as well. Its past views hold poses from before the gap fixed, while the trajectory
  // drifted meanwhile (dead reckoning through stretches without objects): on the default scene the
  // first re-observations after such a gap were 70-190 px away from their prediction, and forcing
  // the window to agree with those frozen views made the accelerometer bias absorb the mismatch
  // (0.1 -> 2 m/s^2) and the estimate diverge (ATE 76 m on 60 s). The window is an odometry;
  // closing such large loops needs a pose graph that can move the old poses, not a window that
  // cannot.
  void InitializeNewObjects(Keyframe* kf);
  // Whether whole view `o` from `kf` agrees with an earlier one (options.start_agree_px).
  bool ViewsAgree(const StartView& first, const Keyframe& kf, const ObjectObservation& o) const;

  // "Up" (−gravity) in the camera frame for classes known to be vertical (single-view
  // initialisation), nullopt for the others.
  static std::optional<Vec3> UpDirection(ObjectClass c, const Rigid3& T_W_C) {
    const bool vertical = c == ObjectClass::kDoor || c == ObjectClass::kWindow ||
                          c == ObjectClass::kCabinet || c == ObjectClass::kPoster;
    if (!vertical) return std::nullopt;
    return T_W_C.rotation().conjugate() * Vec3::UnitZ();
  }

  // The current instance of the object that keyframe KF's view of OBJECT_ID is of; null when there
  // is none or the view is older than the instance (a view from before first_seen belongs to an
  // earlier instance of the id: a start that refused it, a rejected loop, a restart).
  static Object* InstanceSeen(const Objects& objs, const Keyframe& kf, int object_id) {
    const auto it = objs.find(object_id);
    return it != objs.end() && kf.index >= it->second->first_seen ? it->second.get() : nullptr;
  }

  // Whether an observation from camera pose T_W_C agrees with the object's estimate: in front and
  // the RMS corner error (pixels) within options.reinit_gate_px.
  bool ConsistentWithMap(const Object& obj, const Rigid3& T_W_C, const Corners& corners) const {
    const std::optional<double> e = PredictionError(obj, T_W_C, corners);
    return e && *e <= options.reinit_gate_px;
  }

  // RMS distance [px] between observed corners and the object's prediction from camera pose T_W_C;
  // nullopt when the object is behind the camera.
  std::optional<double> PredictionError(const Object& obj, const Rigid3& T_W_C,
                                        const Corners& corners,
                                        const CornerMask& seen = kAllCorners) const {
    const CornerPrediction p = obj.landmark.Predict(K, T_W_C, CameraPose(*obj.anchor));
    if (!p.in_front) return std::nullopt;
    double sum2 = 0.0;
    for (int j = 0; j < 4; ++j) sum2 += seen[j] ? (p.uv[j] - corners[j]).squaredNorm() : 0.0;
    return std::sqrt(sum2 / CountSeen(seen));
  }

  Rigid3 ObjectPose(const Object& obj) const { return obj.landmark.T_W_O(CameraPose(*obj.anchor)); }

  // --- Loops (global step) -----------------------------------------------------------------------
  // An object seen again after it left the window, observed with `corners` from `kf`: keeps its
  // identity when its loop closes. Close (its prediction within loop_direct_px): the global solve
  // of this frame closes it. Further: the window is pre-aligned onto the object's map estimate
  // first (OKVIS2's loop pre-alignment): the camera pose that the corners give with the object's
  // estimated pose and size (single-view homography, scaled by the map's size) says how far the
  // window drifted since the object was last seen, in the 4 drift directions (x, y, z, yaw); that
  // correction is spread over the keyframes since then by distance travelled (the newest moves by
  // all of it), objects first seen in that stretch move with their anchors, older ones stay where
  // they are. When the pre-alignment is implausible (beyond the budget) or does not bring the
  // corners within loop_accept_px of their prediction, the loop is rejected (false; the states
  // restored) and the object starts afresh as a new instance.
  bool CloseLoop(Object* obj, Keyframe* kf, const Corners& corners);
  // A partial view `o` (from camera pose T_W_C) of a returning object: whether it agrees with the
  // map as it is (within loop_direct_px, the loop then closes; without the global step within
  // reinit_gate_px). A part is not enough for CloseLoop's pre-alignment or for a new instance.
  bool ClosesDirectly(const Object& obj, const Rigid3& T_W_C, const ObjectObservation& o);
  // A loop closed: the next global solve frees the keyframes since the object was last seen.
  bool AcceptLoop(const Object& obj);

  // The pre-alignment of CloseLoop; false (states unchanged) when it is implausible, leaves the
  // corners further than loop_accept_px from their prediction or not closer than error_before.
  bool PreAlign(Object* obj, Keyframe* kf, const Corners& corners,
                std::optional<double> error_before);

  // Whether the object's depth sits on the box [min_depth_m, max_depth_m] (an FHP corner's, any):
  // such a depth is not an estimate (no parallax; or, seen in window mode and not yet understood, a
  // collapse onto the minimum), so neither are its size and place; the map leaves it out.
  bool AtDepthBound(const Object& obj) const { return !DepthInBox(obj.landmark); }
  bool DepthInBox(const Landmark& l) const {
    return l.DepthInBox(options.min_depth_m, options.max_depth_m);
  }

  // --- Problem construction
  // ----------------------------------------------------------------------- Adds the factor(s) of
  // one observation of `obj` from keyframe `kf`. Poses of keyframes that are not variables of this
  // problem (`is_variable` false: they left the window) enter as constants.
  // SIGMA_PX: the corners' noise (ObjectObservation::sigma_px; 0: options.factor.sigma_px).
  void AddObservation(ceres::Problem* problem, Keyframe* kf, Object* obj, const Corners& corners,
                      const CornerMask& seen, double sigma_px,
                      const std::function<bool(const Keyframe*)>& is_variable);

  // Observation factors of keyframes [begin, end) and, for every object they see, its past views.
  // `mature`: only objects seen at least options.mature_views times (they constrain the poses), or
  // only the others (refined alone with every pose held constant).
  void AddVisualFactors(ceres::Problem* problem, size_t begin, size_t end, bool mature);

  void AddStateBlocks(ceres::Problem* problem, Keyframe* kf) {
    problem->AddParameterBlock(kf->state.pose, kPoseSize, &pose_manifold);
    problem->AddParameterBlock(kf->state.speed_bias, kSpeedBiasSize);
  }

  // What ties KF to PREV through the IMU: the IMU factor (across an IMU gap the gap prior) and,
  // standing still, the still link; each with its parameter blocks. The window, the global step and
  // the marginalisation all take these.
  struct Link {
    ceres::CostFunction* cost;
    std::vector<double*> blocks;
  };
  std::vector<Link> ImuLink(Keyframe* prev, Keyframe* kf) const;
  void AddImuFactor(ceres::Problem* problem, Keyframe* prev, Keyframe* kf) const {
    for (Link& l : ImuLink(prev, kf)) problem->AddResidualBlock(l.cost, nullptr, l.blocks);
  }

  // Position and yaw pinned (gauge); roll/pitch and the biases as well known as the start gives
  // them.
  void AddGaugePriors(ceres::Problem* problem, Keyframe* first) const;
  static ceres::CostFunction* MakeGaugePosePrior(const Gauge& g);
  static ceres::CostFunction* MakeGaugeBiasPrior(const Gauge& g);
  // Bridges an IMU gap of dt_s seconds (FaultOptions): a constant-velocity motion prior.
  ceres::CostFunction* MakeGapPrior(double dt_s) const;

  // --- Faults ------------------------------------------------------------------------------------
  // The values a solve may change, to restore when its result is rejected.
  struct Snapshot {
    size_t begin = 0;
    std::vector<KeyframeState> states;  // keyframes [begin, end)
    std::vector<Landmark> objects;      // in the order of `objects`
  };
  Snapshot Save(size_t begin) const { return Save(keyframes, objects, begin); }
  static Snapshot Save(const Keyframes& kfs, const Objects& objs, size_t begin) {
    Snapshot s;
    s.begin = begin;
    for (size_t i = begin; i < kfs.size(); ++i) s.states.push_back(kfs[i]->state);
    for (const auto& [id, obj] : objs) s.objects.push_back(obj->landmark);
    return s;
  }
  void Restore(const Snapshot& s) { Restore(s, &keyframes, &objects); }
  static void Restore(const Snapshot& s, Keyframes* kfs, Objects* objs) {
    for (size_t k = 0; k < s.states.size(); ++k) {
      KeyframeState& st = (*kfs)[s.begin + k]->state;
      std::copy(s.states[k].pose, s.states[k].pose + kPoseSize, st.pose);
      std::copy(s.states[k].speed_bias, s.states[k].speed_bias + kSpeedBiasSize, st.speed_bias);
    }
    size_t k = 0;
    for (auto& [id, obj] : *objs) obj->landmark = s.objects[k++];
  }

  // Why a solve's result is implausible (empty when it is not): the solver failed, a state is not
  // finite, a speed or bias beyond FaultOptions' bounds, a keyframe moved further than max_jump_m;
  // for the window's and the batch's solves also the newest frame's views (ViewsDiverged).
  std::string Diverged(const ceres::Solver::Summary& s, const Snapshot& before) const {
    const std::string why = Diverged(s, before, keyframes);
    return why.empty() ? ViewsDiverged() : why;
  }
  // The newest frame's whole views of objects in the map, at least two, all further than
  // FaultOptions::max_view_error_px from the estimate's prediction: why (else empty).
  std::string ViewsDiverged() const;
  std::string Diverged(const ceres::Solver::Summary& s, const Snapshot& before,
                       const Keyframes& kfs) const;

  // Starts a new session at the newest frame after a rejected solve (its state restored: the
  // prediction from the last accepted one): the frame becomes a keyframe with fresh gauge priors at
  // its pose (the trajectory stays continuous), the biases go back to the start's, the velocity is
  // kept when plausible; the window and its marginalisation prior are dropped, and the objects are
  // retired (the map keeps their best instances) and start afresh from this frame's views. In
  // batch mode the session break only cuts the IMU chain (every keyframe stays a variable and the
  // objects are kept).
  void Restart(const std::string& why);

  // Solves PROBLEM (keyframes from FIRST on are its variables); a diverged result is rejected: the
  // states are restored, counted, and the estimator restarted (FINISH: only warned, the final
  // solve has no frame to restart at). False when rejected. S: the solver's summary.
  bool SolveOrReject(ceres::Problem* problem, int max_iterations, size_t first, bool finish,
                     ceres::Solver::Summary* s);

  void AddObjectPriors(ceres::Problem* problem) { AddObjectPriors(problem, &objects); }
  void AddObjectPriors(ceres::Problem* problem, Objects* objs) const {
    for (auto& [id, obj] : *objs)
      obj->landmark.AddWidthPrior(problem, obj->width_prior_m, landmark_context);
  }

  ceres::Problem::Options ProblemOptions() const;

  // Levenberg-Marquardt with sparse normal Cholesky (estimator_problem.cc; backend/README.md,
  // "Cost"). WHOLE: a solve of every keyframe (the global step, the final solve, the batch's),
  // which starts undamped; the window keeps Ceres' damping.
  ceres::Solver::Options SolverOptions(int max_iterations, bool whole = false) const;

  // Solves the window [window_begin, end): states, IMU factors, gauge priors while the first
  // keyframe is in it, the marginalisation prior, mature objects' observations and the object
  // priors. The final solve (finish) iterates longer and computes the map's width/height sigmas;
  // the per-frame one then refines the young objects alone.
  void SolveWindow(int max_iterations, bool finish = false);
  // A frame that is no keyframe with EstimatorOptions::frame_motion_only: its own pose, velocity
  // and biases alone, everything else held (a tracking step).
  void SolveFrameAlone(int max_iterations);

  // The views after which an object constrains the poses: mature_views, and with points the
  // probation's object_probation_views.
  int MatureViews() const {
    return summary.point_frames > 0
               ? std::max(options.mature_views, options.points.object_probation_views)
               : options.mature_views;
  }
  bool Mature(const Object& obj) const { return obj.observations >= MatureViews(); }

  // Objects not mature yet are refined on their own with the poses held constant: a young object's
  // single-view guess (class-prior depth, possibly flipped normal) must not pull the trajectory
  // before parallax has confirmed it. With points, those whose views then disagree with them are
  // dropped (DropInconsistentObjects).
  void RefineYoungObjects(int max_iterations);
  // With points: the objects whose views in the window lie further than
  // PointOptions::object_gate_px from them (on probation, 3 views or more, RMS: erased, their ids
  // put in `moving`; mature, 5 views or more, median: erased, the map loses it). Warned. The
  // mature ones kept get their Object::noise_scale from the same views.
  void DropInconsistentObjects();

  // --- Marginalisation
  // ------------------------------------------------------------------------------ Moves the anchor
  // of every object anchored at `old` to the newest window keyframe with s1 in front.
  void ReanchorObjectsOf(Keyframe* old);

  static bool Sees(const Keyframe& kf, int object_id) {
    return std::any_of(
        kf.observations.begin(), kf.observations.end(),
        [object_id](const ObjectObservation& o) { return o.object_id == object_id; });
  }

  bool FixedBoundary() const {
    return options.global.enabled && options.global.boundary == WindowBoundary::kFixed;
  }

  void MarginalizeOldest();

  // The inertial information of `old` (its IMU link to `next`, its gauge priors, the previous
  // prior) into a linear prior on the states that remain.
  void MarginalizeIntoPrior(Keyframe* old, Keyframe* next);

  // --- Batch
  // ---------------------------------------------------------------------------------------
  // Every keyframe of `kfs` and object of `objs` in one problem, solved (the batch's final solve
  // and the window's global step). Touches nothing but kfs and objs (a background global solve runs
  // it on copies). Returns why the result is implausible (the checks of Diverged; kfs and objs
  // restored then), empty when it is not.
  // Keyframes before `free_from` are held at their estimate (GlobalOptions::max_free_keyframes):
  // only their factors that reach a free state stay in the problem.
  std::string SolveAll(Keyframes* kfs, Objects* objs, const ceres::Solver::Options& solver,
                       ceres::Solver::Summary* s, ceres::Problem* problem, size_t free_from = 0);

  // SolveAll on the estimator's own keyframes and objects; false (with a warning) when rejected.
  bool SolveFull(int max_iterations, bool with_sigmas, const char* what, ceres::Solver::Summary* s);

  void SolveBatch() {
    const auto t0 = Clock::now();
    ceres::Solver::Summary s;
    if (!SolveFull(options.batch_max_iterations, /*with_sigmas=*/true, "the final batch solve", &s))
      ++summary.divergences;
    RepredictDropped();
    summary.batch_solve_ms = MsSince(t0);
  }

  // Batch mode: the frames between keyframes are moved onto the final keyframe estimates through
  // the IMU (preintegrated from the keyframe before them with its final velocity and biases), so
  // their poses carry no state older than the final solve.
  void RepredictDropped();

  // Window mode's final global solve (Finish): every keyframe and object, with the map's sigmas.
  void SolveGlobalFinal();
  // A global solve's counters in the summary.
  void CountGlobal(double ms, size_t keyframes_solved, const ceres::Solver::Summary& s,
                   bool accepted);

  // A global solve in flight (GlobalOptions::apply_after_keyframes, background): it works on copies
  // of the keyframes and objects, so the window goes on meanwhile.
  struct GlobalJob {
    Keyframes kfs;
    Objects objs;
    std::map<int, const Object*> originals;  // id -> the instance that was copied
    int apply_at = 0;                        // summary.keyframes at which it is applied
    size_t free_from = 0;                    // keyframes before it are held
    ceres::Solver::Summary s;
    std::string diverged;
    double ms = 0.0;
    std::thread thread;
  };
  std::unique_ptr<GlobalJob> job;
  // Global solves rejected in a row, and why the last was (ApplyGlobal).
  int global_rejected_in_row = 0;
  std::string global_rejected_why;

  // Copies every keyframe (not a newest frame that is no keyframe: it is dropped later) and object
  // and solves them, on a thread with `background`, else here.
  void StartGlobal();

  // Applies the global solve in flight (waiting for it): the keyframes it solved take its values,
  // the ones added since move rigidly with the newest of them, objects take its values (expressed
  // at their current anchor when they were re-anchored meanwhile); objects retired meanwhile and
  // objects new since are left as they are (the new ones move with their anchors). A diverged solve
  // is rejected; AddFrame restarts the estimator after two in a row.
  void ApplyGlobal();

  // A restart drops the global solve in flight (its states belong to the session that diverged).
  void DiscardGlobal();

  // --- Map covariance
  // -----------------------------------------------------------------------------
  std::map<const Object*, std::pair<double, double>> sigmas;  // (σ_w, σ_h)

  void ComputeSigmas(ceres::Problem* problem);
  // The final solve's variance factor and χ² per factor type (EstimatorSummary::variance_factor);
  // warns when the model does not fit (EstimatorOptions::warn_variance_factor).
  void ComputeConsistency(ceres::Problem* problem);

  void FinishWindow() {
    if (keyframes.empty()) return;
    ApplyGlobal();
    SolveWindow(options.window_max_iterations * 3, /*finish=*/!options.global.enabled);
    if (options.global.enabled && GlobalHasObjects()) SolveGlobalFinal();
    ClearPoints();  // the live points' track lengths into the summary
  }
};

}  // namespace fsp::backend
