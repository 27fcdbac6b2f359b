// The estimator's problem builder (every keyframe and object of a set in one Ceres problem: the
// batch's solves, the window's global step) and the map's covariance; the window's own problem is
// built in estimator_window.cc from the same pieces (AddVisualFactors, AddObservation).
#include "estimator_impl.h"

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
#include <Eigen/Cholesky>

#include "fsp/backend/fhp_factor.h"
#include "fsp/backend/fsp_factor.h"
#include "fsp/backend/imu_factor.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/marginalization.h"
#include "fsp/backend/priors.h"
#include "fsp/backend/static_init.h"
#include "fsp/common/error.h"
#include "fsp/common/time.h"

namespace fsp::backend {

void Estimator::Impl::AddVisualFactors(ceres::Problem* problem, size_t begin, size_t end,
                                       bool mature) {
  const int first_index = keyframes[begin]->index;
  auto is_variable = [first_index, mature](const Keyframe* k) {
    return mature && k->index >= first_index;
  };
  std::vector<Object*> seen;
  for (size_t i = begin; i < end; ++i) {
    Keyframe* kf = keyframes[i].get();
    for (const ObjectObservation& o : kf->observations) {
      Object* obj = InstanceSeen(objects, *kf, o.object_id);
      if (!obj || Mature(*obj) != mature) continue;
      AddObservation(problem, kf, obj, o.corners, o.seen, o.sigma_px, is_variable);
      seen.push_back(obj);
    }
  }
  std::sort(seen.begin(), seen.end(),
            [](const Object* a, const Object* b) { return a->id < b->id; });
  seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
  for (Object* obj : seen)
    for (const auto& view : obj->past)
      AddObservation(problem, view.keyframe, obj, view.corners, view.seen, view.sigma_px,
                     is_variable);
}

void Estimator::Impl::ComputeSigmas(ceres::Problem* problem) {
  sigmas.clear();
  std::vector<std::pair<const double*, const double*>> blocks;
  std::vector<Object*> in_problem;
  for (auto& [id, obj] : objects) {
    if (!obj->landmark.InProblem(*problem)) continue;
    in_problem.push_back(obj.get());
    obj->landmark.AppendCovarianceBlocks(&blocks);
  }
  std::vector<const double*> wanted;
  for (const auto& [a, b] : blocks) wanted.insert(wanted.end(), {a, b});
  // The map's scale (EstimatorSummary::scale_sigma): the objects the map reports, with their
  // cross-covariances (models with a scale block only).
  std::vector<const Object*> mapped;
  for (const Object* obj : in_problem)
    if (obj->landmark.ScaleBlock() && obj->observations >= options.min_observations &&
        !AtDepthBound(*obj))
      mapped.push_back(obj);
  summary.scale_sigma = -1.0;
  MarginalCovariance covariance;
  if (!covariance.Compute(problem, wanted)) return;
  // The covariance assumes the noise model; σ0 (ComputeConsistency) scales it to the residuals.
  const double sigma0 = std::sqrt(std::max(1.0, summary.variance_factor));
  for (Object* obj : in_problem) {
    const std::pair<double, double> wh = obj->landmark.SizeSigmas(covariance);
    sigmas[obj] = {wh.first * sigma0, wh.second * sigma0};
  }
  if (mapped.empty()) return;
  // σ of the precision-weighted (generalised least squares) combination of the objects' log
  // scales s_i with their covariance C: 1 / (1ᵀ C⁻¹ 1). A plain mean let one object seen briefly
  // (σ 50 %) dominate: 20-27 % on the short clips for scale errors of 0.03-0.16 %.
  const size_t n = mapped.size();
  Eigen::MatrixXd C(n, n);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i; j < n; ++j)
      C(i, j) = C(j, i) = mapped[i]->landmark.ScaleCovariance(covariance, mapped[j]->landmark);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(C);
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(n));
  const double information =
      ldlt.info() == Eigen::Success && ldlt.isPositive() ? ones.dot(ldlt.solve(ones)) : 0.0;
  // A singular C (an object's scale not determined at all) falls back to the plain mean.
  const double var = information > 0.0 && std::isfinite(information)
                         ? 1.0 / information
                         : C.sum() / static_cast<double>(n * n);
  summary.scale_sigma = std::sqrt(std::max(0.0, var)) * sigma0;
  if (summary.scale_sigma > options.warn_scale_sigma) {
    char what[200];
    std::snprintf(what, sizeof(what),
                  "the map's metric scale is weakly observable: scale sigma %.1f %% (sizes and "
                  "distances are known to about that; more acceleration or objects seen from "
                  "more sides determine it)",
                  100.0 * summary.scale_sigma);
    Warn(keyframes.back()->state.t_ns, what);
  }
}

