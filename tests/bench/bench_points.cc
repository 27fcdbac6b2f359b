// PointTracker speed per frame on one core (cv::setNumThreads(1)), at 640x480 and 1280x720, with
// the mean points tracked and detected per frame and the mean time of each stage as counters (ms).
//
//   bench_points [--benchmark_repetitions=N] [Google Benchmark flags]
//
// Frames: a textured wall 3 m in front of a camera that turns and slides along it (each frame the
// wall warped through its plane's homography, pixel noise of 2 grey levels), 64 frames played
// forwards and backwards so that the motion never jumps; the camera's rotation between frames
// is given (the gyroscope's). Texture everywhere: the tracker keeps its max_points() (150; 113
// at 1280x720, tracked at 640x360)
// live, so the numbers are those of a full load. "Own pyramid": Track(gray) builds the frame's
// pyramid; "shared pyramid": the FrontEnd's case, the pyramid built once per frame outside.
#include <cmath>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/geometry.h"
#include "fsp/frontend/flow_pyramid.h"
#include "fsp/frontend/point_tracker.h"

namespace fsp::frontend {
namespace {

struct Sequence {
  PinholeRadtan camera;
  std::vector<cv::Mat> frames;  // forwards then backwards
  std::vector<Mat3> R_W_C;
};

// A wall (plane z = 3 m in the first camera frame) with blobs, discs and boxes; the camera turns
// +-6 deg in yaw and slides +-0.3 m over 64 frames.
Sequence MakeSequence(int width, int height) {
  Sequence s;
  s.camera.width = width;
  s.camera.height = height;
  s.camera.fx = s.camera.fy = 0.72 * width;
  s.camera.cx = 0.5 * (width - 1);
  s.camera.cy = 0.5 * (height - 1);
  const int w = 3 * width, h = 3 * height;
  Mat3 K_wall;  // wall texture px <- point on the wall plane, seen from the first camera pose
  K_wall << s.camera.fx, 0.0, 0.5 * (w - 1), 0.0, s.camera.fy, 0.5 * (h - 1), 0.0, 0.0, 1.0;
  std::mt19937 rng(3);
  cv::Mat lo(h / 24, w / 24, CV_32F), wall;
  std::uniform_real_distribution<float> u(-40.f, 40.f);
  for (int y = 0; y < lo.rows; ++y)
    for (int x = 0; x < lo.cols; ++x) lo.at<float>(y, x) = 128.f + u(rng);
  cv::resize(lo, wall, cv::Size(w, h), 0, 0, cv::INTER_CUBIC);
  std::uniform_int_distribution<int> px(0, w - 1), py(0, h - 1), rad(3, 10), grey(20, 235);
  for (int k = 0; k < w * h / 400; ++k) {
    const cv::Point c(px(rng), py(rng));
    if (k % 2)
      cv::circle(wall, c, rad(rng), cv::Scalar(grey(rng)), cv::FILLED, cv::LINE_AA);
    else
      cv::rectangle(wall, cv::Rect(c.x, c.y, 2 * rad(rng), rad(rng)), cv::Scalar(grey(rng)),
                    cv::FILLED);
  }
  cv::GaussianBlur(wall, wall, cv::Size(0, 0), 0.8);
  const Mat3 K = s.camera.K();
  constexpr int kFrames = 64;
  std::vector<cv::Mat> forwards;
  for (int k = 0; k < kFrames; ++k) {
    const double a = 2.0 * M_PI * k / kFrames;
    const Mat3 R_W_C = RotY(0.1 * std::sin(a));
    const Vec3 c_W(0.3 * std::sin(a), 0.05 * std::sin(2.0 * a), 0.0);
    // A wall point X_W = d (x, y, 1) at depth d = 3; the camera sees X_C = R^T (X_W - c). Frame
    // pixel -> wall pixel: the homography of the plane z_W = 3 seen from the camera.
    const double d = 3.0;
    const Mat3 H_C_W =
        R_W_C.transpose() * (Mat3::Identity() - c_W * Vec3(0.0, 0.0, 1.0).transpose() / d);
    const Mat3 M = K_wall * H_C_W.inverse() * K.inverse();
    cv::Mat Mcv(3, 3, CV_64F), f;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Mcv.at<double>(i, j) = M(i, j);
    cv::warpPerspective(wall, f, Mcv, cv::Size(width, height),
                        cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
    std::normal_distribution<float> noise(0.f, 2.f);
    for (int y = 0; y < f.rows; ++y)
      for (int x = 0; x < f.cols; ++x) f.at<float>(y, x) += noise(rng);
    f.convertTo(f, CV_8U);
    forwards.push_back(f);
    s.R_W_C.push_back(R_W_C);
  }
  s.frames = forwards;
  for (int k = kFrames - 2; k > 0; --k) {
    s.frames.push_back(forwards[k]);
    s.R_W_C.push_back(s.R_W_C[k]);
  }
  return s;
}

void Run(benchmark::State& state, int width, int height, bool shared_pyramid) {
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const Sequence seq = MakeSequence(width, height);
  PointTracker tracker(seq.camera);
  const int window = tracker.options().lk_window, levels = tracker.options().lk_levels;
  const size_t n = seq.frames.size();
  // Warm-up: one pass, so that the timed frames track a full set of points.
  for (size_t k = 0; k < n; ++k)
    tracker.Track(
        seq.frames[k], static_cast<int64_t>(k),
        k ? std::optional<Mat3>(seq.R_W_C[k - 1].transpose() * seq.R_W_C[k]) : std::nullopt);
  size_t k = 0;
  double tracked = 0, detected = 0, live = 0;
  std::map<std::string, double> stages;
  int runs = 0;
  for (auto _ : state) {
    const size_t prev = (k + n - 1) % n;
    const std::optional<Mat3> R = seq.R_W_C[prev].transpose() * seq.R_W_C[k];
    PointTrackerResult r;
    if (shared_pyramid) {
      state.PauseTiming();
      const FlowPyramid pyramid = BuildFlowPyramid(seq.frames[k], window, levels);
      state.ResumeTiming();
      r = tracker.Track(pyramid, static_cast<int64_t>(n + runs), R);
    } else {
      r = tracker.Track(seq.frames[k], static_cast<int64_t>(n + runs), R);
    }
    benchmark::DoNotOptimize(r.points.data());
    tracked += r.tracked;
    detected += r.detected;
    live += r.points.size();
    for (const auto& [name, ms] : r.times.ms) stages[name] += ms;
    ++runs;
    k = (k + 1) % n;
  }
  state.counters["live"] = live / runs;
  state.counters["tracked"] = tracked / runs;
  state.counters["detected"] = detected / runs;
  for (const auto& [name, ms] : stages) state.counters[name + "_ms"] = ms / runs;
  cv::setNumThreads(threads);
}

void BM_Points640OwnPyramid(benchmark::State& state) {
  Run(state, 640, 480, false);
}
void BM_Points640SharedPyramid(benchmark::State& state) {
  Run(state, 640, 480, true);
}
void BM_Points1280OwnPyramid(benchmark::State& state) {
  Run(state, 1280, 720, false);
}
void BM_Points1280SharedPyramid(benchmark::State& state) {
  Run(state, 1280, 720, true);
}
BENCHMARK(BM_Points640OwnPyramid)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Points640SharedPyramid)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Points1280OwnPyramid)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Points1280SharedPyramid)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace fsp::frontend

BENCHMARK_MAIN();
