// The sliding window (backend/README.md): its solve and its marginalisation (the oldest keyframe's
// objects re-anchored, its inertial information into the linear prior, its views kept as past
// views).
#include "estimator_impl.h"

namespace fsp::backend {

void Estimator::Impl::SolveWindow(int max_iterations, bool finish) {
  const size_t n = keyframes.size();
  if (!finish && options.frame_motion_only && !keyframes.back()->keyframe &&
      !keyframes.back()->gauge && n >= window_begin + 2) {
    SolveFrameAlone(max_iterations);
    return;
  }
  ceres::Problem problem(ProblemOptions());
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
  AddPointFactors(&problem);
  ceres::Solver::Summary s;
  if (!SolveOrReject(&problem, max_iterations, window_begin, finish, &s)) return;
  RemovePointOutliers();
  summary.final_cost = s.final_cost;
  for (size_t i = window_begin; i < n; ++i)
    output[keyframes[i]->frame] = keyframes[i]->state.ToStateSample();
  if (finish) {
    ComputeSigmas(&problem);
  } else {
    RefineYoungObjects(max_iterations);
    if (summary.point_frames > 0) DropInconsistentObjects();
  }
}

bool Estimator::Impl::SolveOrReject(ceres::Problem* problem, int max_iterations, size_t first,
                                    bool finish, ceres::Solver::Summary* s) {
  const Snapshot before = Save(first);
  std::vector<std::pair<PointTrack*, double>> rho_before;
  for (auto& [id, t] : point_tracks)
    if (t.live) rho_before.emplace_back(&t, t.rho);
  ceres::Solve(SolverOptions(max_iterations, options.mode == EstimatorMode::kBatch), problem, s);
  const std::string diverged = Diverged(*s, before);
  if (diverged.empty()) return true;
  Restore(before);
  for (auto& [t, rho] : rho_before) t->rho = rho;
  ++summary.divergences;
  if (finish) {
    Warn(keyframes.back()->state.t_ns,
         "divergence in the final solve (" + diverged + "): its result was rejected");
  } else {
    Restart(diverged);
  }
  return false;
}

void Estimator::Impl::SolveFrameAlone(int max_iterations) {
  const size_t n = keyframes.size();
  Keyframe* prev = keyframes[n - 2].get();
  Keyframe* kf = keyframes[n - 1].get();
  // Only the factors that reach the frame's state: its IMU link and its views of mature objects
  // (the window's other factors would be built only to be held).
  ceres::Problem problem(ProblemOptions());
  AddStateBlocks(&problem, prev);
  AddStateBlocks(&problem, kf);
  AddImuFactor(&problem, prev, kf);
  if (kf->still)
    problem.AddResidualBlock(MakeZeroVelocityPrior(*kf), nullptr, kf->state.speed_bias);
  const auto is_variable = [kf](const Keyframe* k) { return k == kf; };
  for (const ObjectObservation& o : kf->observations) {
    auto it = objects.find(o.object_id);
    if (it != objects.end() && Mature(*it->second))
      AddObservation(&problem, kf, it->second.get(), o.corners, o.seen, o.sigma_px, is_variable);
  }
  AddPointFactorsOf(&problem, kf);
  std::vector<double*> blocks;
  problem.GetParameterBlocks(&blocks);
  for (double* b : blocks)
    if (b != kf->state.pose && b != kf->state.speed_bias) problem.SetParameterBlockConstant(b);
  ++summary.motion_only_frames;
  ceres::Solver::Summary s;
  if (!SolveOrReject(&problem, max_iterations, n - 1, /*finish=*/false, &s)) return;
  output[kf->frame] = kf->state.ToStateSample();
  RefineYoungObjects(max_iterations);
}

void Estimator::Impl::ReanchorObjectsOf(Keyframe* old) {
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
      Landmark moved = obj->landmark;
      // A keyframe that sees s1 barely in front (looking along the wall past it) would put the
      // object's depth outside the box, where the bound clamps it and destroys its geometry
      // (measured: the default scene's objects collapsed onto the 0.3 m minimum right after such
      // a re-anchoring); take the newest keyframe that keeps the depth inside.
      if (!moved.Reanchor(T_W_F, T_W_Fnew) || !DepthInBox(moved)) continue;
      obj->landmark = moved;
      obj->anchor = cand;

      ++summary.reanchors;
      break;
    }
  }
}

void Estimator::Impl::MarginalizeOldest() {
  Keyframe* old = keyframes[window_begin].get();
  Keyframe* next = keyframes[window_begin + 1].get();
  ReanchorObjectsOf(old);
  // Objects that could not be re-anchored (s1 behind every window camera) keep their anchor:
  // their information from the window leaves with the keyframe and they are frozen.
  if (!FixedBoundary()) MarginalizeIntoPrior(old, next);
  if (UsePoints()) next->window_motion = old->state.T_W_B().Inverse() * next->state.T_W_B();
  ReanchorPointsOf(old);
  // The old keyframe's observations stay as factors with its pose held constant (past views).
  for (const ObjectObservation& o : old->observations) {
    auto it = objects.find(o.object_id);
    if (it == objects.end()) continue;
    auto& past = it->second->past;
    past.push_back({old, o.corners, o.seen, o.sigma_px});
    if (static_cast<int>(past.size()) > options.max_past_views) past.pop_front();
  }
  output[old->frame] = old->state.ToStateSample();
  ++window_begin;
  ++summary.marginalizations;
}

void Estimator::Impl::MarginalizeIntoPrior(Keyframe* old, Keyframe* next) {
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
  if (next->imu_gap_s > 0.0 || !next->gauge)
    for (Link& l : ImuLink(old, next)) add(l.cost, nullptr, std::move(l.blocks));
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
  std::unordered_set<const double*> marginalized = {old->state.pose, old->state.speed_bias};
  if (UsePoints() && options.points.marginalize) {
    // The views of the points anchored at `old` (every point `old` sees is: anchors are first
    // views) with their inverse depths, as VINS-Mono: without them the window's position and yaw
    // keep only the IMU chain's prior and wander (backend/README.md, "Points").
    for (ResidualBlockInput& in : AddPointFactorsOf(old, &costs, &losses)) {
      manifolds[in.parameter_blocks[0]] = &pose_manifold;  // a view's keyframe; [2] is ρ
      marginalized.insert(in.parameter_blocks[2]);
      inputs.push_back(std::move(in));
    }
  }
  const MarginalizationSummary ms =
      Marginalize(inputs, marginalized, manifolds, MarginalizationOptions());
  if (ms.success) {
    prior = ms.prior;
  } else {
    prior.reset();  // information lost, but the window stays solvable (gauge prior below)
    ++summary.marginalization_failures;
  }
}

}  // namespace fsp::backend
