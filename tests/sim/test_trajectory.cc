// Analytic trajectory: waypoints are interpolated, hover is exact, derivatives agree with finite
// differences, jerk is continuous across waypoints, the attitude follows thrust and yaw.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "fsp/common/error.h"
#include "fsp/sim/trajectory.h"

namespace fsp::sim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

std::vector<Waypoint> Flight() {
  return {{0.0, Vec3(1, 1, 1), 0.0},           {2.0, Vec3(1, 1, 1), 0.0},
          {4.0, Vec3(3, 1.5, 1.3), 30 * kDeg}, {6.0, Vec3(5, 3, 1.6), 90 * kDeg},
          {8.5, Vec3(3, 5, 1.2), 200 * kDeg},  {11.0, Vec3(1, 3, 1.5), 270 * kDeg}};
}

TEST(Trajectory, PassesThroughWaypointsAndHoversExactly) {
  const Trajectory traj = Trajectory::FromWaypoints(Flight());
  for (const Waypoint& w : Flight()) {
    const Vec4 f = traj.FlatDerivative(w.t_s, 0);
    EXPECT_NEAR((f.head<3>() - w.p_W).norm(), 0.0, 1e-12) << "t = " << w.t_s;
    EXPECT_NEAR(std::remainder(f[3] - w.yaw_rad, 2 * 3.14159265358979323846), 0.0, 1e-12);
  }
  // The first 2 s repeat one waypoint: a still hover, level, zero rates.
  for (double t : {0.0, 0.5, 1.0, 1.999}) {
    const TrajectoryState s = traj.State(t);
    EXPECT_LT((s.T_W_B.translation() - Vec3(1, 1, 1)).norm(), 1e-12);
    EXPECT_LT(s.v_W.norm(), 1e-12);
    EXPECT_LT(s.a_W.norm(), 1e-12);
    EXPECT_LT(s.w_B.norm(), 1e-12);
    EXPECT_LT((s.T_W_B.R() - Mat3::Identity()).norm(), 1e-12);
  }
}

TEST(Trajectory, DerivativesMatchFiniteDifferences) {
  const Trajectory traj = Trajectory::FromWaypoints(Flight());
  const double h = 1e-5;
  for (double t = 2.1; t < 10.9; t += 0.37) {
    const TrajectoryState s = traj.State(t), sp = traj.State(t + h), sm = traj.State(t - h);
    // v = dp/dt, a = dv/dt (central differences, O(h^2)).
    const Vec3 v_num = (sp.T_W_B.translation() - sm.T_W_B.translation()) / (2 * h);
    const Vec3 a_num = (sp.v_W - sm.v_W) / (2 * h);
    EXPECT_LT((v_num - s.v_W).norm(), 1e-7) << "t = " << t;
    EXPECT_LT((a_num - s.a_W).norm(), 1e-6) << "t = " << t;
    // w_B: R(t + h) = R(t - h) Exp(2 h w_B) to second order.
    const Vec3 w_num = LogSO3(sm.T_W_B.R().transpose() * sp.T_W_B.R()) / (2 * h);
    EXPECT_LT((w_num - s.w_B).norm(), 1e-6) << "t = " << t << " w " << s.w_B.transpose();
  }
}

TEST(Trajectory, JerkAndAngularVelocityAreContinuousAtWaypoints) {
  const Trajectory traj = Trajectory::FromWaypoints(Flight());
  for (const Waypoint& w : Flight()) {
    if (w.t_s <= 0.0 || w.t_s >= 11.0) continue;
    const double e = 1e-9;
    for (int k = 0; k <= 3; ++k) {
      EXPECT_LT((traj.FlatDerivative(w.t_s - e, k) - traj.FlatDerivative(w.t_s + e, k)).norm(),
                1e-5)
          << "derivative " << k << " at t = " << w.t_s;
    }
    EXPECT_LT((traj.State(w.t_s - e).w_B - traj.State(w.t_s + e).w_B).norm(), 1e-6);
  }
}

TEST(Trajectory, AttitudeFollowsThrustAndYaw) {
  const Trajectory traj = Trajectory::FromWaypoints(Flight());
  double max_tilt = 0.0;
  for (double t = 0.0; t <= 11.0; t += 0.05) {
    const TrajectoryState s = traj.State(t);
    const Mat3 R = s.T_W_B.R();
    const Vec3 thrust = (s.a_W - GravityW()).normalized();
    EXPECT_LT((R.col(2) - thrust).norm(), 1e-12);
    // Heading x_c = (cos psi, sin psi, 0): the body y axis is perpendicular to it, the body x axis
    // leans along it (so body x projected on the floor is along psi up to O(tilt^2)).
    const double psi = traj.FlatDerivative(t, 0)[3];
    const Vec3 xc(std::cos(psi), std::sin(psi), 0.0);
    EXPECT_NEAR(R.col(1).dot(xc), 0.0, 1e-12);
    EXPECT_GT(R.col(0).dot(xc), 0.9);
    max_tilt = std::max(max_tilt, std::acos(R(2, 2)));
  }
  EXPECT_GT(max_tilt, 2.0 * kDeg);  // the flight does tilt: roll/pitch follow the acceleration
}

