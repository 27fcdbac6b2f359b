// `fsp render` end to end on a small scene: the folder is a readable EuRoC recording with
// consistent ground truth, two renders are byte-identical (whatever the thread count), bad scenes
// fail cleanly.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fsp/common/dataset.h"
#include "fsp/common/observations_io.h"
#include "fsp/common/trajectory_io.h"
#include "fsp/sim/imu_synth.h"
#include "fsp/sim/scene.h"
#include "fsp/sim/sequence_writer.h"
#include "test_util.h"

namespace fsp::sim {
namespace {

namespace fs = std::filesystem;

const char* kSmallScene = R"(# small test scene: 160 x 120, 1 s
camera: {width: 160, height: 120, fx: 115.0, fy: 115.0, cx: 79.5, cy: 59.5, rate_hz: 20,
         distortion: [-0.05, 0.01, 0, 0]}
imu: {rate_hz: 200, gyroscope_noise_density: 1.7e-4, accelerometer_noise_density: 2.0e-3,
      gyroscope_random_walk: 1.9e-5, accelerometer_random_walk: 3.0e-3}
room: {min: [0, 0, 0], max: [4, 3, 2.5]}
objects:
  - {id: 1, class: door, position: [1.0, 3, 0], rpy_deg: [90, 0, 0], width: 0.9, height: 2.0}
  - {id: 2, class: poster, position: [2.3, 3, 1.0], rpy_deg: [90, 0, 0], width: 0.6, height: 0.8}
  - {id: 7, class: tag, tag_id: 7, position: [3.2, 3, 1.2], rpy_deg: [90, 0, 0], width: 0.3, height: 0.3}
  - {id: 3, class: window, position: [4, 2.5, 1.0], rpy_deg: [90, 0, -90], width: 1.0, height: 0.9}
trajectory:
  waypoints: [[0, 2, 0.8, 1.2, 90], [0.4, 2, 0.8, 1.2, 90], [1.2, 2.3, 1.1, 1.3, 70]]
noise: {pixel_sigma: 1.5, seed: 4}
render: {supersampling: 1}
duration_s: 1
)";

fs::path WriteScene(const fs::path& dir, const std::string& name, const std::string& text) {
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return p;
}

// Relative path -> contents of every file under DIR.
std::map<std::string, std::string> Tree(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = test::Slurp(e.path());
  }
  return files;
}

TEST(PixelNoise, HasTheConfiguredSigmaAndDependsOnlyOnSeedAndFrame) {
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(128));
  cv::Mat a = grey.clone(), b = grey.clone(), c = grey.clone(), d = grey.clone();
  AddPixelNoise(2.0, 1, 7, &a);
  AddPixelNoise(2.0, 1, 7, &b);
  AddPixelNoise(2.0, 1, 8, &c);
  AddPixelNoise(2.0, 2, 7, &d);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0);
  EXPECT_GT(cv::norm(a, d, cv::NORM_L1), 0.0);
  double sum = 0.0, sum2 = 0.0;
  for (int r = 0; r < a.rows; ++r) {
    for (int col = 0; col < a.cols; ++col) {
      const double e = a.at<uint8_t>(r, col) - 128.0;
      sum += e;
      sum2 += e * e;
    }
  }
  const double n = static_cast<double>(a.total());
  EXPECT_NEAR(sum / n, 0.0, 0.02);
  // Rounding to integers adds 1/12 grey level^2 of variance.
  EXPECT_NEAR(std::sqrt(sum2 / n - 1.0 / 12.0), 2.0, 0.02);
  cv::Mat e = grey.clone();
  AddPixelNoise(0.0, 1, 7, &e);
  EXPECT_EQ(cv::norm(e, grey, cv::NORM_INF), 0.0);
}

