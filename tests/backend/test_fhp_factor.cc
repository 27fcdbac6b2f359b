// FHP landmark (the paper's baseline): utilities, per-corner factor Jacobians (tangent-space
// central differences + ceres::GradientChecker), ω-independence at C = F, cheirality, end-to-end
// with known poses.
#include <array>
#include <cmath>
#include <iostream>
#include <random>
#include <vector>

#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <gtest/gtest.h>

#include "backend/landmark_scene.h"
#include "fsp/backend/fhp_factor.h"
#include "fsp/backend/fsp_landmark.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/single_view_init.h"

namespace fsp::backend {
namespace {

using test::TestObject;

struct FhpScene {
  TestObject object;
  Rigid3 T_B_C, T_W_F, T_W_C;
  FhpLandmark landmark;
  double pose_cam[7], pose_anchor[7];
};

FhpScene MakeFhpScene(std::mt19937& rng) {
  FhpScene s;
  s.object = test::RandomObject(rng);
  s.T_B_C = test::TestT_B_C();
  s.T_W_F = test::CameraLookingAt(rng, s.object, test::Uniform(rng, 2.0, 6.0), 1.0, 0.3);
  s.T_W_C = test::CameraLookingAt(rng, s.object, test::Uniform(rng, 2.0, 6.0), 1.0, 0.3);
  std::array<Vec3, 4> p_F;
  const Rigid3 T_F_W = s.T_W_F.Inverse();
  for (int j = 0; j < 4; ++j) p_F[j] = T_F_W * s.object.Corner(j);
  s.landmark = FhpLandmark::FromCornersF(p_F);
  PoseToBlock(s.T_W_C * s.T_B_C.Inverse(), s.pose_cam);
  PoseToBlock(s.T_W_F * s.T_B_C.Inverse(), s.pose_anchor);
  return s;
}

TEST(FhpLandmark, CornersSizeAndPoseFromCorners) {
  std::mt19937 rng(41);
  for (int trial = 0; trial < 20; ++trial) {
    const FhpScene s = MakeFhpScene(rng);
    const auto corners = s.landmark.CornersW(s.T_W_F);
    for (int j = 0; j < 4; ++j) EXPECT_LT((corners[j] - s.object.Corner(j)).norm(), 1e-12);
    EXPECT_NEAR(s.landmark.Width(), s.object.width, 1e-12);
    EXPECT_NEAR(s.landmark.Height(), s.object.height, 1e-12);
    EXPECT_LT((s.landmark.T_W_O(s.T_W_F).Matrix() - s.object.T_W_O.Matrix()).norm(), 1e-12);
    // Same geometry through the FSP representation.
    const FspLandmark fsp = FspLandmark::FromObject(s.T_W_F.Inverse() * s.object.T_W_O,
                                                    s.object.width, s.object.height);
    const FhpLandmark from_fsp = FhpLandmark::FromFsp(fsp);
    for (int j = 0; j < 4; ++j) {
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(from_fsp.corner[j][k], s.landmark.corner[j][k], 1e-12);
    }
  }
}

TEST(FhpFactor, JacobiansMatchNumericAndGradientChecker) {
  std::mt19937 rng(43);
  const Mat3 K = test::TestK();
  PoseManifold pose_manifold;
  for (int trial = 0; trial < 20; ++trial) {
    FhpScene s = MakeFhpScene(rng);
    const Corners obs = test::AddNoise(rng, test::ProjectCorners(K, s.T_W_C, s.object), 3.0);
    const int j = trial % 4;
    FspFactorOptions o;
    o.sigma_px = 0.7;
    FhpFactor factor(obs[j], K, s.T_B_C, o);
    std::vector<double*> params = {s.pose_cam, s.pose_anchor, s.landmark.corner[j]};
    std::vector<const ceres::Manifold*> manifolds = {&pose_manifold, &pose_manifold, nullptr};
    EXPECT_TRUE(test::ExpectFactorJacobiansOk(factor, params, manifolds, 1e-5))
        << "trial " << trial;
  }
}

TEST(FhpAnchorFactor, JacobiansMatchNumericAndGradientChecker) {
  std::mt19937 rng(47);
  const Mat3 K = test::TestK();
  for (int trial = 0; trial < 8; ++trial) {
    FhpScene s = MakeFhpScene(rng);
    const Corners obs = test::AddNoise(rng, test::ProjectCorners(K, s.T_W_F, s.object), 3.0);
    const int j = trial % 4;
    FhpAnchorFactor factor(obs[j], K, FspFactorOptions());
    std::vector<double*> params = {s.landmark.corner[j]};
    std::vector<const ceres::Manifold*> manifolds = {nullptr};
    EXPECT_TRUE(test::ExpectFactorJacobiansOk(factor, params, manifolds, 1e-5))
        << "trial " << trial;
  }
}

TEST(FhpFactor, AtAnchorPredictionIndependentOfOmega) {
  std::mt19937 rng(53);
  const Mat3 K = test::TestK();
  for (int trial = 0; trial < 8; ++trial) {
    FhpScene s = MakeFhpScene(rng);
    const Corners obs = test::AddNoise(rng, test::ProjectCorners(K, s.T_W_F, s.object), 2.0);
    const int j = trial % 4;
    FhpFactor general(obs[j], K, s.T_B_C, FspFactorOptions());
    FhpAnchorFactor anchor(obs[j], K, FspFactorOptions());
    double pose_copy[7];
    std::copy(s.pose_anchor, s.pose_anchor + 7, pose_copy);
    double r_ref[2];
    {
      const double* p[1] = {s.landmark.corner[j]};
      ASSERT_TRUE(anchor.Evaluate(p, r_ref, nullptr));
    }
    for (double log_omega : {-3.0, -0.5, 0.0, 1.0, 2.5}) {
      s.landmark.corner[j][2] = log_omega;
      double r[2];
      Eigen::Matrix<double, 2, 3, Eigen::RowMajor> J;
      double* jac[3] = {nullptr, nullptr, J.data()};
      const double* p[3] = {pose_copy, s.pose_anchor, s.landmark.corner[j]};
      ASSERT_TRUE(general.Evaluate(p, r, jac));
      EXPECT_NEAR(r[0], r_ref[0], 1e-9);
      EXPECT_NEAR(r[1], r_ref[1], 1e-9);
      EXPECT_LT(J.col(2).norm(), 1e-9);
    }
  }
}

TEST(FhpFactor, ZeroResidualOnTruthAndCheirality) {
  std::mt19937 rng(59);
  const Mat3 K = test::TestK();
  FhpScene s = MakeFhpScene(rng);
  const Corners obs = test::ProjectCorners(K, s.T_W_C, s.object);
  const CornerPrediction pred = PredictFhpCorners(K, s.T_W_C, s.T_W_F, s.landmark);
  EXPECT_TRUE(pred.in_front);
  for (int j = 0; j < 4; ++j) {
    EXPECT_LT((pred.uv[j] - obs[j]).norm(), 1e-8);
    FhpFactor factor(obs[j], K, s.T_B_C, FspFactorOptions());
    const double* p[3] = {s.pose_cam, s.pose_anchor, s.landmark.corner[j]};
    double r[2];
    ASSERT_TRUE(factor.Evaluate(p, r, nullptr));
    EXPECT_LT(std::hypot(r[0], r[1]), 1e-8);
  }
  const Rigid3 T_W_C_back = s.T_W_C * Rigid3(RotY(M_PI), Vec3::Zero());
  PoseToBlock(T_W_C_back * s.T_B_C.Inverse(), s.pose_cam);
  FhpFactor factor(obs[0], K, s.T_B_C, FspFactorOptions());
  const double* p[3] = {s.pose_cam, s.pose_anchor, s.landmark.corner[0]};
  double r[2];
  EXPECT_FALSE(factor.Evaluate(p, r, nullptr));
  EXPECT_FALSE(PredictFhpCorners(K, T_W_C_back, s.T_W_F, s.landmark).in_front);
}

// The baseline on the same tiny problem as the FSP end-to-end test: 4 known cameras, noise-free
// corners, initialised from the first view with a wrong scale; width and height become exact.
TEST(FhpFactor, EndToEndKnownPosesRecoversMetricSize) {
  std::mt19937 rng(61);
  const Mat3 K = test::TestK();
  const Rigid3 T_B_C = test::TestT_B_C();
  for (int trial = 0; trial < 5; ++trial) {
    TestObject object = test::RandomObject(rng, 1.2, 2.0);
    std::vector<Rigid3> T_W_C;
    for (int k = 0; k < 4; ++k)
      T_W_C.push_back(test::CameraLookingAt(rng, object, test::Uniform(rng, 3.0, 5.0), 0.6));
    std::vector<std::array<double, 7>> poses(T_W_C.size());
    for (size_t k = 0; k < T_W_C.size(); ++k)
      PoseToBlock(T_W_C[k] * T_B_C.Inverse(), poses[k].data());

    const Corners first = test::ProjectCorners(K, T_W_C[0], object);
    const SingleViewInitSummary init =
        InitializeFspSingleView(first, K, ObjectClass::kWindow, SingleViewInitOptions());
    ASSERT_TRUE(init.success()) << init.reason;
    FhpLandmark l = FhpLandmark::FromFsp(init.landmark);
    ASSERT_GT(std::abs(l.Width() - object.width), 0.05);

    ceres::Problem problem;
    for (int j = 0; j < 4; ++j)
      problem.AddResidualBlock(new FhpAnchorFactor(first[j], K, FspFactorOptions()), nullptr,
                               l.corner[j]);
    for (size_t k = 1; k < T_W_C.size(); ++k) {
      const Corners obs = test::ProjectCorners(K, T_W_C[k], object);
      for (int j = 0; j < 4; ++j) {
        problem.AddResidualBlock(new FhpFactor(obs[j], K, T_B_C, FspFactorOptions()), nullptr,
                                 poses[k].data(), poses[0].data(), l.corner[j]);
      }
    }
    for (auto& p : poses) {
      problem.SetManifold(p.data(), MakePoseManifold().release());
      problem.SetParameterBlockConstant(p.data());
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 50;
    so.function_tolerance = 1e-16;
    so.gradient_tolerance = 1e-16;
    so.parameter_tolerance = 1e-16;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    std::cout << "[end-to-end fhp] trial " << trial << ": width " << object.width << " init "
              << FhpLandmark::FromFsp(init.landmark).Width() << " -> " << l.Width() << ", height "
              << object.height << " -> " << l.Height() << ", iterations "
              << summary.iterations.size() << "\n";
    EXPECT_NEAR(l.Width(), object.width, 1e-6);
    EXPECT_NEAR(l.Height(), object.height, 1e-6);
    const auto corners = l.CornersW(T_W_C[0]);
    for (int j = 0; j < 4; ++j) EXPECT_LT((corners[j] - object.Corner(j)).norm(), 1e-6);
  }
}

}  // namespace
}  // namespace fsp::backend
