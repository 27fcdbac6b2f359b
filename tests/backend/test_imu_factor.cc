// IMU factor: zero residual at the true states, analytic Jacobians (all four blocks, random
// non-trivial states and biases away from the linearisation point) against central differences in
// the tangent space and ceres::GradientChecker, and a small solve that recovers the truth.
#include <memory>
#include <random>

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "backend/imu_test_util.h"
#include "backend/jacobian_check.h"
#include "fsp/backend/imu_factor.h"
#include "fsp/backend/manifolds.h"

namespace fsp::backend {
namespace {

using test::AnalyticTrajectory;

int64_t Ns(double t) {
  return static_cast<int64_t>(std::llround(t * 1e9));
}

struct Fixture {
  AnalyticTrajectory traj;
  PreintegrationOptions opt;
  Vec3 bg{0.01, -0.02, 0.015}, ba{0.1, -0.05, 0.2};
  std::shared_ptr<ImuPreintegration> pre;
  KeyframeState ki, kj;
  Fixture(double ti, double tj) {
    test::ImuSamplingOptions so;
    so.bg = bg;
    so.ba = ba;
    const auto imu = test::SampleImu(traj, ti - 0.1, tj + 0.1, so);
    pre = std::make_shared<ImuPreintegration>(opt, imu, Ns(ti), Ns(tj), Vec3::Zero(), Vec3::Zero());
    ki = traj.State(ti, bg, ba);
    kj = traj.State(tj, bg, ba);
  }
};

Vec3 RandomVec(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return Vec3(n(rng), n(rng), n(rng));
}

TEST(ImuFactor, ZeroResidualAtTruth) {
  Fixture f(1.0, 1.5);
  ImuFactor factor(f.pre);
  // The linearisation point is b = 0 but the true biases are used: first-order correction.
  const Vec15 r = factor.UnwhitenedResidual(f.ki.pose, f.ki.speed_bias, f.kj.pose, f.kj.speed_bias);
  std::printf("[imu_factor] residual at truth: |r_φ| %.2e |r_v| %.2e |r_p| %.2e\n",
              r.segment<3>(0).norm(), r.segment<3>(3).norm(), r.segment<3>(6).norm());
  EXPECT_LT(r.segment<3>(0).norm(), 1e-5);
  // |δb_a| = 0.23 m/s² is large for a first-order correction (second-order terms ~ 1e-4).
  EXPECT_LT(r.segment<3>(3).norm(), 1e-3);
  EXPECT_LT(r.segment<3>(6).norm(), 2e-4);
  EXPECT_EQ(r.tail<6>().norm(), 0.0);
  // Beyond the threshold the estimator re-integrates; the factor sees it through the shared pointer
  // and the residual drops to the discretisation level.
  EXPECT_TRUE(f.pre->ReintegrateIfNeeded(f.bg, f.ba));
  const Vec15 r2 =
      factor.UnwhitenedResidual(f.ki.pose, f.ki.speed_bias, f.kj.pose, f.kj.speed_bias);
  EXPECT_LT(r2.head<9>().norm(), 5e-6);
}

TEST(ImuFactor, AnalyticJacobiansMatchNumeric) {
  std::mt19937 rng(17);
  PoseManifold pose_manifold;
  double worst = 0.0;
  for (int trial = 0; trial < 8; ++trial) {
    Fixture f(0.3 + trial, 0.3 + trial + 0.25 * (1 + trial % 4));
    // Non-trivial states: perturb everything far from the truth and the biases far from b_lin = 0.
    KeyframeState a = f.ki, b = f.kj;
    for (KeyframeState* k : {&a, &b}) {
      double d[6];
      Eigen::Map<Vec6>(d) << RandomVec(rng, 0.5), RandomVec(rng, 0.3);
      double p[7];
      PosePlus(k->pose, d, p);
      std::copy(p, p + 7, k->pose);
      VelocityOf(k->speed_bias) += RandomVec(rng, 0.5);
      GyroBiasOf(k->speed_bias) += RandomVec(rng, 0.02);
      AccBiasOf(k->speed_bias) += RandomVec(rng, 0.2);
    }
    ImuFactor factor(f.pre);
    std::vector<double*> params = {a.pose, a.speed_bias, b.pose, b.speed_bias};
    std::vector<const ceres::Manifold*> manifolds = {&pose_manifold, nullptr, &pose_manifold,
                                                     nullptr};
    const auto res = test::CheckJacobians(factor, params, manifolds);
    worst = std::max(worst, res.worst_error);
    EXPECT_TRUE(test::ExpectJacobiansOk(factor, params, manifolds, 1e-5, 1e-6, 1e-4))
        << "trial " << trial;
  }
  std::printf("[imu_factor] worst relative Jacobian error over 8 random states: %.2e\n", worst);
}

TEST(ImuFactor, SolveRecoversPerturbedEndState) {
  Fixture f(2.0, 2.5);
  f.pre->Reintegrate(f.bg, f.ba);
  KeyframeState a = f.ki, b = f.kj;
  double d[6] = {0.2, -0.1, 0.15, 0.05, -0.08, 0.03}, p[7];
  PosePlus(b.pose, d, p);
  std::copy(p, p + 7, b.pose);
  VelocityOf(b.speed_bias) += Vec3(0.3, -0.2, 0.1);
  ceres::Problem problem;
  problem.AddResidualBlock(new ImuFactor(f.pre), nullptr, a.pose, a.speed_bias, b.pose,
                           b.speed_bias);
  problem.SetManifold(a.pose, MakePoseManifold().release());
  problem.SetManifold(b.pose, MakePoseManifold().release());
  problem.SetParameterBlockConstant(a.pose);
  problem.SetParameterBlockConstant(a.speed_bias);
  ceres::Solver::Options options;
  options.max_num_iterations = 20;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  EXPECT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();
  const Rigid3 Tb = b.T_W_B(), Tt = f.kj.T_W_B();
  std::printf("[imu_factor] solve: %d iterations, final cost %.3e, |Δp| %.2e m |Δv| %.2e m/s\n",
              static_cast<int>(summary.iterations.size()), summary.final_cost,
              (Tb.translation() - Tt.translation()).norm(), (b.v_W() - f.kj.v_W()).norm());
  EXPECT_LT((Tb.translation() - Tt.translation()).norm(), 1e-5);
  EXPECT_LT(LogSO3(Tb.R().transpose() * Tt.R()).norm(), 1e-5);
  EXPECT_LT((b.v_W() - f.kj.v_W()).norm(), 1e-5);
  EXPECT_LT((b.gyro_bias() - f.bg).norm(), 1e-9);
}

}  // namespace
}  // namespace fsp::backend
