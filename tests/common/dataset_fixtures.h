// Tiny recordings written into a scratch directory for the dataset tests (never the shared data).
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fsp/common/calibration.h"
#include "fsp/common/dataset.h"
#include "fsp/common/error.h"

namespace fsp::test {

constexpr int kW = 32, kH = 24;  // fixture image size [px]

inline void WriteText(const std::filesystem::path& p, const std::string& text) {
  std::filesystem::create_directories(p.parent_path());
  std::ofstream out(p);
  out << text;
}

inline std::string ReadText(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A grey test image whose pixels encode K (so frames can be told apart).
inline cv::Mat TestImage(int k, int w = kW, int h = kH) {
  cv::Mat m(h, w, CV_8UC1);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) m.at<uchar>(r, c) = static_cast<uchar>((10 * k + 3 * r + c) % 256);
  return m;
}

inline Calibration TestCalibration(int w = kW, int h = kH) {
  Calibration c;
  c.camera.width = w;
  c.camera.height = h;
  c.camera.fx = c.camera.fy = 30.0;
  c.camera.cx = w / 2.0;
  c.camera.cy = h / 2.0;
  return c;
}

// IMU at 200 Hz over [t0, t1] ns.
inline std::vector<ImuSample> TestImu(int64_t t0, int64_t t1) {
  std::vector<ImuSample> imu;
  for (int64_t t = t0; t <= t1; t += 5'000'000) {
    ImuSample s;
    s.t_ns = t;
    s.gyro = Vec3(0.01, -0.02, 0.03);
    s.acc = Vec3(0.0, 0.0, 9.81);
    imu.push_back(s);
  }
  return imu;
}

// EuRoC sensor.yaml text (no %YAML line, as real EuRoC files) for a WxH pinhole camera.
inline std::string EurocCamYaml(int w = kW, int h = kH) {
  return "sensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [0, -1, 0, 0.01,\n         1, "
         "0, 0, 0.02,\n"
         "         0, 0, 1, 0.03,\n         0, 0, 0, 1]\nrate_hz: 20\nresolution: [" +
         std::to_string(w) + ", " + std::to_string(h) +
         "]\ncamera_model: pinhole\nintrinsics: [30, 30, 16, 12]\ndistortion_model: "
         "radial-tangential\n"
         "distortion_coefficients: [0.01, -0.002, 0.0001, 0.0002]\n";
}

// A small valid EuRoC layout DIR/mav0 with N frames at 20 Hz from T0 and IMU at 200 Hz covering
// them. Frame k is DIR/mav0/cam0/data/<t>.png; data.csv line k+2 lists it (line 1 is the header).
inline std::vector<int64_t> MakeEuroc(const std::filesystem::path& dir, int n = 4,
                                      int64_t t0 = 1'000'000'000) {
  const auto mav0 = dir / "mav0";
  std::filesystem::create_directories(mav0 / "cam0" / "data");
  std::string csv = "#timestamp [ns],filename\n";
  std::vector<int64_t> t;
  for (int k = 0; k < n; ++k) {
    t.push_back(t0 + 50'000'000LL * k);
    const std::string name = std::to_string(t.back()) + ".png";
    cv::imwrite((mav0 / "cam0" / "data" / name).string(), TestImage(k));
    csv += std::to_string(t.back()) + "," + name + "\n";
  }
  WriteText(mav0 / "cam0" / "data.csv", csv);
  WriteText(mav0 / "cam0" / "sensor.yaml", EurocCamYaml());
  std::filesystem::create_directories(mav0 / "imu0");
  WriteImuCsv(TestImu(t0 - 20'000'000, t.back() + 20'000'000),
              (mav0 / "imu0" / "data.csv").string());
  WriteText(mav0 / "imu0" / "sensor.yaml",
            "%YAML:1.0\nsensor_type: imu\nrate_hz: 200\ngyroscope_noise_density: 1.0e-4\n"
            "gyroscope_random_walk: 2.0e-5\naccelerometer_noise_density: "
            "3.0e-3\naccelerometer_random_walk: 4.0e-3\n");
  return t;
}

// The message of the InputError FN throws (fails the test when it throws nothing).
template <typename Fn>
std::string ErrorOf(Fn fn) {
  try {
    fn();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError thrown";
  return "";
}

}  // namespace fsp::test
