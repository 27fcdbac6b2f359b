// Multi-object rectangle tracker, CMT in spirit (Nebehay & Pflugfelder, "Consensus-based Matching and
// Tracking of Keypoints for Object Tracking", WACV 2014), but made for planar rectangles: the output
// is the object's four corners, not a box.
//
// Model of one object (built by Start from one view): keypoints inside its quad with binary
// descriptors, stored in object-plane coordinates (through the homography of its corners), and a
// reference view (the image warped into a fronto-parallel patch of the object) for the appearance
// check.
//
// Per frame (Track): forward-backward pyramidal optical flow of each object's keypoints from the
// previous frame, plus descriptor matching against the model where flow is short of points;
// consensus by a robust homography fit (object plane -> image; a rectangle is planar, so its corners
// follow exactly); the corners refined on the image edges with the detector's refinement
// (edge_refine.h); where keypoints are few (a plain door), the predicted quad (caller's prediction,
// or the last motion) refined on the edges carries the corners. Last, the appearance check: the frame
// warped into the reference view through the new homography is compared with the reference patch by
// normalised cross-correlation; below `min_appearance` the object is reported lost, so no corners
// are reported for an object that is not there.
//
// Pixels: the tracker works on the distorted image as stored; its interface speaks undistorted
// pixels (the back end's), converted through the camera given at construction.
// Deterministic: the same frames give the same results. Not thread-safe.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/types.h"
#include "fsp/frontend/rect_detector.h"

namespace fsp::frontend {

struct ObjectTrackerOptions {
  // (Fields: each with unit, default and trade-off, as in RectDetectorOptions.)
  // Appearance check: least normalised cross-correlation between the reference patch and the frame
  // warped into it through the tracked homography [-1, 1]. Right homographies measured >= 0.88, an
  // object that left the view <= 0.46.
  double min_appearance = 0.7;
  // Edge refinement of the tracked corners (the detector's refinement options are used).
  RectDetectorOptions refine;
  bool Check(std::string* why) const;
};

// One object's outcome in one frame.
struct TrackedObject {
  int id = -1;
  bool tracked = false;         // false: lost in this frame (moved to the dormant models)
  Corners corners_undistorted;  // s1..s4, undistorted px (valid when tracked)
  Corners corners_px;           // s1..s4, distorted image px (valid when tracked)
  int keypoints = 0;            // consensus size (homography inliers)
  bool edge_refined = false;    // corners came from the edge refinement
  double appearance = 0.0;      // NCC of the appearance check
  double score = 0.0;           // confidence in [0, 1]
};

class ObjectTracker {
 public:
  using Options = ObjectTrackerOptions;

  // `camera`: the calibration of every frame (size checked on each call).
  ObjectTracker(const PinholeRadtan& camera, Options options = Options());
  ~ObjectTracker();
  ObjectTracker(const ObjectTracker&) = delete;
  ObjectTracker& operator=(const ObjectTracker&) = delete;

  // Starts tracking object `id` whose corners (undistorted px, s1..s4) are seen in `gray` (CV_8UC1,
  // the frame last given to Track, or the first frame): builds its model and makes it active. An id
  // with a model (active or dormant) gets a new one. Returns false when the quad is too small or
  // leaves the image (nothing is started).
  bool Start(int id, const cv::Mat& gray, const Corners& corners_undistorted);

  // Tracks every active object into `gray`. `predicted` (optional) holds predicted corners per id
  // (undistorted px), e.g. the previous corners moved by the IMU's rotation; without an entry the
  // tracker predicts from its own motion. Returns one entry per object active before the call; an
  // object that is lost becomes dormant (its model kept for Similarity and Resume).
  std::vector<TrackedObject> Track(const cv::Mat& gray,
                                   const std::map<int, Corners>& predicted = {});

  // Appearance of candidate corners (undistorted px, s1..s4) in `gray` against object `id`'s model
  // (active or dormant): the NCC of the appearance check [-1, 1], or nullopt for an unknown id.
  // Used to re-identify a returning object.
  std::optional<double> Similarity(int id, const cv::Mat& gray, const Corners& corners) const;

  // Makes a dormant (or active) object active again at `corners` in `gray` (the frame last given to
  // Track), keeping its model (re-identification). Returns false for an unknown id.
  bool Resume(int id, const cv::Mat& gray, const Corners& corners_undistorted);

  // Forgets an object's model.
  void Drop(int id);

  std::vector<int> ActiveIds() const;
  std::vector<int> DormantIds() const;
  const Options& options() const { return options_; }

 private:
  struct Impl;
  Options options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fsp::frontend
