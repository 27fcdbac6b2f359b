// Input sources: every kind of recording yields frames and IMU samples in time order through one
// interface (Source), so the pipeline never knows where its data came from.
//
// Kinds of INPUT (CONTRACT.md):
//  - EuRoC layout: DIR/mav0/{cam0,imu0}/... or DIR being mav0 itself;
//  - a video file + --imu CSV + --calib FILE (frame times from the video clock or --frame-times FILE);
//  - a folder of images named by nanosecond timestamps, or listed in a data.csv, + --imu + --calib.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "fsp/common/calibration.h"
#include "fsp/common/types.h"

namespace fsp {

enum class InputKind { kEuroc, kVideo, kImageFolder };
const char* ToString(InputKind kind);

struct SourceOptions {
  std::string input;        // dataset folder, video file or image folder
  std::string calib;        // calibration file; required for video and image folders
  std::string imu;          // IMU csv (t_ns,wx,wy,wz,ax,ay,az); required for video and image folders
  std::string frame_times;  // optional: one t_ns per video frame (csv or plain), overrides the video clock
  bool decode_images = true;  // false: frames carry only timestamps and sources (fast scans)
  bool Check(std::string* why) const;
};

// One measurement in time order. IMU samples with t_ns <= a frame's t_ns come before that frame.
using Measurement = std::variant<ImuSample, Frame>;

class Source {
 public:
  virtual ~Source() = default;
  virtual InputKind kind() const = 0;
  virtual const Calibration& calibration() const = 0;
  // Frame timestamps (known up front for every kind; the video kind reads them from its clock).
  virtual const std::vector<int64_t>& frame_times() const = 0;
  virtual const std::vector<ImuSample>& imu() const = 0;
  // Next measurement in time order, or nullopt at the end. Throws InputError on an image that does not
  // decode or whose size does not match the calibration.
  virtual std::optional<Measurement> Next() = 0;
  // Decode frame i (0-based) directly; throws InputError as Next() does.
  virtual Frame ReadFrame(int index) const = 0;
};

// Opens INPUT, validating everything that can be checked without decoding every image: files exist,
// csv rows are well-formed, timestamps strictly increase, values are finite, the calibration fits the
// first image. Throws InputError ("FILE:LINE: what") on the first problem.
std::unique_ptr<Source> OpenSource(const SourceOptions& options);

// IMU csv: "t_ns,wx,wy,wz,ax,ay,az" (EuRoC imu0/data.csv and FSP's imu.csv), '#' comment lines allowed.
std::vector<ImuSample> ReadImuCsv(const std::string& path);
void WriteImuCsv(const std::vector<ImuSample>& imu, const std::string& path);

}  // namespace fsp
