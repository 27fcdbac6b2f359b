// The priors of priors.h: analytic (or automatic) Jacobians against central differences through
// each block's manifold, and the residuals the IMU-gap motion prior is documented to give.
#include <array>
#include <cmath>
#include <memory>
#include <random>

#include <gtest/gtest.h>

#include "fsp/backend/fsp_landmark.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/priors.h"
#include "fsp/backend/reanchor.h"
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

// FHP's width prior: the residual is log(w / w_prior) / σ with w = FhpLandmark::Width(), the same
// for any anchor of the same corners, and its automatic Jacobians agree with central differences.
TEST(Priors, FhpLogWidthPriorFollowsTheCornersWidth) {
  const Rigid3 T_F_O(RotFromRpy(0.1, -0.3, 0.2), Vec3(-0.4, 0.2, 3.0));
  std::array<Vec3, 4> p_F;
  const double w = 1.3, h = 0.8;
  const double xi[4] = {0.0, 1.0, 1.0, 0.0}, eta[4] = {0.0, 0.0, 1.0, 1.0};
  for (int j = 0; j < 4; ++j) p_F[j] = T_F_O * Vec3(xi[j] * w, eta[j] * h, 0.0);
  FhpLandmark l = FhpLandmark::FromCornersF(p_F);
  l.corner[2][2] += 0.3;  // not a rectangle any more: the width is the mean of the two edges
  const double sigma = 0.5;
  std::unique_ptr<ceres::CostFunction> prior(MakeFhpLogWidthPrior(1.0, sigma));
  const auto residual = [&](const FhpLandmark& m) {
    double r = 0.0;
    const double* params[] = {m.corner[0], m.corner[1], m.corner[2], m.corner[3]};
    EXPECT_TRUE(prior->Evaluate(params, &r, nullptr));
    return r;
  };
  EXPECT_NEAR(residual(l), std::log(l.Width()) / sigma, 1e-12);
  EXPECT_GT(std::abs(std::log(l.Width() / w)), 0.01);  // the edit changed the width
  // Another anchor, the same corners: the same residual.
  const Rigid3 T_W_F(RotFromRpy(0.0, 0.2, 1.0), Vec3(1.0, 2.0, 0.5));
  const Rigid3 T_W_Fnew(RotFromRpy(0.1, 0.0, 0.6), Vec3(2.0, 1.0, 0.3));
  FhpLandmark moved;
  ASSERT_TRUE(ReanchorFhp(l, T_W_F, T_W_Fnew, &moved));
  EXPECT_NEAR(residual(moved), residual(l), 1e-12);
  EXPECT_TRUE(test::ExpectJacobiansOk(*prior, {l.corner[0], l.corner[1], l.corner[2], l.corner[3]},
                                      {nullptr, nullptr, nullptr, nullptr}, 1e-6));
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

TEST(Priors, RelativePosePriorJacobiansMatchNumeric) {
  std::mt19937 rng(11);
  PoseManifold pose_manifold;
  for (int trial = 0; trial < 6; ++trial) {
    KeyframeState a = RandomState(rng), b = RandomState(rng);
    const Rigid3 T_a_b(ExpSO3(RandomVec(rng, 1.0)), RandomVec(rng, 2.0));
    for (bool free_length : {false, true}) {
      std::unique_ptr<ceres::CostFunction> prior(
          MakeRelativePosePrior(T_a_b, 0.01, 0.002, free_length));
      EXPECT_TRUE(
          test::ExpectJacobiansOk(*prior, {a.pose, b.pose}, {&pose_manifold, &pose_manifold}, 1e-5))
          << "trial " << trial << (free_length ? ", free length" : "");
    }
  }
}

// With the length free, the pair's relative pose scaled along its translation (a longer or shorter
// step in the same direction) gives no residual; a step across it is penalised as with the
// whole prior.
TEST(Priors, RelativePosePriorWithFreeLengthHoldsOnlyTheDirection) {
  const Rigid3 T_a_b(ExpSO3(Vec3(0.1, -0.2, 0.3)), Vec3(0.5, 0.1, -0.2));
  const double sigma_p = 0.01, sigma_rot = 0.002;
  std::unique_ptr<ceres::CostFunction> free(
      MakeRelativePosePrior(T_a_b, sigma_p, sigma_rot, /*free_length=*/true));
  std::unique_ptr<ceres::CostFunction> whole(MakeRelativePosePrior(T_a_b, sigma_p, sigma_rot));
  const Rigid3 T_W_a(ExpSO3(Vec3(0.4, 0.2, -1.0)), Vec3(1.0, 2.0, 0.5));
  const auto residual = [&](const ceres::CostFunction& prior, const Rigid3& T_a_b_now) {
    KeyframeState a, b;
    a.SetT_W_B(T_W_a);
    b.SetT_W_B(T_W_a * T_a_b_now);
    Eigen::Matrix<double, 6, 1> r;
    const double* params[] = {a.pose, b.pose};
    EXPECT_TRUE(prior.Evaluate(params, r.data(), nullptr));
    return r;
  };
  const Rigid3 longer(T_a_b.rotation(), 1.3 * T_a_b.translation());
  EXPECT_LT(residual(*free, longer).norm(), 1e-9);
  EXPECT_GT(residual(*whole, longer).norm(), 10.0);
  const Vec3 across = T_a_b.translation().cross(Vec3::UnitZ()).normalized() * 0.003;
  const Rigid3 sideways(T_a_b.rotation(), T_a_b.translation() + across);
  EXPECT_LT((residual(*free, sideways).head<3>() - across / sigma_p).norm(), 1e-6);
  EXPECT_LT((residual(*free, sideways) - residual(*whole, sideways)).norm(), 1e-6);
}

// The relative pose it was made from gives no residual, wherever the pair is in the world; a
// translation error d in the first body's frame gives d / σ_p, a turn θ of the second body about
// its own axis gives θ / σ_θ.
TEST(Priors, RelativePosePriorResidualsAreInTheFirstBodysFrame) {
  std::mt19937 rng(12);
  const Rigid3 T_a_b(ExpSO3(Vec3(0.1, -0.2, 0.3)), Vec3(0.5, 0.1, -0.2));
  const double sigma_p = 0.01, sigma_rot = 0.002;
  std::unique_ptr<ceres::CostFunction> prior(MakeRelativePosePrior(T_a_b, sigma_p, sigma_rot));
  const auto residual = [&](const Rigid3& T_W_a, const Rigid3& T_W_b) {
    KeyframeState a, b;
    a.SetT_W_B(T_W_a);
    b.SetT_W_B(T_W_b);
    Eigen::Matrix<double, 6, 1> r;
    const double* params[] = {a.pose, b.pose};
    EXPECT_TRUE(prior->Evaluate(params, r.data(), nullptr));
    return r;
  };
  for (int trial = 0; trial < 4; ++trial) {
    const Rigid3 T_W_a(ExpSO3(RandomVec(rng, 2.0)), RandomVec(rng, 5.0));
    EXPECT_LT(residual(T_W_a, T_W_a * T_a_b).norm(), 1e-9);
    const Vec3 d(0.003, -0.001, 0.002);
    const Rigid3 T_W_b = T_W_a * T_a_b;
    const Eigen::Matrix<double, 6, 1> rt =
        residual(T_W_a, Rigid3(T_W_b.rotation(), T_W_b.translation() + T_W_a.rotation() * d));
    EXPECT_LT((rt.head<3>() - d / sigma_p).norm(), 1e-6);
    const Vec3 theta(0.0, 0.001, -0.002);
    const Eigen::Matrix<double, 6, 1> rr =
        residual(T_W_a, T_W_b * Rigid3(ExpSO3(theta), Vec3::Zero()));
    EXPECT_LT(rr.head<3>().norm(), 1e-9);
    EXPECT_LT((rr.tail<3>() - theta / sigma_rot).norm(), 1e-4);
  }
}

}  // namespace
}  // namespace fsp::backend
