// Camera-IMU calibration and the readers for the calibration files users have.
//
// FSP's own calibration file, calib.yaml (written by WriteCalibration and by `fsp render` beside
// video.mp4, read back by ReadCalibration). Units: pixels, seconds, SI; numbers are written in
// their shortest exact decimal form, so a write/read round trip is lossless.
//
//   camera:
//     width: 640                 # image size [px]
//     height: 480
//     fx: 458.0                  # focal lengths [px]
//     fy: 458.0
//     cx: 320.0                  # principal point [px], OpenCV convention (integer = pixel centre)
//     cy: 240.0
//     distortion: [k1, k2, p1, p2]   # radial-tangential (OpenCV order); [0, 0, 0, 0] for none
//     rate_hz: 20                # nominal frame rate [Hz]
//   T_B_C: [16 numbers]          # camera -> body (IMU), row-major 4x4: p_B = T_B_C * p_C
//   time_offset_ns: 0            # optional, default 0: t_imu = t_cam + time_offset_ns
//   imu:                         # optional (defaults below when absent); Kalibr names and units
//     rate_hz: 200
//     gyroscope_noise_density: 1.6968e-4       # [rad/s/sqrt(Hz)]
//     accelerometer_noise_density: 2.0e-3      # [m/s^2/sqrt(Hz)]
//     gyroscope_random_walk: 1.9393e-5         # [rad/s^2/sqrt(Hz)]
//     accelerometer_random_walk: 3.0e-3        # [m/s^3/sqrt(Hz)]
//
// Only pinhole cameras with radial-tangential distortion are supported. A Kalibr camchain with
// another model (equidistant/fisheye, as TUM-VI's) is rejected by ReadCalibration with "unsupported
// camera model"; ReadCameraExtrinsics still reads its T_B_C (useful to check conventions).
#pragma once

#include <cstdint>
#include <string>

#include "fsp/common/camera.h"
#include "fsp/common/geometry.h"

namespace fsp {

// IMU noise as continuous-time densities, Kalibr names and units. The discrete standard deviation
// of one sample is density / sqrt(dt) (white noise) and density * sqrt(dt) (bias random walk step).
struct ImuNoise {
  double gyroscope_noise_density = 1.6968e-4;   // [rad/s/sqrt(Hz)]
  double accelerometer_noise_density = 2.0e-3;  // [m/s^2/sqrt(Hz)]
  double gyroscope_random_walk = 1.9393e-5;     // [rad/s^2/sqrt(Hz)]
  double accelerometer_random_walk = 3.0e-3;    // [m/s^3/sqrt(Hz)]
  double rate_hz = 200.0;                       // nominal sample rate [Hz]
  // False with a reason unless every density and the rate are positive and finite.
  bool Check(std::string* why) const;
};

struct Calibration {
  PinholeRadtan camera;
  Rigid3 T_B_C;  // camera -> body (IMU). EuRoC T_BS; Kalibr T_imu_cam, or inverse of T_cam_imu.
  ImuNoise imu;
  double camera_rate_hz = 20.0;  // nominal frame rate [Hz]
  // Camera clock -> IMU clock: a frame stamped t_cam (file name, data.csv or video clock) was taken
  // at t_imu = t_cam + time_offset_ns. Every Source adds it to its frame times. Kalibr's
  // timeshift_cam_imu [s] has the same meaning.
  int64_t time_offset_ns = 0;
  std::string source;      // file(s) it was read from, for messages
  std::string imu_source;  // file the IMU noise came from; empty = the ImuNoise defaults
  // False with a reason when the camera, the transform, the rates or the IMU noise are unusable.
  bool Check(std::string* why) const;
};

// Reads a camera calibration by its content (not its name):
//  - EuRoC cam0/sensor.yaml (T_BS, intrinsics, distortion_coefficients, resolution, rate_hz), with
//  or
//    without the "%YAML:1.0" first line (real EuRoC files lack it; OpenCV-written ones have it);
//  - a Kalibr camchain (cam0 with T_imu_cam, or T_cam_imu which is inverted; timeshift_cam_imu);
//  - FSP's own calib.yaml (above).
// The IMU noise is taken from the same file when present (a Kalibr imu0 block or our imu block),
// otherwise defaults (imu_source stays empty). Throws InputError "FILE:LINE: what" on a missing or
// malformed file, an unsupported camera model or values that fail Check.
Calibration ReadCalibration(const std::string& path);
// Reads IMU noise from an EuRoC imu0/sensor.yaml, a Kalibr imu chain (imu0: ...) or our calib.yaml.
ImuNoise ReadImuNoise(const std::string& path);
// T_B_C (camera -> body) from any file ReadCalibration understands, without checking the camera
// model (so a TUM-VI equidistant camchain gives its extrinsics).
Rigid3 ReadCameraExtrinsics(const std::string& path);
// The camera-IMU part of a Kalibr camchain whose intrinsics live elsewhere (a DSO layout's
// camera.txt): cam0's T_imu_cam, or T_cam_imu inverted (T_C_B -> T_B_C); timeshift_cam_imu; the IMU
// noise when the file holds it (an imu0 block, or the four density keys inside cam0 or at the top
// level, as DM-VIO's camchains have them; imu_source is then PATH). A camera model, intrinsics or
// resolution in it are not read (DM-VIO reads only T_cam_imu there either); the returned camera is
// empty. Throws InputError "FILE:LINE: what".
Calibration ReadKalibrCameraImu(const std::string& path);
// A DSO / TUM-VI / DM-VIO cam0/camera.txt (DSO's Undistort format). Line 1, the camera:
//   "Pinhole fx fy cx cy 0"                or bare "fx fy cx cy 0" (a non-zero fifth number is
//                                          DSO's FOV/ATAN model: rejected; a named Pinhole
//                                          ignores it, as DSO does);
//   "RadTan fx fy cx cy k1 k2 p1 p2"       or bare eight numbers (OpenCV order);
//   "FOV ...", "EquiDistant ...", "KannalaBrandt ..."   rejected (ATAN, fisheye).
// Line 2: the image size "width height". When cx < 1 and cy < 1 the numbers are relative (DSO's
// rule): fx * w, fy * h, cx * w - 0.5, cy * h - 0.5 (DSO's relative form counts from the top-left
// pixel's outer corner; -0.5 moves the origin to that pixel's centre, the convention used here);
// otherwise they are pixels with the OpenCV convention. Lines 3-4 (DSO's rectified output: crop,
// full, none or a K, and its size) are not read: fsp works on the original images. Throws
// InputError "FILE:LINE: what".
PinholeRadtan ReadDsoCamera(const std::string& path);
// Writes FSP's calib.yaml (readable by ReadCalibration). Throws InputError when PATH cannot be
// written.
void WriteCalibration(const Calibration& calib, const std::string& path);

}  // namespace fsp
