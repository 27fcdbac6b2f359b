// `fsp run --frontend rect` end to end from pixels: a rendered 640 x 480 sequence (a 10 x 8 x 3 m
// room, 12 rectangles among them 3 AprilTags and a plain door, 10 s: 2 s still, then a loop in
// front of two walls) goes through detection, tracking, association and the estimator. The front
// end is scored against the ground-truth corners (recall, precision, corner error, identities), the
// map and the trajectory against the ground truth. The sequence is rendered once per test process
// (~10 s).

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fsp/eval/evaluate.h"
#include "fsp/sim/scene.h"
#include "fsp/sim/sequence_writer.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;

const char* kScene = R"(
camera: {width: 640, height: 480, fx: 458.0, fy: 458.0, cx: 319.5, cy: 239.5, rate_hz: 20}
T_B_C: [0, 0, 1, 0.05,  -1, 0, 0, 0.0,  0, -1, 0, 0.0,  0, 0, 0, 1]
imu: {rate_hz: 200, gyroscope_noise_density: 1.7e-4, accelerometer_noise_density: 2.0e-3,
      gyroscope_random_walk: 1.9e-5, accelerometer_random_walk: 3.0e-3,
      gyroscope_bias: [0.002, -0.001, 0.0015], accelerometer_bias: [0.03, -0.02, 0.04]}
room: {min: [0, 0, 0], max: [10, 8, 3]}
objects:
  - {id: 1, class: door, texture: plain, corners: [[1.9, 0, 0], [1.0, 0, 0], [1.0, 0, 2.1], [1.9, 0, 2.1]]}
  - {id: 2, class: window, position: [4.6, 0, 1.0], rpy_deg: [90, 0, 180], width: 1.4, height: 1.2}
  - {id: 3, class: window, position: [7.2, 0, 1.0], rpy_deg: [90, 0, 180], width: 1.4, height: 1.2}
  - {id: 4, class: poster, position: [9.2, 0, 1.1], rpy_deg: [90, 0, 180], width: 0.8, height: 1.0}
  - {id: 30, class: tag, tag_id: 30, position: [2.75, 0, 1.3], rpy_deg: [90, 0, 180], width: 0.3, height: 0.3}
  - {id: 31, class: tag, tag_id: 31, position: [5.3, 0, 1.4], rpy_deg: [90, 0, 180], width: 0.2, height: 0.2}
  - {id: 10, class: window, position: [0, 1.5, 1.0], rpy_deg: [90, 0, 90], width: 1.5, height: 1.2}
  - {id: 11, class: poster, position: [0, 3.9, 1.2], rpy_deg: [90, 0, 90], width: 0.7, height: 1.0}
  - {id: 33, class: tag, tag_id: 33, position: [0, 5.3, 1.4], rpy_deg: [90, 0, 90], width: 0.2, height: 0.2}
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

const fs::path& Sequence() {
  static const test::ProcessFolder dir("pixels_e2e_sequence", [](const fs::path& d) {
    sim::SequenceOptions options;
    options.video = true;
    options.top_view = false;
    options.progress = false;
    sim::WriteSequence(sim::ParseScene(kScene, "pixels_e2e_scene.yaml", "."), d.string(), options);
  });
  return dir.path();
}

// A scene of assets/scenes rendered once per test process (SEED >= 0 and DURATION_S > 0 replace
// the scene's, as `fsp render --seed --duration` does).
const fs::path& RenderedClip(const std::string& name, int seed = -1, double duration_s = 0.0) {
  static std::map<std::string, std::unique_ptr<test::ProcessFolder>> clips;
  const std::string key = name + "_s" + std::to_string(seed) + "_" + std::to_string(duration_s);
  std::unique_ptr<test::ProcessFolder>& clip = clips[key];
  if (!clip) {
    clip = std::make_unique<test::ProcessFolder>(key, [&](const fs::path& d) {
      sim::Scene scene =
          sim::LoadScene(std::string(FSP_SOURCE_DIR) + "/assets/scenes/" + name + ".yaml");
      if (seed >= 0) scene.seed = static_cast<uint32_t>(seed);
      if (duration_s > 0.0) scene.duration_s = duration_s;
      sim::SequenceOptions options;
      options.video = false;
      options.top_view = false;
      options.progress = false;
      sim::WriteSequence(scene, d.string(), options);
    });
  }
  return clip->path();
}

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct RunResult {
  test::CommandResult command;
  eval::Metrics metrics;
  nlohmann::json run, map;
};

