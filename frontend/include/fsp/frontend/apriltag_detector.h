// AprilTag detector (libapriltag 3) returning the same Detection type as the rectangle detector.
//
// Corners: libapriltag's det->p[0..3] go counter-clockwise on screen starting at the tag's own
// bottom-left corner, which for an upright tag is s1..s4 (docs/conventions.md), so the tag's
// decoded orientation fixes the order (not the image position). libapriltag's pixel coordinates put
// the centre of pixel (0,0) at (0.5, 0.5); 0.5 is subtracted so integer = pixel centre (OpenCV).
// tag_id = the decoded id; object_class = kTag; score = decision margin / (decision margin + 50),
// in [0, 1). corners_undistorted are the corners undistorted with the calibration (if given): the
// quad fit runs on the distorted image, so the undistorted corners of a strongly distorted, large
// tag carry the curvature error of its straight-edge fit.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/common/camera.h"
#include "fsp/frontend/detection.h"

namespace fsp::frontend {

// Options of AprilTagDetector (see the class comment).
struct AprilTagDetectorOptions {
  // Tag family by libapriltag name: tag36h11, tag25h9, tag16h5, tagCircle21h7, tagCircle49h12,
  // tagStandard41h12, tagStandard52h13, tagCustom48h12.
  std::string family = "tag36h11";
  // Quad detection on an image decimated by this factor [-]: 2 is ~3x faster; small tags (< ~20 px)
  // are lost; the corners are refined on the full image only with refine_edges.
  double decimate = 2.0;
  // Gaussian blur before quad detection [px]; 0 = none. Helps on noisy images, hurts tiny tags.
  double sigma = 0.0;
  // Snap the quad's edges to strong gradients of the full-resolution image (recommended with
  // decimate).
  bool refine_edges = true;
  // Decoding sharpening (libapriltag's decode_sharpening) [-].
  double decode_sharpening = 0.25;
  // Worker threads; 1 keeps results and timings deterministic.
  int threads = 1;
  // Bits of error correction accepted (more: more false positives, more memory for the table).
  int max_hamming = 2;
  // Detections with a smaller decision margin are dropped [libapriltag units, ~ grey levels].
  double min_decision_margin = 0.0;
  bool Check(std::string* why) const;
};

class AprilTagDetector {
 public:
  using Options = AprilTagDetectorOptions;

  struct Result {
    std::vector<Detection> detections;
    StageTimes
        times;  // "apriltag" (quads, decode; the library does not expose its stages) and "convert"
  };

  // Throws InputError when the family name is unknown; FSP_CHECKs the other options.
  explicit AprilTagDetector(Options options = Options());
  ~AprilTagDetector();
  AprilTagDetector(const AprilTagDetector&) = delete;
  AprilTagDetector& operator=(const AprilTagDetector&) = delete;

  // 8-bit grey image (CV_8UC1). `camera` (optional) only undistorts the corners. Not thread-safe:
  // one detector per thread.
  Result Detect(const cv::Mat& gray, const PinholeRadtan* camera = nullptr) const;

  const Options& options() const { return options_; }
  static std::vector<std::string> Families();

 private:
  struct Impl;
  Options options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fsp::frontend
