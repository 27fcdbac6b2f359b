// Real corner tracks through the corners front end: the EuRoC camera-IMU calibration run's
// AprilGrid detections (36 tags, 72 s, no images; $FSP_TEST_DATA/euroc_imu_april_corners)
// converted by scripts/aprilgrid_to_corners.py as the README says. The converted file is accepted
// whole (every time a frame, the tags in s1..s4 order), and `fsp run` refuses clearly: the camera
// moves from the first frame and the estimator initialises from a still start only.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fsp/common/dataset.h"
#include "gt_corners.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;

// Runs the converter on DATA into OUT; returns its exit status (skips without /usr/bin/python3).
int Convert(const std::string& data, const std::string& extrinsics, const fs::path& out) {
  const std::string cmd = "/usr/bin/python3 " + std::string(FSP_SOURCE_DIR) +
                          "/scripts/aprilgrid_to_corners.py " + data + " " + out.string() +
                          " --extrinsics " + extrinsics + " >" + (out.string() + ".log") + " 2>&1";
  return std::system(cmd.c_str());
}

// Signed area of the quad in image coordinates (v down): negative for s1..s4 = bottom-left,
// bottom-right, top-right, top-left of a face seen from the front (README, "Conventions").
double SignedArea(const Corners& c) {
  double a = 0.0;
  for (int j = 0; j < 4; ++j) {
    const Vec2& p = c[j];
    const Vec2& q = c[(j + 1) % 4];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * a;
}

TEST(AprilGridCorners, ConvertedTracksAreAcceptedAndAStillStartAloneRefusesThem) {
  FSP_REQUIRE_TEST_DATA(data, "euroc_imu_april_corners");
  FSP_REQUIRE_TEST_DATA(extrinsics, "euroc_v101_micro/mav0/cam0/sensor.yaml");
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "/usr/bin/python3 not found";
  const fs::path out = test::ScratchDir() / "converted";
  ASSERT_EQ(Convert(data, extrinsics, out), 0) << "see " << out.string() << ".log";

  // The converted folder as `fsp run` opens it, and every row of the corners file accepted.
  SourceOptions source_options;
  source_options.input = out.string();
  source_options.decode_images = false;
  const std::unique_ptr<Source> source = OpenSource(source_options);
  ASSERT_EQ(source->frame_times().size(), 1439u);
  EXPECT_EQ(source->calibration().camera.width, 752);
  EXPECT_TRUE(source->calibration().camera.HasDistortion());
  ExternalCornersFrontend corners((out / "corners.csv").string(), (out / "objects.json").string(),
                                  source->calibration(), source->frame_times());
  int observations = 0, frames_with_tags = 0, wrong_order = 0;
  for (int64_t t : source->frame_times()) {
    const std::vector<ObjectObservation> obs = corners.Process(t);
    frames_with_tags += !obs.empty();
    for (const ObjectObservation& o : obs) {
      ++observations;
      EXPECT_EQ(o.object_class, ObjectClass::kTag);
      EXPECT_TRUE(o.object_id >= 0 && o.object_id < 36) << o.object_id;
      wrong_order += SignedArea(o.corners) >= 0.0;
    }
  }
  EXPECT_EQ(frames_with_tags, 1439 - 23);  // 23 frames have no detection
  EXPECT_GT(observations, 30 * frames_with_tags);
  EXPECT_EQ(wrong_order, 0);

  // Without the initialisation in motion the estimator needs a still start; this recording moves
  // from the first frame.
  std::ofstream(out.parent_path() / "still_only.yaml")
      << "estimator:\n  motion_init:\n    enabled: false\n";
  const test::CommandResult r = test::RunFsp(
      "run " + out.string() + " --frontend corners --corners " + (out / "corners.csv").string() +
      " --objects " + (out / "objects.json").string() + " --config " +
      (out.parent_path() / "still_only.yaml").string() + " --out " +
      (out.parent_path() / "run").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err.rfind("fsp: error: static initialisation refused: too much motion", 0), 0u)
      << r.err;
  EXPECT_NE(r.err.find("(the start is not still)"), std::string::npos) << r.err;
}

// The real recording initialised in motion (motion_init.h) and mapped: the first 10 s of tracks
// (the later frames have no rows: the run dead-reckons to the end, which costs little), every tag
// 0.088 m square. Measured: initialised at the first frames (0.05 s), 36 / 36 tags mapped, size
// error mean 0.89 mm, max 1.36 mm; on the whole 72 s: 0.39 mm mean (3.5 min, not a test).
TEST(AprilGridCorners, InitialisedInMotionTheTagSizesAreRight) {
  FSP_REQUIRE_TEST_DATA(data, "euroc_imu_april_corners");
  FSP_REQUIRE_TEST_DATA(extrinsics, "euroc_v101_micro/mav0/cam0/sensor.yaml");
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "/usr/bin/python3 not found";
  const fs::path dir = test::ScratchDir(), out = dir / "converted";
  ASSERT_EQ(Convert(data, extrinsics, out), 0) << "see " << out.string() << ".log";
  {
    std::ifstream in(out / "corners.csv");
    std::ofstream first(dir / "first10s.csv");
    std::string line;
    int64_t t0 = -1;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') {
        first << line << "\n";
        continue;
      }
      const int64_t t = std::stoll(line.substr(0, line.find(',')));
      if (t0 < 0) t0 = t;
      if (t - t0 < 10'000'000'000) first << line << "\n";
    }
  }
  const test::CommandResult r = test::RunFsp(
      "run " + out.string() + " --frontend corners --corners " + (dir / "first10s.csv").string() +
      " --objects " + (out / "objects.json").string() + " --out " + (dir / "run").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json run, map;
  std::ifstream(dir / "run" / "run.json") >> run;
  std::ifstream(dir / "run" / "map.json") >> map;
  EXPECT_TRUE(run["estimator"]["init_in_motion"].get<bool>());
  EXPECT_LT(run["estimator"]["init_t_s"].get<double>(), 2.0);
  ASSERT_EQ(map["objects"].size(), 36u);
  double sum = 0.0, worst = 0.0;
  for (const auto& o : map["objects"])
    for (const char* key : {"width", "height"}) {
      const double e = std::abs(o[key].get<double>() - 0.088);
      sum += e;
      worst = std::max(worst, e);
    }
  const double mean = sum / (2.0 * static_cast<double>(map["objects"].size()));
  std::printf("tag size error mean %.2f mm, max %.2f mm\n", mean * 1e3, worst * 1e3);
  EXPECT_LT(mean, 0.002);  // the target: within 2 mm of 0.088 m on average
  EXPECT_LT(worst, 0.003);
}

}  // namespace
}  // namespace fsp::apps
