// `fsp run --video FILE`: the run as a person watches it. Each frame shows the image with every
// object the front end reported this frame (outline in distorted pixels, colour by class, its id
// and class, and its width x height in metres once the map holds it), and in a corner the top view
// so far: the estimated trajectory and the map's objects. Drawing lives in apps/ (an observer of
// the pipeline's results, never called by it).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/backend/estimator.h"
#include "fsp/common/calibration.h"
#include "fsp/common/types.h"

namespace fsp::apps {

class AnnotatedVideo {
 public:
  // Opens PATH (mp4v) at FPS frames per second for frames of the calibration's size; an empty PATH
  // draws only (last(), for a live window). The video is written to a temporary name beside PATH
  // (PartPath) and renamed to PATH by Close(): a reader never sees half a video, and a run that
  // fails (no Close) leaves none. Throws InputError when it cannot be written.
  AnnotatedVideo(const std::string& path, const Calibration& calibration, double fps);
  ~AnnotatedVideo();
  // Ends the video and renames it to PATH (throws InputError when that fails).
  void Close();
  AnnotatedVideo(const AnnotatedVideo&) = delete;
  AnnotatedVideo& operator=(const AnnotatedVideo&) = delete;

  // One frame: IMAGE (8-bit grey or BGR; empty when the front end read corners from a file: a grey
  // canvas then), the observations reported for it (undistorted corners), the map and the newest
  // body pose (nullopt before the estimator is initialised).
  void Add(const cv::Mat& image, const std::vector<ObjectObservation>& observations,
           const std::vector<backend::MapObject>& map, const std::optional<Rigid3>& T_W_B);

  // The map after the final solve, once its σ are known: kSummaryFrames frames (2 s at 20 Hz)
  // appended after the last one, the last frame dimmed under a table of the objects (id, class,
  // width +- σ x height +- σ). Nothing when no frame was added.
  static constexpr int kSummaryFrames = 40;
  void AddSummary(const std::vector<backend::MapObject>& map);

  // The last frame drawn (BGR), e.g. for a picture in the docs; empty before the first.
  const cv::Mat& last() const { return last_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  cv::Mat last_;
};

}  // namespace fsp::apps
