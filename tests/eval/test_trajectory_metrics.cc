// Synthetic checks of association, alignment, ATE and RPE with known answers.
#include <cmath>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "fsp/common/error.h"
#include "fsp/common/time.h"
#include "fsp/eval/evaluate.h"
#include "fsp/eval/trajectory_metrics.h"
#include "test_util.h"

namespace fsp::eval {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A random trajectory: N poses 0.05 s apart, positions spread over a few metres, random
// orientations.
Trajectory RandomTrajectory(std::mt19937& rng, size_t n) {
  std::normal_distribution<double> pos(0.0, 2.0), rot(0.0, 1.0);
  Trajectory traj;
  traj.source = "random";
  for (size_t i = 0; i < n; ++i) {
    traj.t_ns.push_back(1'000'000'000 + static_cast<int64_t>(i) * 50'000'000);
    traj.t_s.push_back(static_cast<double>(traj.t_ns.back()) / 1e9);
    traj.T_W_B.push_back(
        Rigid3(ExpQuat(Vec3(rot(rng), rot(rng), rot(rng))), Vec3(pos(rng), pos(rng), pos(rng))));
  }
  return traj;
}

// The estimate seen in another world frame: P_i = G⁻¹ Q_i for the similarity G = (s, R, t), i.e.
// p_est = Rᵀ (p_ref − t) / s and R_est = Rᵀ R_ref, so that aligning it back must recover G.
Trajectory Transformed(const Trajectory& ref, double s, const Mat3& R, const Vec3& t) {
  Trajectory est = ref;
  est.source = "transformed";
  for (Rigid3& T : est.T_W_B)
    T = Rigid3(R.transpose() * T.R(), R.transpose() * (T.translation() - t) / s);
  return est;
}

Trajectory Timed(const std::vector<double>& t_s) {
  Trajectory traj;
  traj.source = "timed";
  for (size_t i = 0; i < t_s.size(); ++i) {
    traj.t_s.push_back(t_s[i]);
    traj.t_ns.push_back(static_cast<int64_t>(std::llround(t_s[i] * 1e9)));
    traj.T_W_B.push_back(
        Rigid3(Quat::Identity(), Vec3(static_cast<double>(i), std::sin(static_cast<double>(i)),
                                      0.1 * static_cast<double>(i * i))));
  }
  return traj;
}

TEST(Align, Se3IsRecoveredAndAteIsZero) {
  std::mt19937 rng(7);
  const Trajectory ref = RandomTrajectory(rng, 60);
  const Mat3 R = RotFromRpy(0.3, -0.7, 2.1);
  const Vec3 t(4.0, -2.0, 1.5);
  TrajectoryOptions options;
  options.align = AlignMode::kSe3;
  const auto m = EvaluateTrajectory(ref, Transformed(ref, 1.0, R, t), options);
  EXPECT_EQ(m.pairs, 60u);
  EXPECT_LT((m.alignment.R - R).norm(), 1e-9);
  EXPECT_LT((m.alignment.t - t).norm(), 1e-9);
  EXPECT_EQ(m.alignment.scale, 1.0);
  EXPECT_LT(m.ate.max, 1e-9);
  EXPECT_LT(m.rpe_trans.max, 1e-9);
  EXPECT_LT(m.rpe_rot.max, 1e-6);  // degrees
}

TEST(Align, Sim3IsRecoveredWithScale) {
  std::mt19937 rng(8);
  const Trajectory ref = RandomTrajectory(rng, 40);
  const Mat3 R = RotFromRpy(-1.0, 0.2, -2.5);
  const Vec3 t(-3.0, 0.5, 2.0);
  TrajectoryOptions options;
  options.align = AlignMode::kSim3;
  const auto m = EvaluateTrajectory(ref, Transformed(ref, 0.37, R, t), options);
  EXPECT_NEAR(m.alignment.scale, 0.37, 1e-9);
  EXPECT_NEAR(m.scale_error, 0.63, 1e-9);
  EXPECT_LT((m.alignment.R - R).norm(), 1e-9);
  EXPECT_LT((m.alignment.t - t).norm(), 1e-9);
  EXPECT_LT(m.ate.max, 1e-9);
  EXPECT_LT(m.rpe_trans.max, 1e-9);  // the estimate's relative translations are scaled back by s

  // SE3 alignment of the same pair cannot absorb the scale.
  options.align = AlignMode::kSe3;
  EXPECT_GT(EvaluateTrajectory(ref, Transformed(ref, 0.37, R, t), options).ate.rmse, 0.1);
}

TEST(Align, PosYawRecoversYawAndTranslation) {
  std::mt19937 rng(9);
  const Trajectory ref = RandomTrajectory(rng, 50);
  const Mat3 R = RotZ(-2.4);
  const Vec3 t(1.0, 2.0, -0.5);
  TrajectoryOptions options;
  options.align = AlignMode::kPosYaw;
  const auto m = EvaluateTrajectory(ref, Transformed(ref, 1.0, R, t), options);
  EXPECT_LT((m.alignment.R - R).norm(), 1e-9);
  EXPECT_LT((m.alignment.t - t).norm(), 1e-9);
  EXPECT_LT(m.ate.max, 1e-9);
}

TEST(Align, PosYawNeverRotatesRollOrPitch) {
  std::mt19937 rng(10);
  const Trajectory ref = RandomTrajectory(rng, 50);
  // The estimate's world is tilted by 5 degrees of roll as well as yawed: posyaw must not undo the
  // tilt.
  const Mat3 R = RotFromRpy(5.0 * kPi / 180.0, 0.0, 0.8);
  TrajectoryOptions options;
  options.align = AlignMode::kPosYaw;
  const auto m = EvaluateTrajectory(ref, Transformed(ref, 1.0, R, Vec3(0.3, 0.0, 0.0)), options);
  EXPECT_EQ(m.alignment.R(2, 2), 1.0);
  EXPECT_EQ(m.alignment.R(0, 2), 0.0);
  EXPECT_EQ(m.alignment.R(1, 2), 0.0);
  EXPECT_EQ(m.alignment.R(2, 0), 0.0);
  EXPECT_EQ(m.alignment.R(2, 1), 0.0);
  EXPECT_GT(m.ate.rmse, 0.05);  // the tilt stays as error
  options.align = AlignMode::kSe3;
  EXPECT_LT(EvaluateTrajectory(ref, Transformed(ref, 1.0, R, Vec3(0.3, 0.0, 0.0)), options).ate.max,
            1e-9);
}

TEST(Align, DegenerateAndTooFewPointsAreFailures) {
  std::vector<Vec3> line = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(3, 0, 0)};
  EXPECT_FALSE(AlignPoints(line, line, AlignMode::kSe3).ok());
  EXPECT_TRUE(AlignPoints(line, line, AlignMode::kPosYaw).ok());  // a horizontal line fixes the yaw
  std::vector<Vec3> vertical = {Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, 2)};
  EXPECT_FALSE(AlignPoints(vertical, vertical, AlignMode::kPosYaw).ok());
  std::vector<Vec3> two = {Vec3(0, 0, 0), Vec3(1, 0, 0)};
  EXPECT_FALSE(AlignPoints(two, two, AlignMode::kSe3).ok());
}

