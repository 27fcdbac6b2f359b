// The two landmark models (landmark_model.h): per operation one overload for FSP and one for FHP;
// Landmark's members dispatch to them. A new model is one more alternative of the variant and its
// overloads here.
#include "landmark_model.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "fsp/backend/priors.h"
#include "fsp/backend/reanchor.h"
#include "fsp/common/error.h"

namespace fsp::backend::internal {

namespace {

// Moves log ω = block[i] into the depth box [1/max_depth, 1/min_depth] (Ceres requires a feasible
// start). AddObservationOf does it before its cheirality check: clamped after it, a landmark
// outside the box could go behind a camera whose factor was already added, and the solve then
// failed at its first evaluation (the hall's FHP global solves at 50 s with a 45-keyframe window).
void ClampLogOmega(double* block, int i, const LandmarkContext& c) {
  block[i] = std::clamp(block[i], -std::log(c.max_depth_m), -std::log(c.min_depth_m));
}

// Keeps an inverse depth ω = exp(block[i]) within the box in the solve: an object with no parallax
// yet (hover, far away) must not drift to infinity and drag the trajectory with it. The value is
// already inside (AddObservationOf clamped it).
void BoundLogOmega(ceres::Problem* problem, double* block, int i, const LandmarkContext& c) {
  problem->SetParameterLowerBound(block, i, -std::log(c.max_depth_m));
  problem->SetParameterUpperBound(block, i, -std::log(c.min_depth_m));
}

bool InsideDepthBox(double log_omega, double min_depth_m, double max_depth_m) {
  const double lo = -std::log(max_depth_m), hi = -std::log(min_depth_m);
  return log_omega > lo + 1e-6 && log_omega < hi - 1e-6;
}

// --- FSP: blocks q_F_O (quaternion manifold) and x (log ω bounded); one 8-residual factor --------

bool AddObservationOf(FspLandmark& l, ceres::Problem* problem, const Corners& corners,
                      const CornerMask& seen, double* camera_pose, double* anchor_pose,
                      const Rigid3& T_W_C, const Rigid3& T_W_F, const LandmarkContext& c) {
  ClampLogOmega(l.x, kFspLogOmega, c);
  if (!PredictFspCorners(c.K, T_W_C, T_W_F, l).in_front) return false;
  ceres::LossFunction* loss = MakeRobustLoss(c.robust, 2 * CountSeen(seen)).release();
  if (camera_pose == anchor_pose) {
    problem->AddResidualBlock(new FspAnchorFactor(corners, c.K, c.factor, seen), loss, l.q_F_O,
                              l.x);
  } else {
    problem->AddResidualBlock(new FspFactor(corners, c.K, c.T_B_C, c.factor, seen), loss,
                              camera_pose, anchor_pose, l.q_F_O, l.x);
  }
  problem->SetManifold(l.q_F_O, c.quaternion_manifold);
  BoundLogOmega(problem, l.x, kFspLogOmega, c);
  return true;
}

void AddWidthPriorOf(FspLandmark& l, ceres::Problem* problem, double width_m,
                     const LandmarkContext& c) {
  if (!problem->HasParameterBlock(l.x)) return;
  problem->AddResidualBlock(new LogWidthPrior(width_m, c.prior_log_omega_sigma), nullptr, l.x);
}

const double* FirstBlock(const FspLandmark& l) {
  return l.x;
}
CornerPrediction PredictOf(const FspLandmark& l, const Mat3& K, const Rigid3& T_W_C,
                           const Rigid3& T_W_F) {
  return PredictFspCorners(K, T_W_C, T_W_F, l);
}
bool DepthInBoxOf(const FspLandmark& l, double min_depth_m, double max_depth_m) {
  return InsideDepthBox(l.x[kFspLogOmega], min_depth_m, max_depth_m);
}
bool ReanchorOf(FspLandmark& l, const Rigid3& T_W_F, const Rigid3& T_W_Fnew) {
  return ReanchorFsp(FspLandmark(l), T_W_F, T_W_Fnew, &l);
}

void AppendCovarianceBlocksOf(const FspLandmark& l,
                              std::vector<std::pair<const double*, const double*>>* blocks) {
  blocks->emplace_back(l.x, l.x);
}

std::pair<double, double> SizeSigmasOf(const FspLandmark& l, const MarginalCovariance& covariance) {
  double c[25];
  FSP_CHECK(covariance.Block(l.x, l.x, c));
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

const double* ScaleBlockOf(const FspLandmark& l) {
  return l.x;
}

// ½ (log w + log h) = log w̄ − log ω − ½ log f.
double ScaleCovarianceOf(const FspLandmark& a, const FspLandmark& b,
                         const MarginalCovariance& covariance) {
  Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
  g[kFspLogWbar] = 1.0;
  g[kFspLogOmega] = -1.0;
  g[kFspLogForm] = -0.5;
  double c[25];
  FSP_CHECK(covariance.Block(a.x, b.x, c));
  const Eigen::Map<Eigen::Matrix<double, 5, 5, Eigen::RowMajor>> C(c);
  return g.dot(C * g);
}

// --- FHP: one block (u, v, log ω) per corner (log ω bounded); one 2-residual factor each --------

bool AddObservationOf(FhpLandmark& l, ceres::Problem* problem, const Corners& corners,
                      const CornerMask& seen, double* camera_pose, double* anchor_pose,
                      const Rigid3& T_W_C, const Rigid3& T_W_F, const LandmarkContext& c) {
  for (int j = 0; j < 4; ++j) ClampLogOmega(l.corner[j], 2, c);
  if (!PredictFhpCorners(c.K, T_W_C, T_W_F, l).in_front) return false;
  for (int j = 0; j < 4; ++j) {
    if (!seen[j]) continue;
    ceres::LossFunction* loss = MakeRobustLoss(c.robust, 2).release();
    if (camera_pose == anchor_pose) {
      problem->AddResidualBlock(new FhpAnchorFactor(corners[j], c.K, c.factor), loss, l.corner[j]);
    } else {
      problem->AddResidualBlock(new FhpFactor(corners[j], c.K, c.T_B_C, c.factor), loss,
                                camera_pose, anchor_pose, l.corner[j]);
    }
    BoundLogOmega(problem, l.corner[j], 2, c);
  }
  return true;
}

void AddWidthPriorOf(FhpLandmark& l, ceres::Problem* problem, double width_m,
                     const LandmarkContext& c) {
  if (!problem->HasParameterBlock(l.corner[0])) return;
  problem->AddResidualBlock(MakeFhpLogWidthPrior(width_m, c.prior_log_omega_sigma), nullptr,
                            l.corner[0], l.corner[1], l.corner[2], l.corner[3]);
}

const double* FirstBlock(const FhpLandmark& l) {
  return l.corner[0];
}
CornerPrediction PredictOf(const FhpLandmark& l, const Mat3& K, const Rigid3& T_W_C,
                           const Rigid3& T_W_F) {
  return PredictFhpCorners(K, T_W_C, T_W_F, l);
}
bool DepthInBoxOf(const FhpLandmark& l, double min_depth_m, double max_depth_m) {
  for (const auto& c : l.corner)
    if (!InsideDepthBox(c[2], min_depth_m, max_depth_m)) return false;
  return true;
}
bool ReanchorOf(FhpLandmark& l, const Rigid3& T_W_F, const Rigid3& T_W_Fnew) {
  return ReanchorFhp(FhpLandmark(l), T_W_F, T_W_Fnew, &l);
}

void AppendCovarianceBlocksOf(const FhpLandmark& l,
                              std::vector<std::pair<const double*, const double*>>* blocks) {
  for (int a = 0; a < 4; ++a)
    for (int b = a; b < 4; ++b) blocks->emplace_back(l.corner[a], l.corner[b]);
}

// w and h are functions of the 12 corner parameters (all in the anchor frame, so the anchor pose
// does not enter): σ² = J C Jᵀ with C the joint 12 x 12 covariance and J by central differences.
std::pair<double, double> SizeSigmasOf(const FhpLandmark& l, const MarginalCovariance& covariance) {
  Eigen::Matrix<double, 12, 12> C;
  for (int a = 0; a < 4; ++a)
    for (int b = a; b < 4; ++b) {
      double c[9];
      FSP_CHECK(covariance.Block(l.corner[a], l.corner[b], c));
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

const double* ScaleBlockOf(const FhpLandmark&) {
  return nullptr;
}

double ScaleCovarianceOf(const FhpLandmark&, const FhpLandmark&, const MarginalCovariance&) {
  return 0.0;  // never asked: ScaleBlock is null
}

}  // namespace

// --- Dispatch --------------------------------------------------------------------------------

Landmark Landmark::FromSingleView(LandmarkType type, const FspLandmark& init) {
  switch (type) {
    case LandmarkType::kFsp:
      return Landmark(init);
    case LandmarkType::kFhp:
      return Landmark(FhpLandmark::FromFsp(init));
  }
  FSP_CHECK(false);
  return Landmark(init);
}

bool Landmark::AddObservation(ceres::Problem* problem, const Corners& corners,
                              const CornerMask& seen, double* camera_pose, double* anchor_pose,
                              const Rigid3& T_W_C, const Rigid3& T_W_F, const LandmarkContext& c) {
  return std::visit(
      [&](auto& l) {
        return AddObservationOf(l, problem, corners, seen, camera_pose, anchor_pose, T_W_C, T_W_F,
                                c);
      },
      l_);
}

void Landmark::AddWidthPrior(ceres::Problem* problem, double width_m, const LandmarkContext& c) {
  std::visit([&](auto& l) { AddWidthPriorOf(l, problem, width_m, c); }, l_);
}

bool Landmark::InProblem(const ceres::Problem& problem) const {
  return problem.HasParameterBlock(std::visit([](const auto& l) { return FirstBlock(l); }, l_));
}

CornerPrediction Landmark::Predict(const Mat3& K, const Rigid3& T_W_C, const Rigid3& T_W_F) const {
  return std::visit([&](const auto& l) { return PredictOf(l, K, T_W_C, T_W_F); }, l_);
}

std::array<Vec3, 4> Landmark::CornersW(const Rigid3& T_W_F) const {
  return std::visit([&](const auto& l) { return l.CornersW(T_W_F); }, l_);
}

Rigid3 Landmark::T_W_O(const Rigid3& T_W_F) const {
  return std::visit([&](const auto& l) { return l.T_W_O(T_W_F); }, l_);
}

std::pair<double, double> Landmark::Size() const {
  return std::visit([](const auto& l) { return std::pair{l.Width(), l.Height()}; }, l_);
}

bool Landmark::DepthInBox(double min_depth_m, double max_depth_m) const {
  return std::visit([&](const auto& l) { return DepthInBoxOf(l, min_depth_m, max_depth_m); }, l_);
}

bool Landmark::Reanchor(const Rigid3& T_W_F, const Rigid3& T_W_Fnew) {
  return std::visit([&](auto& l) { return ReanchorOf(l, T_W_F, T_W_Fnew); }, l_);
}

void Landmark::AppendCovarianceBlocks(
    std::vector<std::pair<const double*, const double*>>* blocks) const {
  std::visit([&](const auto& l) { AppendCovarianceBlocksOf(l, blocks); }, l_);
}

std::pair<double, double> Landmark::SizeSigmas(const MarginalCovariance& covariance) const {
  return std::visit([&](const auto& l) { return SizeSigmasOf(l, covariance); }, l_);
}

const double* Landmark::ScaleBlock() const {
  return std::visit([](const auto& l) { return ScaleBlockOf(l); }, l_);
}

double Landmark::ScaleCovariance(const MarginalCovariance& covariance,
                                 const Landmark& other) const {
  FSP_CHECK(l_.index() == other.l_.index());
  return std::visit(
      [&](const auto& l) {
        using L = std::decay_t<decltype(l)>;
        return ScaleCovarianceOf(l, std::get<L>(other.l_), covariance);
      },
      l_);
}

}  // namespace fsp::backend::internal
