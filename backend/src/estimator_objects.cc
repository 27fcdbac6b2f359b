// Objects entering the map (backend/README.md, "Starting an object" and "Objects partly in view"):
// which frames become keyframes for them, the two agreeing whole views that start an object, and
// the partial views of returning objects; and the objects the points disagree with ("Objects on
// probation").
#include "estimator_impl.h"

#include <map>
#include <vector>

#include "fsp/common/median.h"

namespace fsp::backend {

bool Estimator::Impl::IsKeyframe(int64_t t_ns, int frame,
                                 const std::vector<ObjectObservation>& obs) const {
  const bool batch = options.mode == EstimatorMode::kBatch;
  const double interval = batch ? options.batch_keyframe_interval_s : options.keyframe_interval_s;
  if (interval <= 0.0) return true;
  const Keyframe& last = *keyframes.back();  // a keyframe: a non-keyframe newest was just dropped
  const int min_frames = batch ? 1 : std::max(1, options.keyframe_min_frames);
  if (static_cast<double>(t_ns - last.state.t_ns) >= interval * 1e9 - 1e6 &&
      frame - last.frame >= min_frames)
    return true;
  const int first_in_window = keyframes[window_begin]->index;
  for (const ObjectObservation& o : obs) {
    if (moving.count(o.object_id)) continue;
    auto it = objects.find(o.object_id);
    if (o.Complete() && it == objects.end() && !WaitingStart(o.object_id)) return true;
    if (o.Complete() && it != objects.end() && it->second->last_seen < first_in_window) return true;
  }
  return false;
}

const StartView* Estimator::Impl::WaitingStart(int object_id) const {
  const auto it = start_views.find(object_id);
  if (it == start_views.end() || it->second.kf->index < keyframes[window_begin]->index)
    return nullptr;
  return &it->second;
}

void Estimator::Impl::InitializeNewObjects(Keyframe* kf) {
  const Rigid3 T_W_C = CameraPose(*kf);
  const int first_in_window = keyframes[window_begin]->index;
  std::vector<int> waiting;  // partial views of returning objects that do not close their loop
  for (const ObjectObservation& o : kf->observations) {
    if (moving.count(o.object_id)) continue;
    auto found = objects.find(o.object_id);
    const bool returning = found != objects.end() && options.mode == EstimatorMode::kWindow &&
                           found->second->last_seen < first_in_window;
    if (!o.Complete()) {
      // An object partly in view starts from nothing (its views count once a whole view starts
      // it), and closes a loop only where it is predicted (no pre-alignment from a part).
      if (returning && !ClosesDirectly(*found->second, T_W_C, o)) waiting.push_back(o.object_id);
      continue;
    }
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
    // The object starts at its first view once a second one agrees with it.
    Keyframe* anchor = kf;
    Corners first_corners = o.corners;
    if (options.start_agree_px > 0.0) {
      const StartView* first = WaitingStart(o.object_id);
      if (!first) {
        start_views[o.object_id] = {kf, o};
        continue;
      }
      if (kf->state.t_ns - first->kf->state.t_ns < options.start_agree_gap_s * 1e9 - 1e6) continue;
      if (!ViewsAgree(*first, *kf, o)) {
        ++summary.starts_rejected;
        start_views[o.object_id] = {kf, o};
        continue;
      }
      anchor = first->kf;
      first_corners = first->observation.corners;
      start_views.erase(o.object_id);
    }
    const SingleViewInitSummary s =
        InitializeFspSingleView(first_corners, K, o.object_class, options.init,
                                UpDirection(o.object_class, CameraPose(*anchor)));
    if (!s.success()) {
      ++summary.observations_rejected;
      continue;
    }
    auto obj = std::make_unique<Object>();
    obj->id = o.object_id;
    obj->object_class = o.object_class;
    obj->anchor = anchor;
    // Views of it partly in view from earlier window keyframes count from now on.
    obj->first_seen = anchor->index;
    for (size_t i = window_begin; i < keyframes.size() && keyframes[i].get() != anchor; ++i) {
      const std::vector<ObjectObservation>& seen = keyframes[i]->observations;
      if (std::any_of(seen.begin(), seen.end(), [&](const ObjectObservation& p) {
            return p.object_id == o.object_id && !p.Complete();
          })) {
        obj->first_seen = keyframes[i]->index;
        break;
      }
    }
    // The views of earlier keyframes that become factors count as observations (kf, the newest,
    // is counted by the caller).
    for (size_t i = window_begin; i + 1 < keyframes.size(); ++i) {
      if (keyframes[i]->index < obj->first_seen) continue;
      for (const ObjectObservation& p : keyframes[i]->observations) {
        if (p.object_id != o.object_id) continue;
        ++obj->observations;
        obj->last_seen = keyframes[i]->index;
        ++summary.observations_used;
        if (!p.Complete()) ++summary.observations_partial;
      }
    }
    obj->landmark = Landmark::FromSingleView(options.landmarks, s.landmark);
    obj->width_prior_m = s.landmark.Width();
    objects[o.object_id] = std::move(obj);
  }
  std::vector<ObjectObservation>& obs = kf->observations;
  const auto end = std::remove_if(obs.begin(), obs.end(), [&](const ObjectObservation& o) {
    return !o.Complete() && std::count(waiting.begin(), waiting.end(), o.object_id) > 0;
  });
  summary.partial_dropped += static_cast<int>(obs.end() - end);
  obs.erase(end, obs.end());
}

bool Estimator::Impl::ViewsAgree(const StartView& first, const Keyframe& kf,
                                 const ObjectObservation& o) const {
  const ObjectObservation& a = first.observation;
  const SingleViewInitSummary s =
      InitializeFspSingleView(a.corners, K, o.object_class, options.init,
                              UpDirection(o.object_class, CameraPose(*first.kf)));
  if (!s.success()) return false;
  const std::array<Vec3, 4> p_A = s.landmark.CornersF();
  const Rigid3 T_B_A = CameraPose(kf).Inverse() * CameraPose(*first.kf);
  // RMS corner distance with the first view's rectangle scaled by exp(log_scale) about camera A.
  const auto rms = [&](double log_scale) {
    const double scale = std::exp(log_scale);
    double sum2 = 0.0;
    for (int j = 0; j < 4; ++j) {
      const Vec3 p = K * (T_B_A * (scale * p_A[j]));
      if (!(p.z() > 1e-6)) return std::numeric_limits<double>::infinity();
      sum2 += (p.head<2>() / p.z() - o.corners[j]).squaredNorm();
    }
    return std::sqrt(sum2 / 4.0);
  };
  // Scales 1/8..8 of the single view's (a class prior's) size: a grid, then golden sections
  // between the best grid point's neighbours.
  constexpr int kSteps = 48;
  const double lo = -std::log(8.0), step = 2.0 * std::log(8.0) / kSteps;
  int best = 0;
  double best_rms = rms(lo);
  for (int i = 1; i <= kSteps; ++i) {
    const double r = rms(lo + i * step);
    if (r < best_rms) {
      best = i;
      best_rms = r;
    }
  }
  double x0 = lo + (best - 1) * step, x1 = lo + (best + 1) * step;
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 30; ++it) {
    const double c = x1 - golden * (x1 - x0), d = x0 + golden * (x1 - x0);
    if (rms(c) < rms(d))
      x1 = d;
    else
      x0 = c;
  }
  return std::min(best_rms, rms(0.5 * (x0 + x1))) <= options.start_agree_px;
}

