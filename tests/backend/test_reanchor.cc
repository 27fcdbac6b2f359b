// Exact re-anchoring: every predicted corner in every camera is unchanged (FSP and FHP), the metric
// size is kept, F -> F' -> F is the identity, and an anchor that cannot hold the object is refused.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "backend/landmark_scene.h"
#include "fsp/backend/fhp_factor.h"
#include "fsp/backend/fsp_factor.h"
#include "fsp/backend/reanchor.h"

namespace fsp::backend {
namespace {

using test::TestObject;

struct ReanchorScene {
  TestObject object;
  Rigid3 T_W_F, T_W_Fnew;
  std::vector<Rigid3> cameras;
};

ReanchorScene MakeReanchorScene(std::mt19937& rng) {
  ReanchorScene s;
  s.object = test::RandomObject(rng, 0.3, 2.0);
  s.T_W_F = test::CameraLookingAt(rng, s.object, test::Uniform(rng, 1.5, 8.0), 1.0, 0.5);
  s.T_W_Fnew = test::CameraLookingAt(rng, s.object, test::Uniform(rng, 1.5, 8.0), 1.0, 0.5);
  for (int k = 0; k < 5; ++k)
    s.cameras.push_back(
        test::CameraLookingAt(rng, s.object, test::Uniform(rng, 3.0, 10.0), 1.0, 0.5));
  return s;
}

TEST(Reanchor, FspPredictionsUnchanged) {
  std::mt19937 rng(101);
  const Mat3 K = test::TestK();
  const Rigid3 T_B_C = test::TestT_B_C();
  double worst_px = 0.0;
  for (int trial = 0; trial < 50; ++trial) {
    const ReanchorScene s = MakeReanchorScene(rng);
    // A landmark that is not the truth (perturbed), to show the transform is exact for any
    // parameters.
    FspLandmark l = FspLandmark::FromObject(s.T_W_F.Inverse() * s.object.T_W_O, s.object.width,
                                            s.object.height);
    l.x[kFspLogOmega] += 0.2;
    l.x[kFspLogForm] -= 0.1;
    FspLandmark moved;
    std::string why;
    ASSERT_TRUE(ReanchorFsp(l, s.T_W_F, s.T_W_Fnew, &moved, &why)) << why;
    EXPECT_NEAR(moved.Width(), l.Width(), 1e-12 * l.Width());
    EXPECT_NEAR(moved.Height(), l.Height(), 1e-12 * l.Height());
    EXPECT_NEAR(moved.Form(), l.Form(), 1e-15);
    const auto before = l.CornersW(s.T_W_F), after = moved.CornersW(s.T_W_Fnew);
    for (int j = 0; j < 4; ++j) EXPECT_LT((before[j] - after[j]).norm(), 1e-12);
    // s1 of the new landmark lies at depth 1/ω' along F's optical axis.
    EXPECT_NEAR((s.T_W_Fnew.Inverse() * before[0]).z() * moved.Omega(), 1.0, 1e-12);

    double pose_new[7], pose_old[7];
    PoseToBlock(s.T_W_Fnew * T_B_C.Inverse(), pose_new);
    PoseToBlock(s.T_W_F * T_B_C.Inverse(), pose_old);
    for (const Rigid3& T_W_C : s.cameras) {
      const CornerPrediction p0 = PredictFspCorners(K, T_W_C, s.T_W_F, l);
      const CornerPrediction p1 = PredictFspCorners(K, T_W_C, s.T_W_Fnew, moved);
      for (int j = 0; j < 4; ++j) {
        worst_px = std::max(worst_px, (p0.uv[j] - p1.uv[j]).norm());
        EXPECT_LT((p0.uv[j] - p1.uv[j]).norm(), 1e-9);
      }
      // Through the factor itself (body poses, non-trivial T_B_C): same residuals.
      double pose_cam[7];
      PoseToBlock(T_W_C * T_B_C.Inverse(), pose_cam);
      FspFactor f(p0.uv, K, T_B_C, FspFactorOptions());
      double r0[8], r1[8];
      const double* a0[4] = {pose_cam, pose_old, l.q_F_O, l.x};
      const double* a1[4] = {pose_cam, pose_new, moved.q_F_O, moved.x};
      ASSERT_TRUE(f.Evaluate(a0, r0, nullptr));
      ASSERT_TRUE(f.Evaluate(a1, r1, nullptr));
      for (int i = 0; i < 8; ++i) EXPECT_NEAR(r0[i], r1[i], 1e-9);
    }
    // Back to F: the original parameters.
    FspLandmark back;
    ASSERT_TRUE(ReanchorFsp(moved, s.T_W_Fnew, s.T_W_F, &back));
    EXPECT_LT(LogSO3(back.R_F_O().transpose() * l.R_F_O()).norm(), 1e-12);
    for (int i = 0; i < 5; ++i) EXPECT_NEAR(back.x[i], l.x[i], 1e-11) << i;
  }
  std::printf("[reanchor fsp] worst predicted-corner change %.3g px\n", worst_px);
}

TEST(Reanchor, FhpPredictionsUnchanged) {
  std::mt19937 rng(103);
  const Mat3 K = test::TestK();
  double worst_px = 0.0;
  for (int trial = 0; trial < 50; ++trial) {
    const ReanchorScene s = MakeReanchorScene(rng);
    FhpLandmark l = FhpLandmark::FromFsp(FspLandmark::FromObject(s.T_W_F.Inverse() * s.object.T_W_O,
                                                                 s.object.width, s.object.height));
    l.corner[2][2] += 0.15;  // not a rectangle any more: FHP does not care
    FhpLandmark moved;
    ASSERT_TRUE(ReanchorFhp(l, s.T_W_F, s.T_W_Fnew, &moved));
    const auto before = l.CornersW(s.T_W_F), after = moved.CornersW(s.T_W_Fnew);
    for (int j = 0; j < 4; ++j) EXPECT_LT((before[j] - after[j]).norm(), 1e-12);
    EXPECT_NEAR(moved.Width(), l.Width(), 1e-12);
    EXPECT_NEAR(moved.Height(), l.Height(), 1e-12);
    for (const Rigid3& T_W_C : s.cameras) {
      const CornerPrediction p0 = PredictFhpCorners(K, T_W_C, s.T_W_F, l);
      const CornerPrediction p1 = PredictFhpCorners(K, T_W_C, s.T_W_Fnew, moved);
      for (int j = 0; j < 4; ++j) {
        worst_px = std::max(worst_px, (p0.uv[j] - p1.uv[j]).norm());
        EXPECT_LT((p0.uv[j] - p1.uv[j]).norm(), 1e-9);
      }
    }
  }
  std::printf("[reanchor fhp] worst predicted-corner change %.3g px\n", worst_px);
}

TEST(Reanchor, RefusesAnchorThatSeesTheObjectFromBehind) {
  std::mt19937 rng(107);
  const ReanchorScene s = MakeReanchorScene(rng);
  const FspLandmark l =
      FspLandmark::FromObject(s.T_W_F.Inverse() * s.object.T_W_O, s.object.width, s.object.height);
  // The new anchor looks away from the object: s1 is behind it.
  const Rigid3 T_W_Fback = s.T_W_Fnew * Rigid3(RotY(M_PI), Vec3::Zero());
  FspLandmark out;
  out.x[0] = 123.0;
  std::string why;
  EXPECT_FALSE(ReanchorFsp(l, s.T_W_F, T_W_Fback, &out, &why));
  EXPECT_FALSE(why.empty());
  EXPECT_EQ(out.x[0], 123.0);  // untouched
  FhpLandmark fout;
  why.clear();
  EXPECT_FALSE(ReanchorFhp(FhpLandmark::FromFsp(l), s.T_W_F, T_W_Fback, &fout, &why));
  EXPECT_FALSE(why.empty());
}

}  // namespace
}  // namespace fsp::backend
