// Scoring detections against ground-truth corners (a rendered sequence's observations_gt.csv):
// recall, precision and corner error, per frame or over a whole sequence folder; and against hand
// labels of real frames (polygon overlap, per labelled class).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
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

// --- Hand labels of real frames (tests/frontend/data/README.md) ---------------------------------

// One object in one labelled frame. Corners s1..s4 in pixels of the image file (distorted pixels),
// possibly outside the image when the object is cut by its border.
struct LabelledObject {
  enum class State { kFull, kCut, kIgnore };
  int id = -1;              // the same physical object has the same id in every frame
  std::string label_class;  // door, cabinet, screen, plate, picture, paper, window, other
  State state = State::kFull;
  Corners corners;
  std::array<bool, 4> visible = {true, true, true, true};  // kCut: corners in view
};

struct LabelledFrame {
  int64_t t_ns = 0;
  std::vector<LabelledObject> objects;
};

struct FrameLabels {
  std::string recording;
  int width = 0, height = 0;
  std::vector<LabelledFrame> frames;  // sorted by t_ns
};

// Reads a label file (the JSON shape of tests/frontend/data/README.md); InputError naming the file
// and the entry on anything malformed.
FrameLabels ReadFrameLabels(const std::string& path);

struct LabelMatchOptions {
  double min_iou = 0.5;                // a detection and a label overlap at least this much
  double min_shortest_side_px = 30.0;  // full labels counted for recall
};

// Scores of detections against labels, per labelled class and in total.
struct LabelScore {
  struct PerClass {
    int full = 0;       // full labels counted for recall
    int found = 0;      // ... that a detection overlaps by min_iou
    int cut = 0;        // cut labels
    int cut_found = 0;  // ... that a detection overlaps (its in-image part) by min_iou
    std::vector<double> corner_err_px;  // found full labels' corners (best cyclic shift)
    void Add(const PerClass& other);
  };
  std::map<std::string, PerClass> per_class;
  int frames = 0;
  int detections = 0;      // detections that overlap no ignored label
  int true_positives = 0;  // ... that overlap a full or cut label
  PerClass Total() const;
  double Recall() const;     // full labels found / full labels (1 when there is none)
  double Precision() const;  // true_positives / detections (1 when there is none)
  void Merge(const LabelScore& other);
};

// Scores one frame's detections (corners_px, distorted pixels as the labels) against its labels.
LabelScore ScoreLabelledFrame(const std::vector<Detection>& detections, const LabelledFrame& labels,
                              int width, int height,
                              const LabelMatchOptions& options = LabelMatchOptions());

}  // namespace fsp::frontend
