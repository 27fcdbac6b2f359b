// Point features in anchored inverse depth (point_factor.h): Jacobians against central
// differences in the tangent space and ceres::GradientChecker, the prediction against a direct
// projection, ρ-independence at C = F, and ρ recovered from two views with known poses.
#include <cmath>
#include <random>
#include <vector>

#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <gtest/gtest.h>

#include "backend/landmark_scene.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/point_factor.h"

namespace fsp::backend {
namespace {

// A point 1-8 m in front of an anchor camera, seen from a second camera looking at it.
struct PointScene {
  Rigid3 T_B_C, T_W_F, T_W_C;
  Vec3 p_W;
  Vec3 bearing_F;  // (x, y, 1)
  double rho = 0.0;
  double pose_cam[7], pose_anchor[7];
};

PointScene MakePointScene(std::mt19937& rng) {
  PointScene s;
  const test::TestObject o = test::RandomObject(rng);
  s.T_B_C = test::TestT_B_C();
  s.T_W_F = test::CameraLookingAt(rng, o, test::Uniform(rng, 1.0, 8.0), 1.0, 0.3);
  s.T_W_C = test::CameraLookingAt(rng, o, test::Uniform(rng, 1.0, 8.0), 1.0, 0.3);
  s.p_W = o.Corner(static_cast<int>(rng() % 4));
  const Vec3 p_F = s.T_W_F.Inverse() * s.p_W;
  s.bearing_F = p_F / p_F.z();
  s.rho = 1.0 / p_F.z();
  PoseToBlock(s.T_W_C * s.T_B_C.Inverse(), s.pose_cam);
  PoseToBlock(s.T_W_F * s.T_B_C.Inverse(), s.pose_anchor);
  return s;
}

Vec2 Project(const Mat3& K, const Rigid3& T_W_C, const Vec3& p_W) {
  const Vec3 p = K * (T_W_C.Inverse() * p_W);
  return p.head<2>() / p.z();
}

TEST(PointFactor, PredictionIsTheProjection) {
  std::mt19937 rng(61);
  const Mat3 K = test::TestK();
  for (int trial = 0; trial < 20; ++trial) {
    const PointScene s = MakePointScene(rng);
    const PointPrediction p = PredictPoint(K, s.T_W_C, s.T_W_F, s.bearing_F, s.rho);
    ASSERT_TRUE(p.in_front);
    EXPECT_LT((p.uv - Project(K, s.T_W_C, s.p_W)).norm(), 1e-9);
    EXPECT_NEAR(p.h_z, s.rho * (s.T_W_C.Inverse() * s.p_W).z(), 1e-12);
    // The factor with the exact observation: zero residual.
    PointFactor f(Project(K, s.T_W_C, s.p_W), s.bearing_F, K, s.T_B_C, FspFactorOptions());
    double rho = s.rho, r[2];
    const double* params[3] = {s.pose_cam, s.pose_anchor, &rho};
    ASSERT_TRUE(f.Evaluate(params, r, nullptr));
    EXPECT_LT(std::hypot(r[0], r[1]), 1e-8);
  }
}

TEST(PointFactor, JacobiansMatchNumericAndGradientChecker) {
  std::mt19937 rng(67);
  const Mat3 K = test::TestK();
  PoseManifold pose_manifold;
  std::normal_distribution<double> n(0.0, 3.0);
  int evaluated = 0;
  for (int trial = 0; trial < 20; ++trial) {
    PointScene s = MakePointScene(rng);
    FspFactorOptions o;
    o.sigma_px = 0.7;
    const Vec2 obs = Project(K, s.T_W_C, s.p_W) + Vec2(n(rng), n(rng));
    PointFactor factor(obs, s.bearing_F, K, s.T_B_C, o);
    double rho = s.rho * test::Uniform(rng, 0.7, 1.4);  // away from the minimum
    if (!PredictPoint(K, s.T_W_C, s.T_W_F, s.bearing_F, rho).in_front) continue;
    ++evaluated;
    std::vector<double*> params = {s.pose_cam, s.pose_anchor, &rho};
    std::vector<const ceres::Manifold*> manifolds = {&pose_manifold, &pose_manifold, nullptr};
    EXPECT_TRUE(test::ExpectFactorJacobiansOk(factor, params, manifolds, 1e-5))
        << "trial " << trial;
  }
  EXPECT_GE(evaluated, 15);
}

TEST(PointFactor, AtAnchorIndependentOfRho) {
  std::mt19937 rng(71);
  const Mat3 K = test::TestK();
  for (int trial = 0; trial < 8; ++trial) {
    PointScene s = MakePointScene(rng);
    const Vec2 obs = Project(K, s.T_W_F, s.p_W);
    PointFactor f(obs, s.bearing_F, K, s.T_B_C, FspFactorOptions());
    for (double rho : {0.02, 0.3, 1.0, 5.0}) {
      double r[2];
      const double* params[3] = {s.pose_anchor, s.pose_anchor, &rho};
      ASSERT_TRUE(f.Evaluate(params, r, nullptr));
      EXPECT_LT(std::hypot(r[0], r[1]), 1e-8) << "rho " << rho;
    }
  }
}

TEST(PointFactor, BehindTheCameraFails) {
  std::mt19937 rng(73);
  const Mat3 K = test::TestK();
  PointScene s = MakePointScene(rng);
  PointFactor f(Vec2(320.0, 240.0), s.bearing_F, K, s.T_B_C, FspFactorOptions());
  // The camera turned around (yaw by pi about its own y axis): the point is behind it.
  const Rigid3 T_W_Cback = s.T_W_F * Rigid3(RotFromRpy(0.0, M_PI, 0.0), Vec3::Zero());
  double pose_back[7];
  PoseToBlock(T_W_Cback * s.T_B_C.Inverse(), pose_back);
  double rho = s.rho, r[2];
  const double* params[3] = {pose_back, s.pose_anchor, &rho};
  EXPECT_FALSE(f.Evaluate(params, r, nullptr));
}

TEST(PointFactor, RecoversInverseDepthWithKnownPoses) {
  std::mt19937 rng(79);
  const Mat3 K = test::TestK();
  for (int trial = 0; trial < 10; ++trial) {
    PointScene s = MakePointScene(rng);
    // Enough baseline: skip pairs closer than 20 cm.
    if ((s.T_W_C.translation() - s.T_W_F.translation()).norm() < 0.2) continue;
    double rho = s.rho * 1.3;
    if (!PredictPoint(K, s.T_W_C, s.T_W_F, s.bearing_F, rho).in_front) continue;
    ceres::Problem problem;
    problem.AddResidualBlock(
        new PointFactor(Project(K, s.T_W_C, s.p_W), s.bearing_F, K, s.T_B_C, FspFactorOptions()),
        nullptr, s.pose_cam, s.pose_anchor, &rho);
    problem.SetParameterBlockConstant(s.pose_cam);
    problem.SetParameterBlockConstant(s.pose_anchor);
    ceres::Solver::Options so;
    so.max_num_iterations = 50;
    ceres::Solver::Summary sum;
    ceres::Solve(so, &problem, &sum);
    EXPECT_NEAR(rho, s.rho, 1e-6 * s.rho + 1e-9) << "trial " << trial;
  }
}

}  // namespace
}  // namespace fsp::backend
