// fsp eval against third-party and independently derived numbers in $FSP_TEST_DATA/traj_eval
// (README.txt there). Tolerances are half a unit of the last digit printed there.
#include <gtest/gtest.h>

#include "fsp/eval/trajectory_metrics.h"
#include "test_util.h"

namespace fsp::eval {
namespace {

TrajectoryMetrics Evaluate(const std::string& ref_path, const std::string& est_path,
                           AlignMode align) {
  TrajectoryOptions options;
  options.align = align;
  return EvaluateTrajectory(ReadTrajectory(ref_path), ReadTrajectory(est_path), options);
}

// Published by evo (doc/performance.md): evo_ape tum fr2_desk_groundtruth.txt fr2_desk_ORB.txt
// --align.
TEST(TrajEvalReference, Fr2DeskOrbMatchesEvoPublishedApe) {
  FSP_REQUIRE_TEST_DATA(dir, "traj_eval/evo");
  const auto m =
      Evaluate(dir + "/fr2_desk_groundtruth.txt", dir + "/fr2_desk_ORB.txt", AlignMode::kSe3);
  EXPECT_EQ(m.pairs, 2174u);
  EXPECT_NEAR(m.ate.rmse, 0.008119, 5e-7);
  EXPECT_NEAR(m.ate.mean, 0.007492, 5e-7);
  EXPECT_NEAR(m.ate.median, 0.007415, 5e-7);
  EXPECT_NEAR(m.ate.std, 0.003129, 5e-7);
  EXPECT_NEAR(m.ate.min, 0.000350, 5e-7);
  EXPECT_NEAR(m.ate.max, 0.024300, 5e-7);
}

TEST(TrajEvalReference, Freiburg1XyzSe3AndRpe) {
  FSP_REQUIRE_TEST_DATA(dir, "traj_eval/evo");
  const auto m = Evaluate(dir + "/freiburg1_xyz-groundtruth.txt",
                          dir + "/freiburg1_xyz-rgbdslam.txt", AlignMode::kSe3);
  EXPECT_EQ(m.pairs, 785u);
  EXPECT_NEAR(m.ate.rmse, 0.013470089, 5e-10);
  EXPECT_EQ(m.rpe_trans.count, 784u);
  EXPECT_NEAR(m.rpe_trans.rmse, 0.005764371, 5e-10);
  EXPECT_NEAR(m.rpe_rot.rmse, 0.353613, 5e-7);
}

TEST(TrajEvalReference, Fr2DeskMonoKeyframesSim3) {
  FSP_REQUIRE_TEST_DATA(dir, "traj_eval/evo");
  const auto m = Evaluate(dir + "/fr2_desk_groundtruth.txt", dir + "/fr2_desk_ORB_kf_mono.txt",
                          AlignMode::kSim3);
  EXPECT_EQ(m.pairs, 118u);
  EXPECT_NEAR(m.ate.rmse, 0.007729265, 5e-10);
  EXPECT_NEAR(m.alignment.scale, 2.228021754, 5e-10);
  EXPECT_NEAR(m.scale_error, 1.228021754, 5e-10);
}

TEST(TrajEvalReference, V102EurocCsvSe3AndSim3) {
  FSP_REQUIRE_TEST_DATA(dir, "traj_eval/evo");
  const auto se3 = Evaluate(dir + "/V102_groundtruth.csv", dir + "/V102.txt", AlignMode::kSe3);
  EXPECT_EQ(se3.pairs, 798u);
  EXPECT_NEAR(se3.ate.rmse, 0.091727115, 5e-10);
  const auto sim3 = Evaluate(dir + "/V102_groundtruth.csv", dir + "/V102.txt", AlignMode::kSim3);
  EXPECT_EQ(sim3.pairs, 798u);
  EXPECT_NEAR(sim3.ate.rmse, 0.083841388, 5e-10);
  EXPECT_NEAR(sim3.alignment.scale, 0.979698252, 5e-10);
}

TEST(TrajEvalReference, V101OpenvinsSe3AndPosYaw) {
  FSP_REQUIRE_TEST_DATA(dir, "traj_eval/evo");
  const auto se3 = Evaluate(dir + "/V101_gt.txt", dir + "/V101_openvins.txt", AlignMode::kSe3);
  EXPECT_EQ(se3.pairs, 2760u);
  EXPECT_NEAR(se3.ate.rmse, 0.052101961, 5e-10);
  const auto posyaw =
      Evaluate(dir + "/V101_gt.txt", dir + "/V101_openvins.txt", AlignMode::kPosYaw);
  EXPECT_EQ(posyaw.pairs, 2760u);
  EXPECT_NEAR(posyaw.ate.rmse, 0.052742238, 5e-10);
}

struct RpgCase {
  const char* folder;
  const char* estimate;
  size_t pairs;
  double rmse;
};

TEST(TrajEvalReference, RpgPosYaw) {
  FSP_REQUIRE_TEST_DATA(dir, "traj_eval/rpg");
  const RpgCase cases[] = {
      {"vislam_rp_V1_02", "stamped_traj_estimate0.txt", 1355, 0.065449801},
      {"vislam_rp_V1_02", "stamped_traj_estimate1.txt", 1367, 0.078370244},
      {"vislam_rp_MH_04", "stamped_traj_estimate0.txt", 1347, 0.168780007},
      {"vislam_rp_MH_04", "stamped_traj_estimate1.txt", 1350, 0.200549888},
  };
  for (const RpgCase& c : cases) {
    SCOPED_TRACE(std::string(c.folder) + "/" + c.estimate);
    const std::string base = dir + "/" + c.folder + "/";
    const auto m =
        Evaluate(base + "stamped_groundtruth.txt", base + c.estimate, AlignMode::kPosYaw);
    EXPECT_EQ(m.pairs, c.pairs);
    EXPECT_NEAR(m.ate.rmse, c.rmse, 5e-10);
  }
}

}  // namespace
}  // namespace fsp::eval
