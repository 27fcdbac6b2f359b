#include "fsp/backend/estimator.h"

#include "estimator_impl.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <iterator>
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
#include "fsp/backend/zero_velocity.h"
#include "fsp/common/error.h"
#include "fsp/common/time.h"

namespace fsp::backend {
namespace {

// Global solves rejected in a row before the estimator restarts (AddFrame). One may be a passing
// disagreement (a loop's object far from where the window has it); two in a row, a global step
// apart, are a session the history cannot follow.
constexpr int kGlobalRejectionsToRestart = 2;

}  // namespace

bool FaultOptions::Check(std::string* why) const {
  const bool ok = max_imu_gap_s > 0.0 && gap_max_acc > 0.0 && gap_max_rate > 0.0 &&
                  frame_gap_s > 0.0 && blind_s > 0.0 && max_speed > 0.0 && max_gyro_bias > 0.0 &&
                  max_acc_bias > 0.0 && max_jump_m > 0.0 && max_view_error_px > 0.0 &&
                  restart_velocity_sigma > 0.0 && restart_roll_pitch_sigma > 0.0;
  if (why) *why = ok ? "" : "every fault threshold and sigma must be > 0";
  return ok;
}

bool GlobalOptions::Check(std::string* why) const {
  const bool ok = every_keyframes >= 1 && max_iterations >= 1 && final_iterations >= 1 &&
                  function_tolerance > 0.0 && function_tolerance <= 1.0 &&
                  apply_after_keyframes >= 0 && apply_after_per_keyframes >= 0 &&
                  max_free_keyframes >= 0 && loop_direct_px >= 0.0 &&
                  loop_accept_px >= loop_direct_px && budget_m >= 0.0 && budget_per_m >= 0.0 &&
                  budget_blind_acc >= 0.0 && budget_yaw_deg >= 0.0 && budget_yaw_per_m >= 0.0;
  if (why)
    *why = ok ? ""
              : "every_keyframes and the iterations must be >= 1; 0 < function_tolerance <= 1; "
                "apply_after_keyframes, apply_after_per_keyframes, "
                "max_free_keyframes and the budgets >= 0; 0 <= loop_direct_px <= loop_accept_px";
  return ok;
}

bool ZeroVelocityOptions::Check(std::string* why) const {
  const bool ok = confidence > 0.5 && confidence < 1.0 && imu_confidence > 0.5 &&
                  imu_confidence < 1.0 && velocity_sigma > 0.0 && turn_rate_sigma > 0.0 &&
                  min_points >= 0;
  if (why)
    *why = ok ? ""
              : "velocity_sigma and turn_rate_sigma must be > 0, confidence and imu_confidence in "
                "(0.5, 1), min_points >= 0";
  return ok;
}

bool EstimatorOptions::Check(std::string* why) const {
  std::ostringstream os;
  std::string sub;
  if (window_size < 2)
    os << "window_size must be >= 2 (got " << window_size << ")";
  else if (window_max_iterations < 1 || batch_max_iterations < 1)
    os << "iterations must be >= 1";
  else if (keyframe_min_frames < 0)
    os << "keyframe_min_frames must be >= 0 (got " << keyframe_min_frames << ")";
  else if (!factor.Check(&sub))
    os << "factor: " << sub;
  else if (!robust.Check(&sub))
    os << "robust: " << sub;
  else if (!imu.Check(&sub))
    os << "imu: " << sub;
  else if (!init.Check(&sub))
    os << "init: " << sub;
  else if (!motion_init.Check(&sub))
    os << "motion_init: " << sub;
  else if (!point_init.Check(&sub))
    os << "point_init: " << sub;
  else if (!(motion_init_velocity_sigma > 0.0))
    os << "motion_init_velocity_sigma must be > 0";
  else if (!static_init.Check(&sub))
    os << "static_init: " << sub;
  else if (!(prior_gyro_bias_sigma > 0.0) || !(prior_acc_bias_sigma > 0.0) ||
           !(prior_log_omega_sigma > 0.0))
    os << "prior sigmas must be > 0";
  else if (min_observations < 1)
    os << "min_observations must be >= 1";
  else if (!(max_size_sigma_frac >= 0.0))
    os << "max_size_sigma_frac must be >= 0";
  else if (!(warn_variance_factor > 0.0) || !(warn_scale_sigma > 0.0))
    os << "warn_variance_factor and warn_scale_sigma must be > 0";
  else if (mature_views < 1)
    os << "mature_views must be >= 1";
  else if (max_past_views < 0 || batch_solve_every < 1)
    os << "max_past_views must be >= 0, batch_solve_every >= 1";
  else if (!(min_depth_m > 0.0) || !(max_depth_m > min_depth_m))
    os << "need 0 < min_depth_m < max_depth_m";
  else if (!(reinit_gate_px >= 0.0))
    os << "reinit_gate_px must be >= 0";
  else if (!(start_agree_px >= 0.0))
    os << "start_agree_px must be >= 0";
  else if (!(start_agree_gap_s >= 0.0))
    os << "start_agree_gap_s must be >= 0";
  else if (!faults.Check(&sub))
    os << "faults: " << sub;
  else if (!global.Check(&sub))
    os << "global: " << sub;
  else if (!zero_velocity.Check(&sub))
    os << "zero_velocity: " << sub;
  else if (!points.Check(&sub))
    os << "points: " << sub;
  if (why) *why = os.str();
  return os.str().empty();
}

void Estimator::Impl::NoteFrame(int64_t t_ns, bool sees_objects, bool end) {
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
    // Live points in the window hold the trajectory without objects; without them it is the IMU
    // alone.
    const bool points_live = std::any_of(point_tracks.begin(), point_tracks.end(),
                                         [](const auto& p) { return p.second.live; });
    std::snprintf(what, sizeof(what), "no object in view for %.2f s (since t=%.2f s): %s%s", blind,
                  NsToSeconds(*last_seen_t),
                  points_live ? "held by the points and the IMU" : "IMU dead reckoning",
                  end ? " to the end" : "");
    Warn(t_ns, what);
  }
  last_seen_t = t_ns;
}

