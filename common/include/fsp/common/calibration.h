// Camera-IMU calibration and the readers for the calibration files users have.
#pragma once

#include <string>

#include "fsp/common/camera.h"
#include "fsp/common/geometry.h"

namespace fsp {

// IMU noise as continuous-time densities, Kalibr names and units. The discrete standard deviation of
// one sample is density / sqrt(dt) (white noise) and density * sqrt(dt) (bias random walk step).
struct ImuNoise {
  double gyroscope_noise_density = 1.6968e-4;      // [rad/s/sqrt(Hz)]
  double accelerometer_noise_density = 2.0e-3;     // [m/s^2/sqrt(Hz)]
  double gyroscope_random_walk = 1.9393e-5;        // [rad/s^2/sqrt(Hz)]
  double accelerometer_random_walk = 3.0e-3;       // [m/s^3/sqrt(Hz)]
  double rate_hz = 200.0;                          // nominal sample rate [Hz]
  bool Check(std::string* why) const;
};

struct Calibration {
  PinholeRadtan camera;
  Rigid3 T_B_C;                // camera -> body (IMU). EuRoC T_BS; Kalibr T_imu_cam, or inverse of T_cam_imu.
  ImuNoise imu;
  double camera_rate_hz = 20.0;
  std::string source;          // file(s) it was read from, for messages
  bool Check(std::string* why) const;
};

// Reads a camera calibration by its content (not its name):
//  - EuRoC cam0/sensor.yaml (T_BS, intrinsics, distortion_coefficients, resolution), with or without
//    the "%YAML:1.0" first line (real EuRoC files lack it; OpenCV-written ones have it);
//  - a Kalibr camchain (cam0 with T_imu_cam, or T_cam_imu which is inverted);
//  - FSP's own calib.yaml (written by `fsp render`).
// The IMU noise is taken from the same file when present (Kalibr imu chain keys or our calib.yaml),
// otherwise defaults. Throws InputError naming the file on a missing/malformed file or unsupported model.
Calibration ReadCalibration(const std::string& path);
// Reads IMU noise from an EuRoC imu0/sensor.yaml, a Kalibr imu chain (imu0: ...) or our calib.yaml.
ImuNoise ReadImuNoise(const std::string& path);
// Writes FSP's calib.yaml (readable by ReadCalibration).
void WriteCalibration(const Calibration& calib, const std::string& path);

}  // namespace fsp
