// FSP landmark utilities and the FSP reprojection factor (both variants): conventions, Jacobians
// against central differences in the tangent space + ceres::GradientChecker, ω-independence at C =
// F, cheirality, and a small end-to-end solve with known poses.
#include <cmath>
#include <iostream>
#include <memory>
#include <random>

#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <gtest/gtest.h>

#include "backend/jacobian_check.h"
#include "backend/landmark_scene.h"
#include "fsp/backend/fsp_factor.h"
#include "fsp/backend/fsp_landmark.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/single_view_init.h"

namespace fsp::backend {
namespace {

using test::TestObject;

// Anchor and observing camera of one object, body poses from camera poses with a non-trivial T_B_C.
struct Scene {
  TestObject object;
  Rigid3 T_B_C;
  Rigid3 T_W_F, T_W_C;  // camera poses
  FspLandmark landmark;
  double pose_cam[7], pose_anchor[7];
};

Scene MakeScene(std::mt19937& rng) {
  Scene s;
  s.object = test::RandomObject(rng);
  s.T_B_C = test::TestT_B_C();
  s.T_W_F = test::CameraLookingAt(rng, s.object, test::Uniform(rng, 2.0, 6.0), 1.0, 0.3);
  s.T_W_C = test::CameraLookingAt(rng, s.object, test::Uniform(rng, 2.0, 6.0), 1.0, 0.3);
  s.landmark =
      FspLandmark::FromObject(s.T_W_F.Inverse() * s.object.T_W_O, s.object.width, s.object.height);
  PoseToBlock(s.T_W_C * s.T_B_C.Inverse(), s.pose_cam);
  PoseToBlock(s.T_W_F * s.T_B_C.Inverse(), s.pose_anchor);
  return s;
}

TEST(FspLandmark, FromObjectReproducesCornersAndSize) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const Scene s = MakeScene(rng);
    const auto corners = s.landmark.CornersW(s.T_W_F);
    for (int j = 0; j < 4; ++j) EXPECT_LT((corners[j] - s.object.Corner(j)).norm(), 1e-12);
    EXPECT_NEAR(s.landmark.Width(), s.object.width, 1e-12);
    EXPECT_NEAR(s.landmark.Height(), s.object.height, 1e-12);
    const Rigid3 T = s.landmark.T_W_O(s.T_W_F);
    EXPECT_LT((T.Matrix() - s.object.T_W_O.Matrix()).norm(), 1e-12);
    // s1 at depth 1/ω along F's optical axis.
    EXPECT_NEAR((s.T_W_F.Inverse() * s.object.Corner(0)).z(), 1.0 / s.landmark.Omega(), 1e-12);
  }
}

TEST(FspLandmark, SizeJacobianAndSigma) {
  std::mt19937 rng(13);
  const Scene s = MakeScene(rng);
  FspLandmark l = s.landmark;
  const Eigen::Matrix<double, 2, 5> J = l.SizeJacobian();
  for (int i = 0; i < 5; ++i) {
    FspLandmark p = l, m = l;
    p.x[i] += 1e-6;
    m.x[i] -= 1e-6;
    EXPECT_NEAR(J(0, i), (p.Width() - m.Width()) / 2e-6, 1e-8) << i;
    EXPECT_NEAR(J(1, i), (p.Height() - m.Height()) / 2e-6, 1e-8) << i;
  }
  // Only log ω uncertain (σ = 0.1): σ_w = 0.1 w, σ_h = 0.1 h.
  Eigen::Matrix<double, 5, 5> cov = Eigen::Matrix<double, 5, 5>::Zero();
  cov(kFspLogOmega, kFspLogOmega) = 0.01;
  const Eigen::Vector2d sigma = l.SizeSigma(cov);
  EXPECT_NEAR(sigma.x(), 0.1 * l.Width(), 1e-12);
  EXPECT_NEAR(sigma.y(), 0.1 * l.Height(), 1e-12);
}

TEST(FspLandmark, LeftRotationJacobianMatchesCeresPlus) {
  // J · PlusJacobian(q) = 2 I for ceres::EigenQuaternionManifold (Plus = Exp(2δ) on the left), and
  // the radial direction maps to zero: the Jacobian differentiates R(q/|q|).
  std::mt19937 rng(3);
  ceres::EigenQuaternionManifold m;
  for (int trial = 0; trial < 10; ++trial) {
    const Quat q = ExpQuat(test::RandomVec3(rng, 1.5));
    Eigen::Matrix<double, 4, 3, Eigen::RowMajor> P;
    ASSERT_TRUE(m.PlusJacobian(q.coeffs().data(), P.data()));
    const Mat34 J = LeftRotationJacobianWrtQuat(q);
    const Mat3 JP = J * P;
    const Vec3 radial = J * q.coeffs();
    EXPECT_LT((JP - 2.0 * Mat3::Identity()).norm(), 1e-12) << JP;
    EXPECT_LT(radial.norm(), 1e-12);
  }
}