void Estimator::Impl::NoteSight(int64_t t_ns, bool sees, bool end) {
  // A static start holds still until the points have parallax: not dead reckoning.
  if (!sees && !end) {
    if (!unseen_since_t && (seen_once || summary.init_method != "static")) unseen_since_t = t_ns;
    return;
  }
  seen_once = true;
  if (!unseen_since_t) return;
  const double s = NsToSeconds(t_ns - *unseen_since_t);
  if (s >= options.faults.blind_s) {
    ++summary.dead_reckoning_stretches;
    summary.dead_reckoning_max_s = std::max(summary.dead_reckoning_max_s, s);
    char what[200];
    std::snprintf(
        what, sizeof(what),
        "nothing tracked for %.2f s (since t=%.2f s: no object, no point with a depth)%s: "
        "IMU dead reckoning, whose position error grows with the square of the time",
        s, NsToSeconds(*unseen_since_t), end ? " to the end" : "");
    Warn(t_ns, what);
  }
  unseen_since_t.reset();
}

std::pair<int64_t, int64_t> Estimator::Impl::LongestImuHole(int64_t t0, int64_t t1) const {
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

bool Estimator::Impl::Still(const Keyframe& prev, const Keyframe& kf) const {
  const ZeroVelocityOptions& z = options.zero_velocity;
  if (!z.enabled) return false;
  // The IMU agrees: no mean turn, the specific force of rest (zero_velocity.h).
  const double dt = NsToSeconds(kf.state.t_ns - prev.state.t_ns);
  const Vec3 rest_force =
      prev.state.T_W_B().rotation().conjugate() * Vec3(0.0, 0.0, options.imu.gravity) +
      prev.state.acc_bias();
  if (!TestImuStill(ImuBetween(prev.state.t_ns, kf.state.t_ns), prev.state.gyro_bias(), rest_force,
                    z.turn_rate_sigma, z.velocity_sigma / dt, z.imu_confidence)
           .still)
    return false;
  // The objects both keyframes see did not move beyond their corner noise (zero_velocity.h).
  std::vector<std::pair<Corners, Corners>> pairs;
  for (const ObjectObservation& o : kf.observations)
    for (const ObjectObservation& p : still_reference)
      if (p.object_id == o.object_id && p.Complete() && o.Complete())
        pairs.emplace_back(p.corners, o.corners);
  if (!pairs.empty() || z.min_points == 0 || kf.points.empty())
    return TestCornerMotion(pairs, options.factor.sigma_px, z.confidence).still;
  // No object in both: the points both see (each displacement in its own noise).
  std::map<int64_t, const PointObservation*> before;
  for (const PointObservation& p : still_point_reference) before[p.point_id] = &p;
  std::vector<Vec2> displacements;
  for (const PointObservation& p : kf.points) {
    const auto it = before.find(p.point_id);
    if (it != before.end())
      displacements.push_back((p.uv_undistorted - it->second->uv_undistorted) /
                              PointSigmaPx(p.sigma_scale));
  }
  return TestPointMotion(displacements, z.min_points, z.confidence).still;
}

void Estimator::Impl::Restart(const std::string& why) {
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
  Warn(kf->state.t_ns, "divergence (" + why +
                           "): solve rejected, estimator restarted (new session from this frame)");
  if (options.mode == EstimatorMode::kBatch) return;
  window_begin = static_cast<size_t>(kf->index);
  session_begin = window_begin;
  prior.reset();
  ClearPoints();
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

void Estimator::Impl::SolveGlobalFinal() {
  const auto t0 = Clock::now();
  ceres::Solver::Summary s;
  const bool ok = SolveFull(options.global.final_iterations, /*with_sigmas=*/true,
                            "the final global solve", &s);
  CountGlobal(MsSince(t0), keyframes.size(), s, ok);
}

void Estimator::Impl::RepredictDropped() {
  for (Dropped& d : dropped) {
    const Keyframe& ref = *d.ref;
    const int64_t t_ns = output[d.frame].t_ns;
    const std::pair<int64_t, int64_t> hole = LongestImuHole(ref.state.t_ns, t_ns);
    if (NsToSeconds(hole.second - hole.first) > options.faults.max_imu_gap_s) continue;
    const ImuPreintegration preint(options.imu, ImuBetween(ref.state.t_ns, t_ns), ref.state.t_ns,
                                   t_ns, ref.state.gyro_bias(), ref.state.acc_bias());
    Rigid3 T_W_B;
    Vec3 v_W;
    preint.Predict(ref.state.T_W_B(), ref.state.v_W(), ref.state.gyro_bias(), ref.state.acc_bias(),
                   &T_W_B, &v_W);
    const Rigid3 T_W_ref = ref.state.T_W_B();
    d.T_ref_B = T_W_ref.Inverse() * T_W_B;
    d.v_ref = T_W_ref.rotation().conjugate() * v_W;
  }
}

void Estimator::Impl::CountGlobal(double ms, size_t keyframes_solved,
                                  const ceres::Solver::Summary& s, bool accepted) {
  summary.global_ms.push_back(ms);
  summary.global_keyframes.push_back(static_cast<int>(keyframes_solved));
  summary.global_iterations += static_cast<int>(s.iterations.size());
  ++(accepted ? summary.global_solves : summary.global_rejected);
}

void Estimator::Impl::DropNewest() {
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
    if (!o.Complete()) --summary.observations_partial;
  }
  for (auto it = start_views.begin(); it != start_views.end();)
    it = it->second.kf == &kf ? start_views.erase(it) : std::next(it);
  keyframes.pop_back();
}

void Estimator::Impl::AddKeyframe(int64_t t_ns, std::vector<ObjectObservation> obs,
                                  const KeyframeState* initial, const std::optional<Gauge>& gauge,
                                  std::vector<PointObservation> points) {
  const auto t_start = Clock::now();
  if (!keyframes.empty() && !keyframes.back()->keyframe) DropNewest();
  auto kf = std::make_unique<Keyframe>();
  kf->index = static_cast<int>(keyframes.size());
  kf->frame = static_cast<int>(output.size());
  kf->keyframe = initial != nullptr || IsKeyframe(t_ns, kf->frame, obs);
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
      std::snprintf(what, sizeof(what),
                    "IMU gap: no IMU sample since t=%.2f s; bridged by a constant-velocity motion "
                    "prior until the IMU returns",
                    NsToSeconds(hole.first));
      Warn(t_ns, what);
    }
    summary.imu_gap_max_s = std::max(summary.imu_gap_max_s, hole_s);
    ++summary.imu_gap_links;
    kf->imu_gap_s = NsToSeconds(t_ns - prev.state.t_ns);
    const Rigid3 T_W_Bi = prev.state.T_W_B();
    std::copy(prev.state.speed_bias, prev.state.speed_bias + kSpeedBiasSize, kf->state.speed_bias);
    kf->state.SetT_W_B(
        Rigid3(T_W_Bi.rotation(), T_W_Bi.translation() + kf->imu_gap_s * prev.state.v_W()));
  } else {
    const Keyframe& prev = *prev_kf;
    kf->preint = std::make_shared<ImuPreintegration>(options.imu, ImuBetween(prev.state.t_ns, t_ns),
                                                     prev.state.t_ns, t_ns, prev.state.gyro_bias(),
                                                     prev.state.acc_bias());
    Rigid3 T_W_Bj;
    Vec3 v_j;
    kf->preint->Predict(prev.state.T_W_B(), prev.state.v_W(), prev.state.gyro_bias(),
                        prev.state.acc_bias(), &T_W_Bj, &v_j);
    kf->state.SetT_W_B(T_W_Bj);
    std::copy(prev.state.speed_bias, prev.state.speed_bias + kSpeedBiasSize, kf->state.speed_bias);
    VelocityOf(kf->state.speed_bias) = v_j;
  }
  kf->state.t_ns = t_ns;
  kf->observations = std::move(obs);
  if (UsePoints()) kf->points = std::move(points);
  if (kf->preint && prev_kf && Still(*prev_kf, *kf)) {
    kf->still = true;
    if (kf->keyframe) {
      ++summary.zero_velocity_keyframes;
      std::vector<std::pair<double, double>>& z = summary.zero_velocity_stretches;
      const double from = NsToSeconds(prev_kf->state.t_ns), to = NsToSeconds(t_ns);
      if (!z.empty() && z.back().second == from)
        z.back().second = to;
      else
        z.emplace_back(from, to);
    }
  }
  if (kf->keyframe && !kf->still) {
    still_reference = kf->observations;
    still_point_reference = kf->points;
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
      if (!o.Complete()) ++summary.observations_partial;
    }
  }
  if (options.mode == EstimatorMode::kWindow) {
    if (options.global.enabled) {
      if (keyframes.back()->keyframe) ++keyframes_since_global;
      if (!job && GlobalHasObjects() &&
          (loop_pending || keyframes_since_global >= options.global.every_keyframes))
        StartGlobal();
      if (job && summary.keyframes >= job->apply_at) ApplyGlobal();
      // Global solves that diverge again and again (the whole history cannot be made consistent
      // with the window's states, e.g. after a corrupted IMU burst the window absorbed): the
      // session is broken, as when the window's own solve diverges.
      if (global_rejected_in_row >= kGlobalRejectionsToRestart) {
        global_rejected_in_row = 0;
        ++summary.divergences;
        Restart(global_rejected_why);
      }
    }
    Keyframe* newest = keyframes.back().get();
    if (newest->keyframe && !newest->points.empty()) AddPointViews(newest);
    // (Held still, the zero-velocity prior holds it: no dead reckoning.)
    if (newest->keyframe && UsePoints())
      NoteSight(newest->state.t_ns,
                !newest->observations.empty() || newest->sees_points || newest->still);
    SolveWindow(options.window_max_iterations);
    const auto in_window = [this] {
      return static_cast<int>(keyframes.size() - window_begin) -
             (keyframes.back()->keyframe ? 0 : 1);
    };
    while (in_window() > options.window_size) MarginalizeOldest();
  } else if (keyframes.back()->keyframe && summary.keyframes % options.batch_solve_every == 0) {
    // Batch: the whole problem so far (window_begin stays 0), re-solved every few frames so the
    // initial values of the final solve stay close to the optimum. Each solve must converge: with
    // a few iterations per solve (like the window's) the error left behind grew with every solve
    // and the default scene diverged after ~20 s (ATE 39 m); solved to convergence (7-19
    // iterations each) ATE 0.42 cm. Frames that are no keyframe are predicted by the IMU and not
    // solved (they are dropped when the next frame comes).
    SolveWindow(options.batch_max_iterations);
  }
  PruneImu();
  causal.push_back(output[keyframes.back()->frame]);
  summary.backend_ms.push_back(MsSince(t_start));
}

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