TEST(Trajectory, ResamplesPoseFileSmoothly) {
  const Trajectory ref = Trajectory::FromWaypoints(Flight());
  std::vector<StampedPose> poses;
  const int64_t t0 = 1'400'000'000'000'000'000;  // an absolute clock, as in recordings
  for (int i = 0; i <= 1100; ++i) {
    const double t = i * 0.01;
    poses.push_back({t0 + static_cast<int64_t>(i) * 10'000'000, ref.Pose(t)});
  }
  TrajectoryOptions options;
  options.pose_smoothing_s = 0.02;
  options.pose_knot_s = 0.1;
  const Trajectory traj = Trajectory::FromPoses(poses, options);
  // A hover of 3 knots at each end: the file's time t is the trajectory's t + 0.3 s.
  const double lag = 3 * options.pose_knot_s;
  EXPECT_DOUBLE_EQ(traj.t_begin(), 0.0);
  EXPECT_NEAR(traj.t_end(), 11.0 + 2.0 * lag, 1e-9);
  double max_err = 0.0;
  for (double t = 0.3; t < 10.7; t += 0.05) {
    max_err =
        std::max(max_err, (traj.Pose(t + lag).translation() - ref.Pose(t).translation()).norm());
  }
  EXPECT_LT(max_err, 0.01);
}

// A recorded flight (a pose every 10 ms with centimetre jitter) must not become a vibration: the
// flight model turns jerk into roll and pitch rates, and knots that impose a jerk (the waypoint
// Hermite segments set it to zero at every knot) shook the attitude at the knot rate, 0.3 rad/s
// rms on the C-SLAM flight, more than a 100 Hz IMU can integrate. Here the gyroscope, integrated
// as the estimator does (midpoint rule at 100 Hz, no noise), must follow the attitude over each
// 0.1 s step to within a few times a 100 Hz gyroscope's noise (1.7e-4 rad/s/sqrt(Hz): 5.4e-5 rad
// per 0.1 s). Measured: 5.4e-5 rad; with the Hermite knots 0.015 rad.
TEST(Trajectory, PoseFileWithJitterGivesSmoothAttitude) {
  const Trajectory ref = Trajectory::FromWaypoints(Flight());
  std::mt19937 rng(7);
  std::normal_distribution<double> jitter(0.0, 0.01);  // [m]
  std::vector<StampedPose> poses;
  for (int i = 0; i <= 1100; ++i) {
    Rigid3 T = ref.Pose(i * 0.01);
    T = Rigid3(T.rotation(), T.translation() + Vec3(jitter(rng), jitter(rng), jitter(rng)));
    poses.push_back({static_cast<int64_t>(i) * 10'000'000, T});
  }
  const Trajectory traj = Trajectory::FromPoses(poses, TrajectoryOptions());
  double worst = 0.0, max_rate = 0.0;
  for (double t0 = 0.0; t0 + 0.1 < traj.t_end(); t0 += 0.1) {
    Mat3 R = traj.Pose(t0).R();
    for (int k = 0; k < 10; ++k) {
      const double t = t0 + 0.01 * k;
      const Vec3 w = 0.5 * (traj.State(t).w_B + traj.State(t + 0.01).w_B);
      max_rate = std::max(max_rate, traj.State(t).w_B.head<2>().norm());
      R = R * Eigen::AngleAxisd(w.norm() * 0.01, w.norm() > 0 ? w.normalized() : Vec3::UnitX())
                  .toRotationMatrix();
    }
    const Eigen::AngleAxisd err(traj.Pose(t0 + 0.1).R().transpose() * R);
    worst = std::max(worst, std::abs(err.angle()));
  }
  EXPECT_LT(worst, 2e-4);    // [rad] per 0.1 s
  EXPECT_LT(max_rate, 1.0);  // [rad/s] roll and pitch rate (measured 0.61)
}

TEST(Trajectory, RejectsBadWaypoints) {
  EXPECT_THROW(Trajectory::FromWaypoints({{0.0, Vec3::Zero(), 0.0}}), InputError);
  EXPECT_THROW(Trajectory::FromWaypoints({{0.0, Vec3::Zero(), 0.0}, {0.0, Vec3::Ones(), 0.0}}),
               InputError);
  // Dropping 5 m in 1 s from rest and stopping needs more than free fall.
  try {
    Trajectory::FromWaypoints({{0.0, Vec3(0, 0, 6), 0.0}, {1.0, Vec3(0, 0, 1), 0.0}});
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("free fall"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fsp::sim