TEST(FspFactor, ZeroResidualOnTruthMatchesIndependentProjection) {
  std::mt19937 rng(5);
  const Mat3 K = test::TestK();
  for (int trial = 0; trial < 20; ++trial) {
    Scene s = MakeScene(rng);
    const Corners obs = test::ProjectCorners(K, s.T_W_C, s.object);
    FspFactor factor(obs, K, s.T_B_C, FspFactorOptions());
    const double* params[4] = {s.pose_cam, s.pose_anchor, s.landmark.q_F_O, s.landmark.x};
    double r[8];
    ASSERT_TRUE(factor.Evaluate(params, r, nullptr));
    EXPECT_LT((Eigen::Map<Eigen::Matrix<double, 8, 1>>(r).norm()), 1e-8);
    const CornerPrediction pred = PredictFspCorners(K, s.T_W_C, s.T_W_F, s.landmark);
    EXPECT_TRUE(pred.in_front);
    for (int j = 0; j < 4; ++j) EXPECT_LT((pred.uv[j] - obs[j]).norm(), 1e-8);
  }
}

TEST(FspFactor, JacobiansMatchNumericAndGradientChecker) {
  std::mt19937 rng(17);
  const Mat3 K = test::TestK();
  PoseManifold pose_manifold;
  ceres::EigenQuaternionManifold quat_manifold;
  for (int trial = 0; trial < 20; ++trial) {
    Scene s = MakeScene(rng);
    const Corners obs = test::AddNoise(rng, test::ProjectCorners(K, s.T_W_C, s.object), 3.0);
    FspFactorOptions o;
    o.sigma_px = 1.3;
    FspFactor factor(obs, K, s.T_B_C, o);
    std::vector<double*> params = {s.pose_cam, s.pose_anchor, s.landmark.q_F_O, s.landmark.x};
    std::vector<const ceres::Manifold*> manifolds = {&pose_manifold, &pose_manifold, &quat_manifold,
                                                     nullptr};
    EXPECT_TRUE(test::ExpectFactorJacobiansOk(factor, params, manifolds, 1e-5))
        << "trial " << trial;
  }
}

TEST(FspAnchorFactor, JacobiansMatchNumericAndGradientChecker) {
  std::mt19937 rng(19);
  const Mat3 K = test::TestK();
  ceres::EigenQuaternionManifold quat_manifold;
  for (int trial = 0; trial < 20; ++trial) {
    Scene s = MakeScene(rng);
    const Corners obs = test::AddNoise(rng, test::ProjectCorners(K, s.T_W_F, s.object), 3.0);
    FspAnchorFactor factor(obs, K, FspFactorOptions());
    std::vector<double*> params = {s.landmark.q_F_O, s.landmark.x};
    std::vector<const ceres::Manifold*> manifolds = {&quat_manifold, nullptr};
    EXPECT_TRUE(test::ExpectFactorJacobiansOk(factor, params, manifolds, 1e-5))
        << "trial " << trial;
  }
}

