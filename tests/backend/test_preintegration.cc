// IMU preintegration: exactness on an analytic trajectory (unequal dt, boundary interpolation),
// real EuRoC V1_02 flight against Vicon ground truth, Monte-Carlo covariance consistency, bias
// Jacobians and first-order bias correction vs re-integration.
#include <algorithm>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "backend/imu_test_util.h"
#include "fsp/backend/imu_preintegration.h"
#include "fsp/common/error.h"
#include "test_util.h"

namespace fsp::backend {
namespace {

using test::AnalyticTrajectory;
using test::ImuSamplingOptions;
using test::SampleImu;

int64_t Ns(double t) {
  return static_cast<int64_t>(std::llround(t * 1e9));
}

struct DeltaError {
  double rot = 0, vel = 0, pos = 0;
};

// Preintegrated (ΔR, Δv, Δp) vs the trajectory's true relative motion between t_i and t_j.
DeltaError CompareWithTruth(const ImuPreintegration& pre, const PreintegratedDelta& d,
                            const AnalyticTrajectory& traj, double ti, double tj) {
  const Vec3 g(0, 0, -traj.gravity);
  const double dt = tj - ti;
  const Mat3 Ri = traj.Rotation(ti);
  const Mat3 dR_true = Ri.transpose() * traj.Rotation(tj);
  const Vec3 dv_true = Ri.transpose() * (traj.Velocity(tj) - traj.Velocity(ti) - g * dt);
  const Vec3 dp_true = Ri.transpose() * (traj.Position(tj) - traj.Position(ti) -
                                         traj.Velocity(ti) * dt - 0.5 * g * dt * dt);
  EXPECT_NEAR(pre.dt(), dt, 1e-9);
  DeltaError e;
  e.rot = LogSO3(dR_true.transpose() * d.dR.toRotationMatrix()).norm();
  e.vel = (d.dv - dv_true).norm();
  e.pos = (d.dp - dp_true).norm();
  return e;
}

TEST(Preintegration, NoiseFreeAnalyticTrajectoryIsExact) {
  const AnalyticTrajectory traj;
  PreintegrationOptions opt;
  std::mt19937 rng(42);
  ImuSamplingOptions so;
  so.jitter = 0.2;  // unequal dt: 4..6 ms
  so.bg = Vec3(0.01, -0.02, 0.015);
  so.ba = Vec3(0.1, -0.05, 0.2);
  const std::vector<ImuSample> imu = SampleImu(traj, 0.0, 12.0, so, &rng);
  double worst_p = 0, worst_v = 0, worst_r = 0;
  for (double ti : {0.5123, 3.3, 7.77, 10.0001}) {
    const double tj = ti + 1.0;
    // Keyframe times are rounded to ns like real ones.
    const ImuPreintegration pre(opt, imu, Ns(ti), Ns(tj), so.bg, so.ba);
    const DeltaError e =
        CompareWithTruth(pre, pre.Corrected(so.bg, so.ba), traj, 1e-9 * Ns(ti), 1e-9 * Ns(tj));
    worst_p = std::max(worst_p, e.pos);
    worst_v = std::max(worst_v, e.vel);
    worst_r = std::max(worst_r, e.rot);
    EXPECT_EQ(pre.extrapolated_s(), 0.0);
  }
  std::printf(
      "[preintegration] analytic, 200 Hz ±20%% jitter, 1 s: worst |ΔR err| %.2e rad, |Δv err| %.2e "
      "m/s, "
      "|Δp err| %.2e m\n",
      worst_r, worst_v, worst_p);
  // Midpoint scheme, second order: errors ~ dt² (see the 200/400 Hz ratio below).
  EXPECT_LT(worst_p, 5e-6);
  EXPECT_LT(worst_v, 2e-5);
  EXPECT_LT(worst_r, 2e-6);

  // Second-order scheme: halving the step divides the error by ~4.
  ImuSamplingOptions fine = so;
  fine.jitter = 0.0;
  fine.rate_hz = 400.0;
  ImuSamplingOptions coarse = fine;
  coarse.rate_hz = 200.0;
  const auto e200 = CompareWithTruth(
      ImuPreintegration(opt, SampleImu(traj, 0, 6, coarse), Ns(2), Ns(3), so.bg, so.ba),
      ImuPreintegration(opt, SampleImu(traj, 0, 6, coarse), Ns(2), Ns(3), so.bg, so.ba)
          .Corrected(so.bg, so.ba),
      traj, 2, 3);
  const ImuPreintegration p400(opt, SampleImu(traj, 0, 6, fine), Ns(2), Ns(3), so.bg, so.ba);
  const auto e400 = CompareWithTruth(p400, p400.Corrected(so.bg, so.ba), traj, 2, 3);
  std::printf("[preintegration] |Δv err| 200 Hz %.2e, 400 Hz %.2e (ratio %.2f)\n", e200.vel,
              e400.vel, e200.vel / e400.vel);
  EXPECT_GT(e200.vel / e400.vel, 3.0);
}

TEST(Preintegration, PredictReproducesTrajectoryState) {
  const AnalyticTrajectory traj;
  PreintegrationOptions opt;
  const std::vector<ImuSample> imu = SampleImu(traj, 0.0, 4.0, ImuSamplingOptions{});
  const ImuPreintegration pre(opt, imu, Ns(1.0), Ns(2.0), Vec3::Zero(), Vec3::Zero());
  Rigid3 Tj;
  Vec3 vj;
  pre.Predict(traj.Pose(1.0), traj.Velocity(1.0), Vec3::Zero(), Vec3::Zero(), &Tj, &vj);
  EXPECT_LT((Tj.translation() - traj.Position(2.0)).norm(), 5e-6);
  EXPECT_LT((vj - traj.Velocity(2.0)).norm(), 2e-5);
  EXPECT_LT(LogSO3(Tj.R().transpose() * traj.Rotation(2.0)).norm(), 2e-6);
}

// One integration step between the keyframes (both inside the same IMU interval, or the samples
// ending before the interval, as in an IMU gap) gives a rank-6 noise covariance: the
// preintegration floors it instead of aborting (it did: an LLT check), and its information is
// finite and positive definite.
TEST(Preintegration, SingleStepIntervalHasAFiniteInformation) {
  PreintegrationOptions opt;
  ImuSample s;
  s.t_ns = Ns(1.0);
  s.acc = Vec3(0.1, 0.0, 9.81);
  s.gyro = Vec3(0.01, 0.0, 0.0);
  const ImuPreintegration pre(opt, {s}, Ns(1.0), Ns(1.05), Vec3::Zero(), Vec3::Zero());
  EXPECT_TRUE(pre.sqrt_information().allFinite());
  const Mat15 info = pre.sqrt_information().transpose() * pre.sqrt_information();
  EXPECT_GT(info.ldlt().vectorD().minCoeff(), 0.0);
}

TEST(Preintegration, RealEurocFlightAgainstGroundTruth) {
  FSP_REQUIRE_TEST_DATA(dir, "euroc_v102_imu_gt_40s");
  const auto imu = test::ReadEurocImu(dir + "/mav0/imu0/data.csv");
  const auto gt = test::ReadEurocGt(dir + "/mav0/gt0/data.csv");
  ASSERT_GT(imu.size(), 7000u);
  PreintegrationOptions opt;
  for (double window : {0.25, 0.5, 1.0}) {
    std::vector<double> pos_err, rot_err, vel_err;
    const int64_t step = Ns(window);
    for (size_t i = 0; i < gt.size(); i += 4) {  // a start every 0.1 s
      const StateSample& a = gt[i];
      if (a.t_ns < imu.front().t_ns || a.t_ns + step > imu.back().t_ns) continue;
      // GT at t_i + window: nearest GT row (40 Hz rows, windows are multiples of 25 ms).
      const auto it = std::lower_bound(gt.begin(), gt.end(), a.t_ns + step,
                                       [](const StateSample& s, int64_t t) { return s.t_ns < t; });
      if (it == gt.end() || std::llabs(it->t_ns - (a.t_ns + step)) > 1'000'000) continue;
      const StateSample& b = *it;
      const ImuPreintegration pre(opt, imu, a.t_ns, b.t_ns, a.gyro_bias, a.acc_bias);
      Rigid3 Tb;
      Vec3 vb;
      pre.Predict(a.T_W_B, a.v_W, a.gyro_bias, a.acc_bias, &Tb, &vb);
      pos_err.push_back((Tb.translation() - b.T_W_B.translation()).norm());
      vel_err.push_back((vb - b.v_W).norm());
      rot_err.push_back(LogSO3(Tb.R().transpose() * b.T_W_B.R()).norm());
    }
    ASSERT_GT(pos_err.size(), 300u);
    auto median = [](std::vector<double> v) {
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    auto maxv = [](const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); };
    std::printf(
        "[preintegration] EuRoC V1_02, %.2f s windows (%zu): position err median %.2f cm max %.2f "
        "cm, "
        "velocity median %.3f max %.3f m/s, rotation median %.3f max %.3f deg\n",
        window, pos_err.size(), 100 * median(pos_err), 100 * maxv(pos_err), median(vel_err),
        maxv(vel_err), median(rot_err) * 180 / M_PI, maxv(rot_err) * 180 / M_PI);
    // Loose but meaningful bounds (the numbers above are what it achieves; ignoring gravity or the
    // rotation would give metres): position grows ~ window², rotation ~ window.
    const double w2 = window * window;
    EXPECT_LT(median(pos_err), 0.04 * w2 + 0.005);
    EXPECT_LT(maxv(pos_err), 0.15 * w2 + 0.01);
    EXPECT_LT(median(rot_err) * 180 / M_PI, 0.5 * window + 0.1);
  }
}

TEST(Preintegration, MonteCarloCovarianceIsConsistent) {
  const AnalyticTrajectory traj;
  PreintegrationOptions opt;
  // 10x EuRoC noise so that the nonlinearity is exercised a bit.
  opt.noise.gyroscope_noise_density *= 10.0;
  opt.noise.accelerometer_noise_density *= 10.0;
  ImuSamplingOptions so;
  so.gyro_density = opt.noise.gyroscope_noise_density;
  so.acc_density = opt.noise.accelerometer_noise_density;
  const double ti = 1.0, tj = 2.0;
  const ImuPreintegration ref(opt, SampleImu(traj, 0.9, 2.1, ImuSamplingOptions{}), Ns(ti), Ns(tj),
                              Vec3::Zero(), Vec3::Zero());
  const Mat9& P = ref.covariance();
  const Eigen::LDLT<Mat9> ldlt(P);
  std::mt19937 rng(1);
  const int n = 1000;
  Mat9 emp = Mat9::Zero();
  double nees = 0.0;
  for (int k = 0; k < n; ++k) {
    const ImuPreintegration noisy(opt, SampleImu(traj, 0.9, 2.1, so, &rng), Ns(ti), Ns(tj),
                                  Vec3::Zero(), Vec3::Zero());
    Eigen::Matrix<double, 9, 1> e;
    // ΔR̃ = ΔR Exp(δφ)  =>  δφ = Log(ΔRᵀ ΔR̃)
    e << LogQuat(ref.delta_R().conjugate() * noisy.delta_R()), noisy.delta_v() - ref.delta_v(),
        noisy.delta_p() - ref.delta_p();
    emp += e * e.transpose();
    nees += e.dot(ldlt.solve(e));
  }
  emp /= n;
  nees /= n;
  std::printf(
      "[preintegration] Monte Carlo (%d runs, 1 s): mean NEES %.3f (expected 9, σ of the mean "
      "%.2f)\n",
      n, nees, std::sqrt(18.0 / n));
  for (int i = 0; i < 9; ++i) {
    std::printf("  var[%d] empirical %.3e propagated %.3e ratio %.3f\n", i, emp(i, i), P(i, i),
                emp(i, i) / P(i, i));
    EXPECT_NEAR(emp(i, i) / P(i, i), 1.0, 0.15) << i;
  }
  EXPECT_NEAR(nees, 9.0, 0.6);
}

TEST(Preintegration, BiasJacobiansAndFirstOrderCorrection) {
  const AnalyticTrajectory traj;
  PreintegrationOptions opt;
  const std::vector<ImuSample> imu = SampleImu(traj, 0.0, 3.0, ImuSamplingOptions{});
  const Vec3 bg0(0.002, -0.001, 0.003), ba0(0.02, 0.01, -0.03);
  ImuPreintegration pre(opt, imu, Ns(0.7), Ns(1.7), bg0, ba0);

  // Bias Jacobians against central differences of re-integration.
  const double h = 1e-5;
  Eigen::Matrix<double, 9, 6> Jn, Ja;
  Ja << pre.dR_dbg(), Mat3::Zero(), pre.dv_dbg(), pre.dv_dba(), pre.dp_dbg(), pre.dp_dba();
  for (int c = 0; c < 6; ++c) {
    Vec3 dbg = Vec3::Zero(), dba = Vec3::Zero();
    (c < 3 ? dbg : dba)[c % 3] = h;
    ImuPreintegration p(opt, imu, Ns(0.7), Ns(1.7), bg0 + dbg, ba0 + dba);
    ImuPreintegration m(opt, imu, Ns(0.7), Ns(1.7), bg0 - dbg, ba0 - dba);
    Jn.block<3, 1>(0, c) = (LogQuat(pre.delta_R().conjugate() * p.delta_R()) -
                            LogQuat(pre.delta_R().conjugate() * m.delta_R())) /
                           (2 * h);
    Jn.block<3, 1>(3, c) = (p.delta_v() - m.delta_v()) / (2 * h);
    Jn.block<3, 1>(6, c) = (p.delta_p() - m.delta_p()) / (2 * h);
  }
  const double jac_err = (Ja - Jn).cwiseAbs().maxCoeff() / Jn.cwiseAbs().maxCoeff();
  std::printf("[preintegration] bias Jacobians vs re-integration differences: rel. err %.2e\n",
              jac_err);
  EXPECT_LT(jac_err, 1e-6);

  // Small bias change: first-order correction vs re-integration. The remaining difference is the
  // second-order term (~|δb|²), so halving the change divides it by ~4.
  auto correction_error = [&](double scale, double* change) {
    const Vec3 bg1 = bg0 + scale * Vec3(0.003, -0.002, 0.001),
               ba1 = ba0 + scale * Vec3(-0.03, 0.02, 0.04);
    const PreintegratedDelta c = pre.Corrected(bg1, ba1);
    const ImuPreintegration re(opt, imu, Ns(0.7), Ns(1.7), bg1, ba1);
    const double er = LogQuat(re.delta_R().conjugate() * c.dR).norm();
    const double ev = (re.delta_v() - c.dv).norm(), ep = (re.delta_p() - c.dp).norm();
    *change = (re.delta_v() - pre.delta_v()).norm();
    std::printf(
        "[preintegration] |δbg| %.1e |δba| %.1e: correction vs re-integration ΔR %.2e rad Δv %.2e "
        "m/s "
        "Δp %.2e m (uncorrected Δv off by %.2e)\n",
        (bg1 - bg0).norm(), (ba1 - ba0).norm(), er, ev, ep, *change);
    return Eigen::Vector3d(er, ev, ep);
  };
  double change1 = 0, change2 = 0;
  const Eigen::Vector3d e1 = correction_error(1.0, &change1);
  const Eigen::Vector3d e2 = correction_error(0.5, &change2);
  EXPECT_LT(e1[0], 1e-6);
  EXPECT_LT(e1[1], 2e-4);
  EXPECT_LT(e1[2], 1e-4);
  EXPECT_LT(e1[1], 0.01 * change1);  // the correction removes > 99% of the bias effect
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(e1[i] / e2[i], 4.0, 0.5) << i;
  const Vec3 bg1 = bg0 + Vec3(0.003, -0.002, 0.001), ba1 = ba0 + Vec3(-0.03, 0.02, 0.04);

  // Re-integration policy: below the thresholds nothing happens, above it re-integrates exactly.
  EXPECT_FALSE(pre.ReintegrateIfNeeded(bg1, ba1));
  EXPECT_EQ(pre.num_reintegrations(), 0);
  const Vec3 bg2 = bg0 + Vec3(0.02, 0, 0);
  EXPECT_TRUE(pre.ReintegrateIfNeeded(bg2, ba0));
  EXPECT_EQ(pre.num_reintegrations(), 1);
  EXPECT_EQ(pre.bg_lin(), bg2);
  const ImuPreintegration direct(opt, imu, Ns(0.7), Ns(1.7), bg2, ba0);
  EXPECT_LT((pre.delta_p() - direct.delta_p()).norm(), 1e-15);
  EXPECT_LT((pre.covariance() - direct.covariance()).norm(), 1e-18);
}

TEST(Preintegration, CovarianceAndInformationAreWellFormed) {
  const AnalyticTrajectory traj;
  PreintegrationOptions opt;
  const ImuPreintegration pre(opt, SampleImu(traj, 0.0, 2.0, ImuSamplingOptions{}), Ns(0.5),
                              Ns(0.55), Vec3::Zero(), Vec3::Zero());
  EXPECT_EQ(pre.num_intervals(), 10);
  // sqrt_informationᵀ sqrt_information = Σ15⁻¹
  const Mat15 I = pre.sqrt_information().transpose() * pre.sqrt_information() * pre.covariance15();
  EXPECT_LT((I - Mat15::Identity()).norm(), 1e-6);
  // Bias random walk block: σ² Δt.
  EXPECT_NEAR(pre.covariance15()(9, 9), std::pow(opt.noise.gyroscope_random_walk, 2) * 0.05, 1e-20);
  // Rotation variance after 50 ms ≈ σ_g² Δt.
  EXPECT_NEAR(pre.covariance()(0, 0) / (std::pow(opt.noise.gyroscope_noise_density, 2) * 0.05), 1.0,
              1e-4);
  std::string why;
  PreintegrationOptions bad;
  bad.gravity = -1;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_FALSE(why.empty());
  EXPECT_THROW(ImuPreintegration(opt, {}, 0, 10, Vec3::Zero(), Vec3::Zero()), InputError);
}

}  // namespace
}  // namespace fsp::backend
