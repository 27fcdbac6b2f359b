// Internal to the front end (not installed): FrontEnd::Impl, the state it keeps per object, and the
// work of one frame. Its member functions live in two files:
//   frontend.cc     tracking, when to detect, detection (with tag decoding), the object lifecycle
//                   (votes, confirmation) and the observations emitted;
//   association.cc  detections to objects: tags by id, plain rectangles to live tracks, unmatched
//                   ones to dormant objects (re-identification) or new candidates; corrections of
//                   a track onto a detection.
#pragma once

#include <map>
#include <memory>
#include <set>
#include <vector>

#include <opencv2/core.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/types.h"
#include "fsp/frontend/apriltag_detector.h"
#include "fsp/frontend/detection.h"
#include "fsp/frontend/flow_pyramid.h"
#include "fsp/frontend/frontend.h"
#include "fsp/frontend/object_tracker.h"
#include "fsp/frontend/point_tracker.h"
#include "fsp/frontend/rect_detector.h"

namespace fsp::frontend {

// Where corners C of the previous frame appear after the camera turned by R_Cprev_Ccur (the
// infinite homography K R_Ccur_Cprev K^-1).
Corners RotateCorners(const Corners& c, const Mat3& K, const Mat3& R_Cprev_Ccur);

namespace frontend_internal {

struct ObjectInfo {
  bool confirmed = false;
  bool active = false;
  bool is_tag = false;       // a decoded AprilTag (its id is the tag id)
  int detections = 0;        // detection runs that matched it
  int candidate_frames = 0;  // frames tracked as a candidate
  std::map<ObjectClass, int> class_votes;
  Corners last;  // last tracked corners (undistorted px)

  ObjectClass Class() const {
    ObjectClass best = ObjectClass::kUnknown;
    int best_n = 0;
    for (const auto& [c, n] : class_votes)
      if (n > best_n) {
        best = c;
        best_n = n;
      }
    return best;
  }
};

}  // namespace frontend_internal

struct FrontEnd::Impl {
  using ObjectInfo = frontend_internal::ObjectInfo;

  PinholeRadtan camera;
  Mat3 K;
  RectDetector rect;
  AprilTagDetector tags;   // full frames (kAprilTag)
  AprilTagDetector crops;  // tag-like rectangles (kRect): small crops, decimate 1
  ObjectTracker tracker;
  std::unique_ptr<PointTracker> points;  // points.enabled
  std::map<int, ObjectInfo> objects;
  int next_rect_id = 0;
  int frame_index = 0;
  int last_detect_frame = -1000000;
  int last_tag_scan = -1000000;
  bool lost_last_frame = false;

  Impl(const PinholeRadtan& cam, const FrontEndOptions& o)
      : camera(cam),
        K(cam.K()),
        rect(o.rect),
        tags(o.apriltag),
        crops([&] {
          AprilTagDetectorOptions c = o.apriltag;
          c.decimate = 1.0;
          return c;
        }()),
        tracker(cam,
                [&] {
                  ObjectTrackerOptions t = o.tracker;
                  t.refine = o.rect;  // one set of refinement options for detector and tracker
                  return t;
                }()),
        points(o.points.enabled ? std::make_unique<PointTracker>(cam, o.points) : nullptr),
        next_rect_id(o.first_rect_id) {}

  // What one Process call builds up.
  struct FrameWork {
    FrameWork(const cv::Mat& g, const FlowPyramid& pyr, const FramePrediction& p,
              const FrontEndOptions& opt)
        : gray(g), pyramid(pyr), prediction(p), o(opt) {}
    const cv::Mat& gray;
    const FlowPyramid& pyramid;  // GRAY's: the objects' flow and the points' use it
    const FramePrediction& prediction;
    const FrontEndOptions& o;
    FrontEndResult result;
    std::map<int, Corners> tracked;         // this frame's corners of the live objects
    std::map<int, Corners> from_detection;  // corners of objects (re)started in this frame
    std::map<int, double> score;            // their confidence (tracker or detector)
    std::map<int, CornerMask> out_of_view;  // tracked partly out of view: the corners in it
    std::set<int> blurred;  // tracked with smeared edges: a detection does not correct them
    // Tracked corners reported with keypoint_sigma_px: not fitted to the edges (or smeared), or
    // still since the previous frame (FrontEndOptions::edge_sigma_min_motion_px).
    std::set<int> coarse;
    std::set<int> edge_fitted;  // tracked with corners fitted to the edges in this frame
    std::set<int> outline_off;  // tracked with its outline off the edges: not reported
  };

  // frontend.cc
  void DecodeTags(const cv::Mat& gray, const FrontEndOptions& o, std::vector<Detection>* dets);
  std::vector<Detection> Detect(const cv::Mat& gray, const FramePrediction& prediction,
                                const std::map<int, Corners>& tracked, const FrontEndOptions& o);
  bool TrackAll(FrameWork* w);
  std::vector<const std::pair<int, Corners>*> PredictedDormant(const FramePrediction& prediction,
                                                               double margin_px) const;
  bool DetectionDue(bool lost_now, const FramePrediction& prediction,
                    const FrontEndOptions& o) const;
  void Vote(ObjectInfo& info, const Detection& d, FrameWork* w) const;
  void Activate(int id, const Corners& corners, const Detection& d, FrameWork* w);
  void Emit(int64_t t_ns, FrameWork* w);

  // association.cc
  int NearBorders(const Vec2& c, const FrontEndOptions& o) const;
  bool AwayFromBorder(const Detection& d, const FrontEndOptions& o) const;
  // Whether two neighbouring corners of D lie within border_margin_px of the same image border:
  // that side may be an inner edge closing an object cut off by the border.
  bool SideAlongBorder(const Detection& d, const FrontEndOptions& o) const;
  int Reidentify(const cv::Mat& gray, const Detection& d, const FramePrediction& prediction,
                 const FrontEndOptions& o, Corners* corners) const;
  void AssociateTags(const std::vector<Detection>& dets, std::vector<bool>* used, FrameWork* w);
  void EndPlainTracksOnTags(const std::vector<Detection>& dets, FrameWork* w);
  void MatchTracks(const std::vector<Detection>& dets, std::vector<bool>* used, FrameWork* w);
  bool ReidentifyAtConfirmation(int id, const Detection& d, FrameWork* w);
  void Correct(int id, const Detection& d, FrameWork* w);
  void StartOrResume(const std::vector<Detection>& dets, const std::vector<bool>& used,
                     FrameWork* w);
  void ReacquirePredicted(FrameWork* w);
};

}  // namespace fsp::frontend
