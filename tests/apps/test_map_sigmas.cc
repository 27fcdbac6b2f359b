// Are the map's width and height σ (map.json width_sigma, height_sigma: the covariance of the final
// solve) honest? Over independent renders of the room loop (room_loop.h: the seed draws the IMU
// noise, the biases' walk and the corner noise), the normalised errors (estimate − truth) / σ of
// every mapped object must have a mean square near 1 (NEES, the issue asks 0.5-2): well below 1 the
// σ are too cautious, well above they promise an accuracy the map does not have.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fsp/eval/evaluate.h"
#include "room_loop.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;

struct Nees {
  double sum = 0.0;
  int n = 0;
  double Mean() const { return n > 0 ? sum / n : -1.0; }
  void Add(double z) {
    sum += z * z;
    ++n;
  }
};

// Renders the room loop with SEED, runs `fsp run` with ARGS on it and adds its objects' normalised
// width and height errors to NEES.
void AddRun(uint32_t seed, const std::string& args, const fs::path& dir, Nees* nees, Nees* scale) {
  sim::Scene scene = test::RoomLoopScene();
  scene.seed = seed;
  const fs::path seq = dir / ("seq" + std::to_string(seed)),
                 out = dir / ("run" + std::to_string(seed));
  test::WriteSequenceForGtCorners(scene, seq);
  const test::CommandResult c =
      test::RunFsp("run " + seq.string() + " --frontend gt-corners --seed " + std::to_string(seed) +
                   " --out " + out.string() + " " + args);
  ASSERT_EQ(c.exit_code, 0) << c.err;
  nlohmann::json gt, map;
  std::ifstream(seq / "objects_gt.json") >> gt;
  std::ifstream(out / "map.json") >> map;
  std::map<int, std::pair<double, double>> truth;
  for (const auto& o : gt["objects"])
    truth[o["id"].get<int>()] = {o["width"].get<double>(), o["height"].get<double>()};
  Nees run;
  for (const auto& o : map["objects"]) {
    const auto it = truth.find(o["id"].get<int>());
    ASSERT_NE(it, truth.end()) << "object " << o["id"] << " is not in the ground truth";
    const double sw = o["width_sigma"].get<double>(), sh = o["height_sigma"].get<double>();
    ASSERT_GT(sw, 0.0) << "object " << o["id"];
    ASSERT_GT(sh, 0.0) << "object " << o["id"];
    const double zw = (o["width"].get<double>() - it->second.first) / sw;
    const double zh = (o["height"].get<double>() - it->second.second) / sh;
    run.Add(zw);
    run.Add(zh);
  }
  // The map's scale σ (run.json estimator.scale_sigma) against the Sim3 scale of the trajectory.
  nlohmann::json report;
  std::ifstream(out / "run.json") >> report;
  const double scale_sigma = report["estimator"]["scale_sigma"].get<double>();
  eval::EvalOptions sim3;
  sim3.trajectory.align = eval::AlignMode::kSim3;
  const eval::Metrics m = eval::Evaluate(eval::ResolvePaths(seq.string(), out.string()), sim3);
  ASSERT_TRUE(m.trajectory.has_value());
  std::printf("[seed %u %s] %d normalised errors, mean square %.3f; scale error %.4f, σ %.4f\n",
              seed, args.c_str(), run.n, run.Mean(), m.trajectory->scale_error, scale_sigma);
  EXPECT_GT(scale_sigma, 0.0);
  scale->Add(m.trajectory->scale_error / scale_sigma);
  // The final solve's variance factor: the noise model (1 px corners, the IMU's densities) fits.
  const double vf = report["estimator"]["variance_factor"].get<double>();
  std::printf("[seed %u %s] variance factor %.3f\n", seed, args.c_str(), vf);
  EXPECT_GT(vf, 0.5);
  EXPECT_LT(vf, 2.0);
  nees->sum += run.sum;
  nees->n += run.n;
}