RunResult RunAndEvaluate(const std::string& input_and_args, const fs::path& out,
                         const fs::path& gt = Sequence()) {
  RunResult r;
  r.command = test::RunFsp("run " + input_and_args + " --out " + out.string());
  EXPECT_EQ(r.command.exit_code, 0) << r.command.err;
  if (r.command.exit_code != 0) return r;
  r.metrics = eval::Evaluate(eval::ResolvePaths(gt.string(), out.string()), eval::EvalOptions());
  r.run = nlohmann::json::parse(Slurp(out / "run.json"));
  r.map = nlohmann::json::parse(Slurp(out / "map.json"));
  return r;
}

void Print(const char* label, const RunResult& r) {
  const auto& t = r.metrics.trajectory;
  const auto& o = r.metrics.objects;
  const auto& f = r.metrics.frontend;
  if (!t || !o || !f) return;
  std::printf(
      "[%s] ATE %.4f m, objects %zu/%zu (map %zu), width err mean %.4f max %.4f m, height err mean "
      "%.4f max %.4f m, corner err mean %.4f m; front end recall %.3f precision %.3f corner median "
      "%.3f px, id switches %d; front end median %.2f ms, back end median %.2f ms\n",
      label, t->ate.rmse, o->matched, o->gt, r.map["objects"].size(), o->width_err.mean,
      o->width_err.max, o->height_err.mean, o->height_err.max, o->corner_err.mean,
      f->recall.value_or(0.0), f->precision.value_or(0.0), f->corner_err_px.median, f->id_switches,
      r.run["stage_ms"]["frontend"]["median"].get<double>(),
      r.run["stage_ms"]["backend"]["median"].get<double>());
}

void PrintTracking(const char* label, const eval::FrontendMetrics& f) {
  std::printf(
      "[%s] success %zu/%zu (%.3f), corner median %.3f px, boxes out of view %zu, returns %zu "
      "re-identified %zu, id switches %d, recall %.3f, precision %.3f\n",
      label, f.success_frames, f.success_total, f.success_rate.value_or(0.0),
      f.corner_err_px.median, f.boxes_out_of_view, f.returns, f.reidentified, f.id_switches,
      f.recall.value_or(0.0), f.precision.value_or(0.0));
}

// The tracker's clips (assets/scenes/clip_*.yaml), from pixels in window mode, scored against the
// ground-truth corners. Zoom/roll: a poster zooms 0.51-1.97x, banks to +-45 deg in a sideways dash,
// leaves the view for 35 frames and returns; a plain door, a window, a tag. Measured: success
// 580/581 (0.998; 577 before a side on a thin dark frame's edge moved to the frame's centre,
// rect.band_thin_px and rect.band_thin_inside_max_dip; 553, 0.952, before the front end re-acquired
// dormant objects where the map predicts them and put framed objects' sides on their outline; 549,
// 0.937, before the detector ran while the map predicts a return), median 0.151 px, no box out of
// view, 5/5 returns re-identified, 0 id switches.
TEST(PixelsEndToEnd, TrackingClipZoomRollAndReturn) {
  const fs::path clip = RenderedClip("clip_zoom_roll");
  const RunResult r = RunAndEvaluate(clip.string(), test::ScratchDir() / "run", clip);
  ASSERT_TRUE(r.metrics.frontend && r.metrics.frontend->success_rate);
  const eval::FrontendMetrics& f = *r.metrics.frontend;
  PrintTracking("zoom/roll", f);
  EXPECT_GE(*f.success_rate, 0.98);
  EXPECT_LE(f.corner_err_px.median, 0.3);
  EXPECT_LE(f.boxes_out_of_view, 2u);
  EXPECT_GE(f.returns, 4u);
  EXPECT_EQ(f.reidentified, f.returns);
  EXPECT_EQ(f.id_switches, 0);
  EXPECT_GE(*f.precision, 0.98);
}

