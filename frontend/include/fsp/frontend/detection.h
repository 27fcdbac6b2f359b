// What a detector returns for one image, and per-stage timing.
//
// Two pixel frames (see common/camera.h):
//  - corners_px: DISTORTED pixels, i.e. positions in the image file as stored (what `fsp detect`
//  writes
//    to detections.csv and draws);
//  - corners_undistorted: undistorted pixels (same K, no lens distortion), what the back end
//  consumes
//    (ObjectObservation.corners). Without a calibration both are identical.
// Corner order is s1..s4 (docs/conventions.md): bottom-left, bottom-right, top-right, top-left of
// the object seen from the front. Pixels follow OpenCV: integer coordinates are pixel centres.
#pragma once

#include <array>
#include <string>
#include <utility>
#include <vector>

#include "fsp/common/types.h"

namespace fsp::frontend {

struct Detection {
  int tag_id = -1;  // AprilTag id; -1 for a plain rectangle
  // Class guess: kTag for AprilTags and for tag-like rectangles (then tag_id -1).
  ObjectClass object_class = ObjectClass::kUnknown;
  Corners corners_px;           // s1..s4, DISTORTED image pixels
  Corners corners_undistorted;  // s1..s4, undistorted pixels
  double score = 0.0;           // confidence in [0, 1] (edge support, decode margin)
  // Per side (side i joins corners i-1 and i): the polarity of the edge the detector's refinement
  // fitted it to, as EdgeRefinement::side_sign (+1: brighter towards the side's left normal); 0
  // where unknown (AprilTags, a door's bottom taken without an edge).
  std::array<int, 4> side_sign = {0, 0, 0, 0};

  // The back end's type: undistorted corners; object_id = tag_id (-1 until association assigns
  // one).
  ObjectObservation ToObservation(int64_t t_ns) const;
};

// Wall time of named pipeline stages in milliseconds, in execution order.
struct StageTimes {
  std::vector<std::pair<std::string, double>> ms;
  void Add(const std::string& stage, double milliseconds);
  double Total() const;
  // "name=1.23 name2=0.45 ..." for logs.
  std::string ToString() const;
};

// Monotonic stopwatch in milliseconds.
class Stopwatch {
 public:
  Stopwatch();
  // Milliseconds since construction or the last Lap(), and restarts.
  double Lap();

 private:
  long long start_ns_;
};

}  // namespace fsp::frontend