bool Estimator::AddFrame(int64_t t_ns, const std::vector<ObjectObservation>& given,
                         const std::vector<PointObservation>& points) {
  Impl& d = *impl_;
  // An observation without a corner seen says nothing.
  std::vector<ObjectObservation> observations;
  std::copy_if(given.begin(), given.end(), std::back_inserter(observations),
               [](const ObjectObservation& o) { return CountSeen(o.seen) > 0; });
  ++d.summary.frames;
  if (d.UsePoints() && !points.empty()) ++d.summary.point_frames;
  d.NoteFrame(t_ns, !observations.empty());
  if (!d.summary.initialized) {
    if (!d.summary.init_failure.empty()) return false;
    // The initialisation works from whole objects.
    std::vector<ObjectObservation> whole;
    std::copy_if(observations.begin(), observations.end(), std::back_inserter(whole),
                 [](const ObjectObservation& o) { return o.Complete(); });
    d.pending.emplace_back(t_ns, std::move(whole));
    if (!points.empty() && (d.UsePoints() || d.options.point_init.enabled))
      d.pending_points[t_ns] = points;
    return d.TryInitialize();
  }
  d.AddKeyframe(t_ns, observations, nullptr, std::nullopt,
                d.UsePoints() ? points : std::vector<PointObservation>{});
  return true;
}

