// IMU synthesis: noise-free samples integrate back to the trajectory; noise statistics match the
// configured densities; seeded runs repeat.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "fsp/sim/imu_synth.h"

namespace fsp::sim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Trajectory Flight() {
  // A few m/s^2 of acceleration with turns (max |a| is checked below).
  return Trajectory::FromWaypoints({{0.0, Vec3(1, 1, 1), 0.0},
                                    {1.0, Vec3(1, 1, 1), 0.0},
                                    {3.0, Vec3(3, 1.5, 1.3), 30 * kDeg},
                                    {5.0, Vec3(5, 3, 1.6), 90 * kDeg},
                                    {7.0, Vec3(3, 5, 1.2), 200 * kDeg},
                                    {9.0, Vec3(1, 3, 1.5), 270 * kDeg},
                                    {10.5, Vec3(2, 2, 1.0), 300 * kDeg}});
}

Trajectory Hover(double duration_s) {
  return Trajectory::FromWaypoints({{0.0, Vec3(0, 0, 1), 0.3}, {duration_s, Vec3(0, 0, 1), 0.3}});
}

struct NavState {
  Quat q = Quat::Identity();
  Vec3 v = Vec3::Zero();
  Vec3 p = Vec3::Zero();
};

// d/dt (q, v, p) = (q * (0, w / 2), R(q) f + g, v).
void Derivative(const NavState& s, const Vec3& w, const Vec3& f, Vec4* dq, Vec3* dv, Vec3* dp) {
  const Quat wq(0.0, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z());
  *dq = (s.q * wq).coeffs();
  *dv = s.q.normalized() * f + GravityW();
  *dp = s.v;
}

NavState Step(const NavState& s, const Vec4& dq, const Vec3& dv, const Vec3& dp, double h) {
  NavState out;
  out.q.coeffs() = s.q.coeffs() + h * dq;
  out.v = s.v + h * dv;
  out.p = s.p + h * dp;
  return out;
}

// Classic RK4 over two IMU intervals: samples k, k+1, k+2 give the start, midpoint and end values.
NavState Rk4(const NavState& s, const ImuSample& a, const ImuSample& m, const ImuSample& b,
             double h) {
  Vec4 q1, q2, q3, q4;
  Vec3 v1, v2, v3, v4, p1, p2, p3, p4;
  Derivative(s, a.gyro, a.acc, &q1, &v1, &p1);
  Derivative(Step(s, q1, v1, p1, h / 2), m.gyro, m.acc, &q2, &v2, &p2);
  Derivative(Step(s, q2, v2, p2, h / 2), m.gyro, m.acc, &q3, &v3, &p3);
  Derivative(Step(s, q3, v3, p3, h), b.gyro, b.acc, &q4, &v4, &p4);
  NavState out;
  out.q.coeffs() = s.q.coeffs() + h / 6 * (q1 + 2 * q2 + 2 * q3 + q4);
  out.q.normalize();
  out.v = s.v + h / 6 * (v1 + 2 * v2 + 2 * v3 + v4);
  out.p = s.p + h / 6 * (p1 + 2 * p2 + 2 * p3 + p4);
  return out;
}

TEST(ImuSynth, NoiseFreeSamplesIntegrateToTheTrajectory) {
  const Trajectory traj = Flight();
  ImuSynthOptions options;
  options.add_noise = false;
  options.noise.rate_hz = 200.0;
  const int64_t t_end = 10'000'000'000;
  const ImuSequence imu = SynthesizeImu(traj, t_end, options, nullptr);
  ASSERT_EQ(imu.samples.size(), 2001u);
  EXPECT_EQ(imu.samples[1].t_ns, 5'000'000);
  EXPECT_EQ(imu.samples.back().t_ns, t_end);

  double max_acc = 0.0;
  for (double t = 0; t <= 10.0; t += 0.01) max_acc = std::max(max_acc, traj.State(t).a_W.norm());
  EXPECT_GT(max_acc, 1.5);  // a real test: the body accelerates and turns

  const TrajectoryState s0 = traj.State(0.0);
  NavState s{s0.T_W_B.rotation(), s0.v_W, s0.T_W_B.translation()};
  const double h = 2.0 / options.noise.rate_hz;
  for (size_t k = 0; k + 2 < imu.samples.size(); k += 2) {
    s = Rk4(s, imu.samples[k], imu.samples[k + 1], imu.samples[k + 2], h);
  }
  const TrajectoryState s1 = traj.State(10.0);
  std::printf("RK4 drift after 10 s: position %.3g m, velocity %.3g m/s\n",
              (s.p - s1.T_W_B.translation()).norm(), (s.v - s1.v_W).norm());
  EXPECT_LT((s.p - s1.T_W_B.translation()).norm(), 1e-3);
  EXPECT_LT((s.v - s1.v_W).norm(), 1e-4);
  EXPECT_LT(LogQuat(s.q.conjugate() * s1.T_W_B.rotation()).norm(), 1e-6);
}

