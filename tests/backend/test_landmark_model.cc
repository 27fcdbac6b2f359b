// The estimator's landmark-model interface (backend/src/landmark_model.h), FSP and FHP: the same
// rectangle gives the same prediction, pose and size in both; re-anchoring keeps the prediction and
// refuses an anchor the object is behind; an observation adds each model's blocks, factors and
// depth bounds (zero residual at the truth), nothing when behind the camera; both have a width
// prior; the scale block is FSP's only; FSP's size σ agrees with FspLandmark::SizeSigma.
#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "backend/landmark_scene.h"
#include "landmark_model.h"

namespace fsp::backend::internal {
namespace {

using test::TestObject;

struct Scene {
  TestObject object;
  Rigid3 T_W_F;  // anchor camera
  std::vector<Rigid3> cameras;
  FspLandmark truth;  // anchored at T_W_F
};

Scene MakeScene(std::mt19937& rng) {
  Scene s;
  // Every corner further than 1.7 m from every camera (half-diagonal <= 1.2 m, tilt <= 0.8 rad).
  s.object = test::RandomObject(rng, 0.3, 1.0);
  s.T_W_F = test::CameraLookingAt(rng, s.object, test::Uniform(rng, 2.5, 6.0), 0.8, 0.3);
  for (int k = 0; k < 4; ++k)
    s.cameras.push_back(
        test::CameraLookingAt(rng, s.object, test::Uniform(rng, 2.5, 8.0), 0.8, 0.3));
  s.truth =
      FspLandmark::FromObject(s.T_W_F.Inverse() * s.object.T_W_O, s.object.width, s.object.height);
  return s;
}

LandmarkContext Context(ceres::Manifold* quaternion_manifold) {
  LandmarkContext c;
  c.K = test::TestK();
  c.T_B_C = test::TestT_B_C();
  c.quaternion_manifold = quaternion_manifold;
  return c;
}

// A problem that leaves the manifolds to the test (they live on its stack).
ceres::Problem::Options KeepManifolds() {
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return po;
}

// The nearest and furthest corner depth in the anchor camera.
std::pair<double, double> CornerDepthRange(const Scene& s) {
  double nearest = 1e9, furthest = 0.0;
  for (int j = 0; j < 4; ++j) {
    const double z = (s.T_W_F.Inverse() * s.object.Corner(j)).z();
    nearest = std::min(nearest, z);
    furthest = std::max(furthest, z);
  }
  return {nearest, furthest};
}

double MaxCornerDistancePx(const Corners& a, const Corners& b) {
  double d = 0.0;
  for (int j = 0; j < 4; ++j) d = std::max(d, (a[j] - b[j]).norm());
  return d;
}

TEST(LandmarkModel, SameRectangleSameGeometryInBothModels) {
  std::mt19937 rng(7);
  const Mat3 K = test::TestK();
  for (int trial = 0; trial < 20; ++trial) {
    const Scene s = MakeScene(rng);
    const Landmark fsp = Landmark::FromSingleView(LandmarkType::kFsp, s.truth);
    const Landmark fhp = Landmark::FromSingleView(LandmarkType::kFhp, s.truth);
    for (const Rigid3& T_W_C : s.cameras) {
      const CornerPrediction a = fsp.Predict(K, T_W_C, s.T_W_F), b = fhp.Predict(K, T_W_C, s.T_W_F);
      ASSERT_TRUE(a.in_front && b.in_front);
      EXPECT_LT(MaxCornerDistancePx(a.uv, test::ProjectCorners(K, T_W_C, s.object)), 1e-8);
      EXPECT_LT(MaxCornerDistancePx(a.uv, b.uv), 1e-8);
    }
    const auto [w_fsp, h_fsp] = fsp.Size();
    const auto [w_fhp, h_fhp] = fhp.Size();
    EXPECT_NEAR(w_fsp, s.object.width, 1e-9);
    EXPECT_NEAR(h_fsp, s.object.height, 1e-9);
    EXPECT_NEAR(w_fhp, s.object.width, 1e-9);
    EXPECT_NEAR(h_fhp, s.object.height, 1e-9);
    const auto cf = fsp.CornersW(s.T_W_F), ch = fhp.CornersW(s.T_W_F);
    for (int j = 0; j < 4; ++j) {
      EXPECT_LT((cf[j] - s.object.Corner(j)).norm(), 1e-9);
      EXPECT_LT((ch[j] - s.object.Corner(j)).norm(), 1e-9);
    }
    for (const Landmark* l : {&fsp, &fhp}) {
      const Rigid3 T = l->T_W_O(s.T_W_F);
      EXPECT_LT((T.translation() - s.object.T_W_O.translation()).norm(), 1e-9);
      EXPECT_LT((T.R() - s.object.T_W_O.R()).norm(), 1e-9);
    }
    EXPECT_NE(fsp.ScaleBlock(), nullptr);
    EXPECT_EQ(fhp.ScaleBlock(), nullptr);
  }
}

TEST(LandmarkModel, ReanchorKeepsPredictionAndRefusesAnchorBehind) {
  std::mt19937 rng(8);
  const Mat3 K = test::TestK();
  for (int trial = 0; trial < 20; ++trial) {
    const Scene s = MakeScene(rng);
    const Rigid3 T_W_Fnew = s.cameras[0];
    // Looking away from the object: every corner behind the new anchor.
    const Rigid3 T_W_Fbehind(s.T_W_F.R() * RotY(M_PI), s.T_W_F.translation());
    for (const LandmarkType type : {LandmarkType::kFsp, LandmarkType::kFhp}) {
      const Landmark l = Landmark::FromSingleView(type, s.truth);
      Landmark moved = l;
      ASSERT_TRUE(moved.Reanchor(s.T_W_F, T_W_Fnew));
      for (const Rigid3& T_W_C : s.cameras)
        EXPECT_LT(MaxCornerDistancePx(l.Predict(K, T_W_C, s.T_W_F).uv,
                                      moved.Predict(K, T_W_C, T_W_Fnew).uv),
                  1e-8);
      Landmark refused = l;
      EXPECT_FALSE(refused.Reanchor(s.T_W_F, T_W_Fbehind));
      const auto a = l.CornersW(s.T_W_F), b = refused.CornersW(s.T_W_F);
      for (int j = 0; j < 4; ++j) EXPECT_EQ(a[j], b[j]);  // untouched
    }
  }
}

TEST(LandmarkModel, ObservationAddsBlocksFactorsAndDepthBounds) {
  std::mt19937 rng(9);
  ceres::EigenQuaternionManifold quat;
  const LandmarkContext c = Context(&quat);
  const Scene s = MakeScene(rng);
  const Rigid3 T_W_C = s.cameras[0];
  double cam_pose[7], anchor_pose[7];
  PoseToBlock(T_W_C * c.T_B_C.Inverse(), cam_pose);
  PoseToBlock(s.T_W_F * c.T_B_C.Inverse(), anchor_pose);
  const Corners z = test::ProjectCorners(c.K, T_W_C, s.object);
  const Corners z_anchor = test::ProjectCorners(c.K, s.T_W_F, s.object);
  struct Expected {
    LandmarkType type;
    int blocks_per_view, landmark_blocks, prior_blocks;  // residual blocks / parameter blocks
  };
  for (const Expected e :
       {Expected{LandmarkType::kFsp, 1, 2, 1}, Expected{LandmarkType::kFhp, 4, 4, 1}}) {
    Landmark l = Landmark::FromSingleView(e.type, s.truth);
    ceres::Problem problem(KeepManifolds());
    EXPECT_FALSE(l.InProblem(problem));
    l.AddWidthPrior(&problem, s.object.width, c);
    EXPECT_EQ(problem.NumResidualBlocks(), 0);  // not in the problem yet
    ASSERT_TRUE(
        l.AddObservation(&problem, z, kAllCorners, cam_pose, anchor_pose, T_W_C, s.T_W_F, c));
    EXPECT_TRUE(l.InProblem(problem));
    EXPECT_EQ(problem.NumResidualBlocks(), e.blocks_per_view);
    EXPECT_EQ(problem.NumResiduals(), 8);
    EXPECT_EQ(problem.NumParameterBlocks(), 2 + e.landmark_blocks);
    // The anchor's own view: the anchor factor(s), on the landmark's blocks only.
    ASSERT_TRUE(l.AddObservation(&problem, z_anchor, kAllCorners, anchor_pose, anchor_pose, s.T_W_F,
                                 s.T_W_F, c));
    EXPECT_EQ(problem.NumResidualBlocks(), 2 * e.blocks_per_view);
    EXPECT_EQ(problem.NumParameterBlocks(), 2 + e.landmark_blocks);
    double cost = -1.0;
    ASSERT_TRUE(
        problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr));
    EXPECT_LT(cost, 1e-16);  // the truth
    l.AddWidthPrior(&problem, s.object.width, c);
    EXPECT_EQ(problem.NumResidualBlocks(), 2 * e.blocks_per_view + e.prior_blocks);
    EXPECT_TRUE(l.DepthInBox(c.min_depth_m, c.max_depth_m));
    EXPECT_FALSE(l.DepthInBox(c.min_depth_m, 0.5 * c.min_depth_m + 0.5));  // box nearer than it
    // Behind the camera: nothing added.
    const Rigid3 T_W_Cbehind(T_W_C.R() * RotY(M_PI), T_W_C.translation());
    double behind_pose[7];
    PoseToBlock(T_W_Cbehind * c.T_B_C.Inverse(), behind_pose);
    const int before = problem.NumResidualBlocks();
    EXPECT_FALSE(l.AddObservation(&problem, z, kAllCorners, behind_pose, anchor_pose, T_W_Cbehind,
                                  s.T_W_F, c));
    EXPECT_EQ(problem.NumResidualBlocks(), before);
  }
}

TEST(LandmarkModel, DepthOutsideTheBoxIsClampedOntoIt) {
  std::mt19937 rng(10);
  ceres::EigenQuaternionManifold quat;
  LandmarkContext c = Context(&quat);
  const Scene s = MakeScene(rng);
  double anchor_pose[7];
  PoseToBlock(s.T_W_F * c.T_B_C.Inverse(), anchor_pose);
  const Corners z = test::ProjectCorners(c.K, s.T_W_F, s.object);
  const double nearest = CornerDepthRange(s).first;
  c.max_depth_m = 0.5 * nearest;  // every corner too far
  c.min_depth_m = 0.5 * c.max_depth_m;
  for (const LandmarkType type : {LandmarkType::kFsp, LandmarkType::kFhp}) {
    Landmark l = Landmark::FromSingleView(type, s.truth);
    ceres::Problem problem(KeepManifolds());
    ASSERT_TRUE(
        l.AddObservation(&problem, z, kAllCorners, anchor_pose, anchor_pose, s.T_W_F, s.T_W_F, c));
    // On the far bound (not strictly inside), and the depth box no longer includes the truth.
    EXPECT_FALSE(l.DepthInBox(c.min_depth_m, c.max_depth_m));
    EXPECT_TRUE(l.DepthInBox(0.5 * c.min_depth_m, 2.0 * c.max_depth_m));
  }
}

// A landmark beyond the depth box is clamped onto it before the cheirality check: a camera between
// the clamped rectangle and the true one sees the true corners in front of it but the clamped ones
// behind, so its view is refused and the problem stays evaluable. Checked after the clamp instead,
// the view was added, and the solve failed at its first evaluation (the hall's FHP global solves).
TEST(LandmarkModel, ViewBehindTheClampedDepthIsRefused) {
  std::mt19937 rng(11);
  ceres::EigenQuaternionManifold quat;
  LandmarkContext c = Context(&quat);
  const Scene s = MakeScene(rng);
  const auto [nearest, furthest] = CornerDepthRange(s);
  c.max_depth_m = 0.5 * nearest;  // every corner too far
  c.min_depth_m = 0.5 * c.max_depth_m;
  // The camera 0.75 x nearest ahead of the anchor along its axis: the true corners lie in front of
  // it; clamped, FHP's corners sit at 0.5 x nearest and FSP's rectangle shrinks towards the anchor
  // by max_depth / depth of s1, both behind it.
  const Vec3 ahead = s.T_W_F.R() * Vec3(0.0, 0.0, 0.75 * nearest);
  const Rigid3 T_W_C(s.T_W_F.R(), s.T_W_F.translation() + ahead);
  const double s1_depth = (s.T_W_F.Inverse() * s.object.Corner(0)).z();
  ASSERT_LT(furthest * c.max_depth_m / s1_depth, 0.75 * nearest);
  double cam_pose[7], anchor_pose[7];
  PoseToBlock(T_W_C * c.T_B_C.Inverse(), cam_pose);
  PoseToBlock(s.T_W_F * c.T_B_C.Inverse(), anchor_pose);
  const Corners z = test::ProjectCorners(c.K, T_W_C, s.object);
  for (const LandmarkType type : {LandmarkType::kFsp, LandmarkType::kFhp}) {
    Landmark l = Landmark::FromSingleView(type, s.truth);
    ceres::Problem problem(KeepManifolds());
    EXPECT_FALSE(
        l.AddObservation(&problem, z, kAllCorners, cam_pose, anchor_pose, T_W_C, s.T_W_F, c))
        << static_cast<int>(type);
    EXPECT_EQ(problem.NumResidualBlocks(), 0);
    // The anchor's view goes in (on the clamped depth) and the problem evaluates.
    ASSERT_TRUE(l.AddObservation(&problem, test::ProjectCorners(c.K, s.T_W_F, s.object),
                                 kAllCorners, anchor_pose, anchor_pose, s.T_W_F, s.T_W_F, c));
    double cost = -1.0;
    EXPECT_TRUE(
        problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr));
  }
}

