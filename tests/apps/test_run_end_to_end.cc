// `fsp run --frontend gt-corners` (and `--frontend corners` fed the same corners) end to end on a
// short rendered sequence (a 10 x 8 x 3 m room, 12 rectangles, 10 s: 2 s still, then a loop in
// front of two walls; 320 x 240 images): window mode with 1 px corner noise stays within bounds set
// from measurement, and noise-free corners converge to the truth. The sequence is rendered once per
// test binary run (a few seconds).

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include "common/dataset_fixtures.h"
#include "fsp/common/calibration.h"
#include "fsp/common/observations_io.h"
#include "fsp/common/trajectory_io.h"

#include "fsp/eval/evaluate.h"
#include "fsp/sim/scene.h"
#include "fsp/sim/sequence_writer.h"
#include "room_loop.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;

// The objects and the flight; test::SmallRoomRig() adds the camera, the IMU and the room.
const char* kScene = R"(
objects:
  - {id: 1, class: door, corners: [[1.9, 0, 0], [1.0, 0, 0], [1.0, 0, 2.1], [1.9, 0, 2.1]]}
  - {id: 2, class: window, position: [4.6, 0, 1.0], rpy_deg: [90, 0, 180], width: 1.4, height: 1.2}
  - {id: 3, class: window, position: [7.2, 0, 1.0], rpy_deg: [90, 0, 180], width: 1.4, height: 1.2}
  - {id: 4, class: poster, position: [9.2, 0, 1.1], rpy_deg: [90, 0, 180], width: 0.8, height: 1.0}
  - {id: 30, class: tag, tag_id: 30, position: [2.75, 0, 1.3], rpy_deg: [90, 0, 180], width: 0.3, height: 0.3}
  - {id: 31, class: tag, tag_id: 31, position: [5.3, 0, 1.4], rpy_deg: [90, 0, 180], width: 0.16, height: 0.16}
  - {id: 10, class: window, position: [0, 1.5, 1.0], rpy_deg: [90, 0, 90], width: 1.5, height: 1.2}
  - {id: 11, class: poster, position: [0, 3.9, 1.2], rpy_deg: [90, 0, 90], width: 0.7, height: 1.0}
  - {id: 33, class: tag, tag_id: 33, position: [0, 5.3, 1.4], rpy_deg: [90, 0, 90], width: 0.16, height: 0.16}
  - {id: 12, class: door, position: [0, 6.4, 0], rpy_deg: [90, 0, 90], width: 0.9, height: 2.1}
  - {id: 5, class: cabinet, corners: [[0.8, 8, 0], [2.0, 8, 0], [2.0, 8, 1.8], [0.8, 8, 1.8]]}
  - {id: 6, class: painting, position: [2.8, 8, 1.3], rpy_deg: [90, 0, 0], width: 1.2, height: 0.8}
trajectory:
  waypoints:
    - [0,  5.0, 4.0, 1.3, -90]
    - [2,  5.0, 4.0, 1.3, -90]
    - [4,  5.0, 2.4, 1.5, -90]
    - [6,  3.5, 1.8, 1.3, -110]
    - [8,  2.0, 2.4, 1.5, -160]
    - [10, 1.8, 3.6, 1.2, 170]
    - [12, 2.2, 5.0, 1.6, 150]
noise: {pixel_sigma: 1.0, seed: 3}
duration_s: 10
)";

// The sequence, rendered once per test process into its own folder (CTest runs the tests of this
// file as parallel processes: a shared folder would be deleted by one while another reads it).
const fs::path& Sequence() {
  static const test::ProcessFolder dir("apps_e2e_sequence", [](const fs::path& d) {
    sim::SequenceOptions options;
    options.video = false;
    options.top_view = false;
    options.progress = false;
    sim::WriteSequence(sim::ParseScene(test::SmallRoomRig() + kScene, "e2e_scene.yaml", "."),
                       d.string(), options);
  });
  return dir.path();
}

struct RunResult {
  test::CommandResult command;
  eval::Metrics metrics;
  nlohmann::json run;
};

