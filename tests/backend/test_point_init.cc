// The initialisation in motion from points (point_init.h, visual_sfm.h) on a rendered start: an
// analytic flight from the simulator (sim/trajectory.h) with its IMU (sim/imu_synth.h: noise and a
// gyroscope bias), and points scattered in front of the camera projected into 20 Hz frames with
// 0.5 px noise. Checks the scale, gravity's direction, the gyroscope bias and the velocity against
// the truth; the refusal on a pure rotation; and the estimator starting from points with no object
// in view.
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "fsp/backend/estimator.h"
#include "fsp/backend/point_init.h"
#include "fsp/sim/imu_synth.h"
#include "fsp/sim/trajectory.h"

namespace fsp::backend {
namespace {

constexpr double kRateHz = 20.0;

// Camera looking along body x (x right = −y_B, y down = −z_B), 5 cm in front of the IMU.
Rigid3 CameraMount() {
  Mat3 R_B_C;
  R_B_C << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return Rigid3(R_B_C, Vec3(0.05, 0.0, 0.02));
}

// 640x480 at f = 400 px, or (WIDE) 1280x720 at f = 900 px (the DM-VIO walk's camera).
Mat3 Intrinsics(bool wide = false) {
  Mat3 K;
  if (wide)
    K << 900, 0, 639.5, 0, 900, 359.5, 0, 0, 1;
  else
    K << 400, 0, 320, 0, 400, 240, 0, 0, 1;
  return K;
}

// What a scene looks like: the camera (Intrinsics(wide)), the motion's amplitude (1: the default
// hand-held flight) and the points (count, depth range in front of the start [m]).
struct StartScene {
  bool wide = false;
  double motion = 1.0;
  int points = 300;
  double near_m = 3.0, far_m = 8.0;
  double background = 0.0;  // this fraction of the points lies 40-80 m away instead
};

struct RenderedStart {
  sim::Trajectory trajectory;
  std::vector<ImuSample> imu;
  std::vector<SfmFrame> frames;  // from t_begin_s
  Vec3 gyro_bias;
};

// A hand-held-like flight (sideways, forward and back, up and down, turning), or (ROTATE_ONLY) a
// hover that only turns. Frames from t_begin_s to t_end_s.
RenderedStart Render(bool rotate_only, double t_begin_s, double t_end_s, uint32_t seed,
                     const StartScene& scene = StartScene()) {
  std::vector<sim::Waypoint> wps;
  for (int k = 0; k <= 16; ++k) {
    const double t = 0.25 * k;
    const Vec3 p = rotate_only ? Vec3(0.0, 0.0, 1.5)
                               : Vec3(0.25 * std::sin(2.1 * t), 0.5 * std::sin(1.4 * t),
                                      0.12 * std::sin(3.0 * t)) *
                                         scene.motion +
                                     Vec3(0.0, 0.0, 1.5);
    wps.push_back({t, p, 0.35 * std::sin(1.2 * t)});
  }
  RenderedStart out{sim::Trajectory::FromWaypoints(wps), {}, {}, Vec3(0.012, -0.02, 0.008)};
  std::mt19937 rng(seed);
  sim::ImuSynthOptions io;
  io.gyro_bias0 = out.gyro_bias;
  io.acc_bias0 = Vec3(0.02, -0.01, 0.015);
  const sim::ImuSequence imu = sim::SynthesizeImu(
      out.trajectory, static_cast<int64_t>(t_end_s * 1e9) + 50'000'000, io, &rng);
  out.imu = imu.samples;
  // Points near_m-far_m in front of the start (body x), spread over the view.
  const double spread = scene.far_m / 8.0;
  std::uniform_real_distribution<double> ux(scene.near_m, scene.far_m),
      uy(-4.0 * spread, 4.0 * spread), uz(1.5 - 2.5 * spread, 1.5 + 2.5 * spread);
  std::vector<Vec3> points;
  for (int i = 0; i < scene.points; ++i) points.push_back(Vec3(ux(rng), uy(rng), uz(rng)));
  std::uniform_real_distribution<double> u_bg(40.0, 80.0), u_side(-0.5, 0.5);
  for (int i = static_cast<int>(std::lround((1.0 - scene.background) * scene.points));
       i < scene.points; ++i) {
    const double d = u_bg(rng);  // within the view: lateral offsets of up to half the depth
    points[i] = Vec3(d, u_side(rng) * d, 1.5 + 0.5 * u_side(rng) * d);
  }
  std::normal_distribution<double> noise(0.0, 0.5);
  const Mat3 K = Intrinsics(scene.wide);
  const double width = scene.wide ? 1280.0 : 640.0, height = scene.wide ? 720.0 : 480.0;
  const Rigid3 T_B_C = CameraMount();
  std::vector<int> age(points.size(), -1);
  for (int k = static_cast<int>(std::ceil(t_begin_s * kRateHz)); k / kRateHz <= t_end_s; ++k) {
    const int64_t t_ns = sim::SampleTimeNs(k, kRateHz);
    const Rigid3 T_C_W = (out.trajectory.Pose(1e-9 * t_ns) * T_B_C).Inverse();
    SfmFrame f;
    f.t_ns = t_ns;
    for (size_t i = 0; i < points.size(); ++i) {
      const Vec3 p_C = T_C_W * points[i];
      const Vec3 m = K * p_C;
      const Vec2 uv = m.head<2>() / m.z();
      if (p_C.z() < 0.3 || uv.x() < 0 || uv.x() > width - 1 || uv.y() < 0 || uv.y() > height - 1) {
        age[i] = -1;
        continue;
      }
      ++age[i];
      f.points.push_back(
          {t_ns, static_cast<int64_t>(i), uv + Vec2(noise(rng), noise(rng)), age[i]});
    }
    out.frames.push_back(std::move(f));
  }
  return out;
}

PreintegrationOptions Preint() {
  PreintegrationOptions p;
  p.gravity = sim::kGravity;
  return p;
}

TEST(PointInit, RecoversScaleGravityAndGyroBiasInMotion) {
  // The default window (2 s) from 1 s into the flight. Over render seeds 1-10 the baseline came out
  // -1.1..+2.0 % off, gravity 0.08-0.20 deg, the gyro bias 0.0005-0.0011 rad/s (1.5 s windows:
  // -3.8..+2.4 %; noise-free: exact; with acc_bias_sigma 10: -1.8..+1.5 %).
  const PointInitOptions options;
  const RenderedStart r = Render(false, 1.0, 1.0 + options.window_s, 1);
  const PointInitSummary s =
      InitializeFromPoints(r.frames, r.imu, Intrinsics(), CameraMount(), Preint(), options);
  ASSERT_TRUE(s.success) << s.reason << " max parallax " << s.sfm.max_parallax_px;
  // Scale: the metric distance between the first and the last keyframe's camera.
  const Rigid3 T_B_C = CameraMount();
  const int64_t t0 = r.frames[s.first].t_ns;
  const Vec3 c0 = (r.trajectory.Pose(1e-9 * t0) * T_B_C).translation();
  const Vec3 c1 = (r.trajectory.Pose(1e-9 * s.t_last_ns) * T_B_C).translation();
  const double true_baseline = (c1 - c0).norm();
  // Gravity in the body frame: R_W_Bᵀ e_z, estimated against true.
  const sim::TrajectoryState truth = r.trajectory.State(1e-9 * t0);
  const Vec3 up_est = s.T_W_B.R().transpose() * Vec3::UnitZ();
  const Vec3 up_true = truth.T_W_B.R().transpose() * Vec3::UnitZ();
  const double gravity_deg = std::acos(std::min(1.0, up_est.dot(up_true))) * 180.0 / M_PI;
  const Vec3 v_B_est = s.T_W_B.R().transpose() * s.v_W;
  const Vec3 v_B_true = truth.T_W_B.R().transpose() * truth.v_W;
  std::printf(
      "[point_init] rot rms %.4f deg, %d keyframes, %d points, pair parallax %.1f px, BA %.2f px; "
      "baseline %.4f m "
      "(true %.4f, %+.2f %%), gravity dir %.3f deg (|g| off %.3f before), gyro bias err %.4f "
      "rad/s, velocity err %.3f m/s (speed %.2f)\n",
      s.rotation_rms_deg, s.keyframes, s.points, s.sfm.pair_parallax_px, s.sfm.rms_px, s.baseline_m,
      true_baseline, 100.0 * (s.baseline_m / true_baseline - 1.0), gravity_deg, s.gravity_error,
      (s.gyro_bias - r.gyro_bias).norm(), (v_B_est - v_B_true).norm(), v_B_true.norm());
  EXPECT_NEAR(s.baseline_m / true_baseline, 1.0, 0.02);
  EXPECT_LT(gravity_deg, 1.0);
  EXPECT_LT((s.gyro_bias - r.gyro_bias).norm(), 0.003);
  EXPECT_LT((v_B_est - v_B_true).norm(), 0.05);
  EXPECT_LT(s.gravity_error, 0.1 * sim::kGravity);
}

// Few points, 40 % of them in the distance (40-80 m, 60-120 baselines of the initial pair), with a
// long focal length: the distant ones agree with the pair's essential matrix too. recoverPose's
// default drops points beyond 50 baselines, and this start was refused ("24 of 32 agree, needs
// 30"), as the DM-VIO walk's were.
TEST(PointInit, DistantPointsAgreeWithTheEssentialMatrix) {
  StartScene scene;
  scene.wide = true;
  scene.points = 50;
  scene.near_m = 3.0;
  scene.far_m = 6.0;
  scene.background = 0.4;
  const PointInitOptions options;
  const RenderedStart r = Render(false, 1.0, 1.0 + options.window_s, 2, scene);
  const PointInitSummary s =
      InitializeFromPoints(r.frames, r.imu, Intrinsics(true), CameraMount(), Preint(), options);
  const Rigid3 T_B_C = CameraMount();
  const Vec3 c0 = (r.trajectory.Pose(1e-9 * r.frames[s.sfm.pair_first].t_ns) * T_B_C).translation();
  const Vec3 c1 =
      (r.trajectory.Pose(1e-9 * r.frames[s.sfm.pair_second].t_ns) * T_B_C).translation();
  std::printf("[point_init] distant points: %s; pair baseline %.3f m, parallax %.1f px\n",
              s.success ? "initialised" : s.reason.c_str(), (c1 - c0).norm(),
              s.sfm.pair_parallax_px);
  EXPECT_TRUE(s.success) << s.reason;
  EXPECT_EQ(s.reason.find("agree with the essential matrix"), std::string::npos) << s.reason;
}

// The pair with the most parallax is not always the one to start from. Tracks here live 1.2 s
// (as on the DM-VIO walk's fast turns: a third of the points lost per frame) and a quarter of them
// jump 8 px once, on a random frame (a track that slid to a neighbouring corner), so the widest
// pairs share barely 30 points of which too few agree with one essential matrix; the candidate
// pairs are tried in turn and one sharing more starts. Over render seeds 1-10 of this start: 2
// start only so (this one after 3 pairs, scale +0.3 %; seed 4 after 2, +0.9 %), 2 from the widest
// pair, 6 are refused whatever the pair (at most 2 pairs reach the 8 px of parallax).
TEST(PointInit, ACloserPairStartsWhenTheWidestIsRefused) {
  PointInitOptions options;
  const double t_begin = 1.0;
  RenderedStart r = Render(false, t_begin, t_begin + options.window_s, 2);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  struct Life {
    double begin_s, jump_s;
    Vec2 jump_px;
  };
  std::map<int64_t, Life> life;
  for (SfmFrame& f : r.frames) {
    std::vector<PointObservation> kept;
    const double t = 1e-9 * static_cast<double>(f.t_ns);
    for (PointObservation p : f.points) {
      auto it = life.find(p.point_id);
      if (it == life.end()) {
        const double begin = t_begin - 0.6 + (options.window_s + 0.6) * u01(rng);
        const double angle = 2.0 * M_PI * u01(rng);
        const bool jumps = u01(rng) < 0.25;
        it = life.emplace(p.point_id, Life{begin, jumps ? begin + 1.2 * u01(rng) : 1e9,
                                           8.0 * Vec2(std::cos(angle), std::sin(angle))})
                 .first;
      }
      if (t < it->second.begin_s || t > it->second.begin_s + 1.2) continue;
      if (t >= it->second.jump_s) p.uv_undistorted += it->second.jump_px;
      kept.push_back(p);
    }
    f.points = std::move(kept);
  }
  options.sfm.max_pairs = 1;
  const PointInitSummary widest =
      InitializeFromPoints(r.frames, r.imu, Intrinsics(), CameraMount(), Preint(), options);
  options.sfm.max_pairs = PointInitOptions().sfm.max_pairs;
  const PointInitSummary s =
      InitializeFromPoints(r.frames, r.imu, Intrinsics(), CameraMount(), Preint(), options);
  std::printf(
      "[point_init] widest pair only: %s; tried in turn: %s after %d pairs, parallax %.1f px\n",
      widest.success ? "initialised" : widest.reason.c_str(),
      s.success ? "initialised" : s.reason.c_str(), s.sfm.pairs_tried, s.sfm.pair_parallax_px);
  EXPECT_FALSE(widest.success);
  ASSERT_TRUE(s.success) << s.reason;
  EXPECT_GT(s.sfm.pairs_tried, 1);
  const Rigid3 T_B_C = CameraMount();
  const Vec3 c0 = (r.trajectory.Pose(1e-9 * r.frames[s.first].t_ns) * T_B_C).translation();
  const Vec3 c1 = (r.trajectory.Pose(1e-9 * s.t_last_ns) * T_B_C).translation();
  std::printf("[point_init] baseline %+.2f %% off\n",
              100.0 * (s.baseline_m / (c1 - c0).norm() - 1));
  EXPECT_NEAR(s.baseline_m / (c1 - c0).norm(), 1.0, 0.02);
}

// The start's motion is checked: the hand-held flight at 5 % of its amplitude, before points
// 0.3-0.6 m away (enough parallax), moves the camera ~8 cm. It starts with the default
// min_motion_m (5 cm) and is refused, with that reason, when 15 cm are asked for.
TEST(PointInit, RefusesAStartThatMovedTooLittle) {
  StartScene scene;
  scene.motion = 0.05;
  scene.near_m = 0.3;
  scene.far_m = 0.6;
  PointInitOptions options;
  const RenderedStart r = Render(false, 1.0, 1.0 + options.window_s, 1, scene);
  const PointInitSummary s =
      InitializeFromPoints(r.frames, r.imu, Intrinsics(), CameraMount(), Preint(), options);
  options.min_motion_m = 0.15;
  const PointInitSummary refused =
      InitializeFromPoints(r.frames, r.imu, Intrinsics(), CameraMount(), Preint(), options);
  std::printf("[point_init] little motion: %s (baseline %.3f m); asking 0.15 m: %s\n",
              s.success ? "initialised" : s.reason.c_str(), s.baseline_m,
              refused.success ? "initialised" : refused.reason.c_str());
  EXPECT_TRUE(s.success) << s.reason;
  EXPECT_FALSE(refused.success);
  EXPECT_NE(refused.reason.find("the camera moved"), std::string::npos) << refused.reason;
}

TEST(PointInit, RefusesPureRotation) {
  const RenderedStart r = Render(true, 1.0, 3.0, 1);
  const PointInitSummary s = InitializeFromPoints(r.frames, r.imu, Intrinsics(), CameraMount(),
                                                  Preint(), PointInitOptions());
  std::printf("[point_init] pure rotation: %s\n", s.reason.c_str());
  EXPECT_FALSE(s.success);
  EXPECT_NE(s.reason.find("too little parallax"), std::string::npos) << s.reason;
}

// The estimator starts from the points (no object in view, no still start) and reports it.
TEST(PointInit, EstimatorStartsFromPointsWithoutObjects) {
  const RenderedStart r = Render(false, 0.5, 3.0, 11);
  Calibration calib;
  calib.camera.width = 640;
  calib.camera.height = 480;
  calib.camera.fx = calib.camera.fy = 400;
  calib.camera.cx = 320;
  calib.camera.cy = 240;
  calib.T_B_C = CameraMount();
  EstimatorOptions options;
  options.imu.gravity = sim::kGravity;
  options.global.background = false;
  Estimator estimator(calib, options);
  size_t next_imu = 0;
  bool initialised = false;
  for (const SfmFrame& f : r.frames) {
    while (next_imu < r.imu.size() && r.imu[next_imu].t_ns <= f.t_ns + 10'000'000)
      estimator.AddImu(r.imu[next_imu++]);
    initialised = estimator.AddFrame(f.t_ns, {}, f.points) || initialised;
  }
  estimator.Finish();
  const EstimatorSummary& s = estimator.summary();
  ASSERT_TRUE(s.initialized) << s.init_failure << " / " << s.init_last_refusal;
  EXPECT_TRUE(initialised);
  EXPECT_EQ(s.init_method, "points");
  EXPECT_TRUE(s.init_in_motion);
  EXPECT_LT((s.init_gyro_bias - r.gyro_bias).norm(), 0.005);
  EXPECT_GT(s.init_scale, 0.0);
  // The first state's velocity against the truth (in the body frame: the yaw is a gauge).
  const std::vector<StateSample> states = estimator.States();
  ASSERT_FALSE(states.empty());
  EXPECT_GE(s.init_t_s, 0.0);
}

}  // namespace
}  // namespace fsp::backend
