// The configuration of `fsp run` (a YAML file, --config): estimator options, IMU noise overrides
// and front-end options. The defaults come from the C++ Options structs (one source of truth, each
// option documented there with its reason): a key absent from the file keeps the struct's default.
// assets/config/default.yaml holds the options a user may change, with the same values (a test
// checks it); `fsp run --print-config` (ToYaml) lists every key.
//
//   estimator:            # fsp::backend::EstimatorOptions (estimator.h)
//     static_init: {...}  # StaticInitOptions
//     window_size: 20     # ...
//     factor: {...}       # FspFactorOptions
//     robust: {...}       # RobustLossOptions (type: none | huber | cauchy)
//     preintegration: {...}     # PreintegrationOptions (gravity, re-integration thresholds)
//     single_view_init: {...}   # SingleViewInitOptions
//   imu:                  # overrides of the calibration's IMU noise densities; null = keep the
//   calibration's frontend:
//     gt_corners: {pixel_sigma, seed}
//     detect_every, confirm_detections, ...   # fsp::frontend::FrontEndOptions (frontend.h)
//     rect: {...}         # RectDetectorOptions
//     apriltag: {...}     # AprilTagDetectorOptions
//     tracker: {...}      # ObjectTrackerOptions
//     points: {...}       # PointTrackerOptions (enabled: point features beside the objects)
//
// An unknown key, a value of the wrong type or out of range throws InputError("FILE:LINE: KEY:
// what").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fsp/backend/estimator.h"
#include "fsp/common/calibration.h"
#include "fsp/frontend/frontend.h"

namespace fsp::apps {

// The gt-corners front end: ground-truth corner projections of a rendered sequence plus pixel
// noise.
struct GtCornersOptions {
  // Standard deviation of the Gaussian noise added to each corner coordinate [px]. 0 gives the
  // exact projections (the paper's noise-free experiment); 1 px is a good detector.
  double pixel_sigma = 1.0;
  // Seed of the noise generator (std::mt19937); the same seed gives the same noisy corners.
  uint32_t seed = 1;
  // A row of an object partly in view (fully_visible 0) is handed out with the corners it shows
  // when it shows at least this many (2..4; 4: only fully visible rows). Needs the file's
  // visible_corners column (sequences rendered without it give fully visible rows only).
  int min_visible_corners = 2;
  bool Check(std::string* why) const;
};

// Replacements for the calibration's IMU noise (Kalibr names and units); unset fields keep the
// calibration's values.
struct ImuNoiseOverrides {
  std::optional<double> gyroscope_noise_density;      // [rad/s/sqrt(Hz)]
  std::optional<double> accelerometer_noise_density;  // [m/s^2/sqrt(Hz)]
  std::optional<double> gyroscope_random_walk;        // [rad/s^2/sqrt(Hz)]
  std::optional<double> accelerometer_random_walk;    // [m/s^3/sqrt(Hz)]
  // Returns NOISE with the set fields replaced.
  ImuNoise Apply(ImuNoise noise) const;
};

struct RunConfig {
  backend::EstimatorOptions estimator;
  ImuNoiseOverrides imu;
  // Camera-IMU time offset replacing the calibration's (t_imu = t_cam + offset) [s].
  std::optional<double> camera_time_offset_s;
  GtCornersOptions gt_corners;
  frontend::FrontEndOptions
      frontend;        // --frontend rect | apriltag (the detector kind comes from the flag)
  std::string source;  // the file it was read from; empty for the built-in defaults
};

// Reads a config file on top of the defaults. Throws InputError naming the file, line and key on an
// unknown key, a wrong type or a bad value (and on a file that is missing or not YAML).
RunConfig ReadRunConfig(const std::string& path);
// The same from YAML text; `name` is used in messages.
RunConfig ParseRunConfig(const std::string& yaml_text, const std::string& name);

// Every key of the config ("estimator.window_size", ...), in the order of --print-config.
std::vector<std::string> RunConfigKeys();
// Whether every key has the same value in A and B (doubles compared exactly).
bool SameValues(const RunConfig& a, const RunConfig& b, std::string* first_difference = nullptr);
// The config as YAML, one "key: value" per line under its sections (values exact: doubles in
// shortest round-trip form). Parsing it gives back the same values.
std::string ToYaml(const RunConfig& config);

}  // namespace fsp::apps