// Runs `fsp run` on the sequence into OUT and evaluates it against the ground truth.
RunResult RunAndEvaluate(const std::string& extra_args, const fs::path& out) {
  RunResult r;
  r.command = test::RunFsp("run " + Sequence().string() + " --frontend gt-corners --out " +
                           out.string() + " " + extra_args);
  EXPECT_EQ(r.command.exit_code, 0) << r.command.err;
  if (r.command.exit_code != 0) return r;
  r.metrics =
      eval::Evaluate(eval::ResolvePaths(Sequence().string(), out.string()), eval::EvalOptions());
  std::ifstream in(out / "run.json");
  in >> r.run;
  return r;
}

void Print(const char* label, const RunResult& r) {
  if (!r.metrics.trajectory || !r.metrics.objects) return;
  const auto& t = *r.metrics.trajectory;
  const auto& o = *r.metrics.objects;
  std::printf(
      "[%s] ATE %.4f m, RPE %.4f m/frame, objects %zu/%zu, corner err mean %.4f median %.4f m, "
      "width err mean %.4f max %.4f m, height err mean %.4f max %.4f m, back end median %.2f ms\n",
      label, t.ate.rmse, t.rpe_trans.rmse, o.matched, o.gt, o.corner_err.mean, o.corner_err.median,
      o.width_err.mean, o.width_err.max, o.height_err.mean, o.height_err.max,
      r.run["stage_ms"]["backend"]["median"].get<double>());
}

// Bounds: measured values plus ~50 % margin. With 1 px noise the window mode is far from the
// issue's targets on this short, low-resolution sequence (320 x 240). Measured with the defaults:
// ATE 9.1 cm, 5 objects in the map (the others are never fully visible long enough), width error
// mean 8.5 cm (max 31 cm), corner error mean 26 cm. Before re-anchoring kept depths inside the
// depth box, objects collapsed onto the 0.3 m minimum and only 2 reached the map (ATE 14.5 cm).
// These bounds guard against regressions and are to be tightened as the window mode improves;
// noise-free corners give 3 cm.
TEST(RunEndToEnd, WindowModeWithOnePixelNoise) {
  const RunResult r =
      RunAndEvaluate("--mode window --landmarks fsp --seed 1", test::ScratchDir() / "run");
  ASSERT_TRUE(r.metrics.trajectory.has_value());
  ASSERT_TRUE(r.metrics.objects.has_value());
  Print("window, 1 px", r);
  // Outputs as docs/outputs.md names them.
  EXPECT_EQ(r.run["frames"].get<int>(), 200);
  EXPECT_GT(r.run["keyframes"].get<int>(), 0);
  // Objects partly in view reach the window through the corners they show.
  EXPECT_GT(r.run["estimator"]["observations_partial"].get<int>(), 0);
  EXPECT_GT(r.run["estimator"]["observations_used"].get<int>(),
            r.run["estimator"]["observations_partial"].get<int>());
  EXPECT_TRUE(r.run["stage_ms"]["backend"].contains("p90"));
  EXPECT_GT(r.run["realtime_factor"].get<double>(), 0.0);
  EXPECT_NE(r.command.out.find("real time"), std::string::npos);
  const auto& t = *r.metrics.trajectory;
  const auto& o = *r.metrics.objects;
  EXPECT_EQ(t.pairs, 200u);
  EXPECT_GE(o.matched, 4u);
  EXPECT_LT(t.ate.rmse, 0.15);
  EXPECT_LT(o.width_err.mean, 0.13);
  EXPECT_LT(o.height_err.mean, 0.11);
  EXPECT_LT(o.corner_err.mean, 0.40);
}

