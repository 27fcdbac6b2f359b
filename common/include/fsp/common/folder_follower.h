// Following an image folder that a camera driver fills while the pipeline runs (`fsp run FOLDER
// --follow`): frames are image files named by their nanosecond timestamps (<t_ns>.png, .jpg, .jpeg,
// .pgm, .bmp, as the image-folder input), the IMU csv (t_ns,wx,wy,wz,ax,ay,az) may grow too.
//
// Polling, no inotify: every poll_s the folder is listed and the IMU csv read from where the last
// poll stopped.
//  - An image is taken once its size is the same (and not zero) in two polls, or once it has not
//    changed for stale_s (1 s): a file still being written is never read half-written. An image
//    that then does not decode is tried again at each poll until it has not changed for stale_s
//    (a writer may pause between two writes), then skipped with a warning. Writers that write to a
//    temporary name and rename (the safe way) are followed as well: names that are not
//    <t_ns>.<image extension> are ignored (a warning for the first few image names that are not
//    timestamps).
//  - The IMU csv: complete lines (ending in a newline) are read as they appear, a partial last
//    line waits for its newline. Each line is checked as the IMU reader checks it; a malformed
//    line ends the follow with an error (the frames covered by the lines before it still go out).
//  - Order: frames in time order, each after the IMU samples up to its time. A frame waits until
//    the IMU csv has reached its time, at most imu_wait_s; then it goes without them (the estimator
//    bridges the gap with a warning) and IMU samples that arrive later than a frame already given
//    out are dropped (counted, one warning). A frame older than one already given out (it arrived
//    late) is skipped with a warning.
//  - The end: no new image file for idle_s (the frames still waiting are given out first), STOP
//    set (a signal handler's flag; nothing more is read), the folder or the IMU csv removed (a
//    clear message; what was given out stands), or an error (a malformed IMU line).
// The library prints nothing: warnings go to the WARN callback.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "fsp/common/calibration.h"
#include "fsp/common/dataset.h"

namespace fsp {

struct FollowOptions {
  std::string folder;  // the image folder
  std::string calib;   // calibration file (required)
  std::string imu;     // IMU csv (required; it must exist, it may be empty and grow)
  std::optional<int64_t> time_offset_ns;  // replaces the calibration's when set [ns]
  double idle_s = 5.0;                    // end after this long without a new image file
  double poll_s = 0.02;                   // polling period
  double imu_wait_s = 1.0;                // how long a frame waits for the IMU to reach its time
  double stale_s = 1.0;  // an image unchanged this long is taken even if its size never settled
  const std::atomic<bool>* stop = nullptr;       // set from outside: end now
  std::function<void(const std::string&)> warn;  // warnings (may be empty)
  bool Check(std::string* why) const;
};

enum class FollowEnd {
  kRunning,     // not ended yet
  kIdle,        // no new image for idle_s
  kStopped,     // the stop flag was set
  kFolderGone,  // the folder or the IMU csv disappeared
  kError,       // a malformed IMU line (message())
};
const char* ToString(FollowEnd end);  // "running", "idle", "stopped", "folder-gone", "error"

class FolderFollower {
 public:
  // Reads the calibration and checks that the folder and the IMU csv exist; throws InputError.
  explicit FolderFollower(const FollowOptions& options);
  ~FolderFollower();
  FolderFollower(const FolderFollower&) = delete;
  FolderFollower& operator=(const FolderFollower&) = delete;

  const Calibration& calibration() const;
  // The next measurement in time order (frames decoded, 8-bit grey, the calibration's time offset
  // added); waits (polling) until one is ready. nullopt at the end: end() and message() say why.
  // Throws InputError when the first image does not fit the calibration (size); later ones that
  // do not are skipped with a warning.
  std::optional<Measurement> Next();

  FollowEnd end() const;
  // For kFolderGone and kError: one line saying what happened ("FILE:LINE: what").
  const std::string& message() const;
  int frames() const;          // frames given out
  int imu_samples() const;     // IMU samples given out
  int images_skipped() const;  // undecodable, wrong size, arrived late or duplicate
  int imu_dropped() const;     // IMU samples that arrived after a later frame was given out
  // Time of the first and the last frame given out (camera time + offset); 0 before the first.
  int64_t t_first_ns() const;
  int64_t t_last_ns() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fsp