TEST(Associate, NearestWithinMaxDiffAndDropsTheRest) {
  // Reference at 10 Hz; the estimate has fewer poses, so each estimate pose searches the reference.
  const Trajectory ref = Timed({1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6});
  const Trajectory est = Timed({1.004, 1.1099, 1.2111, 1.349, 1.397, 1.496});
  const Association a = Associate(ref, est, AssociationOptions{});
  // 1.004 -> 1.0 (4 ms), 1.1099 -> 1.1 (9.9 ms), 1.2111 dropped (11.1 ms), 1.349 dropped (49 ms
  // from both 1.3 and 1.4; nearest is 1.3 at 49 ms), 1.397 -> 1.4, 1.496 -> 1.5.
  EXPECT_EQ(a.est, (std::vector<size_t>{0, 1, 4, 5}));
  EXPECT_EQ(a.ref, (std::vector<size_t>{0, 1, 4, 5}));

  AssociationOptions wide;
  wide.max_diff_s = 0.05;
  const Association b = Associate(ref, est, wide);
  EXPECT_EQ(b.est, (std::vector<size_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(b.ref, (std::vector<size_t>{0, 1, 2, 3, 4, 5}));  // 1.349: |1.3-1.349| < |1.4-1.349|
}

TEST(Associate, LongerEstimateSearchesReferenceAndMayReuseAPose) {
  const Trajectory ref = Timed({1.0, 1.2, 1.4});
  const Trajectory est =
      Timed({0.99, 1.0, 1.005, 1.2, 1.21, 1.5});  // more poses than the reference
  const Association a = Associate(ref, est, AssociationOptions{});
  // Each reference pose picks the nearest estimate pose: 1.0 -> 1.0, 1.2 -> 1.2, 1.4 -> none.
  EXPECT_EQ(a.ref, (std::vector<size_t>{0, 1}));
  EXPECT_EQ(a.est, (std::vector<size_t>{1, 3}));
  // Equal sizes: the estimate searches the reference, and one reference pose may serve two
  // estimates.
  const Trajectory ref2 = Timed({1.0, 1.1, 1.2});
  const Trajectory est2 = Timed({1.001, 1.003, 1.2});
  const Association b = Associate(ref2, est2, AssociationOptions{});
  EXPECT_EQ(b.est, (std::vector<size_t>{0, 1, 2}));
  EXPECT_EQ(b.ref, (std::vector<size_t>{0, 0, 2}));
}

TEST(Associate, OffsetIsAddedToTheEstimatesTimes) {
  const Trajectory ref = Timed({1.0, 1.1, 1.2, 1.3});
  const Trajectory est = Timed({1.5, 1.6, 1.7});
  AssociationOptions options;
  EXPECT_EQ(Associate(ref, est, options).size(), 0u);
  options.offset_s = -0.5;  // est + offset = 1.0, 1.1, 1.2
  const Association a = Associate(ref, est, options);
  EXPECT_EQ(a.ref, (std::vector<size_t>{0, 1, 2}));
  EXPECT_EQ(a.est, (std::vector<size_t>{0, 1, 2}));
}

TEST(EvaluateTrajectory, RpeOfHandMadeErrors) {
  // Reference: 4 poses along x, 1 m apart. Estimate: the third step is 0.5 m too long and the last
  // pose is yawed by 10 degrees. RPE errors per step: translation (0, 0.5, 0) m, rotation (0, 0,
  // 10) deg.
  Trajectory ref = Timed({1.0, 1.1, 1.2, 1.3});
  Trajectory est = ref;
  for (size_t i = 0; i < 4; ++i)
    ref.T_W_B[i] = Rigid3(Quat::Identity(), Vec3(static_cast<double>(i), 0, 0));
  est.T_W_B = {Rigid3(Quat::Identity(), Vec3(0, 0, 0)), Rigid3(Quat::Identity(), Vec3(1, 0, 0)),
               Rigid3(Quat::Identity(), Vec3(2.5, 0, 0)),
               Rigid3(Quat(Eigen::AngleAxisd(10.0 * kPi / 180.0, Vec3::UnitZ())), Vec3(3.5, 0, 0))};
  // The positions are collinear: use posyaw (a horizontal line fixes the yaw).
  TrajectoryOptions options;
  options.align = AlignMode::kPosYaw;
  const auto m = EvaluateTrajectory(ref, est, options);
  EXPECT_EQ(m.rpe_trans.count, 3u);
  EXPECT_NEAR(m.rpe_trans.rmse, std::sqrt(0.25 / 3.0), 1e-12);
  EXPECT_NEAR(m.rpe_trans.max, 0.5, 1e-12);
  EXPECT_NEAR(m.rpe_rot.rmse, 10.0 / std::sqrt(3.0), 1e-9);
  // ATE: the estimate's positions 0, 1, 2.5, 3.5 against 0, 1, 2, 3 shifted by the mean offset 0.25
  // (the yaw stays 0): errors 0.25, 0.25, 0.25, 0.25.
  EXPECT_NEAR(m.ate.rmse, 0.25, 1e-12);
  EXPECT_NEAR(m.ate.median, 0.25, 1e-12);
  // The series behind the statistics: per pair and per step.
  ASSERT_EQ(m.series.t_s.size(), 4u);
  ASSERT_EQ(m.series.ate.size(), 4u);
  ASSERT_EQ(m.series.p_ref.size(), 4u);
  ASSERT_EQ(m.series.p_est_aligned.size(), 4u);
  EXPECT_DOUBLE_EQ(m.series.t_s[2], 1.2);
  EXPECT_NEAR((m.series.p_est_aligned[2] - m.series.p_ref[2]).norm(), 0.25, 1e-12);
  ASSERT_EQ(m.series.rpe_trans.size(), 3u);
  EXPECT_NEAR(m.series.rpe_trans[0], 0.0, 1e-12);
  EXPECT_NEAR(m.series.rpe_trans[1], 0.5, 1e-12);
  EXPECT_NEAR(m.series.rpe_rot[2], 10.0, 1e-9);
}

TEST(EvaluateTrajectory, NoOverlapAndTooFewPairsAreClearErrors) {
  const Trajectory ref = Timed({1.0, 1.1, 1.2, 1.3});
  try {
    EvaluateTrajectory(ref, Timed({5.0, 5.1, 5.2}), TrajectoryOptions{});
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("do not overlap in time"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("only 0 pose pairs"), std::string::npos) << e.what();
  }
  try {
    EvaluateTrajectory(ref, Timed({1.0, 1.1, 1.25}), TrajectoryOptions{});
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("only 2 pose pairs within 0.01 s (need 3)"),
              std::string::npos)
        << e.what();
  }
}

// A camera at an irregular rate (steps of 33, 67 and 40 ms, as a RealSense's) whose estimate is
// stamped on the IMU's clock, 45 ms before the reference's camera stamps: few stamps meet within 10
// ms, and the summary says so; with the offset given, every pose pairs and nothing is said.
TEST(EvaluateTrajectory, StampsOfAnotherClockAreWarned) {
  std::vector<double> t_ref, t_est;
  for (int i = 0; i < 200; ++i) {
    const double step[3] = {0.033, 0.067, 0.040};
    t_ref.push_back(i == 0 ? 10.0 : t_ref.back() + step[i % 3]);
    t_est.push_back(t_ref.back() - 0.045);
  }
  Metrics m;
  m.trajectory = EvaluateTrajectory(Timed(t_ref), Timed(t_est), TrajectoryOptions{});
  EXPECT_LT(2 * m.trajectory->pairs, m.trajectory->possible_pairs);
  EXPECT_GE(m.trajectory->possible_pairs, 195u);
  EXPECT_NE(FormatSummary(m).find("warning: only"), std::string::npos) << FormatSummary(m);
  TrajectoryOptions shifted;
  shifted.association.offset_s = 0.045;
  m.trajectory = EvaluateTrajectory(Timed(t_ref), Timed(t_est), shifted);
  EXPECT_EQ(m.trajectory->pairs, 200u);
  EXPECT_EQ(m.trajectory->possible_pairs, 200u);
  EXPECT_EQ(FormatSummary(m).find("warning"), std::string::npos) << FormatSummary(m);
}

TEST(ReadTrajectory, TellsEurocFromTum) {
  const auto dir = test::ScratchDir();
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream((dir / name).string()) << text;
    return (dir / name).string();
  };
  // 8 integer-stamped columns in a .csv: EuRoC (quaternion w first), times in ns.
  const Trajectory euroc =
      ReadTrajectory(write("gt.csv", "1000,1,2,3,0,0,0,1\n2000,1,2,3,1,0,0,0\n"));
  ASSERT_EQ(euroc.size(), 2u);
  EXPECT_EQ(euroc.t_ns[0], 1000);
  EXPECT_NEAR(std::abs(euroc.T_W_B[0].rotation().z()), 1.0, 1e-12);  // w=0, x=0, y=0, z=1
  // 17 columns: EuRoC whatever the name; 8 columns in a .txt: TUM seconds (quaternion w last).
  EXPECT_EQ(ReadTrajectory(write("gt.txt", "5,1,2,3,1,0,0,0,0,0,0,0,0,0,0,0,0\n")).t_ns[0], 5);
  const Trajectory tum = ReadTrajectory(write("est.txt", "1000 1 2 3 0 0 0 1\n"));
  EXPECT_EQ(tum.t_ns[0], 1000 * kNsPerSecond);
  EXPECT_NEAR(tum.T_W_B[0].rotation().w(), 1.0, 1e-12);
  // Real EuRoC stamps (> 1e12) are told apart in any file name.
  EXPECT_EQ(ReadTrajectory(write("big.txt", "1403715524907143168,1,2,3,1,0,0,0\n")).t_ns[0],
            1403715524907143168);
}

TEST(Stats, MatchesNumpyConventions) {
  const ErrorStats s = ComputeStats({3.0, 1.0, 4.0, 2.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(Median({5.0, 1.0, 3.0}), 3.0);
  // numpy.percentile([3, 1, 4, 2], [0, 50, 90, 100]) = 1, 2.5, 3.7, 4.
  EXPECT_DOUBLE_EQ(::fsp::Percentile({3.0, 1.0, 4.0, 2.0}, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(::fsp::Percentile({3.0, 1.0, 4.0, 2.0}, 0.5), 2.5);
  EXPECT_NEAR(::fsp::Percentile({3.0, 1.0, 4.0, 2.0}, 0.9), 3.7, 1e-12);
  EXPECT_DOUBLE_EQ(::fsp::Percentile({3.0, 1.0, 4.0, 2.0}, 1.0), 4.0);
  EXPECT_DOUBLE_EQ(::fsp::Percentile({}, 0.9), 0.0);
}

}  // namespace
}  // namespace fsp::eval