void Estimator::Impl::ComputeConsistency(ceres::Problem* problem) {
  summary.variance_factor = summary.imu_chi2_per_residual = summary.corner_chi2_per_residual = -1.0;
  // Free parameters: the tangent dimensions of the blocks the solve moved.
  std::vector<double*> params;
  problem->GetParameterBlocks(&params);
  double free = 0.0;
  for (double* p : params)
    if (!problem->IsParameterBlockConstant(p)) free += problem->ParameterBlockTangentSize(p);
  // Residuals: whitened, without the loss. A residual that is exactly zero is not a measurement (a
  // corner out of view in a partial view, a gauge prior at its value) and is not counted.
  std::vector<ceres::ResidualBlockId> blocks;
  problem->GetResidualBlocks(&blocks);
  double chi2 = 0.0, count = 0.0, imu_chi2 = 0.0, imu_count = 0.0, corner_chi2 = 0.0,
         corner_count = 0.0;
  std::vector<double> r;
  for (ceres::ResidualBlockId id : blocks) {
    const ceres::CostFunction* f = problem->GetCostFunctionForResidualBlock(id);
    r.assign(static_cast<size_t>(f->num_residuals()), 0.0);
    double cost = 0.0;
    if (!problem->EvaluateResidualBlock(id, /*apply_loss_function=*/false, &cost, r.data(),
                                        nullptr))
      continue;
    double c2 = 0.0, m = 0.0;
    for (double x : r) {
      if (x == 0.0 || !std::isfinite(x)) continue;
      c2 += x * x;
      m += 1.0;
    }
    chi2 += c2;
    count += m;
    if (dynamic_cast<const ImuFactor*>(f)) {
      imu_chi2 += c2;
      imu_count += m;
    } else if (dynamic_cast<const FspFactor*>(f) || dynamic_cast<const FspAnchorFactor*>(f) ||
               dynamic_cast<const FhpFactor*>(f) || dynamic_cast<const FhpAnchorFactor*>(f)) {
      corner_chi2 += c2;
      corner_count += m;
    }
  }
  if (count > free) summary.variance_factor = chi2 / (count - free);
  if (imu_count > 0.0) summary.imu_chi2_per_residual = imu_chi2 / imu_count;
  if (corner_count > 0.0) summary.corner_chi2_per_residual = corner_chi2 / corner_count;
  if (summary.variance_factor > options.warn_variance_factor) {
    char what[320];
    std::snprintf(what, sizeof(what),
                  "the final solve's residuals are %.1f times their noise model (variance factor "
                  "%.1f; chi2 per residual: IMU %.1f, corners %.1f): the IMU noise or the corner "
                  "sigma is too small for this data, or camera and IMU disagree (calibration, time "
                  "offset); the sigmas reported are scaled by %.1f",
                  std::sqrt(summary.variance_factor), summary.variance_factor,
                  summary.imu_chi2_per_residual, summary.corner_chi2_per_residual,
                  std::sqrt(summary.variance_factor));
    Warn(keyframes.back()->state.t_ns, what);
  }
}