// Motion blur (20 ms shutter: median 6 px, p90 17 px of smear on the poster). Measured: success
// 391/409 (0.956; render seed 2 in `fsp bench`: 389/409; 381 without the relearnt
// polarities and re-acquisition over a candidate; 377 before the blur test also kept a weakly held
// object off its smeared edges at the start of a turn; 368 before an object lost in a fast move was
// looked for at its prediction by its smeared reference, `tracker.fast_align_*`; 365 before a
// detection with a corner at the image border could correct a track its edges had not fitted;
// 300/409 before the tracker's blur test, `tracker.blur_sharpness_ratio`, kept the keypoint
// homography and refused detections' corrections while the poster's sides are smeared; 342/409
// before the blurred frames' alignment to the reference, `tracker.blur_align_*`, held the poster
// through 1 s of zoom under blur, where the flow had drifted 2-6 px), no box out of view, every
// return re-identified, 0 id switches. The misses (18): poster 1 in the dash (rolling 8 deg per
// frame) and at its peak (6), as it decelerates at 3.35 s and as it comes back in the last turn;
// tag 30 in the dash and as it comes back in the last turn at up to 174 px per frame (8, its smear
// longer than the tag); poster 4 at the start of the last turn (2).
TEST(PixelsEndToEnd, TrackingClipMotionBlur) {
  const fs::path clip = RenderedClip("clip_blur");
  const RunResult r = RunAndEvaluate(clip.string(), test::ScratchDir() / "run", clip);
  ASSERT_TRUE(r.metrics.frontend && r.metrics.frontend->success_rate);
  const eval::FrontendMetrics& f = *r.metrics.frontend;
  PrintTracking("blur", f);
  EXPECT_GE(*f.success_rate, 0.95);
  EXPECT_LE(f.corner_err_px.median, 0.5);
  EXPECT_EQ(f.boxes_out_of_view, 0u);
  EXPECT_EQ(f.reidentified, f.returns);
  EXPECT_EQ(f.id_switches, 0);
}

// The handheld walk (assets/scenes/handheld_walk.yaml), render seed 2, its first 20 s from pixels:
// it starts from a rectangle at 1.2 s and then sees no whole object for 12 s, held by the points
// and the IMU. Measured: ATE 0.68 cm, no divergence; with a 30-keyframe window (3 s) the scale
// drifted, the speed grew to 3.5 m/s and the ATE reached 4.4 m (backend/README.md, "Window
// length").
TEST(PixelsEndToEnd, HandheldWalkHoldsThroughAStretchOfPointsOnly) {
  const fs::path walk = RenderedClip("handheld_walk", 2, 20.0);
  const RunResult r = RunAndEvaluate(walk.string(), test::ScratchDir() / "run", walk);
  ASSERT_TRUE(r.metrics.trajectory.has_value());
  Print("handheld walk s2 20 s", r);
  EXPECT_EQ(r.run["faults"]["divergences"].get<int>(), 0);
  EXPECT_GT(r.run["faults"]["blind_max_s"].get<double>(), 8.0);  // the stretch is there
  EXPECT_LT(r.metrics.trajectory->ate.rmse, 0.03);
}

