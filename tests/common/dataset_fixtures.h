// Tiny recordings written into a scratch directory for the dataset tests (never the shared data).
#pragma once

#include <cstdint>
#include <cstdio>
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

// A Kalibr camchain as DM-VIO's recordings have it: cam0 with T_cam_imu (= T_C_B) and the IMU
// noise inside cam0, no intrinsics. T_cam_imu is a 90 deg turn about z plus (0.01, 0.02, 0.03).
inline std::string DsoCamchain(bool with_noise = true) {
  std::string s =
      "cam0:\n  T_cam_imu:\n  - [0.0, -1.0, 0.0, 0.01]\n  - [1.0, 0.0, 0.0, 0.02]\n"
      "  - [0.0, 0.0, 1.0, 0.03]\n  - [0.0, 0.0, 0.0, 1.0]\n";
  if (with_noise) {
    s += "  accelerometer_noise_density: 0.1829589017330412      # m/s^1.5\n"
         "  accelerometer_random_walk:   0.024480362284765463     # m/s^2.5\n"
         "  gyroscope_noise_density:     3.7425273003024506e-05    # rad/s^0.5\n"
         "  gyroscope_random_walk:       2.5996760318842082e-06   # rad/s^1.5\n"
         "  integration_sigma:           0.8\t\t\t#\n";
  }
  return s;
}

// "1650458716.848713": T_NS in seconds rounded to the microsecond, as DM-VIO's times.txt has it.
inline std::string MicrosecondSeconds(int64_t t_ns) {
  const int64_t us = (t_ns + 500) / 1000;
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%lld.%06lld", static_cast<long long>(us / 1'000'000),
                static_cast<long long>(us % 1'000'000));
  return buf;
}

// A small valid DSO / DM-VIO layout in DIR: N frames 50 ms apart from T0 named by their nanosecond
// time (cam0/images/<t>.png; times.txt line k+1 is frame k: "<t> <seconds>"), camera.txt (a bare
// pinhole line: fx 30, fy 31, cx 15.5, cy 11.5), imu.txt at 200 Hz covering the frames (line 1 the
// header, line i+2 sample i), camchain.yaml (DsoCamchain).
inline std::vector<int64_t> MakeDso(const std::filesystem::path& dir, int n = 4,
                                    int64_t t0 = 1'650'458'716'848'712'921LL) {
  const auto cam0 = dir / "cam0";
  std::filesystem::create_directories(cam0 / "images");
  std::string times;
  std::vector<int64_t> t;
  for (int k = 0; k < n; ++k) {
    t.push_back(t0 + 50'000'000LL * k);
    cv::imwrite((cam0 / "images" / (std::to_string(t.back()) + ".png")).string(), TestImage(k));
    times += std::to_string(t.back()) + " " + MicrosecondSeconds(t.back()) + "\n";
  }
  WriteText(cam0 / "times.txt", times);
  WriteText(cam0 / "camera.txt", "30 31 15.5 11.5 0\n" + std::to_string(kW) + " " +
                                     std::to_string(kH) + "\ncrop\n16 16\n");
  std::string imu = "# timestamp[ns] w.x w.y w.z a.x a.y a.z\n";
  for (const ImuSample& s : TestImu(t0 - 20'000'000, t.back() + 20'000'000)) {
    imu += std::to_string(s.t_ns) + " 0.01 -0.02 0.03 0.0 0.0 9.81\n";
  }
  WriteText(dir / "imu.txt", imu);
  WriteText(dir / "camchain.yaml", DsoCamchain());
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