// An object partly in view: the corners not seen have residual and Jacobian rows 0 (also where
// they would lie behind the camera), the seen ones are the whole factor's; the Jacobians of both
// variants still match numeric differentiation.
TEST(FspFactor, CornersNotSeenGiveZeroRowsAndTheOthersAreUnchanged) {
  std::mt19937 rng(31);
  const Mat3 K = test::TestK();
  PoseManifold pose_manifold;
  ceres::EigenQuaternionManifold quat_manifold;
  const CornerMask seen = {true, false, true, false};
  for (int trial = 0; trial < 10; ++trial) {
    Scene s = MakeScene(rng);
    const Corners obs = test::AddNoise(rng, test::ProjectCorners(K, s.T_W_C, s.object), 3.0);
    FspFactor whole(obs, K, s.T_B_C, FspFactorOptions());
    FspFactor part(obs, K, s.T_B_C, FspFactorOptions(), seen);
    const double* p[4] = {s.pose_cam, s.pose_anchor, s.landmark.q_F_O, s.landmark.x};
    double r_whole[8], r_part[8];
    Eigen::Matrix<double, 8, 7, Eigen::RowMajor> J_whole, J_part;
    J_part.setConstant(7.0);  // rows of unseen corners must be overwritten with 0
    double* jw[4] = {J_whole.data(), nullptr, nullptr, nullptr};
    double* jp[4] = {J_part.data(), nullptr, nullptr, nullptr};
    ASSERT_TRUE(whole.Evaluate(p, r_whole, jw));
    ASSERT_TRUE(part.Evaluate(p, r_part, jp));
    for (int j = 0; j < 4; ++j) {
      for (int k = 0; k < 2; ++k) {
        const int i = 2 * j + k;
        EXPECT_EQ(r_part[i], seen[j] ? r_whole[i] : 0.0) << "trial " << trial << " row " << i;
        if (seen[j])
          EXPECT_TRUE(J_part.row(i) == J_whole.row(i)) << "trial " << trial << " row " << i;
        else
          EXPECT_TRUE(J_part.row(i).isZero(0.0)) << "trial " << trial << " row " << i;
      }
    }
    std::vector<double*> params = {s.pose_cam, s.pose_anchor, s.landmark.q_F_O, s.landmark.x};
    EXPECT_TRUE(test::ExpectFactorJacobiansOk(
        part, params, {&pose_manifold, &pose_manifold, &quat_manifold, nullptr}, 1e-5));
    FspAnchorFactor anchor(obs, K, FspFactorOptions(), seen);
    std::vector<double*> anchor_params = {s.landmark.q_F_O, s.landmark.x};
    EXPECT_TRUE(
        test::ExpectFactorJacobiansOk(anchor, anchor_params, {&quat_manifold, nullptr}, 1e-5));
  }
  // A corner not seen may lie behind the camera: the factor still evaluates.
  Scene s = MakeScene(rng);
  const Corners obs = test::ProjectCorners(K, s.T_W_C, s.object);
  FspFactor none_seen(obs, K, s.T_B_C, FspFactorOptions(), {false, false, false, false});
  const Rigid3 T_W_C_back = s.T_W_C * Rigid3(RotY(M_PI), Vec3::Zero());
  PoseToBlock(T_W_C_back * s.T_B_C.Inverse(), s.pose_cam);
  const double* p[4] = {s.pose_cam, s.pose_anchor, s.landmark.q_F_O, s.landmark.x};
  double r[8];
  EXPECT_TRUE(none_seen.Evaluate(p, r, nullptr));
  for (double v : r) EXPECT_EQ(v, 0.0);
}

TEST(FspFactor, AtAnchorPredictionIndependentOfOmegaAndEqualsAnchorVariant) {
  std::mt19937 rng(23);
  const Mat3 K = test::TestK();
  for (int trial = 0; trial < 10; ++trial) {
    Scene s = MakeScene(rng);
    const Corners obs = test::AddNoise(rng, test::ProjectCorners(K, s.T_W_F, s.object), 2.0);
    FspFactor general(obs, K, s.T_B_C, FspFactorOptions());
    FspAnchorFactor anchor(obs, K, FspFactorOptions());
    double pose_copy[7];
    std::copy(s.pose_anchor, s.pose_anchor + 7,
              pose_copy);  // C = F, two blocks with the same value
    double r_ref[8];
    {
      const double* p[2] = {s.landmark.q_F_O, s.landmark.x};
      ASSERT_TRUE(anchor.Evaluate(p, r_ref, nullptr));
    }
    for (double log_omega : {-3.0, -1.0, 0.0, 0.7, 2.5}) {
      s.landmark.x[kFspLogOmega] = log_omega;
      double r[8];
      Eigen::Matrix<double, 8, 5, Eigen::RowMajor> J_x;
      double* jac[4] = {nullptr, nullptr, nullptr, J_x.data()};
      const double* p[4] = {pose_copy, s.pose_anchor, s.landmark.q_F_O, s.landmark.x};
      ASSERT_TRUE(general.Evaluate(p, r, jac));
      for (int i = 0; i < 8; ++i) EXPECT_NEAR(r[i], r_ref[i], 1e-9) << "log ω " << log_omega;
      EXPECT_LT(J_x.col(kFspLogOmega).norm(), 1e-9);
    }
  }
}