TEST(PixelsEndToEnd, BatchFromPixelsMapsTheRoom) {
  const RunResult r = RunAndEvaluate(Sequence().string() + " --frontend rect --mode batch",
                                     test::ScratchDir() / "run");
  ASSERT_TRUE(r.metrics.trajectory && r.metrics.objects && r.metrics.frontend);
  Print("rect, batch", r);
  // Measured: ATE 1.1 cm, 5 of the 12 objects matched in the map (the others are never fully in
  // view long enough in these 10 s, as with gt-corners), width error mean 0.47 cm (max 0.84),
  // front end recall 0.969, precision 1.000, corner median 0.090 px, 0 id switches (ATE 3.5 cm
  // and width error 2.2 cm before the back end's predictions gated re-identification).
  const auto& f = *r.metrics.frontend;
  EXPECT_GE(*f.recall, 0.95);
  EXPECT_GE(*f.precision, 0.99);
  EXPECT_LE(f.corner_err_px.median, 0.2);
  EXPECT_EQ(f.id_switches, 0);
  EXPECT_LT(r.metrics.trajectory->ate.rmse, 0.03);
  EXPECT_GE(r.metrics.objects->matched, 5u);
  EXPECT_LT(r.metrics.objects->width_err.mean, 0.012);
  EXPECT_LT(r.metrics.objects->height_err.mean, 0.01);
  // Every matched object gets its class right (a painting counts as a poster).
  for (const auto& o : r.metrics.objects->per_object)
    EXPECT_TRUE(o.class_right) << "object " << o.id << ": " << o.gt_class << " mapped as "
                               << o.est_class;
  // Tags are mapped under their tag ids (tag 33 is never in view).
  std::set<int> ids;
  for (const auto& o : r.map["objects"]) ids.insert(o["id"].get<int>());
  for (int tag : {30, 31}) EXPECT_TRUE(ids.count(tag)) << "tag " << tag;
}

// The same rendered sequence as an image folder (cam0/data with imu.csv and calib.yaml) gives
// exactly the EuRoC layout's result; as a video (mp4v, lossy) the images differ by compression, so
// the result agrees to within a bound, not byte for byte. Window mode (cheap); the same input twice
// gives byte-identical outputs.
TEST(PixelsEndToEnd, EveryInputKindGivesTheSameResult) {
  const fs::path dir = test::ScratchDir();
  const std::string seq = Sequence().string();
  const std::string side = " --imu " + (Sequence() / "imu.csv").string() + " --calib " +
                           (Sequence() / "calib.yaml").string();
  const RunResult euroc = RunAndEvaluate(seq + " --frontend rect", dir / "euroc");
  const RunResult again = RunAndEvaluate(seq + " --frontend rect", dir / "again");
  const RunResult folder =
      RunAndEvaluate((Sequence() / "mav0" / "cam0" / "data").string() + side, dir / "folder");
  const RunResult video = RunAndEvaluate((Sequence() / "video.mp4").string() + side, dir / "video");
  ASSERT_TRUE(euroc.metrics.trajectory && folder.metrics.trajectory && video.metrics.trajectory);
  Print("euroc", euroc);
  Print("video", video);
  for (const char* f : {"observations.csv", "trajectory.tum", "map.json"}) {
    EXPECT_EQ(Slurp(dir / "euroc" / f), Slurp(dir / "again" / f)) << f;
    EXPECT_EQ(Slurp(dir / "euroc" / f), Slurp(dir / "folder" / f)) << f;
  }
  EXPECT_FALSE(Slurp(dir / "euroc" / "observations.csv").empty());
  // Objects partly out of the image are observed through their corners in view.
  EXPECT_GT(euroc.run["estimator"]["observations_partial"].get<int>(), 0);
  // Video: the front end's numbers agree (measured recall 0.961 vs 0.963, precision 1.000 both);
  // the window's ATE can then differ by a few cm (measured 1.04 vs 0.98 cm; 4.6 vs 2.2 cm before
  // the predictions).
  ASSERT_TRUE(video.metrics.frontend && euroc.metrics.frontend);
  EXPECT_NEAR(*video.metrics.frontend->recall, *euroc.metrics.frontend->recall, 0.02);
  EXPECT_NEAR(*video.metrics.frontend->precision, *euroc.metrics.frontend->precision, 0.02);
  EXPECT_LT(video.metrics.trajectory->ate.rmse, 0.04);
  EXPECT_EQ(video.map["objects"].size(), euroc.map["objects"].size());
}

}  // namespace
}  // namespace fsp::apps