// Batch mode with 1 px noise, FSP and the FHP baseline. Measured (seed 1, objects partly in view
// observed through the corners they show): FSP ATE 0.97 cm, width error mean 0.35 cm (max 0.69),
// height 0.35 cm, corner mean 1.3 cm; FHP ATE 1.4 cm, width 0.67 cm (max 1.2), height 0.43 cm,
// corner mean 1.8 cm (with whole views only: FSP 2.3 cm / 0.56 / 0.47 / 2.9 cm, FHP 2.8 cm / 0.80 /
// 0.85 / 4.2 cm). Before every periodic batch solve was run to convergence (6 iterations each)
// the default scene diverged (ATE 39 m).
//
// With estimator.batch_keyframe_interval_s 0.2 the batch solves keyframes only and predicts the
// frames between them through the IMU (for long sequences); on these 10 s that costs accuracy, and
// one seed's 5 objects vary a lot, so it is scored as the mean over seeds 1-3. Measured: ATE 1.94 /
// 2.04 / 1.97 cm, width error mean 1.05 / 0.74 / 1.07 cm, height 0.76 / 1.06 / 0.97 cm (the scale
// is 0.5-1.5 % short in every mode on these 10 s, and sets the sizes' error; seeds 4-8 give heights
// 0.5-1.5 cm); when written: ATE 1.86 / 2.43 / 2.95, widths 1.13 / 0.88 / 0.80, heights 0.81 / 1.05
// / 0.72 cm (with whole views only: ATE 1.66 / 3.89 / 3.94, widths 0.87 / 1.30 / 0.95, heights 0.62
// / 1.72 / 0.95, corners 3.6 / 6.9 / 4.5: its means fail these bounds).
TEST(RunEndToEnd, BatchModeWithOnePixelNoiseFspAndFhp) {
  const fs::path dir = test::ScratchDir(), keyframes = dir / "keyframes.yaml";
  std::ofstream(keyframes) << "estimator:\n  batch_keyframe_interval_s: 0.2\n";
  struct Bounds {
    const char* landmarks;
    bool keyframes;
    int seeds;  // the means over seeds 1..seeds are bounded
    double ate, width_mean, width_max, height_mean, corner_mean;
  };
  for (const Bounds& b : {Bounds{"fsp", false, 1, 0.02, 0.006, 0.012, 0.006, 0.025},
                          Bounds{"fhp", false, 1, 0.025, 0.01, 0.02, 0.008, 0.03},
                          Bounds{"fsp", true, 3, 0.03, 0.01, 0.025, 0.0095, 0.045}}) {
    double ate = 0.0, width_mean = 0.0, width_max = 0.0, height_mean = 0.0, corner_mean = 0.0;
    for (int seed = 1; seed <= b.seeds; ++seed) {
      const std::string name = std::string(b.landmarks) + (b.keyframes ? "_keyframes" : "") +
                               "_seed" + std::to_string(seed);
      const RunResult r = RunAndEvaluate(
          "--mode batch --seed " + std::to_string(seed) + " --landmarks " + b.landmarks +
              (b.keyframes ? " --config " + keyframes.string() : std::string()),
          dir / name);
      ASSERT_TRUE(r.metrics.trajectory.has_value()) << name;
      ASSERT_TRUE(r.metrics.objects.has_value()) << name;
      Print(name.c_str(), r);
      ate += r.metrics.trajectory->ate.rmse / b.seeds;
      width_mean += r.metrics.objects->width_err.mean / b.seeds;
      width_max += r.metrics.objects->width_err.max / b.seeds;
      height_mean += r.metrics.objects->height_err.mean / b.seeds;
      corner_mean += r.metrics.objects->corner_err.mean / b.seeds;
      // Width/height sigma from the covariance (FHP: propagated from its 12 corner parameters).
      std::ifstream in(dir / name / "map.json");
      nlohmann::json map;
      in >> map;
      ASSERT_FALSE(map["objects"].empty()) << name;
      for (const auto& o : map["objects"]) {
        ASSERT_TRUE(o["width_sigma"].is_number()) << name << " object " << o["id"];
        EXPECT_GT(o["width_sigma"].get<double>(), 0.0) << name;
        EXPECT_LT(o["width_sigma"].get<double>(), 0.15) << name;  // measured 0.002-0.073 m
        EXPECT_GT(o["height_sigma"].get<double>(), 0.0) << name;
      }
    }
    EXPECT_LT(ate, b.ate) << b.landmarks;
    EXPECT_LT(width_mean, b.width_mean) << b.landmarks;
    EXPECT_LT(width_max, b.width_max) << b.landmarks;
    EXPECT_LT(height_mean, b.height_mean) << b.landmarks;
    EXPECT_LT(corner_mean, b.corner_mean) << b.landmarks;
  }
}

