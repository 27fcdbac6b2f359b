#include "fsp/backend/estimator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <optional>
#include <sstream>
#include <thread>
#include <tuple>
#include <unordered_map>

#include <ceres/ceres.h>

#include "fsp/backend/fhp_factor.h"
#include "fsp/backend/imu_factor.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/marginalization.h"
#include "fsp/backend/priors.h"
#include "fsp/backend/reanchor.h"
#include "fsp/backend/static_init.h"
#include "fsp/common/error.h"
#include "fsp/common/time.h"

namespace fsp::backend {

bool FaultOptions::Check(std::string* why) const {
  const bool ok = max_imu_gap_s > 0.0 && gap_max_acc > 0.0 && gap_max_rate > 0.0 &&
                  frame_gap_s > 0.0 && blind_s > 0.0 && max_speed > 0.0 && max_gyro_bias > 0.0 &&
                  max_acc_bias > 0.0 && max_jump_m > 0.0 && restart_velocity_sigma > 0.0 &&
                  restart_roll_pitch_sigma > 0.0;
  if (why) *why = ok ? "" : "every fault threshold and sigma must be > 0";
  return ok;
}

bool GlobalOptions::Check(std::string* why) const {
  const bool ok = every_keyframes >= 1 && max_iterations >= 1 && final_iterations >= 1 &&
                  apply_after_keyframes >= 0 && max_free_keyframes >= 0 && loop_direct_px >= 0.0 &&
                  loop_accept_px >= loop_direct_px && budget_m >= 0.0 && budget_per_m >= 0.0 &&
                  budget_yaw_deg >= 0.0 && budget_yaw_per_m >= 0.0;
  if (why)
    *why = ok ? ""
              : "every_keyframes and the iterations must be >= 1; apply_after_keyframes, "
                "max_free_keyframes and the budgets >= 0; 0 <= loop_direct_px <= loop_accept_px";
  return ok;
}

bool ZeroVelocityOptions::Check(std::string* why) const {
  const bool ok = max_turn_rate > 0.0 && max_disparity_px > 0.0 && velocity_sigma > 0.0;
  if (why) *why = ok ? "" : "every threshold and sigma must be > 0";
  return ok;
}

bool EstimatorOptions::Check(std::string* why) const {
  std::ostringstream os;
  std::string sub;
  if (window_size < 2)
    os << "window_size must be >= 2 (got " << window_size << ")";
  else if (window_max_iterations < 1 || batch_max_iterations < 1)
    os << "iterations must be >= 1";
  else if (!factor.Check(&sub))
    os << "factor: " << sub;
  else if (!robust.Check(&sub))
    os << "robust: " << sub;
  else if (!imu.Check(&sub))
    os << "imu: " << sub;
  else if (!init.Check(&sub))
    os << "init: " << sub;
  else if (!static_init.Check(&sub))
    os << "static_init: " << sub;
  else if (!(prior_gyro_bias_sigma > 0.0) || !(prior_acc_bias_sigma > 0.0) ||
           !(prior_log_omega_sigma > 0.0))
    os << "prior sigmas must be > 0";
  else if (min_observations < 1)
    os << "min_observations must be >= 1";
  else if (mature_views < 1)
    os << "mature_views must be >= 1";
  else if (max_past_views < 0 || batch_solve_every < 1)
    os << "max_past_views must be >= 0, batch_solve_every >= 1";
  else if (!(min_depth_m > 0.0) || !(max_depth_m > min_depth_m))
    os << "need 0 < min_depth_m < max_depth_m";
  else if (!(reinit_gate_px >= 0.0))
    os << "reinit_gate_px must be >= 0";
  else if (!faults.Check(&sub))
    os << "faults: " << sub;
  else if (!global.Check(&sub))
    os << "global: " << sub;
  else if (!zero_velocity.Check(&sub))
    os << "zero_velocity: " << sub;
  if (why) *why = os.str();
  return os.str().empty();
}

namespace {

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// The priors that fix a session's gauge at its first keyframe: pose (position and yaw pinned, roll
// and pitch as well as known) and speed/biases.
struct Gauge {
  Rigid3 T_W_B0;
  double sigma_p = 1e-3, sigma_roll_pitch = 0.02, sigma_yaw = 1e-3;
  Eigen::Matrix<double, 9, 1> sb0 = Eigen::Matrix<double, 9, 1>::Zero();
  Eigen::Matrix<double, 9, 1> sigma_sb = Eigen::Matrix<double, 9, 1>::Ones();
};

struct Keyframe {
  int index = 0;  // position in Impl::keyframes
  int frame = 0;  // position in Impl::output (the frame's reported state)
  // False for a window-mode frame that is solved with the window and dropped when the next frame
  // arrives (it is always the newest state).
  bool keyframe = true;
  KeyframeState state;
  // Preintegrated IMU from the previous keyframe (null for the first keyframe of a session and
  // across an IMU gap).
  std::shared_ptr<ImuPreintegration> preint;
  // > 0: the IMU has a hole between the previous keyframe and this one, which are linked by the
  // motion prior over this interval instead [s].
  double imu_gap_s = 0.0;
  // Set on the first keyframe of a session (the start, and every restart): no link to the
  // previous keyframe, its gauge priors instead.
  std::optional<Gauge> gauge;
  std::vector<ObjectObservation> observations;
  // Standing still since the previous keyframe (ZeroVelocityOptions): a zero-velocity prior.
  bool still = false;
};

struct Object {
  int id = -1;
  ObjectClass object_class = ObjectClass::kUnknown;
  Keyframe* anchor = nullptr;  // F = camera frame of this keyframe
  FspLandmark fsp;
  FhpLandmark fhp;
  double width_prior_m = 1.0;
  int observations = 0;
  int first_seen = -1;  // index of the keyframe that first saw it (its first anchor)
  int last_seen = -1;   // index of the newest keyframe that saw it
  // Observations from keyframes that left the window (pose constant), newest last, capped.
  struct PastView {
    Keyframe* keyframe;
    Corners corners;
  };
  std::deque<PastView> past;
};

using Keyframes = std::deque<std::unique_ptr<Keyframe>>;
using Objects = std::map<int, std::unique_ptr<Object>>;

}  // namespace

struct Estimator::Impl {
  Impl(const Calibration& calib, const EstimatorOptions& opts) : calibration(calib), options(opts) {
    K = calibration.camera.K();
    T_B_C = calibration.T_B_C;
    options.imu.noise = calibration.imu;
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
  std::deque<std::unique_ptr<Keyframe>>
      keyframes;  // every keyframe (window = the last window_size)
  std::map<int, std::unique_ptr<Object>> objects;
  // Window mode: the best-observed earlier instance of each re-initialised object (the map reports
  // whichever instance of an id has more observations).
  std::map<int, std::unique_ptr<Object>> retired;
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
  Rigid3 T_W_B0;            // gauge prior of the first keyframe
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

  PoseManifold pose_manifold;
  ceres::EigenQuaternionManifold quat_manifold;

  // --- IMU -------------------------------------------------------------------------------------
  std::vector<ImuSample> ImuBetween(int64_t t0, int64_t t1) const {
    // One sample before t0 and one after t1 so the preintegration can interpolate the boundaries.
    auto lo = std::lower_bound(imu.begin(), imu.end(), t0,
                               [](const ImuSample& s, int64_t t) { return s.t_ns < t; });
    if (lo != imu.begin()) --lo;
    auto hi = std::upper_bound(imu.begin(), imu.end(), t1,
                               [](int64_t t, const ImuSample& s) { return t < s.t_ns; });
    if (hi != imu.end()) ++hi;
    return std::vector<ImuSample>(lo, hi);
  }

  // The longest stretch without an IMU sample that the interval [t0, t1] needs: from the last
  // sample at or before t0 (t0 if none) through the samples inside to the first sample at or after
  // t1 (t1 when none has arrived yet). [from, to] in ns.
  std::pair<int64_t, int64_t> LongestImuHole(int64_t t0, int64_t t1) const {
    auto it = std::upper_bound(imu.begin(), imu.end(), t0,
                               [](int64_t t, const ImuSample& s) { return t < s.t_ns; });
    int64_t prev = it == imu.begin() ? t0 : (it - 1)->t_ns;
    std::pair<int64_t, int64_t> best{prev, prev};
    while (prev < t1) {
      const int64_t next = it == imu.end() ? t1 : it->t_ns;
      if (next - prev > best.second - best.first) best = {prev, next};
      prev = next;
      if (it != imu.end()) ++it;
    }
    return best;
  }

  // Frame gaps and stretches without any object in view (counted and warned; `end`: the sequence
  // ended at t_ns, only the trailing stretch is examined).
  void NoteFrame(int64_t t_ns, bool sees_objects, bool end = false) {
    const FaultOptions& f = options.faults;
    char what[160];
    if (last_frame_t && !end) {
      const double gap = NsToSeconds(t_ns - *last_frame_t);
      if (gap > f.frame_gap_s) {
        ++summary.frame_gaps;
        summary.frame_gap_max_s = std::max(summary.frame_gap_max_s, gap);
        std::snprintf(what, sizeof(what),
                      "frame gap: no frame for %.2f s; bridged by the IMU preintegration", gap);
        Warn(t_ns, what);
        // Objects in view until the gap: the stretch without frames is a frame gap, not a blind
        // one.
        if (last_seen_t == last_frame_t) last_seen_t = t_ns;
      }
    }
    if (!end) last_frame_t = t_ns;
    if (!last_seen_t) last_seen_t = t_ns;
    if (!sees_objects) return;
    const double blind = NsToSeconds(t_ns - *last_seen_t);
    if (blind >= f.blind_s) {
      ++summary.blind_stretches;
      summary.blind_max_s = std::max(summary.blind_max_s, blind);
      std::snprintf(what, sizeof(what),
                    "no object in view for %.2f s (since t=%.2f s): IMU dead reckoning%s", blind,
                    NsToSeconds(*last_seen_t), end ? " to the end" : "");
      Warn(t_ns, what);
    }
    last_seen_t = t_ns;
  }

  void Warn(int64_t t_ns, const std::string& what) {
    if (static_cast<int>(summary.warnings.size()) >= EstimatorSummary::kMaxWarnings) return;
    char t[32];
    std::snprintf(t, sizeof(t), "t=%.2f s: ", NsToSeconds(t_ns));
    summary.warnings.push_back(t + what);
  }

  // --- Initialisation ----------------------------------------------------------------------------
  // Returns true once initialised; false while waiting for IMU or after a refusal.
  bool TryInitialize() {
    if (summary.initialized) return true;
    if (!summary.init_failure.empty() || pending.empty()) return false;
    const int64_t t0 = pending.front().first;
    const int64_t t1 = t0 + static_cast<int64_t>(options.static_init.window_s * 1e9);
    if (imu.empty() || imu.back().t_ns < t1) return false;  // wait for the whole still interval
    StaticInitOptions so = options.static_init;
    so.gravity = options.imu.gravity;
    const StaticInitSummary s = StaticInitialize(ImuBetween(t0, t1), so, t0);
    if (!s.success) {
      summary.init_failure = s.reason;
      return false;
    }
    summary.initialized = true;
    KeyframeState first;
    first.t_ns = t0;
    first.SetT_W_B(Rigid3(s.state.T_W_B.rotation(), Vec3::Zero()));
    GyroBiasOf(first.speed_bias) = s.state.gyro_bias;
    T_W_B0 = first.T_W_B();
    sb0.segment<3>(3) = s.state.gyro_bias;
    auto frames = std::move(pending);
    pending.clear();
    Gauge gauge;
    gauge.T_W_B0 = T_W_B0;
    gauge.sb0 = sb0;
    gauge.sigma_sb << Vec3::Constant(0.01), Vec3::Constant(options.prior_gyro_bias_sigma),
        Vec3::Constant(options.prior_acc_bias_sigma);
    bool first_frame = true;
    for (auto& [t_ns, obs] : frames) {
      if (first_frame) {
        AddKeyframe(t_ns, std::move(obs), &first, gauge);
        first_frame = false;
      } else {
        AddKeyframe(t_ns, std::move(obs), nullptr);
      }
    }
    return true;
  }

  // --- Keyframes ---------------------------------------------------------------------------------
  void AddKeyframe(int64_t t_ns, std::vector<ObjectObservation> obs, const KeyframeState* initial,
                   const std::optional<Gauge>& gauge = std::nullopt) {
    const auto t_start = Clock::now();
    if (!keyframes.empty() && !keyframes.back()->keyframe) DropNewest();
    auto kf = std::make_unique<Keyframe>();
    kf->index = static_cast<int>(keyframes.size());
    kf->frame = static_cast<int>(output.size());
    kf->keyframe = initial != nullptr || IsKeyframe(t_ns, obs);
    kf->gauge = gauge;
    const Keyframe* prev_kf = initial ? nullptr : keyframes.back().get();
    const std::pair<int64_t, int64_t> hole =
        prev_kf ? LongestImuHole(prev_kf->state.t_ns, t_ns) : std::pair<int64_t, int64_t>{0, 0};
    const double hole_s = NsToSeconds(hole.second - hole.first);
    if (initial) {
      kf->state = *initial;
    } else if (hole_s > options.faults.max_imu_gap_s) {
      // The preintegration across a hole in the IMU stream is unusable: the constant-velocity
      // motion prior links the two keyframes instead, and predicts the new state.
      const Keyframe& prev = *prev_kf;
      if (hole.first != counted_imu_hole_from) {
        counted_imu_hole_from = hole.first;
        ++summary.imu_gaps;
        char what[160];
        std::snprintf(
            what, sizeof(what),
            "IMU gap: no IMU sample since t=%.2f s; bridged by a constant-velocity motion "
            "prior until the IMU returns",
            NsToSeconds(hole.first));
        Warn(t_ns, what);
      }
      summary.imu_gap_max_s = std::max(summary.imu_gap_max_s, hole_s);
      ++summary.imu_gap_links;
      kf->imu_gap_s = NsToSeconds(t_ns - prev.state.t_ns);
      const Rigid3 T_W_Bi = prev.state.T_W_B();
      std::copy(prev.state.speed_bias, prev.state.speed_bias + kSpeedBiasSize,
                kf->state.speed_bias);
      kf->state.SetT_W_B(
          Rigid3(T_W_Bi.rotation(), T_W_Bi.translation() + kf->imu_gap_s * prev.state.v_W()));
    } else {
      const Keyframe& prev = *prev_kf;
      kf->preint = std::make_shared<ImuPreintegration>(
          options.imu, ImuBetween(prev.state.t_ns, t_ns), prev.state.t_ns, t_ns,
          prev.state.gyro_bias(), prev.state.acc_bias());
      Rigid3 T_W_Bj;
      Vec3 v_j;
      kf->preint->Predict(prev.state.T_W_B(), prev.state.v_W(), prev.state.gyro_bias(),
                          prev.state.acc_bias(), &T_W_Bj, &v_j);
      kf->state.SetT_W_B(T_W_Bj);
      std::copy(prev.state.speed_bias, prev.state.speed_bias + kSpeedBiasSize,
                kf->state.speed_bias);
      VelocityOf(kf->state.speed_bias) = v_j;
    }
    kf->state.t_ns = t_ns;
    kf->observations = std::move(obs);
    if (kf->preint && prev_kf && Still(*prev_kf, *kf)) {
      kf->still = true;
      if (kf->keyframe) ++summary.zero_velocity_keyframes;
    }
    keyframes.push_back(std::move(kf));
    output.push_back(keyframes.back()->state.ToStateSample());
    if (keyframes.back()->keyframe) ++summary.keyframes;

    InitializeNewObjects(keyframes.back().get());
    for (const ObjectObservation& o : keyframes.back()->observations) {
      auto it = objects.find(o.object_id);
      if (it != objects.end()) {
        ++it->second->observations;
        it->second->last_seen = keyframes.back()->index;
        ++summary.observations_used;
      }
    }
    if (options.mode == EstimatorMode::kWindow) {
      if (options.global.enabled) {
        if (keyframes.back()->keyframe) ++keyframes_since_global;
        if (!job && (loop_pending || keyframes_since_global >= options.global.every_keyframes))
          StartGlobal();
        if (job && summary.keyframes >= job->apply_at) ApplyGlobal();
      }
      SolveWindow(options.window_max_iterations);
      const auto in_window = [this] {
        return static_cast<int>(keyframes.size() - window_begin) -
               (keyframes.back()->keyframe ? 0 : 1);
      };
      while (in_window() > options.window_size) MarginalizeOldest();
    } else if (keyframes.size() % static_cast<size_t>(options.batch_solve_every) == 0) {
      // Batch: the whole problem so far (window_begin stays 0), re-solved every few frames so the
      // initial values of the final solve stay close to the optimum. Each solve must converge: with
      // a few iterations per solve (like the window's) the error left behind grew with every solve
      // and the default scene diverged after ~20 s (ATE 39 m); solved to convergence (7-19
      // iterations each) ATE 0.42 cm.
      SolveWindow(options.batch_max_iterations);
    }
    PruneImu();
    causal.push_back(output[keyframes.back()->frame]);
    summary.backend_ms.push_back(MsSince(t_start));
  }

  // Window mode: whether a frame is kept as a keyframe. Kept: every keyframe_interval_s, and any
  // frame that sees an object not in the map or back after leaving the window (it may become the
  // object's anchor, and only keyframes can be anchors).
  bool IsKeyframe(int64_t t_ns, const std::vector<ObjectObservation>& obs) const {
    if (options.mode == EstimatorMode::kBatch || options.keyframe_interval_s <= 0.0) return true;
    const Keyframe& last = *keyframes.back();  // a keyframe: a non-keyframe newest was just dropped
    if (static_cast<double>(t_ns - last.state.t_ns) >= options.keyframe_interval_s * 1e9 - 1e6)
      return true;
    const int first_in_window = keyframes[window_begin]->index;
    for (const ObjectObservation& o : obs) {
      auto it = objects.find(o.object_id);
      if (it == objects.end() || it->second->last_seen < first_in_window) return true;
    }
    return false;
  }

  // Whether the vehicle stood still between keyframes `prev` and `kf` (ZeroVelocityOptions): no
  // mean turn and every object seen by both at the same place in the image.
  bool Still(const Keyframe& prev, const Keyframe& kf) const {
    const ZeroVelocityOptions& z = options.zero_velocity;
    if (!z.enabled) return false;
    // The mean turn rate (a vibrating vehicle, motors running on the ground, has a noisy IMU but
    // no mean rotation).
    const std::vector<ImuSample> samples = ImuBetween(prev.state.t_ns, kf.state.t_ns);
    if (samples.size() < 3) return false;
    Vec3 g_mean = Vec3::Zero();
    for (const ImuSample& s : samples) g_mean += s.gyro;
    g_mean /= static_cast<double>(samples.size());
    if ((g_mean - prev.state.gyro_bias()).norm() > z.max_turn_rate) return false;
    int shared = 0;
    for (const ObjectObservation& o : kf.observations) {
      for (const ObjectObservation& p : prev.observations) {
        if (p.object_id != o.object_id) continue;
        double d = 0.0;
        for (int j = 0; j < 4; ++j) d += (o.corners[j] - p.corners[j]).norm() / 4.0;
        if (d > z.max_disparity_px) return false;
        ++shared;
      }
    }
    return shared > 0;
  }

  ceres::CostFunction* MakeZeroVelocityPrior(const Keyframe& kf) const {
    Eigen::Matrix<double, 9, 1> still, sigma;
    still << Vec3::Zero(), kf.state.gyro_bias(), kf.state.acc_bias();
    sigma << Vec3::Constant(options.zero_velocity.velocity_sigma), Vec3::Constant(1e6),
        Vec3::Constant(1e6);  // the biases are free
    return new SpeedBiasPrior(still, sigma);
  }

  // Removes the newest frame (not a keyframe) from the window: its pose was reported, its
  // observations are forgotten, and the next frame's IMU factor starts at the last keyframe.
  void DropNewest() {
    const Keyframe& kf = *keyframes.back();
    const Keyframe* ref = keyframes[keyframes.size() - 2].get();  // a keyframe (see AddKeyframe)
    const Rigid3 T_W_ref = ref->state.T_W_B();
    dropped.push_back({kf.frame, ref, T_W_ref.Inverse() * kf.state.T_W_B(),
                       T_W_ref.rotation().conjugate() * kf.state.v_W()});
    for (const ObjectObservation& o : kf.observations) {
      auto it = objects.find(o.object_id);
      if (it == objects.end()) continue;
      --it->second->observations;
      --summary.observations_used;
    }
    keyframes.pop_back();
  }

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
  void InitializeNewObjects(Keyframe* kf) {
    const Rigid3 T_W_C = CameraPose(*kf);
    const int first_in_window = keyframes[window_begin]->index;
    for (const ObjectObservation& o : kf->observations) {
      auto found = objects.find(o.object_id);
      const bool returning = found != objects.end() && options.mode == EstimatorMode::kWindow &&
                             found->second->last_seen < first_in_window;
      if (returning &&
          (options.global.enabled ? !CloseLoop(found->second.get(), kf, o.corners)
                                  : !ConsistentWithMap(*found->second, T_W_C, o.corners))) {
        std::unique_ptr<Object>& best = retired[o.object_id];
        if (!best || best->observations < found->second->observations)
          best = std::move(found->second);
        objects.erase(found);
        found = objects.end();
        ++summary.objects_reinitialized;
      }
      if (found != objects.end()) continue;
      const SingleViewInitSummary s = InitializeFspSingleView(
          o.corners, K, o.object_class, options.init, UpDirection(o.object_class, T_W_C));
      if (!s.success()) {
        ++summary.observations_rejected;
        continue;
      }
      auto obj = std::make_unique<Object>();
      obj->id = o.object_id;
      obj->object_class = o.object_class;
      obj->anchor = kf;
      obj->first_seen = kf->index;
      obj->fsp = s.landmark;
      obj->fhp = FhpLandmark::FromFsp(s.landmark);
      obj->width_prior_m = s.landmark.Width();
      objects[o.object_id] = std::move(obj);
    }
  }

  // "Up" (−gravity) in the camera frame for classes known to be vertical (single-view
  // initialisation), nullopt for the others.
  static std::optional<Vec3> UpDirection(ObjectClass c, const Rigid3& T_W_C) {
    const bool vertical = c == ObjectClass::kDoor || c == ObjectClass::kWindow ||
                          c == ObjectClass::kCabinet || c == ObjectClass::kPoster;
    if (!vertical) return std::nullopt;
    return T_W_C.rotation().conjugate() * Vec3::UnitZ();
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
                                        const Corners& corners) const {
    const Rigid3 T_W_F = CameraPose(*obj.anchor);
    const CornerPrediction p = options.landmarks == LandmarkType::kFsp
                                   ? PredictFspCorners(K, T_W_C, T_W_F, obj.fsp)
                                   : PredictFhpCorners(K, T_W_C, T_W_F, obj.fhp);
    if (!p.in_front) return std::nullopt;
    double sum2 = 0.0;
    for (int j = 0; j < 4; ++j) sum2 += (p.uv[j] - corners[j]).squaredNorm();
    return std::sqrt(sum2 / 4.0);
  }

  Rigid3 ObjectPose(const Object& obj) const {
    const Rigid3 T_W_F = CameraPose(*obj.anchor);
    return options.landmarks == LandmarkType::kFsp ? obj.fsp.T_W_O(T_W_F) : obj.fhp.T_W_O(T_W_F);
  }
  std::pair<double, double> ObjectSize(const Object& obj) const {
    return options.landmarks == LandmarkType::kFsp ? std::pair{obj.fsp.Width(), obj.fsp.Height()}
                                                   : std::pair{obj.fhp.Width(), obj.fhp.Height()};
  }

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
  bool CloseLoop(Object* obj, Keyframe* kf, const Corners& corners) {
    const GlobalOptions& g = options.global;
    const std::optional<double> e0 = PredictionError(*obj, CameraPose(*kf), corners);
    if (e0 && *e0 <= g.loop_direct_px) return AcceptLoop(*obj);
    // The pre-alignment needs the newest map: a global solve in flight is applied first.
    if (job) {
      ApplyGlobal();
      const std::optional<double> e = PredictionError(*obj, CameraPose(*kf), corners);
      if (e && *e <= g.loop_direct_px) return AcceptLoop(*obj);
    }
    const int last_seen = obj->last_seen;
    if (PreAlign(obj, kf, corners)) {
      ++summary.loops_prealigned;
      return AcceptLoop(*obj, last_seen);
    }
    // Closing a loop of more than a few pixels as it is was measured to be unsafe: small tags
    // accepted at 10 px pulled the default room's global solve into a wrong minimum (ATE 1.6 m).
    ++summary.loops_rejected;
    return false;
  }
  // A loop closed: the next global solve frees the keyframes since the object was last seen.
  bool AcceptLoop(const Object& obj, int last_seen = -1) {
    ++summary.loops_closed;
    loop_pending = true;
    loop_from = std::min(loop_from, std::max(0, last_seen >= 0 ? last_seen : obj.last_seen));
    return true;
  }

  // The pre-alignment of CloseLoop; false (states unchanged) when it is implausible or leaves the
  // corners further than loop_accept_px from their prediction.
  bool PreAlign(Object* obj, Keyframe* kf, const Corners& corners) {
    const GlobalOptions& g = options.global;
    // The camera pose in the map's frame from this view of the object.
    const SingleViewInitSummary sv =
        InitializeFspSingleView(corners, K, obj->object_class, options.init,
                                UpDirection(obj->object_class, CameraPose(*kf)));
    if (!sv.success()) return false;
    FspLandmark view = sv.landmark;
    const auto [w_map, h_map] = ObjectSize(*obj);
    view.x[kFspLogOmega] +=
        0.5 * (std::log(view.Width() / w_map) + std::log(view.Height() / h_map));
    const Rigid3 T_W_Cmap = ObjectPose(*obj) * view.T_F_O().Inverse();
    const Rigid3 T_W_C = CameraPose(*kf);
    const Mat3 dR = (T_W_Cmap.rotation() * T_W_C.rotation().conjugate()).toRotationMatrix();
    const double yaw = std::atan2(dR(1, 0) - dR(0, 1), dR(0, 0) + dR(1, 1));
    const Vec3 pivot = T_W_C.translation();
    const Vec3 shift = T_W_Cmap.translation() - pivot;
    // Distance travelled since the object was last seen, per keyframe.
    const size_t from = static_cast<size_t>(std::max(obj->last_seen, 0));
    std::vector<double> travelled(keyframes.size() - from, 0.0);
    for (size_t i = from + 1; i < keyframes.size(); ++i)
      travelled[i - from] =
          travelled[i - from - 1] + (keyframes[i]->state.T_W_B().translation() -
                                     keyframes[i - 1]->state.T_W_B().translation())
                                        .norm();
    const double distance = travelled.back();
    if (shift.norm() > g.budget_m + g.budget_per_m * distance ||
        std::abs(yaw) > (g.budget_yaw_deg + g.budget_yaw_per_m * distance) * M_PI / 180.0)
      return false;
    const Snapshot before = Save(from);
    // Objects that stay: their world pose before the keyframes move.
    std::vector<std::pair<Object*, Rigid3>> stay;
    for (auto& [id, o] : objects)
      if (o->first_seen <= static_cast<int>(from) && o->anchor->index > static_cast<int>(from))
        stay.emplace_back(o.get(), CameraPose(*o->anchor));
    for (size_t i = from + 1; i < keyframes.size(); ++i) {
      const double a = distance > 0.0 ? travelled[i - from] / distance : 1.0;
      const Quat Rz(Eigen::AngleAxisd(a * yaw, Vec3::UnitZ()));
      KeyframeState& st = keyframes[i]->state;
      const Rigid3 T = st.T_W_B();
      st.SetT_W_B(Rigid3(Rz * T.rotation(), pivot + Rz * (T.translation() - pivot) + a * shift));
      VelocityOf(st.speed_bias) = Rz * st.v_W();
    }
    for (auto& [o, T_W_F_before] : stay) {
      const Rigid3 T_W_F_after = CameraPose(*o->anchor);
      if (options.landmarks == LandmarkType::kFsp)
        ReanchorFsp(FspLandmark(o->fsp), T_W_F_before, T_W_F_after, &o->fsp);
      else
        ReanchorFhp(FhpLandmark(o->fhp), T_W_F_before, T_W_F_after, &o->fhp);
    }
    const std::optional<double> e1 = PredictionError(*obj, CameraPose(*kf), corners);
    const std::optional<double> e0 = PredictionError(*obj, T_W_C, corners);
    if (!e1 || *e1 > g.loop_accept_px || (e0 && *e1 >= *e0)) {
      Restore(before);
      return false;
    }
    for (size_t i = from + 1; i < keyframes.size(); ++i)
      output[keyframes[i]->frame] = keyframes[i]->state.ToStateSample();
    if (prior) prior = Recentered(*prior);
    return true;
  }

  // Whether the object's depth sits on the box [min_depth_m, max_depth_m] (an FHP corner's, any):
  // such a depth is not an estimate (no parallax; or, seen in window mode and not yet understood, a
  // collapse onto the minimum), so neither are its size and place; the map leaves it out.
  bool AtDepthBound(const Object& obj) const { return !DepthInBox(obj.fsp, obj.fhp); }

  // Whether the depth of s1 (FSP) or of every corner (FHP) lies strictly inside the depth box.
  bool DepthInBox(const FspLandmark& fsp, const FhpLandmark& fhp) const {
    const double lo = -std::log(options.max_depth_m), hi = -std::log(options.min_depth_m);
    const auto inside = [&](double log_omega) {
      return log_omega > lo + 1e-6 && log_omega < hi - 1e-6;
    };
    if (options.landmarks == LandmarkType::kFsp) return inside(fsp.x[kFspLogOmega]);
    for (const auto& c : fhp.corner)
      if (!inside(c[2])) return false;
    return true;
  }

  // --- Problem construction
  // ----------------------------------------------------------------------- Adds the factor(s) of
  // one observation of `obj` from keyframe `kf`. Poses of keyframes that are not variables of this
  // problem (`is_variable` false: they left the window) enter as constants.
  template <typename IsVariable>
  void AddObservation(ceres::Problem* problem, Keyframe* kf, Object* obj, const Corners& corners,
                      const IsVariable& is_variable) {
    for (Keyframe* k : {kf, obj->anchor}) {
      if (is_variable(k) || problem->HasParameterBlock(k->state.pose)) continue;
      problem->AddParameterBlock(k->state.pose, kPoseSize, &pose_manifold);
      problem->SetParameterBlockConstant(k->state.pose);
    }
    const Rigid3 T_W_C = CameraPose(*kf);
    const Rigid3 T_W_F = CameraPose(*obj->anchor);
    const bool at_anchor = obj->anchor == kf;
    if (options.landmarks == LandmarkType::kFsp) {
      if (!PredictFspCorners(K, T_W_C, T_W_F, obj->fsp).in_front) return;  // behind the camera
      ceres::LossFunction* loss = MakeRobustLoss(options.robust, 8).release();
      if (at_anchor) {
        problem->AddResidualBlock(new FspAnchorFactor(corners, K, options.factor), loss,
                                  obj->fsp.q_F_O, obj->fsp.x);
      } else {
        problem->AddResidualBlock(new FspFactor(corners, K, T_B_C, options.factor), loss,
                                  kf->state.pose, obj->anchor->state.pose, obj->fsp.q_F_O,
                                  obj->fsp.x);
      }
      problem->SetManifold(obj->fsp.q_F_O, &quat_manifold);
      BoundLogParameter(problem, obj->fsp.x, kFspLogOmega, options.min_depth_m,
                        options.max_depth_m);
    } else {
      if (!PredictFhpCorners(K, T_W_C, T_W_F, obj->fhp).in_front) return;  // behind the camera
      for (int j = 0; j < 4; ++j) {
        ceres::LossFunction* loss = MakeRobustLoss(options.robust, 2).release();
        if (at_anchor) {
          problem->AddResidualBlock(new FhpAnchorFactor(corners[j], K, options.factor), loss,
                                    obj->fhp.corner[j]);
        } else {
          problem->AddResidualBlock(new FhpFactor(corners[j], K, T_B_C, options.factor), loss,
                                    kf->state.pose, obj->anchor->state.pose, obj->fhp.corner[j]);
        }
        BoundLogParameter(problem, obj->fhp.corner[j], 2, options.min_depth_m, options.max_depth_m);
      }
    }
  }

  // Keeps an inverse depth ω = exp(x[i]) within [1/max_depth, 1/min_depth]: an object with no
  // parallax yet (hover, far away) must not drift to infinity and drag the trajectory with it. The
  // current value is clamped into the box first (Ceres requires a feasible start).
  static void BoundLogParameter(ceres::Problem* problem, double* block, int i, double min_depth,
                                double max_depth) {
    const double lo = -std::log(max_depth), hi = -std::log(min_depth);
    block[i] = std::clamp(block[i], lo, hi);
    problem->SetParameterLowerBound(block, i, lo);
    problem->SetParameterUpperBound(block, i, hi);
  }

  // Observation factors of keyframes [begin, end) and, for every object they see, its past views.
  // `mature`: only objects seen at least options.mature_views times (they constrain the poses), or
  // only the others (refined alone with every pose held constant).
  void AddVisualFactors(ceres::Problem* problem, size_t begin, size_t end, bool mature) {
    const int first_index = keyframes[begin]->index;
    auto is_variable = [first_index, mature](const Keyframe* k) {
      return mature && k->index >= first_index;
    };
    std::vector<Object*> seen;
    for (size_t i = begin; i < end; ++i) {
      Keyframe* kf = keyframes[i].get();
      for (const ObjectObservation& o : kf->observations) {
        auto it = objects.find(o.object_id);
        if (it == objects.end() || (it->second->observations >= options.mature_views) != mature)
          continue;
        AddObservation(problem, kf, it->second.get(), o.corners, is_variable);
        seen.push_back(it->second.get());
      }
    }
    std::sort(seen.begin(), seen.end(),
              [](const Object* a, const Object* b) { return a->id < b->id; });
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    for (Object* obj : seen)
      for (const auto& view : obj->past)
        AddObservation(problem, view.keyframe, obj, view.corners, is_variable);
  }

  void AddStateBlocks(ceres::Problem* problem, Keyframe* kf) {
    problem->AddParameterBlock(kf->state.pose, kPoseSize, &pose_manifold);
    problem->AddParameterBlock(kf->state.speed_bias, kSpeedBiasSize);
  }

  void AddImuFactor(ceres::Problem* problem, Keyframe* prev, Keyframe* kf) {
    if (kf->imu_gap_s > 0.0) {
      problem->AddResidualBlock(MakeGapPrior(kf->imu_gap_s), nullptr, prev->state.pose,
                                prev->state.speed_bias, kf->state.pose, kf->state.speed_bias);
      return;
    }
    kf->preint->ReintegrateIfNeeded(prev->state.gyro_bias(), prev->state.acc_bias());
    problem->AddResidualBlock(new ImuFactor(kf->preint), nullptr, prev->state.pose,
                              prev->state.speed_bias, kf->state.pose, kf->state.speed_bias);
  }

  void AddGaugePriors(ceres::Problem* problem, Keyframe* first) {
    // Position and yaw pinned (gauge); roll/pitch as well known as the start gives them.
    problem->AddResidualBlock(MakeGaugePosePrior(*first->gauge), nullptr, first->state.pose);
    problem->AddResidualBlock(MakeGaugeBiasPrior(*first->gauge), nullptr, first->state.speed_bias);
  }
  static ceres::CostFunction* MakeGaugePosePrior(const Gauge& g) {
    return new PosePrior(g.T_W_B0, g.sigma_p, g.sigma_roll_pitch, g.sigma_yaw);
  }
  static ceres::CostFunction* MakeGaugeBiasPrior(const Gauge& g) {
    return new SpeedBiasPrior(g.sb0, g.sigma_sb);
  }
  ceres::CostFunction* MakeGapPrior(double dt_s) const {
    ImuGapPriorOptions o;
    o.max_acc = options.faults.gap_max_acc;
    o.max_rate = options.faults.gap_max_rate;
    o.gyro_walk = options.imu.noise.gyroscope_random_walk;
    o.acc_walk = options.imu.noise.accelerometer_random_walk;
    return MakeImuGapPrior(dt_s, o);
  }

  // --- Faults ------------------------------------------------------------------------------------
  // The values a solve may change, to restore when its result is rejected.
  struct Snapshot {
    size_t begin = 0;
    std::vector<KeyframeState> states;                         // keyframes [begin, end)
    std::vector<std::pair<FspLandmark, FhpLandmark>> objects;  // in the order of `objects`
  };
  Snapshot Save(size_t begin) const { return Save(keyframes, objects, begin); }
  static Snapshot Save(const Keyframes& kfs, const Objects& objs, size_t begin) {
    Snapshot s;
    s.begin = begin;
    for (size_t i = begin; i < kfs.size(); ++i) s.states.push_back(kfs[i]->state);
    for (const auto& [id, obj] : objs) s.objects.emplace_back(obj->fsp, obj->fhp);
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
    for (auto& [id, obj] : *objs) {
      obj->fsp = s.objects[k].first;
      obj->fhp = s.objects[k].second;
      ++k;
    }
  }

  // Why a solve's result is implausible (empty when it is not): the solver failed, a state is not
  // finite, a speed or bias beyond FaultOptions' bounds, a keyframe moved further than max_jump_m.
  std::string Diverged(const ceres::Solver::Summary& s, const Snapshot& before) const {
    return Diverged(s, before, keyframes);
  }
  std::string Diverged(const ceres::Solver::Summary& s, const Snapshot& before,
                       const Keyframes& kfs) const {
    const FaultOptions& f = options.faults;
    if (s.termination_type == ceres::FAILURE || !std::isfinite(s.final_cost))
      return "the solver failed";
    char buf[128];
    for (size_t k = 0; k < before.states.size(); ++k) {
      const KeyframeState& st = kfs[before.begin + k]->state;
      const Eigen::Map<const Eigen::Matrix<double, kPoseSize, 1>> pose(st.pose);
      const Eigen::Map<const Eigen::Matrix<double, kSpeedBiasSize, 1>> sb(st.speed_bias);
      if (!pose.allFinite() || !sb.allFinite()) return "a state is not finite";
      const double jump =
          (st.T_W_B().translation() - before.states[k].T_W_B().translation()).norm();
      const double speed = st.v_W().norm(), bg = st.gyro_bias().norm(), ba = st.acc_bias().norm();
      if (speed > f.max_speed) {
        std::snprintf(buf, sizeof(buf), "speed %.3g m/s", speed);
      } else if (bg > f.max_gyro_bias) {
        std::snprintf(buf, sizeof(buf), "gyroscope bias %.3g rad/s", bg);
      } else if (ba > f.max_acc_bias) {
        std::snprintf(buf, sizeof(buf), "accelerometer bias %.3g m/s^2", ba);
      } else if (jump > f.max_jump_m) {
        std::snprintf(buf, sizeof(buf), "a keyframe moved %.3g m in one solve", jump);
      } else {
        continue;
      }
      return buf;
    }
    return "";
  }

  // Starts a new session at the newest frame after a rejected solve (its state restored: the
  // prediction from the last accepted one): the frame becomes a keyframe with fresh gauge priors at
  // its pose (the trajectory stays continuous), the biases go back to the start's, the velocity is
  // kept when plausible; the window and its marginalisation prior are dropped, and the objects are
  // retired (the map keeps their best instances) and start afresh from this frame's views. In
  // batch mode the session break only cuts the IMU chain (every keyframe stays a variable and the
  // objects are kept).
  void Restart(const std::string& why) {
    DiscardGlobal();
    Keyframe* kf = keyframes.back().get();
    if (!kf->keyframe) {
      kf->keyframe = true;
      ++summary.keyframes;
    }
    const FaultOptions& f = options.faults;
    Vec3 v = kf->state.v_W();
    if (!v.allFinite() || v.norm() > f.max_speed) v.setZero();
    Rigid3 T = kf->state.T_W_B();
    if (!T.Matrix().allFinite())
      T = keyframes.size() >= 2 ? keyframes[keyframes.size() - 2]->state.T_W_B() : T_W_B0;
    kf->state.SetT_W_B(T);
    VelocityOf(kf->state.speed_bias) = v;
    GyroBiasOf(kf->state.speed_bias) = sb0.segment<3>(3);
    AccBiasOf(kf->state.speed_bias) = sb0.segment<3>(6);
    Gauge g;
    g.T_W_B0 = T;
    g.sigma_roll_pitch = f.restart_roll_pitch_sigma;
    g.sb0 = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(kf->state.speed_bias);
    g.sigma_sb << Vec3::Constant(f.restart_velocity_sigma),
        Vec3::Constant(options.prior_gyro_bias_sigma), Vec3::Constant(options.prior_acc_bias_sigma);
    kf->gauge = g;
    kf->preint.reset();
    kf->imu_gap_s = 0.0;
    output[kf->frame] = kf->state.ToStateSample();
    ++summary.resets;
    Warn(kf->state.t_ns,
         "divergence (" + why +
             "): solve rejected, estimator restarted (new session from this frame)");
    if (options.mode == EstimatorMode::kBatch) return;
    window_begin = static_cast<size_t>(kf->index);
    prior.reset();
    for (auto& [id, obj] : objects) {
      std::unique_ptr<Object>& best = retired[id];
      if (!best || best->observations < obj->observations) best = std::move(obj);
    }
    objects.clear();
    InitializeNewObjects(kf);
    for (const ObjectObservation& o : kf->observations) {
      auto it = objects.find(o.object_id);
      if (it != objects.end()) {
        ++it->second->observations;
        it->second->last_seen = kf->index;
      }
    }
  }

  void AddObjectPriors(ceres::Problem* problem) { AddObjectPriors(problem, &objects); }
  void AddObjectPriors(ceres::Problem* problem, Objects* objs) const {
    if (options.landmarks != LandmarkType::kFsp) return;
    for (auto& [id, obj] : *objs) {
      if (!problem->HasParameterBlock(obj->fsp.x)) continue;
      problem->AddResidualBlock(
          new LogWidthPrior(obj->width_prior_m, options.prior_log_omega_sigma), nullptr,
          obj->fsp.x);
    }
  }

  ceres::Problem::Options ProblemOptions() const {
    ceres::Problem::Options po;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.enable_fast_removal = false;
    return po;
  }

  ceres::Solver::Options SolverOptions(int max_iterations) const {
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    so.max_num_iterations = max_iterations;
    so.num_threads = 1;
    so.minimizer_progress_to_stdout = false;
    so.logging_type = ceres::SILENT;
    so.function_tolerance = 1e-8;
    so.parameter_tolerance = 1e-10;
    return so;
  }

  // Solves the window [window_begin, end): states, IMU factors, gauge priors while the first
  // keyframe is in it, the marginalisation prior, mature objects' observations and the object
  // priors. The final solve (finish) iterates longer and computes the map's width/height sigmas;
  // the per-frame one then refines the young objects alone.
  void SolveWindow(int max_iterations, bool finish = false) {
    ceres::Problem problem(ProblemOptions());
    const size_t n = keyframes.size();
    for (size_t i = window_begin; i < n; ++i) AddStateBlocks(&problem, keyframes[i].get());
    for (size_t i = window_begin + 1; i < n; ++i)
      if (!keyframes[i]->gauge) AddImuFactor(&problem, keyframes[i - 1].get(), keyframes[i].get());
    for (size_t i = window_begin; i < n; ++i) {
      if (keyframes[i]->gauge) AddGaugePriors(&problem, keyframes[i].get());
      if (keyframes[i]->still)
        problem.AddResidualBlock(MakeZeroVelocityPrior(*keyframes[i]), nullptr,
                                 keyframes[i]->state.speed_bias);
    }
    if (FixedBoundary() && window_begin > 0 && !keyframes[window_begin]->gauge) {
      // The keyframe before the window, held at its estimate, with its IMU link into the window.
      Keyframe* boundary = keyframes[window_begin - 1].get();
      AddStateBlocks(&problem, boundary);
      problem.SetParameterBlockConstant(boundary->state.pose);
      problem.SetParameterBlockConstant(boundary->state.speed_bias);
      AddImuFactor(&problem, boundary, keyframes[window_begin].get());
    }
    if (prior) {
      problem.AddResidualBlock(new MarginalizationPriorFactor(prior), nullptr, prior->blocks);
      for (size_t b = 0; b < prior->blocks.size(); ++b)
        if (prior->manifolds[b])
          problem.SetManifold(prior->blocks[b], const_cast<ceres::Manifold*>(prior->manifolds[b]));
    }
    AddVisualFactors(&problem, window_begin, n, /*mature=*/true);
    AddObjectPriors(&problem);
    const Snapshot before = Save(window_begin);
    ceres::Solver::Summary s;
    ceres::Solve(SolverOptions(max_iterations), &problem, &s);
    const std::string diverged = Diverged(s, before);
    if (!diverged.empty()) {
      Restore(before);
      ++summary.divergences;
      if (finish) {
        Warn(keyframes.back()->state.t_ns,
             "divergence in the final solve (" + diverged + "): its result was rejected");
      } else {
        Restart(diverged);
      }
      return;
    }
    summary.final_cost = s.final_cost;
    for (size_t i = window_begin; i < n; ++i)
      output[keyframes[i]->frame] = keyframes[i]->state.ToStateSample();
    if (finish) {
      ComputeSigmas(&problem);
    } else {
      RefineYoungObjects(max_iterations);
    }
  }

  // Objects seen fewer than mature_views times are refined on their own with the poses held
  // constant: a young object's single-view guess (class-prior depth, possibly flipped normal) must
  // not pull the trajectory before parallax has confirmed it.
  void RefineYoungObjects(int max_iterations) {
    ceres::Problem problem(ProblemOptions());
    AddVisualFactors(&problem, window_begin, keyframes.size(), /*mature=*/false);
    if (problem.NumResidualBlocks() == 0) return;
    AddObjectPriors(&problem);
    ceres::Solver::Summary s;
    ceres::Solve(SolverOptions(max_iterations), &problem, &s);
  }

  // --- Marginalisation
  // ------------------------------------------------------------------------------ Moves the anchor
  // of every object anchored at `old` to the newest window keyframe with s1 in front.
  void ReanchorObjectsOf(Keyframe* old) {
    const size_t n = keyframes.size();
    for (auto& [id, obj] : objects) {
      if (obj->anchor != old) continue;
      const Rigid3 T_W_F = CameraPose(*old);
      for (size_t i = n; i-- > window_begin + 1;) {
        Keyframe* cand = keyframes[i].get();
        if (!cand->keyframe) continue;
        // With the global step, only a keyframe that saw the object: the global solve moves every
        // keyframe, and an object anchored at one that never saw it (a later one, after a
        // stretch of dead reckoning) moved with that keyframe's drift; measured on the room loop
        // with 10 s of nothing in view: the old objects collapsed onto the depth bound.
        if (options.global.enabled && !Sees(*cand, id)) continue;
        const Rigid3 T_W_Fnew = CameraPose(*cand);
        FspLandmark fsp_new;
        FhpLandmark fhp_new;
        const bool ok = options.landmarks == LandmarkType::kFsp
                            ? ReanchorFsp(obj->fsp, T_W_F, T_W_Fnew, &fsp_new)
                            : ReanchorFhp(obj->fhp, T_W_F, T_W_Fnew, &fhp_new);
        // A keyframe that sees s1 barely in front (looking along the wall past it) would put the
        // object's depth outside the box, where the bound clamps it and destroys its geometry
        // (measured: the default scene's objects collapsed onto the 0.3 m minimum right after such
        // a re-anchoring); take the newest keyframe that keeps the depth inside.
        if (!ok || !DepthInBox(fsp_new, fhp_new)) continue;
        if (options.landmarks == LandmarkType::kFsp)
          obj->fsp = fsp_new;
        else
          obj->fhp = fhp_new;
        obj->anchor = cand;

        ++summary.reanchors;
        break;
      }
    }
  }

  static bool Sees(const Keyframe& kf, int object_id) {
    return std::any_of(
        kf.observations.begin(), kf.observations.end(),
        [object_id](const ObjectObservation& o) { return o.object_id == object_id; });
  }

  bool FixedBoundary() const {
    return options.global.enabled && options.global.boundary == WindowBoundary::kFixed;
  }

  void MarginalizeOldest() {
    Keyframe* old = keyframes[window_begin].get();
    Keyframe* next = keyframes[window_begin + 1].get();
    ReanchorObjectsOf(old);
    // Objects that could not be re-anchored (s1 behind every window camera) keep their anchor:
    // their information from the window leaves with the keyframe and they are frozen.
    if (!FixedBoundary()) MarginalizeIntoPrior(old, next);
    // The old keyframe's observations stay as factors with its pose held constant (past views).
    for (const ObjectObservation& o : old->observations) {
      auto it = objects.find(o.object_id);
      if (it == objects.end()) continue;
      auto& past = it->second->past;
      past.push_back({old, o.corners});
      if (static_cast<int>(past.size()) > options.max_past_views) past.pop_front();
    }
    output[old->frame] = old->state.ToStateSample();
    ++window_begin;
    ++summary.marginalizations;
  }

  // The inertial information of `old` (its IMU link to `next`, its gauge priors, the previous
  // prior) into a linear prior on the states that remain.
  void MarginalizeIntoPrior(Keyframe* old, Keyframe* next) {
    // Every factor that touches the old keyframe's state, linearised at the current estimate.
    std::vector<std::unique_ptr<ceres::CostFunction>> costs;
    std::vector<std::unique_ptr<ceres::LossFunction>> losses;
    std::vector<ResidualBlockInput> inputs;
    std::unordered_map<const double*, const ceres::Manifold*> manifolds;
    auto add = [&](ceres::CostFunction* cost, std::unique_ptr<ceres::LossFunction> loss,
                   std::vector<double*> blocks) {
      costs.emplace_back(cost);
      inputs.push_back({cost, loss.get(), std::move(blocks)});
      losses.push_back(std::move(loss));
    };
    manifolds[old->state.pose] = &pose_manifold;
    manifolds[next->state.pose] = &pose_manifold;
    if (next->imu_gap_s > 0.0) {
      add(MakeGapPrior(next->imu_gap_s), nullptr,
          {old->state.pose, old->state.speed_bias, next->state.pose, next->state.speed_bias});
    } else if (!next->gauge) {
      next->preint->ReintegrateIfNeeded(old->state.gyro_bias(), old->state.acc_bias());
      add(new ImuFactor(next->preint), nullptr,
          {old->state.pose, old->state.speed_bias, next->state.pose, next->state.speed_bias});
    }
    if (old->gauge) {
      add(MakeGaugePosePrior(*old->gauge), nullptr, {old->state.pose});
      add(MakeGaugeBiasPrior(*old->gauge), nullptr, {old->state.speed_bias});
    }
    if (old->still) add(MakeZeroVelocityPrior(*old), nullptr, {old->state.speed_bias});
    if (prior) {
      for (size_t b = 0; b < prior->blocks.size(); ++b)
        manifolds[prior->blocks[b]] = prior->manifolds[b];
      add(new MarginalizationPriorFactor(prior), nullptr, prior->blocks);
    }
    const MarginalizationSummary ms = Marginalize(inputs, {old->state.pose, old->state.speed_bias},
                                                  manifolds, MarginalizationOptions());
    if (ms.success) {
      prior = ms.prior;
    } else {
      prior.reset();  // information lost, but the window stays solvable (gauge prior below)
      ++summary.marginalization_failures;
    }
  }

  // --- Batch
  // ---------------------------------------------------------------------------------------
  // Every keyframe of `kfs` and object of `objs` in one problem, solved (the batch's final solve
  // and the window's global step). Touches nothing but kfs and objs (a background global solve runs
  // it on copies). Returns why the result is implausible (the checks of Diverged; kfs and objs
  // restored then), empty when it is not.
  // Keyframes before `free_from` are held at their estimate (GlobalOptions::max_free_keyframes):
  // only their factors that reach a free state stay in the problem.
  std::string SolveAll(Keyframes* kfs, Objects* objs, int max_iterations, ceres::Solver::Summary* s,
                       ceres::Problem* problem, size_t free_from = 0) {
    free_from = std::min(free_from, kfs->size() - 1);
    const auto is_free = [free_from](const Keyframe* k) {
      return k->index >= static_cast<int>(free_from);
    };
    for (size_t i = free_from; i < kfs->size(); ++i) AddStateBlocks(problem, (*kfs)[i].get());
    if (free_from > 0) {
      Keyframe* boundary = (*kfs)[free_from - 1].get();
      AddStateBlocks(problem, boundary);
      problem->SetParameterBlockConstant(boundary->state.pose);
      problem->SetParameterBlockConstant(boundary->state.speed_bias);
    }
    for (size_t i = std::max<size_t>(free_from, 1); i < kfs->size(); ++i)
      if (!(*kfs)[i]->gauge) AddImuFactor(problem, (*kfs)[i - 1].get(), (*kfs)[i].get());
    for (size_t i = free_from; i < kfs->size(); ++i) {
      Keyframe* kf = (*kfs)[i].get();
      if (kf->gauge) AddGaugePriors(problem, kf);
      if (kf->still)
        problem->AddResidualBlock(MakeZeroVelocityPrior(*kf), nullptr, kf->state.speed_bias);
    }
    for (auto& kf : *kfs) {
      for (const ObjectObservation& o : kf->observations) {
        // Views from before an object's first_seen belong to an earlier instance of its id (a
        // rejected loop, a restart); an object no free keyframe saw stays as it is.
        auto it = objs->find(o.object_id);
        if (it != objs->end() && kf->index >= it->second->first_seen &&
            it->second->last_seen >= static_cast<int>(free_from))
          AddObservation(problem, kf.get(), it->second.get(), o.corners, is_free);
      }
    }
    AddObjectPriors(problem, objs);
    const Snapshot before = Save(*kfs, *objs, free_from);
    ceres::Solve(SolverOptions(max_iterations), problem, s);
    const std::string diverged = Diverged(*s, before, *kfs);
    if (!diverged.empty()) Restore(before, kfs, objs);
    return diverged;
  }

  // SolveAll on the estimator's own keyframes and objects; false (with a warning) when rejected.
  bool SolveFull(int max_iterations, bool with_sigmas, const char* what,
                 ceres::Solver::Summary* s) {
    ceres::Problem problem(ProblemOptions());
    const std::string diverged = SolveAll(&keyframes, &objects, max_iterations, s, &problem);
    if (!diverged.empty()) {
      Warn(keyframes.back()->state.t_ns,
           std::string("divergence in ") + what + " (" + diverged + "): its result was rejected");
      return false;
    }
    summary.final_cost = s->final_cost;
    for (auto& kf : keyframes) output[kf->frame] = kf->state.ToStateSample();
    if (with_sigmas) ComputeSigmas(&problem);
    return true;
  }

  void SolveBatch() {
    const auto t0 = Clock::now();
    ceres::Solver::Summary s;
    if (!SolveFull(options.batch_max_iterations, /*with_sigmas=*/true, "the final batch solve", &s))
      ++summary.divergences;
    summary.batch_solve_ms = MsSince(t0);
  }

  // Window mode's global step: every keyframe and object, then the window's prior re-centred at
  // the result (WindowBoundary::kPrior) so that it does not pull the window back.
  void SolveGlobal(int max_iterations, bool final_solve = false) {
    const auto t0 = Clock::now();
    ceres::Solver::Summary s;
    const bool ok = SolveFull(max_iterations, final_solve,
                              final_solve ? "the final global solve" : "a global solve", &s);
    keyframes_since_global = 0;
    loop_pending = false;
    summary.global_ms.push_back(MsSince(t0));
    summary.global_keyframes.push_back(static_cast<int>(keyframes.size()));
    summary.global_iterations += static_cast<int>(s.iterations.size());
    if (!ok) {
      ++summary.global_rejected;
      return;
    }
    ++summary.global_solves;
    if (prior) prior = Recentered(*prior);
  }

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

  // Copies every keyframe (not a newest frame that is no keyframe: it is dropped later) and object
  // and solves them, on a thread with `background`, else here.
  void StartGlobal() {
    auto j = std::make_unique<GlobalJob>();
    const size_t n = keyframes.size() - (keyframes.back()->keyframe ? 0 : 1);
    for (size_t i = 0; i < n; ++i) {
      auto c = std::make_unique<Keyframe>(*keyframes[i]);
      if (c->preint) c->preint = std::make_shared<ImuPreintegration>(*c->preint);
      j->kfs.push_back(std::move(c));
    }
    for (const auto& [id, obj] : objects) {
      if (obj->anchor->index >= static_cast<int>(n)) continue;  // anchors are keyframes
      auto c = std::make_unique<Object>(*obj);
      c->anchor = j->kfs[static_cast<size_t>(obj->anchor->index)].get();
      c->past.clear();
      j->originals[id] = obj.get();
      j->objs[id] = std::move(c);
    }
    j->apply_at = summary.keyframes + options.global.apply_after_keyframes;
    // The free part: the newest max_free_keyframes, and every keyframe since a closed loop's object
    // was last seen.
    const int max_free = options.global.max_free_keyframes;
    size_t free_from = max_free > 0 && n > static_cast<size_t>(max_free) ? n - max_free : 0;
    free_from = std::min(free_from, static_cast<size_t>(std::max(0, loop_from)));
    j->free_from = free_from;
    keyframes_since_global = 0;
    loop_pending = false;
    loop_from = std::numeric_limits<int>::max();
    GlobalJob* w = j.get();
    auto work = [this, w] {
      const auto t0 = Clock::now();
      ceres::Problem problem(ProblemOptions());
      w->diverged =
          SolveAll(&w->kfs, &w->objs, options.global.max_iterations, &w->s, &problem, w->free_from);
      w->ms = MsSince(t0);
    };
    if (options.global.background)
      j->thread = std::thread(work);
    else
      work();
    job = std::move(j);
  }

  // Applies the global solve in flight (waiting for it): the keyframes it solved take its values,
  // the ones added since move rigidly with the newest of them, objects take its values (expressed
  // at their current anchor when they were re-anchored meanwhile); objects retired meanwhile and
  // objects new since are left as they are (the new ones move with their anchors).
  void ApplyGlobal() {
    if (!job) return;
    const std::unique_ptr<GlobalJob> j = std::move(job);
    if (j->thread.joinable()) j->thread.join();
    summary.global_ms.push_back(j->ms);
    summary.global_keyframes.push_back(static_cast<int>(j->kfs.size()));
    summary.global_iterations += static_cast<int>(j->s.iterations.size());
    if (!j->diverged.empty()) {
      ++summary.global_rejected;
      Warn(keyframes.back()->state.t_ns,
           "divergence in a global solve (" + j->diverged + "): its result was rejected");
      return;
    }
    ++summary.global_solves;
    const size_t n = j->kfs.size();
    const Rigid3 correction =
        j->kfs[n - 1]->state.T_W_B() * keyframes[n - 1]->state.T_W_B().Inverse();
    for (size_t i = 0; i < n; ++i) {
      const KeyframeState& from = j->kfs[i]->state;
      KeyframeState& to = keyframes[i]->state;
      std::copy(from.pose, from.pose + kPoseSize, to.pose);
      std::copy(from.speed_bias, from.speed_bias + kSpeedBiasSize, to.speed_bias);
    }
    for (size_t i = n; i < keyframes.size(); ++i) {
      KeyframeState& st = keyframes[i]->state;
      st.SetT_W_B(correction * st.T_W_B());
      VelocityOf(st.speed_bias) = correction.rotation() * st.v_W();
    }
    for (const auto& [id, c] : j->objs) {
      auto it = objects.find(id);
      if (it == objects.end() || it->second.get() != j->originals.at(id)) continue;
      Object& o = *it->second;
      if (o.anchor->index == c->anchor->index) {
        o.fsp = c->fsp;
        o.fhp = c->fhp;
      } else if (options.landmarks == LandmarkType::kFsp) {
        ReanchorFsp(c->fsp, CameraPose(*c->anchor), CameraPose(*o.anchor), &o.fsp);
      } else {
        ReanchorFhp(c->fhp, CameraPose(*c->anchor), CameraPose(*o.anchor), &o.fhp);
      }
    }
    for (auto& kf : keyframes) output[kf->frame] = kf->state.ToStateSample();
    if (prior) prior = Recentered(*prior);
  }

  // A restart drops the global solve in flight (its states belong to the session that diverged).
  void DiscardGlobal() {
    if (job && job->thread.joinable()) job->thread.join();
    job.reset();
  }

  // --- Map covariance
  // -----------------------------------------------------------------------------
  std::map<const Object*, std::pair<double, double>> sigmas;  // (σ_w, σ_h)

  void ComputeSigmas(ceres::Problem* problem) {
    sigmas.clear();
    const bool fsp = options.landmarks == LandmarkType::kFsp;
    ceres::Covariance::Options co;
    co.algorithm_type = ceres::SPARSE_QR;
    co.num_threads = 1;
    ceres::Covariance covariance(co);
    std::vector<std::pair<const double*, const double*>> blocks;
    std::vector<Object*> in_problem;
    for (auto& [id, obj] : objects) {
      if (!problem->HasParameterBlock(fsp ? obj->fsp.x : obj->fhp.corner[0])) continue;
      in_problem.push_back(obj.get());
      if (fsp) blocks.emplace_back(obj->fsp.x, obj->fsp.x);
      for (int a = 0; !fsp && a < 4; ++a)
        for (int b = a; b < 4; ++b) blocks.emplace_back(obj->fhp.corner[a], obj->fhp.corner[b]);
    }
    if (blocks.empty() || !covariance.Compute(blocks, problem)) return;
    // ceres::Covariance orders its columns by parameter block address, so the last bits of a σ
    // depend on heap layout; 9 significant digits keep the output deterministic and lose nothing.
    const auto round9 = [](double v) {
      if (!(v > 0.0)) return v;
      const double scale = std::pow(10.0, 8 - static_cast<int>(std::floor(std::log10(v))));
      return std::round(v * scale) / scale;
    };
    for (Object* obj : in_problem) {
      const auto [sw, sh] = fsp ? FspSigmas(covariance, obj->fsp) : FhpSigmas(covariance, obj->fhp);
      sigmas[obj] = {round9(sw), round9(sh)};
    }
  }

  static std::pair<double, double> FspSigmas(const ceres::Covariance& covariance,
                                             const FspLandmark& l) {
    double c[25];
    covariance.GetCovarianceBlock(l.x, l.x, c);
    Eigen::Map<Eigen::Matrix<double, 5, 5, Eigen::RowMajor>> C(c);
    // log w = log w̄ − log ω;  log h = log w̄ − log f − log ω;  σ_w = w σ_log w.
    Eigen::Matrix<double, 1, 5> jw = Eigen::Matrix<double, 1, 5>::Zero(), jh = jw;
    jw[kFspLogWbar] = 1.0;
    jw[kFspLogOmega] = -1.0;
    jh = jw;
    jh[kFspLogForm] = -1.0;
    return {l.Width() * std::sqrt(std::max(0.0, (jw * C * jw.transpose())(0))),
            l.Height() * std::sqrt(std::max(0.0, (jh * C * jh.transpose())(0)))};
  }

  // FHP: w and h are functions of the 12 corner parameters (all in the anchor frame, so the anchor
  // pose does not enter): σ² = J C Jᵀ with C the joint 12 x 12 covariance and J by central
  // differences.
  static std::pair<double, double> FhpSigmas(const ceres::Covariance& covariance,
                                             const FhpLandmark& l) {
    Eigen::Matrix<double, 12, 12> C;
    for (int a = 0; a < 4; ++a)
      for (int b = a; b < 4; ++b) {
        double c[9];
        covariance.GetCovarianceBlock(l.corner[a], l.corner[b], c);
        const Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> Cab(c);
        C.block<3, 3>(3 * a, 3 * b) = Cab;
        C.block<3, 3>(3 * b, 3 * a) = Cab.transpose();
      }
    Eigen::Matrix<double, 2, 12> J;
    constexpr double kStep = 1e-6;
    for (int k = 0; k < 12; ++k) {
      FhpLandmark plus = l, minus = l;
      plus.corner[k / 3][k % 3] += kStep;
      minus.corner[k / 3][k % 3] -= kStep;
      J(0, k) = (plus.Width() - minus.Width()) / (2.0 * kStep);
      J(1, k) = (plus.Height() - minus.Height()) / (2.0 * kStep);
    }
    const Eigen::Matrix2d S = J * C * J.transpose();
    return {std::sqrt(std::max(0.0, S(0, 0))), std::sqrt(std::max(0.0, S(1, 1)))};
  }

  void FinishWindow() {
    if (keyframes.empty()) return;
    ApplyGlobal();
    SolveWindow(options.window_max_iterations * 3, /*finish=*/!options.global.enabled);
    if (options.global.enabled) SolveGlobal(options.global.final_iterations, /*final_solve=*/true);
  }
};

Estimator::Estimator(const Calibration& calibration, const EstimatorOptions& options)
    : impl_(std::make_unique<Impl>(calibration, options)) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("estimator options: " + why);
}

Estimator::~Estimator() = default;

void Estimator::AddImu(const ImuSample& sample) {
  if (!impl_->imu.empty() && sample.t_ns <= impl_->imu.back().t_ns) {
    throw InputError("IMU sample at t_ns " + std::to_string(sample.t_ns) +
                     " is not after the previous one");
  }
  impl_->imu.push_back(sample);
}

bool Estimator::AddFrame(int64_t t_ns, const std::vector<ObjectObservation>& observations) {
  Impl& d = *impl_;
  ++d.summary.frames;
  d.NoteFrame(t_ns, !observations.empty());
  if (!d.summary.initialized) {
    if (!d.summary.init_failure.empty()) return false;
    d.pending.emplace_back(t_ns, observations);
    return d.TryInitialize();
  }
  d.AddKeyframe(t_ns, observations, nullptr);
  return true;
}

void Estimator::Finish() {
  Impl& d = *impl_;
  if (d.finished) return;
  d.finished = true;
  if (!d.summary.initialized && d.summary.init_failure.empty() && !d.pending.empty()) {
    d.summary.init_failure = "the sequence ended before the static initialisation interval (" +
                             std::to_string(d.options.static_init.window_s) +
                             " s of IMU after the first frame)";
  }
  if (d.last_frame_t) d.NoteFrame(*d.last_frame_t, true, /*end=*/true);
  if (!d.summary.initialized) return;
  if (d.options.mode == EstimatorMode::kBatch) {
    d.SolveBatch();
  } else {
    d.FinishWindow();
  }
}

std::vector<StateSample> Estimator::States() const {
  return impl_->Reported();
}

std::vector<StampedPose> Estimator::CausalTrajectory() const {
  std::vector<StampedPose> poses;
  poses.reserve(impl_->causal.size());
  for (const StateSample& s : impl_->causal) poses.push_back({s.t_ns, s.T_W_B});
  return poses;
}

std::vector<StampedPose> Estimator::Trajectory() const {
  std::vector<StampedPose> poses;
  poses.reserve(impl_->output.size());
  for (const StateSample& s : impl_->Reported()) poses.push_back({s.t_ns, s.T_W_B});
  return poses;
}

std::optional<StateSample> Estimator::Latest() const {
  const Impl& d = *impl_;
  if (d.output.empty()) return std::nullopt;
  const int last = static_cast<int>(d.output.size()) - 1;
  if (!d.dropped.empty() && d.dropped.back().frame == last) return d.Resolve(d.dropped.back());
  return d.output[last];
}

std::vector<MapObject> Estimator::Map() const {
  const Impl& d = *impl_;
  // Per id the current instance, or a retired one (window re-initialisation) seen more often.
  std::map<int, const Object*> best;
  for (const auto* instances : {&d.objects, &d.retired})
    for (const auto& [id, obj] : *instances) {
      const Object*& b = best[id];
      if (!b || b->observations < obj->observations) b = obj.get();
    }
  std::vector<MapObject> map;
  for (const auto& [id, obj] : best) {
    if (obj->observations < d.options.min_observations || d.AtDepthBound(*obj)) continue;
    MapObject m;
    m.id = id;
    m.object_class = obj->object_class;
    m.observations = obj->observations;
    const Rigid3 T_W_F = d.CameraPose(*obj->anchor);
    m.corners_W = d.options.landmarks == LandmarkType::kFsp ? obj->fsp.CornersW(T_W_F)
                                                            : obj->fhp.CornersW(T_W_F);
    std::tie(m.width, m.height) = d.ObjectSize(*obj);
    m.T_W_O = d.ObjectPose(*obj);
    auto it = d.sigmas.find(obj);
    m.width_sigma = it == d.sigmas.end() ? -1.0 : it->second.first;
    m.height_sigma = it == d.sigmas.end() ? -1.0 : it->second.second;
    map.push_back(m);
  }
  return map;
}

const EstimatorSummary& Estimator::summary() const {
  return impl_->summary;
}

}  // namespace fsp::backend
