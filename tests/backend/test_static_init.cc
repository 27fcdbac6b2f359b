// Static initialisation on real EuRoC data: V1_01 standing still (gyro bias and gravity direction
// recovered), V1_02 in flight (refused: too much motion), too few samples (refused).
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "backend/imu_test_util.h"
#include "fsp/backend/static_init.h"
#include "test_util.h"

namespace fsp::backend {
namespace {

TEST(StaticInit, RecoversGyroBiasAndGravityOnEurocV101) {
  FSP_REQUIRE_TEST_DATA(dir, "euroc_v101_micro");
  const auto imu = test::ReadEurocImu(dir + "/mav0/imu0/data.csv");
  StaticInitOptions opt;
  const StaticInitSummary s = StaticInitialize(imu, opt);
  std::printf(
      "[static_init] V1_01: %s%s, %d samples, gyro mean (%.5f, %.5f, %.5f), |acc| %.3f, block std "
      "gyro "
      "%.4f acc %.3f\n",
      s.success ? "ok" : "refused: ", s.reason.c_str(), s.num_samples, s.gyro_mean.x(),
      s.gyro_mean.y(), s.gyro_mean.z(), s.acc_mean.norm(), s.gyro_block_std, s.acc_block_std);
  ASSERT_TRUE(s.success) << s.reason;
  EXPECT_EQ(s.num_samples, 200);
  // Mean gyro over the 95 still frames (README): (-0.00201, 0.02092, 0.07815); vicon2gt bias
  // (-0.00225, 0.02154, 0.07703). One second gives it to ~1e-3 rad/s.
  EXPECT_LT((s.state.gyro_bias - Vec3(-0.00201, 0.02092, 0.07815)).norm(), 2e-3);
  EXPECT_LT((s.state.gyro_bias - Vec3(-0.00225, 0.02154, 0.07703)).norm(), 3e-3);
  EXPECT_NEAR(s.acc_mean.norm(), 9.797, 0.05);
  EXPECT_EQ(s.state.v_W, Vec3::Zero());
  // Gravity: R_W_B maps the measured specific force onto +z, and the yaw is zero.
  const Mat3 R = s.state.T_W_B.R();
  EXPECT_LT((R * s.acc_mean.normalized() - Vec3::UnitZ()).norm(), 1e-12);
  EXPECT_NEAR(R(1, 0), 0.0, 1e-12);
  EXPECT_GT(R(0, 0), 0.0);
  // The EuRoC IMU's x axis points roughly up on the standing MAV (acc x ≈ +9.1 m/s²).
  EXPECT_GT((R * Vec3::UnitX()).z(), 0.9);

  // Over the whole still period (4.7 s) the estimate agrees with the README's mean.
  StaticInitOptions longer = opt;
  longer.window_s = 4.6;
  const StaticInitSummary s2 = StaticInitialize(imu, longer);
  ASSERT_TRUE(s2.success) << s2.reason;
  EXPECT_LT((s2.state.gyro_bias - Vec3(-0.00201, 0.02092, 0.07815)).norm(), 5e-4);
}

TEST(StaticInit, RefusesInFlightOnEurocV102) {
  FSP_REQUIRE_TEST_DATA(dir, "euroc_v102_imu_gt_40s");
  const auto imu = test::ReadEurocImu(dir + "/mav0/imu0/data.csv");
  StaticInitOptions opt;
  int refused = 0, tried = 0;
  for (double t = 6.0; t < 38.0; t += 2.0) {
    const StaticInitSummary s =
        StaticInitialize(imu, opt, imu.front().t_ns + static_cast<int64_t>(t * 1e9));
    ++tried;
    if (!s.success) {
      ++refused;
      EXPECT_NE(s.reason.find("too much motion"), std::string::npos) << s.reason;
    }
    if (t == 10.0) std::printf("[static_init] V1_02 at +10 s: %s\n", s.reason.c_str());
  }
  EXPECT_EQ(refused, tried);
  // The same recording starts still: its first second is accepted.
  EXPECT_TRUE(StaticInitialize(imu, opt).success);
}

TEST(StaticInit, RefusesTooFewSamplesAndChecksOptions) {
  const test::AnalyticTrajectory traj;
  std::vector<ImuSample> few;
  for (int k = 0; k < 20; ++k) few.push_back({k * 5'000'000LL, Vec3::Zero(), Vec3(0, 0, 9.81)});
  const StaticInitSummary s = StaticInitialize(few, StaticInitOptions{});
  EXPECT_FALSE(s.success);
  EXPECT_NE(s.reason.find("too few"), std::string::npos) << s.reason;
  EXPECT_FALSE(StaticInitialize({}, StaticInitOptions{}).success);
  // Noise-free moving trajectory: refused.
  const auto moving = test::SampleImu(traj, 0.0, 2.0, test::ImuSamplingOptions{});
  EXPECT_FALSE(StaticInitialize(moving, StaticInitOptions{}).success);
  StaticInitOptions bad;
  bad.block_s = 0.9;
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_FALSE(why.empty());
}

}  // namespace
}  // namespace fsp::backend