TEST(LandmarkModel, FspSizeSigmaMatchesTheLandmarksOwn) {
  std::mt19937 rng(11);
  ceres::EigenQuaternionManifold quat;
  const LandmarkContext c = Context(&quat);
  const Scene s = MakeScene(rng);
  Landmark l = Landmark::FromSingleView(LandmarkType::kFsp, s.truth);
  ceres::Problem problem(KeepManifolds());
  std::vector<std::array<double, 7>> poses(s.cameras.size() + 1);
  PoseToBlock(s.T_W_F * c.T_B_C.Inverse(), poses[0].data());
  problem.AddParameterBlock(poses[0].data(), 7);
  problem.SetParameterBlockConstant(poses[0].data());
  ASSERT_TRUE(l.AddObservation(&problem, test::ProjectCorners(c.K, s.T_W_F, s.object), kAllCorners,
                               poses[0].data(), poses[0].data(), s.T_W_F, s.T_W_F, c));
  for (size_t k = 0; k < s.cameras.size(); ++k) {
    double* pose = poses[k + 1].data();
    PoseToBlock(s.cameras[k] * c.T_B_C.Inverse(), pose);
    problem.AddParameterBlock(pose, 7);
    problem.SetParameterBlockConstant(pose);
    ASSERT_TRUE(l.AddObservation(&problem, test::ProjectCorners(c.K, s.cameras[k], s.object),
                                 kAllCorners, pose, poses[0].data(), s.cameras[k], s.T_W_F, c));
  }
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance covariance(co);
  std::vector<std::pair<const double*, const double*>> blocks;
  l.AppendCovarianceBlocks(&blocks);
  ASSERT_TRUE(covariance.Compute(blocks, &problem));
  const double* x = l.ScaleBlock();
  Eigen::Matrix<double, 5, 5, Eigen::RowMajor> C;
  covariance.GetCovarianceBlock(x, x, C.data());
  const FspLandmark& as_fsp = s.truth;  // l has the truth's values
  const Eigen::Vector2d expected = as_fsp.SizeSigma(C);
  MarginalCovariance mine;
  ASSERT_TRUE(mine.Compute(&problem, {x}));
  const auto [sw, sh] = l.SizeSigmas(mine);
  EXPECT_GT(sw, 0.0);
  EXPECT_NEAR(sw, expected[0], 1e-9 * expected[0]);
  EXPECT_NEAR(sh, expected[1], 1e-9 * expected[1]);
  // Var of ½ (log w + log h) = log w̄ − log ω − ½ log f.
  Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
  g[kFspLogWbar] = 1.0;
  g[kFspLogOmega] = -1.0;
  g[kFspLogForm] = -0.5;
  EXPECT_NEAR(l.ScaleCovariance(mine, l), g.dot(C * g), 1e-12);
}

}  // namespace
}  // namespace fsp::backend::internal