TEST(ImuSynth, HoverReadsGravityAndNoRotation) {
  ImuSynthOptions options;
  options.add_noise = false;
  options.gyro_bias0 = Vec3(0.01, -0.02, 0.03);
  options.acc_bias0 = Vec3(0.1, 0.2, -0.3);
  const ImuSequence imu = SynthesizeImu(Hover(1.0), 1'000'000'000, options, nullptr);
  for (const ImuSample& s : imu.samples) {
    EXPECT_LT((s.gyro - options.gyro_bias0).norm(), 1e-12);
    EXPECT_LT((s.acc - options.acc_bias0 - Vec3(0, 0, kGravity)).norm(), 1e-12);
  }
}

TEST(ImuSynth, NoiseStatisticsMatchTheDensities) {
  const double duration = 400.0;  // 80 000 samples x 3 axes
  ImuSynthOptions options;
  options.noise.rate_hz = 200.0;
  options.noise.gyroscope_noise_density = 1.7e-4;
  options.noise.accelerometer_noise_density = 2.0e-3;
  options.noise.gyroscope_random_walk = 1.9e-5;
  options.noise.accelerometer_random_walk = 3.0e-3;
  const Trajectory traj = Hover(duration);
  std::mt19937 rng(7);
  const ImuSequence imu = SynthesizeImu(traj, static_cast<int64_t>(duration * 1e9), options, &rng);
  const size_t n = imu.samples.size();
  ASSERT_EQ(n, 80001u);

  // White noise: reading - ideal - true bias; discrete sigma = density * sqrt(rate).
  double sg = 0.0, sa = 0.0, mg = 0.0, ma = 0.0;
  // Bias random walk: increments b_k - b_{k-1}; sigma = random_walk * sqrt(dt).
  double dbg = 0.0, dba = 0.0;
  for (size_t k = 0; k < n; ++k) {
    const ImuSample ideal = IdealImu(traj, imu.samples[k].t_ns);
    const Vec3 ng = imu.samples[k].gyro - ideal.gyro - imu.gyro_bias[k];
    const Vec3 na = imu.samples[k].acc - ideal.acc - imu.acc_bias[k];
    sg += ng.squaredNorm();
    sa += na.squaredNorm();
    mg += ng.sum();
    ma += na.sum();
    if (k > 0) {
      dbg += (imu.gyro_bias[k] - imu.gyro_bias[k - 1]).squaredNorm();
      dba += (imu.acc_bias[k] - imu.acc_bias[k - 1]).squaredNorm();
    }
  }
  const double N = 3.0 * static_cast<double>(n);
  const double rate = options.noise.rate_hz, dt = 1.0 / rate;
  EXPECT_NEAR(std::sqrt(sg / N) / (1.7e-4 * std::sqrt(rate)), 1.0, 0.01);
  EXPECT_NEAR(std::sqrt(sa / N) / (2.0e-3 * std::sqrt(rate)), 1.0, 0.01);
  EXPECT_NEAR(mg / N / (1.7e-4 * std::sqrt(rate)), 0.0, 0.01);
  EXPECT_NEAR(ma / N / (2.0e-3 * std::sqrt(rate)), 0.0, 0.01);
  const double M = 3.0 * static_cast<double>(n - 1);
  EXPECT_NEAR(std::sqrt(dbg / M) / (1.9e-5 * std::sqrt(dt)), 1.0, 0.01);
  EXPECT_NEAR(std::sqrt(dba / M) / (3.0e-3 * std::sqrt(dt)), 1.0, 0.01);
  // The bias starts at its initial value and wanders.
  EXPECT_EQ(imu.gyro_bias[0], Vec3::Zero());
  EXPECT_GT(imu.acc_bias.back().norm(), 0.0);
}

TEST(ImuSynth, SameSeedSameSamples) {
  ImuSynthOptions options;
  const Trajectory traj = Flight();
  std::mt19937 a(3), b(3), c(4);
  const ImuSequence x = SynthesizeImu(traj, 2'000'000'000, options, &a);
  const ImuSequence y = SynthesizeImu(traj, 2'000'000'000, options, &b);
  const ImuSequence z = SynthesizeImu(traj, 2'000'000'000, options, &c);
  ASSERT_EQ(x.samples.size(), y.samples.size());
  for (size_t k = 0; k < x.samples.size(); ++k) {
    EXPECT_EQ(x.samples[k].gyro, y.samples[k].gyro);
    EXPECT_EQ(x.samples[k].acc, y.samples[k].acc);
  }
  EXPECT_NE(x.samples[5].acc, z.samples[5].acc);
}

}  // namespace
}  // namespace fsp::sim
