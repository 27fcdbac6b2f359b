// Scoring detections against ground-truth corners (a rendered sequence's observations_gt.csv):
// recall, precision and corner error, per frame or over a whole sequence folder.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/common/observations_io.h"
#include "fsp/frontend/detection.h"

namespace fsp::frontend {

// Ground truth: rows of observations_gt.csv (fsp::CornerRow, UNDISTORTED pixels, s1..s4).
using GtObservation = CornerRow;

struct MatchOptions {
  // Ground truth counted for recall: fully visible with a shortest side of at least this [px].
  double min_shortest_side_px = 40.0;
  // A detection matches a ground-truth quad when, after the best cyclic shift of the corners, every
  // corner is within max(match_px, match_frac x the GT's shortest side) [px].
  double match_px = 3.0;
  double match_frac = 0.1;
};

struct MatchStats {
  int frames = 0;
  int gt_eligible = 0;        // GT quads counted for recall
  int gt_eligible_found = 0;  // ... that a detection matched
  int detections = 0;
  int true_positives = 0;    // detections that match any GT quad (visible at all, any size)
  int order_mismatches = 0;  // matches whose best cyclic shift was not 0 (s1..s4 order differs)
  std::vector<double> corner_err_px;     // per corner of each eligible match (best shift)
  double Recall() const;                 // gt_eligible_found / gt_eligible (1 when there is none)
  double Precision() const;              // true_positives / detections (1 when there is none)
  double ErrorQuantile(double q) const;  // e.g. 0.5 median, 0.9 p90; NaN when empty
  void Merge(const MatchStats& other);
};

// Scores one frame: detections' corners_undistorted against the frame's GT rows.
MatchStats MatchFrame(const std::vector<Detection>& detections,
                      const std::vector<GtObservation>& gt,
                      const MatchOptions& options = MatchOptions());

// Runs `detect` on every image of a rendered sequence DIR (DIR/mav0/cam0/data.csv + data/, and
// DIR/observations_gt.csv) and accumulates the scores. `every` takes every n-th frame.
using DetectFn = std::function<std::vector<Detection>(const cv::Mat& gray)>;
MatchStats EvaluateSequence(const std::string& dir, const DetectFn& detect,
                            const MatchOptions& options = MatchOptions(), int every = 1);

}  // namespace fsp::frontend
