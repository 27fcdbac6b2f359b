// The front ends that read their corners from a file instead of detecting rectangles in the images
// (no pixels are needed). Both read observations_gt.csv's columns with ReadCornerRows
// (t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4[,fully_visible[,visible_corners]]) and hand out the rows
// of objects partly in view with the corners they show (at least min_visible_corners of them; a
// file without visible_corners gives fully visible rows only):
//  - gt-corners (`fsp run --frontend gt-corners`): a rendered sequence's ground-truth corner
//    projections (observations_gt.csv, undistorted pixels) plus Gaussian pixel noise: the paper's
//    own experiment, which measures the back end alone. Object classes come from objects_gt.json.
//  - corners (`fsp run --frontend corners --corners FILE [--objects FILE]`): the corners another
//    detector found in the raw images (distorted pixels), undistorted with the calibration.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "fsp/common/calibration.h"
#include "fsp/common/observations_io.h"
#include "fsp/common/types.h"
#include "run_config.h"

namespace fsp::apps {

// Folder of a rendered sequence that holds observations_gt.csv for INPUT: INPUT itself, its parent
// when INPUT is the mav0 folder, or the folder of INPUT when it is a file (video.mp4 of a rendered
// sequence).
std::string SequenceRootOf(const std::string& input);

// id -> class from an objects file in objects_gt.json's layout ({"objects": [{"id": 1, "class":
// "door", ...}, ...]}; other keys are ignored, a missing class is unknown). Throws InputError
// naming the file and the object.
std::map<int, ObjectClass> ReadObjectClasses(const std::string& path);

struct CornerFileStats {
  int rows = 0;              // rows in the corners file
  int rows_not_visible = 0;  // dropped: fully_visible = 0 (and too few corners in view)
  int rows_partial = 0;      // handed out with some corners not seen (gt-corners)
  int frames_matched = 0;    // frames given to Process() that had rows
  int observations = 0;      // observations handed out
};

// What both front ends share: the observations, read up front, handed out by frame time.
class CornerFileFrontend {
 public:
  virtual ~CornerFileFrontend() = default;
  // The observations of the frame at t_ns (exact time match; none when the frame has no rows).
  std::vector<ObjectObservation> Process(int64_t t_ns);
  const std::string& observations_path() const { return observations_path_; }
  const CornerFileStats& stats() const { return stats_; }

 protected:
  CornerFileFrontend() = default;
  // Whether a row is handed out: fully visible, or showing at least `min_visible_corners` corners
  // (counted in stats_ either way).
  bool Keep(const CornerRow& row, int min_visible_corners);
  std::string observations_path_;
  std::map<int64_t, std::vector<ObjectObservation>> by_time_;
  CornerFileStats stats_;
};

class GtCornersFrontend : public CornerFileFrontend {
 public:
  // Reads ROOT/observations_gt.csv and ROOT/objects_gt.json (ROOT = SequenceRootOf(input)) and
  // draws the noise of every fully visible row up front, in file order, from
  // std::mt19937(options.seed) (rows partly in view: std::mt19937(options.seed + 1)): the noisy
  // corners do not depend on which frames are processed
  // (--realtime may drop some). Throws InputError
  // ("gt-corners needs a rendered sequence: FILE not found", or naming the file and the problem).
  GtCornersFrontend(const std::string& input, const GtCornersOptions& options);
};

// The corners front end. CORNERS: the columns of observations_gt.csv, but the corners are where a
// detector found them in the raw image (distorted pixels, OpenCV convention: integer coordinates
// are pixel centres), in s1..s4 order (docs/conventions.md); they are undistorted with
// CALIBRATION's camera. t_ns is the frame's time as INPUT lists it (EuRoC cam0/data.csv, image
// name, video clock or --frame-times); the calibration's time_offset_ns is added, as it is to the
// frames. OBJECTS (optional, ReadObjectClasses' layout) names the classes, which give the
// single-view initialisation its width prior; without it every object is of class unknown. Throws
// InputError ("FILE:LINE: what") on a missing or malformed file, a non-finite value, times going
// backwards, a time that matches none of FRAME_TIMES (the input's frame times, offset included),
// an object twice in one frame, an object OBJECTS does not list, or a file without rows. A row not
// fully visible is used with the corners its visible_corners column names when there are at least
// `min_visible_corners` (GtCornersOptions'); without the column it is dropped.
class ExternalCornersFrontend : public CornerFileFrontend {
 public:
  ExternalCornersFrontend(const std::string& corners, const std::string& objects,
                          const Calibration& calibration, const std::vector<int64_t>& frame_times,
                          int min_visible_corners = 2);
};

// One observations.csv row per observation (no visibility flag is written for a run's output).
CornerRow ToCornerRow(const ObjectObservation& observation);

}  // namespace fsp::apps