// The hall flight stands on the floor for its first 20 s, three objects 4 m away in view: no
// parallax, the width prior alone holds their depth. FHP had none: the first solves moved its
// corners' depths onto the depth box to fit the corner noise, at 30 m they held no translation, and
// the window drifted on the IMU (with this seed 0.73 m after 10 s; the whole flight then diverged
// at take-off, ATE 2.7 m). Measured since, the largest displacement from the start: FSP 3.5 cm
// (in its first 3 s, then within 6 mm), FHP 4 mm; bounds with ~50 % margin. With the chi-square
// stand-still test (it fires on these 1 px corners; confidence 0.75: 31 of 50 keyframes): FSP 11.8
// mm, FHP 3.4 mm.
TEST(RunEndToEnd, BothLandmarkModelsHoldTheHallFlightsStandStill) {
  const fs::path dir = test::ScratchDir(), seq = dir / "hall_start";
  sim::Scene scene =
      sim::LoadScene(std::string(FSP_SOURCE_DIR) + "/assets/scenes/hall_flight.yaml");
  scene.duration_s = 10.0;  // standing still until 20 s
  scene.seed = 1;
  sim::SequenceOptions options;
  options.images = false;
  options.video = false;
  options.top_view = false;
  options.progress = false;
  sim::WriteSequence(scene, seq.string(), options);
  for (const auto& [landmarks, bound] : {std::pair{"fsp", 0.05}, std::pair{"fhp", 0.007}}) {
    const fs::path out = dir / landmarks;
    const test::CommandResult c =
        test::RunFsp("run " + seq.string() + " --frontend gt-corners --seed 1 --landmarks " +
                     landmarks + " --out " + out.string());
    ASSERT_EQ(c.exit_code, 0) << c.err;
    // Every frame's own estimate (the online trajectory) against the first: the truth is still.
    const std::vector<StampedPose> online = ReadTum((out / "trajectory_online.tum").string());
    ASSERT_EQ(online.size(), 100u) << landmarks;
    double worst = 0.0;
    for (const StampedPose& p : online)
      worst = std::max(worst, (p.T_W_B.translation() - online[0].T_W_B.translation()).norm());
    std::printf("[stand still %s] worst displacement %.4f m\n", landmarks, worst);
    EXPECT_LT(worst, bound) << landmarks;
  }
}

// Noise-free corners: what remains is the IMU noise (scale, drift) over 10 s. Measured (0c00755):
// batch ATE 1.9 cm, width error max 4.1 cm, height max 3.3 cm, corner mean 4.5 cm; window ATE 0.8
// cm, width max 1.2 cm, height max 1.1 cm, corner mean 1.4 cm (bounds kept from the older 3.2 cm
// window).
//
// The window's global step (on by default) is measured apart: on this sequence it converges to 2.9
// cm ATE (width max 7.5 cm, height max 6.0 cm, corner mean 7.3 cm), worse than the window alone
// (0.77 cm) and than the batch, to the same value with 300 iterations: with noise-free corners the
// whole-history optimum at keyframe granularity is worse than the window's, which the 1 px runs
// (room loop, default room) do not show. The batch at keyframe granularity
// (batch_keyframe_interval_s 0.2) lands on the same 2.65 cm: the loss comes from solving keyframes
// only (the corners seen between them are unused), not from the global step.
TEST(RunEndToEnd, NoiseFreeCornersConverge) {
  const fs::path dir = test::ScratchDir(), cfg = dir / "sigma0.yaml",
                 cfg_window = dir / "sigma0_window_alone.yaml";
  std::ofstream(cfg) << "frontend:\n  gt_corners:\n    pixel_sigma: 0\n";
  std::ofstream(cfg_window) << "frontend:\n  gt_corners:\n    pixel_sigma: 0\n"
                            << "estimator:\n  global:\n    enabled: false\n";
  struct Bounds {
    const char* name;
    const char* mode;
    const fs::path& config;
    double ate, width_max, height_max, corner_mean;
  };
  for (const Bounds& b : {Bounds{"batch", "batch", cfg, 0.03, 0.06, 0.05, 0.07},
                          Bounds{"window", "window", cfg_window, 0.05, 0.13, 0.05, 0.11},
                          Bounds{"window+global", "window", cfg, 0.045, 0.11, 0.09, 0.11}}) {
    const RunResult r = RunAndEvaluate(
        std::string("--mode ") + b.mode + " --config " + b.config.string(), dir / b.name);
    ASSERT_TRUE(r.metrics.trajectory.has_value()) << b.name;
    ASSERT_TRUE(r.metrics.objects.has_value()) << b.name;
    Print(b.name, r);
    EXPECT_LT(r.metrics.trajectory->ate.rmse, b.ate) << b.name;
    EXPECT_LT(r.metrics.objects->width_err.max, b.width_max) << b.name;
    EXPECT_LT(r.metrics.objects->height_err.max, b.height_max) << b.name;
    EXPECT_LT(r.metrics.objects->corner_err.mean, b.corner_mean) << b.name;
  }
}

