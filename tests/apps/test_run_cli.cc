// `fsp run` and `fsp bench` on bad input: a non-zero exit and one clear line on stderr.
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "bench_gate.h"
#include "common/dataset_fixtures.h"
#include "fsp/common/error.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;

// Exactly one line on stderr that starts with "fsp: error: " and contains WHAT.
void ExpectOneLineError(const test::CommandResult& r, const std::string& what) {
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(r.err.rfind("fsp: error: ", 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
}

TEST(RunCli, MissingInput) {
  const fs::path dir = test::ScratchDir();
  ExpectOneLineError(
      test::RunFsp("run " + (dir / "nope").string() + " --out " + (dir / "out").string()), "nope");
}

TEST(RunCli, GtCornersNeedsARenderedSequence) {
  const fs::path dir = test::ScratchDir();
  test::MakeEuroc(dir / "seq", 3);
  ExpectOneLineError(test::RunFsp("run " + (dir / "seq").string() +
                                  " --frontend gt-corners --out " + (dir / "out").string()),
                     "gt-corners needs a rendered sequence: " +
                         (dir / "seq" / "observations_gt.csv").string() + " not found");
}

TEST(RunCli, CornersFrontEndErrors) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = test::MakeEuroc(dir / "seq", 3);
  const std::string run = "run " + (dir / "seq").string() + " --out " + (dir / "out").string();
  ExpectOneLineError(test::RunFsp(run + " --frontend corners"),
                     "--frontend corners needs --corners FILE");
  ExpectOneLineError(test::RunFsp(run + " --corners " + (dir / "c.csv").string()),
                     "--corners and --objects go with --frontend corners");
  ExpectOneLineError(
      test::RunFsp(run + " --frontend corners --corners " + (dir / "c.csv").string()),
      (dir / "c.csv").string() + ": corners file not found");
  test::WriteText(dir / "c.csv", std::to_string(t[0]) + ",1,1,2,3,4,5,6,7,8\n" +
                                     std::to_string(t[2] + 1) + ",1,1,2,3,4,5,6,7,8\n");
  ExpectOneLineError(
      test::RunFsp(run + " --frontend corners --corners " + (dir / "c.csv").string()),
      "c.csv:2: t_ns " + std::to_string(t[2] + 1) + " matches no frame of the input");
  test::WriteText(dir / "c.csv", std::to_string(t[0]) + ",1,1,2,3,4,inf,6,7,8\n");
  ExpectOneLineError(
      test::RunFsp(run + " --frontend corners --corners " + (dir / "c.csv").string()),
      "c.csv:1: column 7 (u3) is not finite");
}

// --until-s: the frames up to the first one's time + S, and their IMU; refused when negative or
// with --follow.
TEST(RunCli, UntilSeconds) {
  const fs::path dir = test::ScratchDir();
  test::MakeEuroc(dir / "seq", 6);  // frames 50 ms apart
  const std::string run = "run " + (dir / "seq").string() + " --out " + (dir / "out").string();
  // 0.12 s of this still fixture cannot initialise (1 s of IMU needed): exit 2, outputs written.
  const test::CommandResult r = test::RunFsp(run + " --until-s 0.12");
  ASSERT_TRUE(fs::exists(dir / "out" / "run.json")) << r.err;
  const std::string json = test::Slurp(dir / "out" / "run.json");
  EXPECT_NE(json.find("\"frames\": 3,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"frames_processed\": 3,"), std::string::npos) << json;
  ExpectOneLineError(test::RunFsp(run + " --until-s -1"), "--until-s must be > 0");
  ExpectOneLineError(test::RunFsp(run + " --until-s 1 --follow"),
                     "--until-s does not go with --follow");
}

TEST(RunCli, BadConfig) {
  const fs::path dir = test::ScratchDir();
  test::MakeEuroc(dir / "seq", 3);
  test::WriteText(dir / "bad.yaml", "estimator:\n  window_size: -3\n");
  ExpectOneLineError(test::RunFsp("run " + (dir / "seq").string() + " --config " +
                                  (dir / "bad.yaml").string() + " --out " + (dir / "out").string()),
                     "bad.yaml:2: estimator.window_size: must be >= 2, got -3");
  test::WriteText(dir / "unknown.yaml", "frontend:\n  gt_corners:\n    sigma: 2\n");
  ExpectOneLineError(
      test::RunFsp("run " + (dir / "seq").string() + " --config " +
                   (dir / "unknown.yaml").string() + " --out " + (dir / "out").string()),
      "unknown.yaml:3: frontend.gt_corners.sigma: unknown key");
  ExpectOneLineError(
      test::RunFsp("run " + (dir / "seq").string() + " --config " + (dir / "none.yaml").string() +
                   " --out " + (dir / "out").string()),
      "none.yaml");
}

TEST(RunCli, PrintConfigShowsTheDefaults) {
  const test::CommandResult r = test::RunFsp("run --print-config");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("  window_size: 45\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("    pixel_sigma: 1.0\n"), std::string::npos) << r.out;
}

TEST(BenchGate, ChecksBoundsAndTargets) {
  const fs::path dir = test::ScratchDir();
  test::WriteText(dir / "t.yaml",
                  "checks:\n"
                  "  - {config: fsp-window, metric: err, max: 0.1, target: 0.01, enforced: true}\n"
                  "  - {config: fsp-window, metric: speed, min: 5, target: 10, enforced: true}\n"
                  "  - {config: rect/fhp-batch, metric: err, max: 0.1, enforced: false}\n"
                  "  - {scene: hall, config: fsp-window, metric: err, max: 0.1}\n");
  const std::vector<GateCheck> checks = ReadGate((dir / "t.yaml").string());
  ASSERT_EQ(checks.size(), 4u);
  EXPECT_EQ(checks[1].line, 3);
  EXPECT_EQ(checks[0].scene, "default_room");  // the default scene and front end
  EXPECT_EQ(checks[0].config, "gt-corners/fsp-window");
  EXPECT_EQ(checks[2].config, "rect/fhp-batch");
  EXPECT_EQ(checks[3].scene, "hall");
  nlohmann::ordered_json rows = {{"default_room",
                                  {{"gt-corners/fsp-window", {{"err", 0.05}, {"speed", 7.0}}},
                                   {"rect/fhp-batch", {{"err", 0.5}}}}}};
  std::vector<GateResult> r = EvaluateGate(checks, rows);
  EXPECT_TRUE(r[0].pass);
  EXPECT_FALSE(*r[0].target_met);
  EXPECT_TRUE(r[1].pass);
  EXPECT_FALSE(r[2].pass);    // outside, but not enforced
  EXPECT_TRUE(r[3].skipped);  // a scene the benchmark did not run: no verdict
  EXPECT_TRUE(GatePasses(r));
  rows["default_room"]["gt-corners/fsp-window"]["speed"] = 4.0;
  EXPECT_FALSE(GatePasses(EvaluateGate(checks, rows)));
  // A missing metric (every run of the configuration failed) fails an enforced check.
  rows["default_room"]["gt-corners/fsp-window"].erase("err");
  r = EvaluateGate(checks, rows);
  EXPECT_FALSE(r[0].skipped);
  EXPECT_FALSE(r[0].value.has_value());
  EXPECT_FALSE(r[0].pass);

  test::WriteText(dir / "bad.yaml",
                  "checks:\n  - {config: fsp-window, metric: err, maximum: 0.1}\n");
  std::string e = test::ErrorOf([&] { ReadGate((dir / "bad.yaml").string()); });
  EXPECT_NE(e.find("bad.yaml:2: unknown key 'maximum'"), std::string::npos) << e;
  test::WriteText(dir / "bad.yaml", "checks:\n  - {config: fsp-walk, metric: err, max: 0.1}\n");
  e = test::ErrorOf([&] { ReadGate((dir / "bad.yaml").string()); });
  EXPECT_NE(e.find("bad.yaml:2: config: 'fsp-walk' is not FRONTEND/LANDMARKS-MODE"),
            std::string::npos)
      << e;
}

TEST(BenchGate, RepositoryThresholdsParse) {
  const std::vector<GateCheck> checks =
      ReadGate(std::string(FSP_SOURCE_DIR) + "/assets/bench/thresholds.yaml");
  EXPECT_GE(checks.size(), 8u);
}

}  // namespace
}  // namespace fsp::apps
