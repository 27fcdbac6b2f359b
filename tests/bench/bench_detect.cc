// Detection speed on one core (cv::setNumThreads(1), libapriltag threads = 1), median over
// repetitions, with the mean time of every pipeline stage as counters (ms).
//
//   bench_detect [--benchmark_repetitions=N] [Google Benchmark flags]
//
// Frames: the synthetic 640x480 frame of the tests (4 rectangles), and -- when the shared test data
// is found ($FSP_TEST_DATA or ../shared/data) -- a 640x480 crop of a real EuRoC in-flight frame
// (board, door, windows, clutter) and an AprilTag photo of the apriltag repository (799x533, 12
// tags).
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>

#include "../frontend/synthetic.h"
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

void RunRect(benchmark::State& state, const cv::Mat& img) {
  RectDetector det;
  std::map<std::string, double> sum;
  int runs = 0;
  size_t found = 0;
  for (auto _ : state) {
    auto res = det.Detect(img);
    benchmark::DoNotOptimize(res.detections.data());
    for (const auto& [name, ms] : res.times.ms) sum[name] += ms;
    found = res.detections.size();
    ++runs;
  }
  ReportStages(state, sum, runs);
  state.counters["detections"] = static_cast<double>(found);
}

void BM_RectSynthetic640(benchmark::State& state) {
  RunRect(state, test::MakeSyntheticFrame(1).image);
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
  RunRect(state, full(cv::Rect((full.cols - 640) / 2, 0, 640, 480)).clone());
}
BENCHMARK(BM_RectEuroc640)->Unit(benchmark::kMillisecond);

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
  RunRect(state, ReadGray8(path));
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