// --video: one annotated frame per input frame, of the camera's size (here from ground-truth
// corners: no image is decoded, the objects are drawn on a grey canvas), then the map with its σ
// (AnnotatedVideo::kSummaryFrames); an unwritable path is one clear error.
TEST(RunEndToEnd, AnnotatedVideoHasEveryFrame) {
  const fs::path dir = test::ScratchDir();
  const RunResult r = RunAndEvaluate("--video " + (dir / "annotated.mp4").string(), dir / "run");
  ASSERT_EQ(r.command.exit_code, 0);
  cv::VideoCapture video((dir / "annotated.mp4").string());
  ASSERT_TRUE(video.isOpened());
  int frames = 0;
  cv::Mat frame, last;
  while (video.read(frame)) {
    ++frames;
    EXPECT_EQ(frame.cols, 320);
    EXPECT_EQ(frame.rows, 240);
    last = frame.clone();
  }
  EXPECT_EQ(frames, 200 + 40);  // every frame, then 2 s of the map with its σ
  // The last frame is not the plain canvas: outlines, labels and the top view are drawn on it.
  ASSERT_FALSE(last.empty());
  cv::Mat grey;
  cv::cvtColor(last, grey, cv::COLOR_BGR2GRAY);
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(grey, &lo, &hi);
  EXPECT_GT(hi - lo, 100.0);

  const test::CommandResult bad =
      test::RunFsp("run " + Sequence().string() + " --frontend gt-corners --out " +
                   (dir / "bad").string() + " --video /nonexistent/x.mp4");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("cannot write the video"), std::string::npos) << bad.err;
}

TEST(RunEndToEnd, SameSeedSameOutput) {
  const fs::path a = test::ScratchDir() / "a", b = test::ScratchDir().parent_path() / "b_same_seed";
  const std::string base = "run " + Sequence().string() + " --frontend gt-corners --seed 5 --out ";
  ASSERT_EQ(test::RunFsp(base + a.string()).exit_code, 0);
  ASSERT_EQ(test::RunFsp(base + b.string()).exit_code, 0);
  for (const char* f : {"observations.csv", "trajectory.tum", "map.json"})
    EXPECT_EQ(test::ReadText(a / f), test::ReadText(b / f)) << f;
  EXPECT_FALSE(test::ReadText(a / "observations.csv").empty());
}

