// The window's global step end to end (`fsp run --frontend gt-corners`, window mode) on the room
// loop (room_loop.h): its objects return after the flight looked at the other walls, so loops
// close; the global bundle adjustment must keep their identities, end more accurate than the
// window alone, write the causal trajectory beside the final one, and stay deterministic.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fsp/common/trajectory_io.h"
#include "fsp/eval/evaluate.h"
#include "room_loop.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;

struct LoopRun {
  nlohmann::json run;
  double ate = -1.0, causal_ate = -1.0, width_mean = -1.0;
  size_t causal_poses = 0, objects = 0;
};

// Runs the room loop with the config text CONFIG (YAML; empty: defaults) into OUT.
LoopRun RunLoop(const fs::path& out, const std::string& config) {
  fs::create_directories(out);
  std::string extra;
  if (!config.empty()) {
    std::ofstream(out / "config.yaml") << config;
    extra = " --config " + (out / "config.yaml").string();
  }
  LoopRun r;
  const test::CommandResult c =
      test::RunFsp("run " + test::RoomLoopSequence().string() +
                   " --frontend gt-corners --seed 1 --out " + (out / "run").string() + extra);
  EXPECT_EQ(c.exit_code, 0) << c.err;
  if (c.exit_code != 0) return r;
  std::ifstream(out / "run" / "run.json") >> r.run;
  const eval::EvalOptions eo;
  const eval::Metrics m = eval::Evaluate(
      eval::ResolvePaths(test::RoomLoopSequence().string(), (out / "run").string()), eo);
  const fs::path causal = out / "run" / "trajectory_online.tum";
  r.causal_poses = ReadTum(causal.string()).size();
  const eval::Metrics mc =
      eval::Evaluate(eval::ResolvePaths(test::RoomLoopSequence().string(), causal.string()), eo);
  if (m.trajectory) r.ate = m.trajectory->ate.rmse;
  if (mc.trajectory) r.causal_ate = mc.trajectory->ate.rmse;
  if (m.objects) {
    r.width_mean = m.objects->width_err.mean;
    r.objects = m.objects->matched;
  }
  std::printf("[%s] ATE %.4f m (causal %.4f m), width err mean %.4f m, %zu objects, global %s\n",
              out.filename().c_str(), r.ate, r.causal_ate, r.width_mean, r.objects,
              r.run["global"].dump().c_str());
  return r;
}

// Measured (seed 1) when written: global step ATE 2.8 cm, causal 7.1 cm, width error mean 2.4 cm,
// 13 objects matched, 3 loops closed, none rejected, 15 global solves; the window alone
// (global.enabled false) ATE 11.9 cm, width error 4.7 cm, 12 objects, its 3 returning objects
// started afresh. Bounds: ~50 % over that measurement, and the global step at least 3x better than
// the window alone. Since the window keeps the gyroscope bias the start stood still for
// (backend/README.md, "Standing still"), the window alone drifts less in yaw: today global step
// 1.41 cm (causal 3.3 cm, widths 1.2 cm, 14 objects), window alone 3.1 cm (6.4 with the start's
// bias given σ 0.01 rad/s; 14 objects, 3 started afresh). So the global step's own bound is ~50 %
// over today's 1.41 cm, and it must stay 1.5x better than the window alone (measured 2.2x).
TEST(GlobalStep, ClosesTheRoomLoopWithOneIdentityPerObject) {
  const fs::path dir = test::ScratchDir();
  const LoopRun on = RunLoop(dir / "global", "");
  const LoopRun off = RunLoop(dir / "window_alone", "estimator:\n  global:\n    enabled: false\n");
  ASSERT_GT(on.ate, 0.0);
  ASSERT_GT(off.ate, 0.0);
  const nlohmann::json& g = on.run["global"];
  EXPECT_GE(g["loops_closed"].get<int>(), 3);
  EXPECT_EQ(g["loops_rejected"].get<int>(), 0);
  EXPECT_EQ(g["objects_reinitialized"].get<int>(), 0);
  EXPECT_GE(g["solves"].get<int>(), 5);
  EXPECT_EQ(g["rejected"].get<int>(), 0);
  EXPECT_GT(off.run["global"]["objects_reinitialized"].get<int>(), 0);
  EXPECT_EQ(off.run["global"]["solves"].get<int>(), 0);
  EXPECT_EQ(on.causal_poses, test::kRoomLoopFrames);
  EXPECT_LT(on.ate, 0.022);
  EXPECT_LT(on.causal_ate, 0.10);
  EXPECT_LT(on.width_mean, 0.035);
  EXPECT_LT(1.5 * on.ate, off.ate);
  EXPECT_GE(on.objects, off.objects);
}