void Estimator::Impl::AddObservation(ceres::Problem* problem, Keyframe* kf, Object* obj,
                                     const Corners& corners, const CornerMask& seen,
                                     double sigma_px,
                                     const std::function<bool(const Keyframe*)>& is_variable) {
  for (Keyframe* k : {kf, obj->anchor}) {
    if (is_variable(k) || problem->HasParameterBlock(k->state.pose)) continue;
    problem->AddParameterBlock(k->state.pose, kPoseSize, &pose_manifold);
    problem->SetParameterBlockConstant(k->state.pose);
  }
  // Nothing added when the object is behind the camera.
  const LandmarkContext* c = &landmark_context;
  LandmarkContext own_sigma;
  const double sigma =
      (sigma_px > 0.0 ? sigma_px : landmark_context.factor.sigma_px) * obj->noise_scale;
  if (sigma != landmark_context.factor.sigma_px) {
    own_sigma = landmark_context;
    own_sigma.factor.sigma_px = sigma;
    c = &own_sigma;
  }
  obj->landmark.AddObservation(problem, corners, seen, kf->state.pose, obj->anchor->state.pose,
                               CameraPose(*kf), CameraPose(*obj->anchor), *c);
}

std::string Estimator::Impl::Diverged(const ceres::Solver::Summary& s, const Snapshot& before,
                                      const Keyframes& kfs) const {
  const FaultOptions& f = options.faults;
  if (s.termination_type == ceres::FAILURE || !std::isfinite(s.final_cost))
    return "the solver failed: " + s.message;
  char buf[128];
  for (size_t k = 0; k < before.states.size(); ++k) {
    const KeyframeState& st = kfs[before.begin + k]->state;
    const Eigen::Map<const Eigen::Matrix<double, kPoseSize, 1>> pose(st.pose);
    const Eigen::Map<const Eigen::Matrix<double, kSpeedBiasSize, 1>> sb(st.speed_bias);
    if (!pose.allFinite() || !sb.allFinite()) return "a state is not finite";
    const double jump = (st.T_W_B().translation() - before.states[k].T_W_B().translation()).norm();
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

std::string Estimator::Impl::ViewsDiverged() const {
  const Keyframe& kf = *keyframes.back();
  int views = 0;
  double least = std::numeric_limits<double>::infinity();
  for (const ObjectObservation& o : kf.observations) {
    const auto it = objects.find(o.object_id);
    if (!o.Complete() || it == objects.end()) continue;
    const std::optional<double> e = PredictionError(*it->second, CameraPose(kf), o.corners);
    ++views;
    least = std::min(least, e ? *e : std::numeric_limits<double>::infinity());
  }
  if (views < 2 || least <= options.faults.max_view_error_px) return "";
  char buf[128];
  std::snprintf(buf, sizeof(buf), "the %d objects in view %.3g px or more from their prediction",
                views, least);
  return buf;
}

ceres::CostFunction* Estimator::Impl::MakeZeroVelocityPrior(const Keyframe& kf) const {
  Eigen::Matrix<double, 9, 1> still, sigma;
  still << Vec3::Zero(), kf.state.gyro_bias(), kf.state.acc_bias();
  sigma << Vec3::Constant(options.zero_velocity.velocity_sigma), Vec3::Constant(1e6),
      Vec3::Constant(1e6);  // the biases are free
  return new SpeedBiasPrior(still, sigma);
}

ceres::CostFunction* Estimator::Impl::MakeStillLink(const Keyframe& prev,
                                                    const Keyframe& kf) const {
  const double dt = NsToSeconds(kf.state.t_ns - prev.state.t_ns);
  const ZeroVelocityOptions& z = options.zero_velocity;
  return MakeRelativePosePrior(Rigid3::Identity(), z.velocity_sigma * dt, z.turn_rate_sigma * dt);
}

void Estimator::Impl::AddGaugePriors(ceres::Problem* problem, Keyframe* first) const {
  problem->AddResidualBlock(MakeGaugePosePrior(*first->gauge), nullptr, first->state.pose);
  problem->AddResidualBlock(MakeGaugeBiasPrior(*first->gauge), nullptr, first->state.speed_bias);
}

ceres::CostFunction* Estimator::Impl::MakeGaugePosePrior(const Gauge& g) {
  return new PosePrior(g.T_W_B0, g.sigma_p, g.sigma_roll_pitch, g.sigma_yaw);
}

ceres::CostFunction* Estimator::Impl::MakeGaugeBiasPrior(const Gauge& g) {
  return new SpeedBiasPrior(g.sb0, g.sigma_sb);
}

std::vector<Estimator::Impl::Link> Estimator::Impl::ImuLink(Keyframe* prev, Keyframe* kf) const {
  if (kf->imu_gap_s > 0.0)
    return {{MakeGapPrior(kf->imu_gap_s),
             {prev->state.pose, prev->state.speed_bias, kf->state.pose, kf->state.speed_bias}}};
  kf->preint->ReintegrateIfNeeded(prev->state.gyro_bias(), prev->state.acc_bias());
  std::vector<Link> link = {
      {new ImuFactor(kf->preint),
       {prev->state.pose, prev->state.speed_bias, kf->state.pose, kf->state.speed_bias}}};
  if (kf->still) link.push_back({MakeStillLink(*prev, *kf), {prev->state.pose, kf->state.pose}});
  return link;
}

ceres::CostFunction* Estimator::Impl::MakeGapPrior(double dt_s) const {
  ImuGapPriorOptions o;
  o.max_acc = options.faults.gap_max_acc;
  o.max_rate = options.faults.gap_max_rate;
  o.gyro_walk = options.imu.noise.gyroscope_random_walk;
  o.acc_walk = options.imu.noise.accelerometer_random_walk;
  return MakeImuGapPrior(dt_s, o);
}

namespace {
constexpr double kWholeTrustRegion = 1e8;
}  // namespace

ceres::Problem::Options Estimator::Impl::ProblemOptions() const {
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.enable_fast_removal = false;
  return po;
}

// Levenberg-Marquardt with sparse normal Cholesky. Window mode (many small solves: the window
// every frame, the global step; backend/README.md, "Cost"): Eigen's simplicial Cholesky, and the
// projected line search that the depth box's bounds turn on tries its step by the cost alone
// (Ceres' default interpolation also evaluates every Jacobian once more per iteration); together
// 18-25 % less CPU than CHOLMOD and the default line search, whose supernodal factorisation and
// OpenMP threads cost more than they save on a few hundred variables. The batch (one problem of
// every frame) keeps CHOLMOD.
// WHOLE: a solve of every keyframe (the global step, the final solve, the batch's) starts with a
// wide trust region (kWholeTrustRegion), so its first step is the
// Gauss-Newton step: from Ceres' default (1e4) each of its 10 iterations took another ~1 % off the
// cost along the weakly determined directions; now it converges in 3-5. The window keeps the
// default: its damping holds it near the previous estimate, and undamped its causal error triples.
ceres::Solver::Options Estimator::Impl::SolverOptions(int max_iterations, bool whole) const {
  ceres::Solver::Options so;
  if (whole) so.initial_trust_region_radius = kWholeTrustRegion;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  if (options.mode == EstimatorMode::kWindow) {
    so.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
    so.line_search_interpolation_type = ceres::BISECTION;
  }
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.max_num_iterations = max_iterations;
  so.num_threads = 1;
  so.minimizer_progress_to_stdout = false;
  so.logging_type = ceres::SILENT;
  so.function_tolerance = 1e-8;
  so.parameter_tolerance = 1e-10;
  return so;
}

std::string Estimator::Impl::SolveAll(Keyframes* kfs, Objects* objs,
                                      const ceres::Solver::Options& solver,
                                      ceres::Solver::Summary* s, ceres::Problem* problem,
                                      size_t free_from) {
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
      // An object no free keyframe saw stays as it is.
      Object* obj = InstanceSeen(*objs, *kf, o.object_id);
      if (obj && obj->last_seen >= static_cast<int>(free_from))
        AddObservation(problem, kf.get(), obj, o.corners, o.seen, o.sigma_px, is_free);
    }
  }
  AddObjectPriors(problem, objs);
  // Keyframes that saw points alone through a stretch without objects of at least
  // faults.blind_s are tied to their neighbours by the window's relative poses: without the points
  // the global problem has nothing but the IMU there (measured on the room without objects: a false
  // rectangle at 28 s started global solves that moved 28 s of dead reckoning by 5 m). Elsewhere
  // keyframes that saw points are tied by the shape of that relative pose alone, its length free
  // (global_shape_links: one object and the IMU alone let a sliding track set the gyroscope bias;
  // backend/README.md, "Points").
  const PointOptions& po = options.points;
  const auto tie = [&](Keyframe* a, Keyframe* b, bool free_length) {
    if ((!is_free(a) && !is_free(b)) || b->gauge) return;
    const Rigid3 T_a_b =
        b->window_motion ? *b->window_motion : a->state.T_W_B().Inverse() * b->state.T_W_B();
    problem->AddResidualBlock(
        MakeRelativePosePrior(
            T_a_b, po.global_sigma_m + po.global_sigma_per_m * T_a_b.translation().norm(),
            po.global_sigma_deg * M_PI / 180.0, free_length),
        nullptr, a->state.pose, b->state.pose);
  };
  // whole[k]: keyframe k is tied to k - 1 by the whole relative pose.
  std::vector<bool> whole(kfs->size(), false);
  for (size_t i = free_from; i < kfs->size();) {
    if (!(*kfs)[i]->observations.empty()) {
      ++i;
      continue;
    }
    size_t end = i;
    while (end < kfs->size() && (*kfs)[end]->observations.empty()) ++end;
    const int64_t from = (*kfs)[i > 0 ? i - 1 : i]->state.t_ns;
    const int64_t to = (*kfs)[end < kfs->size() ? end : end - 1]->state.t_ns;
    if (NsToSeconds(to - from) >= options.faults.blind_s) {
      for (size_t k = std::max<size_t>(i, 1); k < end; ++k)
        whole[k] = (*kfs)[k]->PointsOnly() || (*kfs)[k - 1]->PointsOnly();
      if (end < kfs->size()) whole[end] = (*kfs)[end - 1]->PointsOnly();
    }
    i = end;
  }
  for (size_t k = std::max<size_t>(free_from, 1); k < kfs->size(); ++k) {
    Keyframe *a = (*kfs)[k - 1].get(), *b = (*kfs)[k].get();
    if (whole[k])
      tie(a, b, /*free_length=*/false);
    else if (po.global_shape_links && a->sees_points && b->sees_points)
      tie(a, b, /*free_length=*/true);
  }
  const Snapshot before = Save(*kfs, *objs, free_from);
  ceres::Solve(solver, problem, s);
  const std::string diverged = Diverged(*s, before, *kfs);
  if (!diverged.empty()) Restore(before, kfs, objs);
  return diverged;
}

bool Estimator::Impl::SolveFull(int max_iterations, bool with_sigmas, const char* what,
                                ceres::Solver::Summary* s) {
  ceres::Problem problem(ProblemOptions());
  const std::string diverged =
      SolveAll(&keyframes, &objects, SolverOptions(max_iterations, /*whole=*/true), s, &problem,
               session_begin);
  if (!diverged.empty()) {
    Warn(keyframes.back()->state.t_ns,
         std::string("divergence in ") + what + " (" + diverged + "): its result was rejected");
    return false;
  }
  summary.final_cost = s->final_cost;
  for (auto& kf : keyframes) output[kf->frame] = kf->state.ToStateSample();
  if (with_sigmas) {
    ComputeConsistency(&problem);
    ComputeSigmas(&problem);
  }
  return true;
}

}  // namespace fsp::backend