// The corners front end fed the sequence's own observations_gt.csv and objects_gt.json (no lens
// distortion in this scene, so its undistorted corners are also the raw image's) is gt-corners
// without noise: the same outputs, byte for byte.
TEST(RunEndToEnd, CornersFrontEndOnTheGroundTruthIsGtCornersWithoutNoise) {
  const fs::path dir = test::ScratchDir(), cfg = dir / "sigma0.yaml";
  std::ofstream(cfg) << "frontend:\n  gt_corners:\n    pixel_sigma: 0\n";
  const std::string base = "run " + Sequence().string() + " --mode window --out ";
  const test::CommandResult gt = test::RunFsp(base + (dir / "gt").string() +
                                              " --frontend gt-corners --config " + cfg.string());
  ASSERT_EQ(gt.exit_code, 0) << gt.err;
  const test::CommandResult corners =
      test::RunFsp(base + (dir / "corners").string() + " --frontend corners --corners " +
                   (Sequence() / "observations_gt.csv").string() + " --objects " +
                   (Sequence() / "objects_gt.json").string());
  ASSERT_EQ(corners.exit_code, 0) << corners.err;
  EXPECT_NE(corners.out.find("front end corners ("), std::string::npos) << corners.out;
  for (const char* f : {"observations.csv", "trajectory.tum", "map.json"})
    EXPECT_EQ(test::ReadText(dir / "gt" / f), test::ReadText(dir / "corners" / f)) << f;
  EXPECT_EQ(ReadTum((dir / "corners" / "trajectory.tum").string()).size(), 200u);
  std::ifstream in(dir / "corners" / "map.json");
  const nlohmann::json map = nlohmann::json::parse(in);
  EXPECT_GE(map["objects"].size(), 4u);
}

// The same with lens distortion: the corners file holds the distorted corners (as a detector finds
// them in the raw image; 4 decimals), the calibration says how to undo it. The trajectory equals
// gt-corners' to the rounding of the file.
TEST(RunEndToEnd, CornersFrontEndUndoesTheLensDistortion) {
  const fs::path dir = test::ScratchDir();
  Calibration calib = ReadCalibration((Sequence() / "calib.yaml").string());
  calib.camera.distortion = {-0.1, 0.03, 0.0002, -0.0001};  // the default room's lens
  WriteCalibration(calib, (dir / "calib.yaml").string());
  std::vector<CornerRow> rows = ReadCornerRows((Sequence() / "observations_gt.csv").string());
  double max_shift = 0.0;
  for (CornerRow& r : rows) {
    for (Vec2& c : r.corners) {
      const Vec2 d = calib.camera.DistortPixel(c);
      if (r.FullyVisible()) max_shift = std::max(max_shift, (d - c).norm());
      c = d;
    }
  }
  EXPECT_GT(max_shift, 5.0);  // pixels: ignoring the distortion would matter
  WriteCornerRows(rows, (dir / "distorted.csv").string(), /*with_flag=*/true);
  std::ofstream(dir / "sigma0.yaml") << "frontend:\n  gt_corners:\n    pixel_sigma: 0\n";
  const std::string base = "run " + Sequence().string() + " --mode window --calib " +
                           (dir / "calib.yaml").string() + " --out ";
  const test::CommandResult gt =
      test::RunFsp(base + (dir / "gt").string() + " --frontend gt-corners --config " +
                   (dir / "sigma0.yaml").string());
  ASSERT_EQ(gt.exit_code, 0) << gt.err;
  const test::CommandResult corners = test::RunFsp(
      base + (dir / "corners").string() + " --frontend corners --corners " +
      (dir / "distorted.csv").string() + " --objects " + (Sequence() / "objects_gt.json").string());
  ASSERT_EQ(corners.exit_code, 0) << corners.err;
  const std::vector<StampedPose> a = ReadTum((dir / "gt" / "trajectory.tum").string());
  const std::vector<StampedPose> b = ReadTum((dir / "corners" / "trajectory.tum").string());
  ASSERT_EQ(a.size(), 200u);
  ASSERT_EQ(a.size(), b.size());
  double max_diff = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].t_ns, b[i].t_ns);
    max_diff = std::max(max_diff, (a[i].T_W_B.translation() - b[i].T_W_B.translation()).norm());
  }
  std::printf("[corners, distorted] largest position difference to gt-corners %.3g m\n", max_diff);
  EXPECT_LT(max_diff, 1e-4);
}

}  // namespace
}  // namespace fsp::apps
