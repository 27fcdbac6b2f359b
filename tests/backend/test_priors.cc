// The priors of priors.h: analytic (or automatic) Jacobians against central differences through
// each block's manifold, and the residuals the IMU-gap motion prior is documented to give.
#include <random>

#include <gtest/gtest.h>

#include "fsp/backend/fsp_landmark.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/priors.h"
#include "fsp/backend/state.h"
#include "jacobian_check.h"

namespace fsp::backend {
namespace {

Vec3 RandomVec(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return Vec3(u(rng), u(rng), u(rng));
}

KeyframeState RandomState(std::mt19937& rng) {
  KeyframeState k;
  k.SetT_W_B(Rigid3(ExpSO3(RandomVec(rng, 1.5)), RandomVec(rng, 3.0)));
  VelocityOf(k.speed_bias) = RandomVec(rng, 1.0);
  GyroBiasOf(k.speed_bias) = RandomVec(rng, 0.02);
  AccBiasOf(k.speed_bias) = RandomVec(rng, 0.2);
  return k;
}

TEST(Priors, PoseAndSpeedBiasPriorJacobiansMatchNumeric) {
  std::mt19937 rng(5);
  PoseManifold pose_manifold;
  for (int trial = 0; trial < 6; ++trial) {
    KeyframeState k = RandomState(rng);
    const KeyframeState k0 = RandomState(rng);
    const PosePrior pose_prior(k0.T_W_B(), 0.01, 0.02, 0.005);
    EXPECT_TRUE(test::ExpectJacobiansOk(pose_prior, {k.pose}, {&pose_manifold}, 1e-5))
        << "trial " << trial;
    const SpeedBiasPrior sb_prior(Eigen::Map<const Eigen::Matrix<double, 9, 1>>(k0.speed_bias),
                                  Eigen::Matrix<double, 9, 1>::Constant(0.1));
    EXPECT_TRUE(test::ExpectJacobiansOk(sb_prior, {k.speed_bias}, {nullptr}, 1e-6))
        << "trial " << trial;
  }
}

TEST(Priors, LogWidthPriorJacobianMatchesNumeric) {
  double x[5] = {0.1, -0.2, std::log(0.25), std::log(0.3), std::log(0.7)};
  const LogWidthPrior prior(1.2, 0.3);
  EXPECT_TRUE(test::ExpectJacobiansOk(prior, {x}, {nullptr}, 1e-6));
  double r = 0.0;
  const double* params[] = {x};
  ASSERT_TRUE(prior.Evaluate(params, &r, nullptr));
  // w = w̄ / ω = 0.3 / 0.25 = 1.2 m: the prior's width, no residual.
  EXPECT_NEAR(r, 0.0, 1e-12);
}

TEST(Priors, ImuGapPriorJacobiansMatchNumeric) {
  std::mt19937 rng(9);
  PoseManifold pose_manifold;
  ImuGapPriorOptions o;
  for (int trial = 0; trial < 6; ++trial) {
    KeyframeState a = RandomState(rng), b = RandomState(rng);
    std::unique_ptr<ceres::CostFunction> prior(MakeImuGapPrior(0.5 + trial, o));
    EXPECT_TRUE(test::ExpectJacobiansOk(*prior, {a.pose, a.speed_bias, b.pose, b.speed_bias},
                                        {&pose_manifold, nullptr, &pose_manifold, nullptr}, 1e-5))
        << "trial " << trial;
  }
}

// Constant acceleration a over dt with a constant turn: r_p = 0, r_v = a dt / (a_max dt), r_θ =
// θ / (ω_max dt), no bias residual.
TEST(Priors, ImuGapPriorResidualsFollowTheMotionModel) {
  ImuGapPriorOptions o;
  o.max_acc = 2.0;
  o.max_rate = 1.0;
  const double dt = 3.0;
  const Vec3 acc(0.5, -0.2, 0.1), v0(1.0, 0.0, 0.2), p0(1.0, 2.0, 1.5), turn(0.0, 0.0, 0.6);
  KeyframeState a, b;
  a.SetT_W_B(Rigid3(Mat3::Identity(), p0));
  VelocityOf(a.speed_bias) = v0;
  b.SetT_W_B(Rigid3(ExpSO3(turn), p0 + v0 * dt + 0.5 * acc * dt * dt));
  VelocityOf(b.speed_bias) = v0 + acc * dt;
  std::unique_ptr<ceres::CostFunction> prior(MakeImuGapPrior(dt, o));
  Eigen::Matrix<double, 15, 1> r;
  const double* params[] = {a.pose, a.speed_bias, b.pose, b.speed_bias};
  ASSERT_TRUE(prior->Evaluate(params, r.data(), nullptr));
  EXPECT_LT((r.segment<3>(0) - turn / (o.max_rate * dt)).norm(), 1e-9);
  EXPECT_LT((r.segment<3>(3) - acc / o.max_acc).norm(), 1e-9);
  EXPECT_LT(r.segment<3>(6).norm(), 1e-9);
  EXPECT_LT(r.tail<6>().norm(), 1e-12);
}

}  // namespace
}  // namespace fsp::backend
