// Detection speed on one core (cv::setNumThreads(1), libapriltag threads = 1), median over
// repetitions, with the mean time of every pipeline stage as counters (ms).
//
//   bench_detect [--benchmark_repetitions=N] [Google Benchmark flags]
//
// Frames: the synthetic 640x480 frame of the tests (4 rectangles), and -- when the shared test data
// is found ($FSP_TEST_DATA) -- a 640x480 crop of a real EuRoC in-flight frame
// (board, door, windows, clutter), the ten calibrated in-flight EuRoC frames (752x480) and an
// AprilTag photo of the apriltag repository (799x533, 12 tags).
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>

#include "../frontend/synthetic.h"
#include "fsp/common/calibration.h"
#include "fsp/frontend/apriltag_detector.h"
#include "fsp/frontend/image_io.h"
#include "fsp/frontend/rect_detector.h"

namespace fsp::frontend {
namespace {

std::string DataDir() {
  if (const char* env = std::getenv("FSP_TEST_DATA"); env && *env) return env;
  return FSP_DEFAULT_TEST_DATA;
}

void ReportStages(benchmark::State& state, const std::map<std::string, double>& sum, int runs) {
  for (const auto& [name, ms] : sum) state.counters[name + "_ms"] = ms / runs;
}

// One detection per iteration, cycling through `imgs` (with `camera`, the calibrated path: texture
// hypotheses, bridged sides, ...); `detections` is the mean count per image.
void RunRect(benchmark::State& state, const std::vector<cv::Mat>& imgs,
             const PinholeRadtan* camera = nullptr) {
  RectDetector det;
  std::map<std::string, double> sum;
  int runs = 0;
  size_t found = 0;
  for (auto _ : state) {
    auto res = det.Detect(imgs[runs % imgs.size()], camera);
    benchmark::DoNotOptimize(res.detections.data());
    for (const auto& [name, ms] : res.times.ms) sum[name] += ms;
    found += res.detections.size();
    ++runs;
  }
  ReportStages(state, sum, runs);
  state.counters["detections"] = runs > 0 ? static_cast<double>(found) / runs : 0.0;
}

void BM_RectSynthetic640(benchmark::State& state) {
  RunRect(state, {test::MakeSyntheticFrame(1).image});
}
BENCHMARK(BM_RectSynthetic640)->Unit(benchmark::kMillisecond);

void BM_RectEuroc640(benchmark::State& state) {
  const std::string path =
      DataDir() + "/euroc_v101_micro/inflight_frames_kimera_lcd/left_img_3.png";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("shared test data not found (set FSP_TEST_DATA)");
    return;
  }
  const cv::Mat full = ReadGray8(path);
  RunRect(state, {full(cv::Rect((full.cols - 640) / 2, 0, 640, 480)).clone()});
}
BENCHMARK(BM_RectEuroc640)->Unit(benchmark::kMillisecond);

// The ten in-flight EuRoC frames (752 x 480) with their calibration (RealInFlight.*): the
// calibrated path, which the crop above (no calibration) does not run. Time per frame.
void BM_RectEurocInFlightCalibrated(benchmark::State& state) {
  const std::string dir = DataDir() + "/euroc_v101_inflight10/mav0/cam0";
  if (!std::filesystem::exists(dir + "/sensor.yaml")) {
    state.SkipWithError("shared test data not found (set FSP_TEST_DATA)");
    return;
  }
  const Calibration calib = ReadCalibration(dir + "/sensor.yaml");
  std::vector<std::string> paths;
  for (const auto& e : std::filesystem::directory_iterator(dir + "/data"))
    if (e.path().extension() == ".jpg") paths.push_back(e.path().string());
  std::sort(paths.begin(), paths.end());
  std::vector<cv::Mat> imgs;
  for (const std::string& p : paths) imgs.push_back(ReadGray8(p));
  if (imgs.empty()) {
    state.SkipWithError("no in-flight frames");
    return;
  }
  RunRect(state, imgs, &calib.camera);
}
BENCHMARK(BM_RectEurocInFlightCalibrated)->Unit(benchmark::kMillisecond);

// Door photos of doors_dev (no calibration): Arg 0 = DOR_S3_24.JPG (3456x4608, 15.9 MP, detected on
// a 493x658 level), 1 = DOR_S1_121.jpg (2640x4037, 10.7 MP, 440x672), 2 = 0e25d39652fdda48.jpg
// (768x1024, 384x512).
void BM_RectDoorPhoto(benchmark::State& state) {
  const char* names[] = {"DOR_S3_24.JPG", "DOR_S1_121.jpg", "0e25d39652fdda48.jpg"};
  const std::string path = DataDir() + "/doors_dev/images/" + names[state.range(0)];
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("shared test data not found (set FSP_TEST_DATA)");
    return;
  }
  RunRect(state, {ReadGray8(path)});
}
BENCHMARK(BM_RectDoorPhoto)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_AprilTagUmich(benchmark::State& state) {
  const std::string path = DataDir() + "/apriltag_umich_test/33369213973_9d9bb4cc96_c.jpg";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("shared test data not found (set FSP_TEST_DATA)");
    return;
  }
  const cv::Mat img = ReadGray8(path);
  AprilTagDetector::Options o;
  o.decimate = static_cast<double>(state.range(0));
  AprilTagDetector det(o);
  std::map<std::string, double> sum;
  int runs = 0;
  size_t found = 0;
  for (auto _ : state) {
    auto res = det.Detect(img);
    for (const auto& [name, ms] : res.times.ms) sum[name] += ms;
    found = res.detections.size();
    ++runs;
  }
  ReportStages(state, sum, runs);
  state.counters["detections"] = static_cast<double>(found);
}
BENCHMARK(BM_AprilTagUmich)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace fsp::frontend

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core, as the budget is stated
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
