// The window's global step and loop closure (backend/README.md, "Global step and loops"): the
// global solve on copies, applied at a fixed keyframe, and the loop of a returning object.
#include "estimator_impl.h"

namespace fsp::backend {

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
bool Estimator::Impl::CloseLoop(Object* obj, Keyframe* kf, const Corners& corners) {
  const GlobalOptions& g = options.global;
  std::optional<double> error = PredictionError(*obj, CameraPose(*kf), corners);
  if (error && *error <= g.loop_direct_px) return AcceptLoop(*obj);
  // The pre-alignment needs the newest map: a global solve in flight is applied first.
  if (job) {
    ApplyGlobal();
    error = PredictionError(*obj, CameraPose(*kf), corners);
    if (error && *error <= g.loop_direct_px) return AcceptLoop(*obj);
  }
  if (PreAlign(obj, kf, corners, error)) {
    ++summary.loops_prealigned;
    return AcceptLoop(*obj);
  }
  // Closing a loop of more than a few pixels as it is was measured to be unsafe: small tags
  // accepted at 10 px pulled the default room's global solve into a wrong minimum (ATE 1.6 m).
  ++summary.loops_rejected;
  return false;
}

// A loop closed: the next global solve frees the keyframes since the object was last seen.
bool Estimator::Impl::AcceptLoop(const Object& obj) {
  ++summary.loops_closed;
  loop_pending = true;
  loop_from = std::min(loop_from, std::max(0, obj.last_seen));
  return true;
}

// The pre-alignment of CloseLoop; false (states unchanged) when it is implausible or leaves the
// corners further than loop_accept_px from their prediction.
bool Estimator::Impl::PreAlign(Object* obj, Keyframe* kf, const Corners& corners,
                               std::optional<double> error_before) {
  const GlobalOptions& g = options.global;
  // The camera pose in the map's frame from this view of the object.
  const SingleViewInitSummary sv = InitializeFspSingleView(
      corners, K, obj->object_class, options.init, UpDirection(obj->object_class, CameraPose(*kf)));
  if (!sv.success()) return false;
  FspLandmark view = sv.landmark;
  const auto [w_map, h_map] = obj->landmark.Size();
  view.x[kFspLogOmega] += 0.5 * (std::log(view.Width() / w_map) + std::log(view.Height() / h_map));
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
    travelled[i - from] = travelled[i - from - 1] + (keyframes[i]->state.T_W_B().translation() -
                                                     keyframes[i - 1]->state.T_W_B().translation())
                                                        .norm();
  const double distance = travelled.back();
  double blind_s = 0.0;  // dead reckoning: keyframes with no object in view
  for (size_t i = from + 1; i < keyframes.size(); ++i) {
    if (keyframes[i - 1]->observations.empty())
      blind_s += NsToSeconds(keyframes[i]->state.t_ns - keyframes[i - 1]->state.t_ns);
  }
  if (shift.norm() >
          g.budget_m + g.budget_per_m * distance + 0.5 * g.budget_blind_acc * blind_s * blind_s ||
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
    o->landmark.Reanchor(T_W_F_before, CameraPose(*o->anchor));
  }
  const std::optional<double> e1 = PredictionError(*obj, CameraPose(*kf), corners);
  if (!e1 || *e1 > g.loop_accept_px || (error_before && *e1 >= *error_before)) {
    Restore(before);
    return false;
  }
  for (size_t i = from + 1; i < keyframes.size(); ++i)
    output[keyframes[i]->frame] = keyframes[i]->state.ToStateSample();
  if (prior) prior = Recentered(*prior);
  return true;
}

// Copies every keyframe (not a newest frame that is no keyframe: it is dropped later) and object
// and solves them, on a thread with `background`, else here.
void Estimator::Impl::StartGlobal() {
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
  const GlobalOptions& go = options.global;
  j->apply_at =
      summary.keyframes + go.apply_after_keyframes +
      (go.apply_after_per_keyframes > 0 ? static_cast<int>(n) / go.apply_after_per_keyframes : 0);
  // The free part: the newest max_free_keyframes, and every keyframe since a closed loop's object
  // was last seen, within the current session.
  const int max_free = options.global.max_free_keyframes;
  size_t free_from = max_free > 0 && n > static_cast<size_t>(max_free) ? n - max_free : 0;
  free_from = std::min(free_from, static_cast<size_t>(std::max(0, loop_from)));
  free_from = std::max(free_from, session_begin);
  j->free_from = free_from;
  keyframes_since_global = 0;
  loop_pending = false;
  loop_from = std::numeric_limits<int>::max();
  GlobalJob* w = j.get();
  auto work = [this, w] {
    const auto t0 = Clock::now();
    ceres::Problem problem(ProblemOptions());
    ceres::Solver::Options solver = SolverOptions(options.global.max_iterations, /*whole=*/true);
    solver.function_tolerance = options.global.function_tolerance;
    w->diverged = SolveAll(&w->kfs, &w->objs, solver, &w->s, &problem, w->free_from);
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
void Estimator::Impl::ApplyGlobal() {
  if (!job) return;
  const std::unique_ptr<GlobalJob> j = std::move(job);
  if (j->thread.joinable()) j->thread.join();
  CountGlobal(j->ms, j->kfs.size(), j->s, j->diverged.empty());
  if (!j->diverged.empty()) {
    Warn(keyframes.back()->state.t_ns,
         "divergence in a global solve (" + j->diverged + "): its result was rejected");
    ++global_rejected_in_row;
    global_rejected_why = "two global solves in a row: " + j->diverged;
    return;
  }
  global_rejected_in_row = 0;
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
    // Expressed at its current anchor (unchanged when that fails, as a re-anchoring does).
    Landmark solved = c->landmark;
    if (o.anchor->index == c->anchor->index ||
        solved.Reanchor(CameraPose(*c->anchor), CameraPose(*o.anchor)))
      o.landmark = solved;
  }
  for (auto& kf : keyframes) output[kf->frame] = kf->state.ToStateSample();
  if (prior) prior = Recentered(*prior);
}

// A restart drops the global solve in flight (its states belong to the session that diverged).
void Estimator::Impl::DiscardGlobal() {
  if (job && job->thread.joinable()) job->thread.join();
  job.reset();
}

}  // namespace fsp::backend