void Estimator::Finish() {
  Impl& d = *impl_;
  if (d.finished) return;
  d.finished = true;
  if (!d.summary.initialized && d.summary.init_failure.empty() && !d.pending.empty()) {
    char why[160];
    std::snprintf(why, sizeof(why),
                  "the sequence ended before the static initialisation interval (%g s of IMU "
                  "after the first frame)",
                  d.options.static_init.window_s);
    d.summary.init_failure = d.summary.init_last_refusal.empty()
                                 ? std::string(why)
                                 : "the sequence ended before the initialisation succeeded; the "
                                   "last attempt: " +
                                       d.summary.init_last_refusal;
  }
  if (d.last_frame_t) {
    d.NoteFrame(*d.last_frame_t, true, /*end=*/true);
    d.NoteSight(*d.last_frame_t, false, /*end=*/true);
  }
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
    m.corners_W = obj->landmark.CornersW(T_W_F);
    std::tie(m.width, m.height) = obj->landmark.Size();
    m.T_W_O = d.ObjectPose(*obj);
    auto it = d.sigmas.find(obj);
    m.width_sigma = it == d.sigmas.end() ? -1.0 : it->second.first;
    m.height_sigma = it == d.sigmas.end() ? -1.0 : it->second.second;
    const double frac = d.options.max_size_sigma_frac;
    if (frac > 0.0 && (m.width_sigma > frac * m.width || m.height_sigma > frac * m.height))
      continue;
    map.push_back(m);
  }
  return map;
}

const EstimatorSummary& Estimator::summary() const {
  return impl_->summary;
}

}  // namespace fsp::backend