// CONFIG: the text of a config file for the runs (empty: the defaults).
void ExpectHonestSigmas(std::string args, uint32_t seeds, const std::string& config = "") {
  const fs::path dir = test::ScratchDir();
  if (!config.empty()) {
    std::ofstream(dir / "config.yaml") << config;
    args += " --config " + (dir / "config.yaml").string();
  }
  Nees nees, scale;
  for (uint32_t seed = 1; seed <= seeds; ++seed) AddRun(seed, args, dir, &nees, &scale);
  std::printf("[%s] NEES over %d normalised errors: %.3f; scale: %.3f over %d runs\n", args.c_str(),
              nees.n, nees.Mean(), scale.Mean(), scale.n);
  EXPECT_GE(nees.n, 4 * 2 * 12);  // >= 12 of the 14 objects mapped per run
  EXPECT_GT(nees.Mean(), 0.5);
  EXPECT_LT(nees.Mean(), 2.0);
  // The scale σ over 4-6 runs: a mean square within (0.1, 3) (the chi-square's 95 % range for 6
  // draws is about 0.2-2.4); below, σ is 3x too cautious, above it promises too much.
  EXPECT_GT(scale.Mean(), 0.1);
  EXPECT_LT(scale.Mean(), 3.0);
}

// Measured over seeds 1-6: batch 0.96 (per seed 0.67-1.63), window (σ of its final global solve)
// 1.11 (0.70-1.98); the window runs 4 seeds (1.23), its runs cost 3x the batch's. Scale σ 1.25 %
// against Sim3 scale errors of 0.3-1.4 % (batch) and 0.1-1.7 % (window): mean squares 0.56 / 0.83.
TEST(MapSigmas, BatchSigmasAreHonest) {
  // The batch at keyframe granularity (every frame costs 10x more and the σ come from the same
  // covariance).
  ExpectHonestSigmas("--mode batch", 6, "estimator:\n  batch_keyframe_interval_s: 0.2\n");
}

TEST(MapSigmas, WindowSigmasAreHonest) {
  ExpectHonestSigmas("--mode window", 4);
}

// A noise model four times too optimistic (corners σ 0.25 px in the estimator, 1 px in the data):
// the variance factor sees it (about 16), the run says so, and the scale σ, scaled by σ0, still
// covers the scale error.
TEST(MapSigmas, AnOptimisticNoiseModelIsReported) {
  const fs::path dir = test::ScratchDir();
  sim::Scene scene = test::RoomLoopScene();
  scene.seed = 1;
  test::WriteSequenceForGtCorners(scene, dir / "seq");
  std::ofstream(dir / "config.yaml") << "estimator:\n  factor:\n    sigma_px: 0.25\n";
  const test::CommandResult c = test::RunFsp(
      "run " + (dir / "seq").string() + " --frontend gt-corners --seed 1 --mode window --config " +
      (dir / "config.yaml").string() + " --out " + (dir / "run").string());
  ASSERT_EQ(c.exit_code, 0) << c.err;
  nlohmann::json report;
  std::ifstream(dir / "run" / "run.json") >> report;
  const nlohmann::json& est = report["estimator"];
  const double vf = est["variance_factor"].get<double>();
  EXPECT_GT(vf, 8.0);
  EXPECT_LT(vf, 32.0);
  bool warned = false;
  for (const auto& w : report["faults"]["warnings"])
    warned |= w.get<std::string>().find("times their noise model") != std::string::npos;
  EXPECT_TRUE(warned) << report["faults"]["warnings"].dump();
  eval::EvalOptions sim3;
  sim3.trajectory.align = eval::AlignMode::kSim3;
  const eval::Metrics m =
      eval::Evaluate(eval::ResolvePaths((dir / "seq").string(), (dir / "run").string()), sim3);
  ASSERT_TRUE(m.trajectory.has_value());
  EXPECT_LT(m.trajectory->scale_error, 3.0 * est["scale_sigma"].get<double>());
}

}  // namespace
}  // namespace fsp::apps