TEST(FspFactor, CheiralityReturnsFalseBehindCamera) {
  std::mt19937 rng(29);
  const Mat3 K = test::TestK();
  Scene s = MakeScene(rng);
  const Corners obs = test::ProjectCorners(K, s.T_W_C, s.object);
  // Turn the observing camera around (yaw 180° about its own y axis): the object is behind it.
  const Rigid3 T_W_C_back = s.T_W_C * Rigid3(RotY(M_PI), Vec3::Zero());
  PoseToBlock(T_W_C_back * s.T_B_C.Inverse(), s.pose_cam);
  FspFactor factor(obs, K, s.T_B_C, FspFactorOptions());
  const double* params[4] = {s.pose_cam, s.pose_anchor, s.landmark.q_F_O, s.landmark.x};
  double r[8];
  EXPECT_FALSE(factor.Evaluate(params, r, nullptr));
  EXPECT_FALSE(PredictFspCorners(K, T_W_C_back, s.T_W_F, s.landmark).in_front);
}

TEST(RobustLoss, KneeAtKSigmaRmsPerCoordinate) {
  RobustLossOptions o;
  o.type = RobustLossOptions::Type::kHuber;
  o.k_sigma = 2.0;
  auto loss = MakeRobustLoss(o, 8);
  ASSERT_NE(loss, nullptr);
  double rho[3];
  const double knee = 2.0 * 2.0 * 8.0;  // s = k² d
  loss->Evaluate(0.9 * knee, rho);
  EXPECT_DOUBLE_EQ(rho[0], 0.9 * knee);  // quadratic inside
  loss->Evaluate(4.0 * knee, rho);
  EXPECT_LT(rho[0], 4.0 * knee);  // sub-quadratic outside
  EXPECT_LT(rho[1], 1.0);
  o.type = RobustLossOptions::Type::kNone;
  EXPECT_EQ(MakeRobustLoss(o, 8), nullptr);
  o.type = RobustLossOptions::Type::kCauchy;
  EXPECT_NE(MakeRobustLoss(o, 2), nullptr);
  std::string why;
  o.k_sigma = -1.0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_FALSE(why.empty());
}

// One object seen from 4 known cameras, noise-free corners. Initialised from the first view with a
// wrong ω (class prior for a door: 0.9 m, the object is not 0.9 m wide), solved with the poses
// fixed: the metric width and height become exact.
TEST(FspFactor, EndToEndKnownPosesRecoversMetricSize) {
  std::mt19937 rng(31);
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

    const SingleViewInitSummary init = InitializeFspSingleView(
        test::ProjectCorners(K, T_W_C[0], object), K, ObjectClass::kDoor, SingleViewInitOptions());
    ASSERT_TRUE(init.success()) << init.reason;
    FspLandmark l = init.landmark;
    ASSERT_GT(std::abs(l.Width() - object.width), 0.2);  // the prior is wrong

    ceres::Problem problem;
    problem.AddResidualBlock(
        new FspAnchorFactor(test::ProjectCorners(K, T_W_C[0], object), K, FspFactorOptions()),
        nullptr, l.q_F_O, l.x);
    for (size_t k = 1; k < T_W_C.size(); ++k) {
      problem.AddResidualBlock(
          new FspFactor(test::ProjectCorners(K, T_W_C[k], object), K, T_B_C, FspFactorOptions()),
          nullptr, poses[k].data(), poses[0].data(), l.q_F_O, l.x);
    }
    for (auto& p : poses) {
      problem.SetManifold(p.data(), MakePoseManifold().release());
      problem.SetParameterBlockConstant(p.data());
    }
    problem.SetManifold(l.q_F_O, new ceres::EigenQuaternionManifold());
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 50;
    so.function_tolerance = 1e-16;
    so.gradient_tolerance = 1e-16;
    so.parameter_tolerance = 1e-16;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    std::cout << "[end-to-end fsp] trial " << trial << ": width " << object.width << " init "
              << init.landmark.Width() << " -> " << l.Width() << ", height " << object.height
              << " -> " << l.Height() << ", iterations " << summary.iterations.size() << "\n";
    EXPECT_NEAR(l.Width(), object.width, 1e-6);
    EXPECT_NEAR(l.Height(), object.height, 1e-6);
    const auto corners = l.CornersW(T_W_C[0]);
    for (int j = 0; j < 4; ++j) EXPECT_LT((corners[j] - object.Corner(j)).norm(), 1e-6);
  }
}

}  // namespace
}  // namespace fsp::backend
