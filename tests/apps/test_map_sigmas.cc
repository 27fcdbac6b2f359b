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

#include "room_loop.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;

struct Nees {
  double sum = 0.0;
  int n = 0;
  double Mean() const { return n > 0 ? sum / n : -1.0; }
};

// Renders the room loop with SEED, runs `fsp run` with ARGS on it and adds its objects' normalised
// width and height errors to NEES.
void AddRun(uint32_t seed, const std::string& args, const fs::path& dir, Nees* nees) {
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
    run.sum += zw * zw + zh * zh;
    run.n += 2;
  }
  std::printf("[seed %u %s] %d normalised errors, mean square %.3f\n", seed, args.c_str(), run.n,
              run.Mean());
  nees->sum += run.sum;
  nees->n += run.n;
}

void ExpectHonestSigmas(const std::string& args, uint32_t seeds) {
  const fs::path dir = test::ScratchDir();
  Nees nees;
  for (uint32_t seed = 1; seed <= seeds; ++seed) AddRun(seed, args, dir, &nees);
  std::printf("[%s] NEES over %d normalised errors: %.3f\n", args.c_str(), nees.n, nees.Mean());
  EXPECT_GE(nees.n, 4 * 2 * 12);  // >= 12 of the 14 objects mapped per run
  EXPECT_GT(nees.Mean(), 0.5);
  EXPECT_LT(nees.Mean(), 2.0);
}

// Measured over seeds 1-6: batch 0.96 (per seed 0.67-1.63), window (σ of its final global solve)
// 1.11 (0.70-1.98); the window runs 4 seeds (1.23), its runs cost 3x the batch's.
TEST(MapSigmas, BatchSigmasAreHonest) {
  ExpectHonestSigmas("--mode batch", 6);
}

TEST(MapSigmas, WindowSigmasAreHonest) {
  ExpectHonestSigmas("--mode window", 4);
}

}  // namespace
}  // namespace fsp::apps