bool Estimator::Impl::ClosesDirectly(const Object& obj, const Rigid3& T_W_C,
                                     const ObjectObservation& o) {
  const std::optional<double> e = PredictionError(obj, T_W_C, o.corners, o.seen);
  if (!options.global.enabled) return e && *e <= options.reinit_gate_px;
  return e && *e <= options.global.loop_direct_px && AcceptLoop(obj);
}

void Estimator::Impl::RefineYoungObjects(int max_iterations) {
  ceres::Problem problem(ProblemOptions());
  AddVisualFactors(&problem, window_begin, keyframes.size(), /*mature=*/false);
  if (problem.NumResidualBlocks() == 0) return;
  AddObjectPriors(&problem);
  ceres::Solver::Summary s;
  ceres::Solve(SolverOptions(max_iterations), &problem, &s);
}

void Estimator::Impl::DropInconsistentObjects() {
  constexpr size_t kMinViews = 3, kMinMatureViews = 5;
  // Each object's views in the window: their distances from it [px], and in their σ.
  std::map<const Object*, std::vector<double>> errors, normalized;
  for (size_t i = window_begin; i < keyframes.size(); ++i) {
    const Keyframe& kf = *keyframes[i];
    for (const ObjectObservation& o : kf.observations) {
      const Object* obj = InstanceSeen(objects, kf, o.object_id);
      if (!obj) continue;
      const std::optional<double> e = PredictionError(*obj, CameraPose(kf), o.corners, o.seen);
      errors[obj].push_back(e ? *e : std::numeric_limits<double>::infinity());
      const double sigma = o.sigma_px > 0.0 ? o.sigma_px : options.factor.sigma_px;
      normalized[obj].push_back(errors[obj].back() / sigma);
    }
  }
  // A mature object's noise: the typical view against its σ. The RMS corner distance of a view
  // with Gaussian noise of σ per coordinate is σ sqrt(χ²₈ / 4), whose median is 1.355 σ.
  constexpr double kMedianRmsPerSigma = 1.355;
  for (auto& [id, obj] : objects)
    if (Mature(*obj) && normalized[obj.get()].size() >= kMinMatureViews)
      obj->noise_scale = std::max(1.0, Median(normalized[obj.get()]) / kMedianRmsPerSigma);
  for (auto it = objects.begin(); it != objects.end();) {
    const Object& obj = *it->second;
    const std::vector<double>& views = errors[&obj];
    // On probation its few views, all of them; mature, the typical view (one view off by tens of
    // pixels, a corner on the wrong edge, is the robust loss's to handle).
    const bool mature = Mature(obj);
    double error = 0.0;
    if (!mature && views.size() >= kMinViews) {
      for (double e : views) error += e * e;
      error = std::sqrt(error / static_cast<double>(views.size()));
    } else if (mature && views.size() >= kMinMatureViews) {
      error = Median(views);
    }
    if (error <= options.points.object_gate_px) {
      ++it;
      continue;
    }
    char why[300];
    std::snprintf(
        why, sizeof(why),
        "object %d %s: its %zu views in the window lie %.3g px (%s) from the rectangle "
        "that the trajectory of the points and the IMU allows (%s)",
        obj.id, mature ? "rejected" : "dropped", views.size(), error, mature ? "median" : "RMS",
        mature ? "not a rectangle, or its track slid: it leaves the estimate and the map, "
                 "its id may start afresh"
               : "moving, or not a rectangle: its views are ignored from now on");
    Warn(keyframes.back()->state.t_ns, why);
    start_views.erase(obj.id);
    if (mature) {
      ++summary.objects_rejected;
    } else {
      ++summary.objects_moving;
      moving.insert(obj.id);
    }
    it = objects.erase(it);
  }
}

}  // namespace fsp::backend
