// The gt-corners front end (`fsp run --frontend gt-corners`): instead of detecting rectangles in
// the images, it reads a rendered sequence's ground-truth corner projections (observations_gt.csv),
// keeps the objects that are fully visible in each frame and adds Gaussian pixel noise: the paper's
// own experiment, which measures the back end alone. Object classes come from objects_gt.json. No
// pixels are needed.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "fsp/common/observations_io.h"
#include "fsp/common/types.h"
#include "run_config.h"

namespace fsp::apps {

// Folder of a rendered sequence that holds observations_gt.csv for INPUT: INPUT itself, its parent
// when INPUT is the mav0 folder, or the folder of INPUT when it is a file (video.mp4 of a rendered
// sequence).
std::string SequenceRootOf(const std::string& input);

struct GtCornersStats {
  int rows = 0;              // rows in observations_gt.csv
  int rows_not_visible = 0;  // dropped: fully_visible = 0
  int frames_matched = 0;    // frames given to Process() that had rows
  int observations = 0;      // observations handed out
};

class GtCornersFrontend {
 public:
  // Reads ROOT/observations_gt.csv and ROOT/objects_gt.json (ROOT = SequenceRootOf(input)) and
  // draws the noise of every fully visible row up front, in file order, from
  // std::mt19937(options.seed): the noisy corners do not depend on which frames are processed
  // (--realtime may drop some). Throws InputError
  // ("gt-corners needs a rendered sequence: FILE not found", or naming the file and the problem).
  GtCornersFrontend(const std::string& input, const GtCornersOptions& options);

  // The noisy observations of the frame at t_ns (exact time match; none when the frame has no
  // rows).
  std::vector<ObjectObservation> Process(int64_t t_ns);

  const std::string& observations_path() const { return observations_path_; }
  const GtCornersStats& stats() const { return stats_; }

 private:
  std::string observations_path_;
  std::map<int64_t, std::vector<ObjectObservation>> by_time_;
  GtCornersStats stats_;
};

// One observations.csv row per observation (no visibility flag is written for a run's output).
CornerRow ToCornerRow(const ObjectObservation& observation);

}  // namespace fsp::apps
