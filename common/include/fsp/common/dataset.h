// Input sources: every kind of recording yields frames and IMU samples in time order through one
// interface (Source), so the pipeline never knows where its data came from.
//
// Kinds of INPUT (docs/inputs.md):
//  - EuRoC layout: DIR/mav0/{cam0,imu0}/... or DIR being mav0 itself. cam0/data.csv
//    ("#timestamp [ns],filename") + cam0/data/*, imu0/data.csv, cam0/sensor.yaml (+
//    imu0/sensor.yaml for the IMU noise). --calib and --imu override the files of the folder when
//    given.
//  - DSO / TUM-VI / DM-VIO layout: DIR/cam0/{times.txt, camera.txt, images/}, DIR/imu.txt,
//    DIR/camchain.yaml (recognised by cam0/times.txt, cam0/camera.txt or cam0/images/ without
//    EuRoC's cam0/data.csv). times.txt: rows "id t_s [exposure_ms]", the image
//    cam0/images/<id>.png|jpg; the time is the id when it is the same time in nanoseconds (DM-VIO,
//    TUM-VI: exact where t_s is rounded), else t_s; the exposure is not used. camera.txt: DSO's
//    camera file (ReadDsoCamera: pinhole or radtan, absolute or relative; fisheye rejected).
//    imu.txt: "t_ns wx wy wz ax ay az" [ns, rad/s, m/s^2], whitespace separated, '#' comments
//    (read by ReadImuCsv). camchain.yaml: Kalibr's cam0 T_cam_imu (= T_C_B, inverted) or
//    T_imu_cam, timeshift_cam_imu, and the IMU noise when it holds it (ReadKalibrCameraImu);
//    otherwise the first other YAML file in DIR mentioning a noise density (DM-VIO's settings
//    file, e.g. d435.yaml), else the defaults. camera.txt wins for the intrinsics and image size:
//    it is the file beside the images that DSO and DM-VIO read them from; a camchain's own
//    intrinsics (if any) are not read, as DM-VIO reads only T_cam_imu there. The camera rate is
//    the median frame interval. --calib replaces camera.txt and the camchain's transform (the
//    camchain's IMU noise still applies when --calib has none); --imu replaces imu.txt.
//  - a video file + --imu CSV + --calib FILE. Frame k's time is the video clock (CAP_PROP_POS_MSEC,
//    rounded to 1 us); when that clock agrees with k / fps to 2 us (a constant-rate video) or is
//    unusable, round(k * 1e9 / fps) exactly, which is the renderer's own frame time at any rate.
//    Or line k of --frame-times FILE (one t_ns per line, or a csv whose first column is t_ns).
//    Rendered sequences start at t = 0, so video.mp4 + imu.csv + calib.yaml line up with no offset.
//  - a folder of images (png, jpg, jpeg, pgm, bmp) named by nanosecond timestamps
//    (1403715273262142976.png), or listed in a data.csv inside the folder (EuRoC cam0 style: names
//    relative to FOLDER/data/ when that folder holds them, else to FOLDER), + --imu + --calib.
// Every source adds the calibration's time_offset_ns to its frame times (t_imu = t_cam + offset).
// Decoded frames are CV_8UC1 (colour is converted to grey).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "fsp/common/calibration.h"
#include "fsp/common/types.h"

namespace fsp {

enum class InputKind { kEuroc, kVideo, kImageFolder, kDso };
const char* ToString(InputKind kind);  // "euroc", "video", "image-folder", "dso"

struct SourceOptions {
  std::string input;  // dataset folder, video file or image folder
  std::string calib;  // calibration file; required for video and image folders, overrides EuRoC's
                      // and the DSO layout's
  std::string imu;    // IMU csv (t_ns,wx,wy,wz,ax,ay,az); required for video and image folders
  std::string
      frame_times;  // optional: one t_ns per video frame (csv or plain), overrides the video clock
  bool decode_images =
      true;  // false: Next() yields frames with only timestamps and sources (fast scans)
  // Replaces the calibration's camera-IMU time offset (t_imu = t_cam + offset) when set [ns].
  std::optional<int64_t> time_offset_ns;
  bool Check(std::string* why) const;
};

// One measurement in time order. IMU samples with t_ns <= a frame's t_ns come before that frame.
using Measurement = std::variant<ImuSample, Frame>;

class Source {
 public:
  virtual ~Source() = default;
  virtual InputKind kind() const = 0;
  virtual const Calibration& calibration() const = 0;
  // Frame timestamps in the IMU clock (known up front for every kind; the video kind reads them
  // from its clock at open time).
  virtual const std::vector<int64_t>& frame_times() const = 0;
  virtual const std::vector<ImuSample>& imu() const = 0;
  // Next measurement in time order, or nullopt at the end. Throws InputError naming the image file
  // (or "VIDEO#frame=K") when an image does not decode or its size does not match the calibration.
  virtual std::optional<Measurement> Next() = 0;
  // Decode frame i (0-based) directly (always decodes, whatever decode_images says); throws
  // InputError as Next() does. Sequential calls on a video are cheap; jumping back re-seeks.
  virtual Frame ReadFrame(int index) const = 0;
};

// Opens INPUT, validating everything that can be checked without decoding every image: files exist,
// csv rows are well-formed, timestamps strictly increase, values are finite, the first image
// decodes and fits the calibration, frames and IMU overlap in time. A video is scanned once (grab
// without colour conversion) to read its clock. Throws InputError ("FILE:LINE: what") on the first
// problem.
std::unique_ptr<Source> OpenSource(const SourceOptions& options);

// What a source holds, for `fsp info` and for apps to warn about (libraries stay silent).
struct SourceSummary {
  InputKind kind = InputKind::kEuroc;
  int frames = 0;
  int64_t t_first_ns = 0, t_last_ns = 0;  // over frames
  double frame_rate_hz = 0.0;             // from the median frame interval; 0 with < 2 frames
  int imu_samples = 0;
  int64_t imu_t_first_ns = 0, imu_t_last_ns = 0;
  double imu_rate_hz = 0.0;           // from the median IMU interval
  int64_t largest_imu_gap_ns = 0;     // largest interval between consecutive IMU samples
  int64_t largest_imu_gap_at_ns = 0;  // time of the sample that ends it
  int imu_gaps = 0;            // intervals longer than 5x the calibration's nominal IMU period
  int frames_outside_imu = 0;  // frames before the first or after the last IMU sample
};
SourceSummary Summarize(const Source& source);

// IMU csv: "t_ns,wx,wy,wz,ax,ay,az" (EuRoC imu0/data.csv and FSP's imu.csv), '#' comment lines
// allowed. Exactly 7 columns, finite values, strictly increasing t_ns, at least one sample; else
// InputError "FILE:LINE: what".
std::vector<ImuSample> ReadImuCsv(const std::string& path);
// Writes the same format with a EuRoC header line; values in shortest exact decimal (lossless).
void WriteImuCsv(const std::vector<ImuSample>& imu, const std::string& path);

}  // namespace fsp