TEST(RenderCli, WritesAReadableSequenceWithConsistentGroundTruth) {
  const fs::path dir = test::ScratchDir();
  const fs::path scene_path = WriteScene(dir, "small.yaml", kSmallScene);
  const test::CommandResult run =
      test::RunFsp("render " + scene_path.string() + " --out " + (dir / "seq").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("20 frames 160x120"), std::string::npos) << run.out;
  const fs::path seq = dir / "seq";
  for (const char* f :
       {"mav0/cam0/data.csv", "mav0/cam0/sensor.yaml", "mav0/imu0/data.csv",
        "mav0/imu0/sensor.yaml", "mav0/state_groundtruth_estimate0/data.csv", "objects_gt.json",
        "observations_gt.csv", "video.mp4", "imu.csv", "calib.yaml", "top_view.png"}) {
    EXPECT_TRUE(fs::exists(seq / f)) << f;
  }

  // It opens as a recording: 20 frames from t = 0, 201 IMU samples, the scene's calibration.
  SourceOptions options;
  options.input = seq.string();
  const std::unique_ptr<Source> source = OpenSource(options);
  ASSERT_EQ(source->frame_times().size(), 20u);
  EXPECT_EQ(source->frame_times()[0], 0);
  EXPECT_EQ(source->frame_times()[1], 50'000'000);
  ASSERT_EQ(source->imu().size(), 201u);
  EXPECT_EQ(source->imu().back().t_ns, 1'000'000'000);
  const Calibration& calib = source->calibration();
  EXPECT_EQ(calib.camera.width, 160);
  EXPECT_DOUBLE_EQ(calib.camera.fx, 115.0);
  EXPECT_DOUBLE_EQ(calib.camera.distortion[0], -0.05);
  EXPECT_DOUBLE_EQ(calib.camera_rate_hz, 20.0);
  EXPECT_LT((calib.T_B_C.Matrix() - DefaultCameraMount().Matrix()).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(calib.imu.accelerometer_noise_density, 2.0e-3);
  const Frame frame = source->ReadFrame(3);
  EXPECT_EQ(frame.image.cols, 160);
  EXPECT_EQ(frame.image.rows, 120);
  // The video + imu.csv + calib.yaml triple holds the same sequence.
  SourceOptions video;
  video.input = (seq / "video.mp4").string();
  video.imu = (seq / "imu.csv").string();
  video.calib = (seq / "calib.yaml").string();
  const std::unique_ptr<Source> vsrc = OpenSource(video);
  EXPECT_EQ(vsrc->frame_times().size(), 20u);
  EXPECT_EQ(vsrc->frame_times()[1], 50'000'000);
  EXPECT_EQ(vsrc->imu().size(), 201u);

  // Ground truth: states at the IMU times, the trajectory's poses; IMU readings with the noise.
  const Scene scene = LoadScene(scene_path.string());
  const std::vector<StateSample> gt =
      ReadEurocGroundTruth((seq / "mav0/state_groundtruth_estimate0/data.csv").string());
  ASSERT_EQ(gt.size(), 201u);
  for (size_t k = 0; k < gt.size(); k += 20) {
    const TrajectoryState s = scene.trajectory.State(k * 0.005);
    EXPECT_LT((gt[k].T_W_B.translation() - s.T_W_B.translation()).norm(), 1e-9);
    EXPECT_LT(gt[k].T_W_B.rotation().angularDistance(s.T_W_B.rotation()), 1e-9);
    EXPECT_LT((gt[k].v_W - s.v_W).norm(), 1e-9);
    const ImuSample ideal = IdealImu(scene.trajectory, gt[k].t_ns);
    const Vec3 residual = source->imu()[k].acc - ideal.acc - gt[k].acc_bias;
    EXPECT_LT(residual.norm(), 6 * 2.0e-3 * std::sqrt(200.0) * std::sqrt(3.0));
  }

  // Objects and corner rows: ids, sizes, projections of the ground-truth corners.
  const nlohmann::json objects = nlohmann::json::parse(test::Slurp(seq / "objects_gt.json"));
  ASSERT_EQ(objects["objects"].size(), 4u);
  EXPECT_EQ(objects["objects"][2]["class"], "tag");
  EXPECT_NEAR(objects["objects"][0]["width"].get<double>(), 0.9, 1e-12);
  const std::vector<CornerRow> rows = ReadCornerRows((seq / "observations_gt.csv").string());
  ASSERT_FALSE(rows.empty());
  int fully = 0;
  for (const CornerRow& row : rows) {
    fully += row.FullyVisible();
    const SceneObject* obj = nullptr;
    for (const SceneObject& o : scene.objects) obj = o.id == row.object_id ? &o : obj;
    ASSERT_NE(obj, nullptr);
    const Rigid3 T_W_C = scene.trajectory.Pose(row.t_ns * 1e-9) * scene.T_B_C;
    for (int j = 0; j < 4; ++j) {
      const Vec2 uv = scene.camera.ProjectIdeal(T_W_C.Inverse() * obj->corners_W[j]);
      EXPECT_LT((uv - row.corners[j]).norm(), 1e-3);  // 4 decimals in the file
    }
  }
  EXPECT_GT(fully, 20);                             // the poster and the tag are in view throughout
  EXPECT_LT(fully, static_cast<int>(rows.size()));  // the door's top leaves the image
}

TEST(RenderCli, SameSceneAndSeedGiveIdenticalFiles) {
  const fs::path dir = test::ScratchDir();
  const fs::path scene = WriteScene(dir, "small.yaml", kSmallScene);
  const auto a =
      test::RunFsp("render " + scene.string() + " --out " + (dir / "a").string() + " --threads 2");
  const auto b =
      test::RunFsp("render " + scene.string() + " --out " + (dir / "b").string() + " --threads 1");
  const auto c =
      test::RunFsp("render " + scene.string() + " --out " + (dir / "c").string() + " --seed 5");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const auto ta = Tree(dir / "a"), tb = Tree(dir / "b"), tc = Tree(dir / "c");
  ASSERT_EQ(ta.size(), tb.size());
  EXPECT_GE(ta.size(), 20u + 10u);
  for (const auto& [name, content] : ta) {
    ASSERT_TRUE(tb.count(name)) << name;
    EXPECT_TRUE(content == tb.at(name)) << name << " differs between two renders";
  }
  // Another seed changes the noise (images, IMU) but not the geometry.
  EXPECT_TRUE(ta.at("objects_gt.json") == tc.at("objects_gt.json"));
  EXPECT_TRUE(ta.at("observations_gt.csv") == tc.at("observations_gt.csv"));
  EXPECT_FALSE(ta.at("imu.csv") == tc.at("imu.csv"));
  EXPECT_FALSE(ta.at("mav0/cam0/data/50000000.png") == tc.at("mav0/cam0/data/50000000.png"));
}

TEST(RenderCli, BadScenesFailWithOneLine) {
  const fs::path dir = test::ScratchDir();
  std::string text = kSmallScene;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"rate_hz: 20,", "rate_hz: 20, gain: 2,"},  // unknown key
      {"fx: 115.0, ", ""},                        // missing field
      {"width: 0.6", "width: 0.0"},               // zero-area rectangle
      {"duration_s: 1", "duration_s: 5"},         // trajectory too short
  };
  const std::vector<std::string> expected = {"unknown key 'gain' in camera",
                                             "missing field 'fx' in camera", "zero-area rectangle",
                                             "trajectory ends at t = 1.2 s"};
  for (size_t i = 0; i < cases.size(); ++i) {
    std::string bad = text;
    bad.replace(bad.find(cases[i].first), cases[i].first.size(), cases[i].second);
    const fs::path p = WriteScene(dir, "bad" + std::to_string(i) + ".yaml", bad);
    const auto r = test::RunFsp("render " + p.string() + " --out " + (dir / "out").string());
    EXPECT_NE(r.exit_code, 0) << expected[i];
    EXPECT_NE(r.err.find(expected[i]), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(p.string() + ":"), std::string::npos) << r.err;  // names the file
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  const auto missing =
      test::RunFsp("render " + (dir / "nope.yaml").string() + " --out " + (dir / "out").string());
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_EQ(std::count(missing.err.begin(), missing.err.end(), '\n'), 1) << missing.err;
  const fs::path good = WriteScene(dir, "good.yaml", kSmallScene);
  const auto longer = test::RunFsp("render " + good.string() + " --out " + (dir / "out").string() +
                                   " --duration 3");
  EXPECT_NE(longer.exit_code, 0);
  EXPECT_NE(longer.err.find("longer than the trajectory"), std::string::npos) << longer.err;
}

}  // namespace
}  // namespace fsp::sim