// The other window boundary (no dense prior; the keyframe before the window held fixed, as
// ORB-SLAM3's local inertial BA): measured ATE 2.8 cm, causal 6.1 cm.
TEST(GlobalStep, FixedBoundaryKeyframeAlsoCloses) {
  const LoopRun r =
      RunLoop(test::ScratchDir() / "fixed", "estimator:\n  global:\n    boundary: fixed\n");
  EXPECT_GE(r.run["global"]["loops_closed"].get<int>(), 3);
  EXPECT_LT(r.ate, 0.045);
  EXPECT_LT(r.causal_ate, 0.08);
}

// A frame that is no keyframe is solved for its own state alone (frame_motion_only, the default),
// not with the whole window: the same accuracy as re-solving the window with it. Measured (seed 1):
// ATE 1.43 / 1.43 cm, causal 3.52 / 3.50 cm (alone / whole window).
TEST(GlobalStep, FramesBetweenKeyframesAreSolvedAlone) {
  const fs::path dir = test::ScratchDir();
  const LoopRun alone = RunLoop(dir / "alone", "");
  const LoopRun whole = RunLoop(dir / "whole", "estimator:\n  frame_motion_only: false\n");
  ASSERT_GT(alone.ate, 0.0);
  ASSERT_GT(whole.ate, 0.0);
  const int frames = alone.run["frames"].get<int>();
  const int keyframes = alone.run["keyframes"].get<int>();
  EXPECT_GT(alone.run["estimator"]["motion_only_frames"].get<int>(), (frames - keyframes) / 2);
  EXPECT_EQ(whole.run["estimator"]["motion_only_frames"].get<int>(), 0);
  EXPECT_LT(alone.ate, 1.25 * whole.ate);
  EXPECT_LT(alone.causal_ate, 1.25 * whole.causal_ate);
  EXPECT_EQ(alone.objects, whole.objects);
}

// estimator.keyframe_min_frames: keyframes at least that many frames apart (the room loop's 20 Hz
// camera with keyframe_interval_s 0.05 would make every frame one), besides those made at once for
// new objects; the default with gt-corners (auto: 1) keeps the time interval alone.
TEST(GlobalStep, KeyframesAtLeastMinFramesApart) {
  const fs::path dir = test::ScratchDir();
  const LoopRun every3 = RunLoop(
      dir / "every3", "estimator:\n  keyframe_interval_s: 0.05\n  keyframe_min_frames: 3\n");
  const LoopRun auto_gt = RunLoop(dir / "auto", "estimator:\n  keyframe_interval_s: 0.05\n");
  ASSERT_GT(every3.ate, 0.0);
  ASSERT_GT(auto_gt.ate, 0.0);
  const int frames = every3.run["frames"].get<int>();
  const int k3 = every3.run["keyframes"].get<int>();
  std::printf("%d frames: %d keyframes at 3 frames apart, %d with the default\n", frames, k3,
              auto_gt.run["keyframes"].get<int>());
  EXPECT_GE(k3, frames / 3 - 2);
  EXPECT_LE(k3, frames / 3 + 10);  // + the keyframes of new and returning objects
  EXPECT_EQ(auto_gt.run["keyframes"].get<int>(), frames);
}

// Deterministic: the same input gives byte-identical outputs, and the background schedule (the
// global solve on its own thread, applied at a fixed keyframe) gives the same bytes as the
// synchronous one.
TEST(GlobalStep, SameInputSameBytesInBothSchedules) {
  const fs::path dir = test::ScratchDir();
  RunLoop(dir / "background_1", "estimator:\n  global:\n    background: true\n");
  RunLoop(dir / "background_2", "estimator:\n  global:\n    background: true\n");
  RunLoop(dir / "synchronous", "estimator:\n  global:\n    background: false\n");
  for (const char* f : {"trajectory.tum", "trajectory_online.tum", "map.json"}) {
    const std::string a = test::Slurp(dir / "background_1" / "run" / f);
    EXPECT_FALSE(a.empty()) << f;
    EXPECT_EQ(a, test::Slurp(dir / "background_2" / "run" / f)) << f;
    EXPECT_EQ(a, test::Slurp(dir / "synchronous" / "run" / f)) << f;
  }
}

}  // namespace
}  // namespace fsp::apps
