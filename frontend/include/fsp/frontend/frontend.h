// The front end as one component: images in, object observations (undistorted corners, object id,
// class, score) out. Per frame:
//  1. track: every live object is tracked into the frame (ObjectTracker), its corners predicted
//     through the gyroscope's rotation since the previous frame when the caller knows it;
//  2. detect where needed: the detector (rectangles, AprilTags, or rectangles with AprilTag
//  decoding
//     of the tag-like ones) runs every `detect_every` frames, and on every frame while an object is
//     waiting for confirmation or a track was just lost;
//  3. associate: each detection is matched to a live track by corner distance (a tag by its id); an
//     unmatched detection is compared with the dormant objects (gone from view) by appearance and,
//     where the back end predicts map objects in view, by geometry: a match resumes the old object
//     under its old id (re-identification); otherwise it starts a candidate, which becomes an
//     object (and produces observations) only once detected again in `confirm_detections` detection
//     runs while tracked in between (confirmed in a view clearly sharper than its first, it
//     relearns its side polarities there: `relearn_outline_sharper`). A candidate lost before that
//     is forgotten; a lost object goes dormant. A tag-like rectangle that no tag decoding names
//     only resumes a dormant object by appearance; it starts nothing (a tag's identity is its id).
//  4. emit: one observation per confirmed object tracked in this frame with its four corners in
//  view;
//  5. re-acquire (after 3, before the emission of 4): a dormant object the map predicts wholly in
//     view that no detection resumed is looked for at its predicted corners and resumes there
//     (`reacquire_predicted`); a plain candidate started on it is dropped then
//     (`reacquire_over_candidates`).
//  6. points (`points.enabled`): point features tracked beside the objects (PointTracker), on the
//     same image pyramid as the objects' flow (one per frame), reported apart from the objects.
//
// Identities: an AprilTag's id is its object id; plain rectangles get ids from `first_rect_id` up,
// never reused. Classes: the most frequent class guess of an object's detections.
// Deterministic for the same frames and predictions. Not thread-safe.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "fsp/common/camera.h"
#include "fsp/common/types.h"
#include "fsp/frontend/apriltag_detector.h"
#include "fsp/frontend/detection.h"
#include "fsp/frontend/object_tracker.h"
#include "fsp/frontend/point_tracker.h"
#include "fsp/frontend/rect_detector.h"

namespace fsp::frontend {

enum class DetectorKind {
  kRect,      // rectangles; tag-like ones decoded as AprilTags (then the tag id is the identity)
  kAprilTag,  // AprilTags only
};
const char* ToString(DetectorKind kind);  // "rect", "apriltag"
bool ParseDetectorKind(const std::string& name, DetectorKind* kind);

struct FrontEndOptions {
  DetectorKind detector = DetectorKind::kRect;
  // Run the detector every this many frames when all is quiet [frames]. 1: every frame (most
  // robust, ~4 ms per 640x480 frame); larger: cheaper, new objects are picked up later.
  int detect_every = 3;
  // A new object is confirmed (and reported) once detected in this many detection runs while being
  // tracked in between. Higher: fewer false objects from stray detections, a later start.
  int confirm_detections = 2;
  // ...within this many frames of its start; a candidate still unconfirmed then is forgotten (a
  // stray detection, and while a candidate waits the detector runs on every frame) [frames].
  int confirm_within_frames = 10;
  // A candidate whose quad and an unmatched detection's overlap (each holds the other's centre,
  // areas within 2x) but are too far apart to match is replaced by the detection (which keeps its
  // votes and may re-identify a dormant object): the candidate was started from a wrong outline
  // (closed by an inner edge at the image border) that its track keeps following.
  bool replace_candidates = true;
  // A plain detection with a corner within `border_margin_px` of the image border does not confirm
  // a candidate (it may be an outline closed by an inner edge, the object's side just out of view);
  // the next one away from the border does.
  bool confirm_away_from_border = true;
  // A candidate about to be confirmed is first compared with the dormant objects (as an unmatched
  // detection is): one that is a returning object takes its old id instead of a new one. A
  // returning object is mostly first detected at the border as it comes into view, where its
  // outline is not trusted for re-identification.
  bool reid_at_confirmation = true;
  // A plain detection touching the border (`border_margin_px`) does not resume a dormant object:
  // its outline may be closed by an inner edge (a door's leaf while its frame is still out of
  // view), and the resumed track would follow that edge. It starts a candidate, which takes the
  // old id when confirmed away from the border (reid_at_confirmation). Default room from pixels,
  // render seeds 1/2/3: ATE 0.51/0.32/0.72 -> 0.38/0.35/0.57 cm, the same 53 of 54 returns
  // re-identified (frontend/README.md, "Returning at the border").
  bool reid_away_from_border = true;
  // The detector also runs on every frame where the back end predicts a dormant object wholly in
  // view, so that a returning object is re-identified in its first frame back in view.
  bool detect_on_predicted_return = true;
  // The detector does not search inside the confirmed objects being tracked: the inside of each
  // (its corners moved towards the centre by this fraction of its shortest side, at least 4 px)
  // is masked out of its edge image, so a window's panes, a door's panels and a poster's print
  // cost no hypotheses while the outline itself is still found. 0 searches everywhere.
  double detect_skip_tracked_frac = 0.1;
  // A detection matches a live track when their mean corner distance (best cyclic shift) is below
  // this fraction of the track's shortest side (at least 3 px). Larger tolerates worse tracks but
  // can steal a neighbour's detection.
  double match_gate_frac = 0.15;
  // Re-identification: least appearance similarity (NCC, see ObjectTracker::Similarity) of a new
  // detection with a dormant object for it to be that object again [-1, 1]. Lower re-identifies
  // more readily, at the risk of two look-alike objects (a row of identical doors) being merged.
  double reid_min_similarity = 0.8;
  // ...and it must beat every other dormant object's similarity by this much [-]: of two look-alike
  // objects neither is taken (the detection starts a new object rather than risk a wrong identity).
  double reid_min_margin = 0.1;
  // ...and when the back end predicts the dormant object in view: the largest mean corner distance
  // from that prediction [fraction of the predicted quad's shortest side] for a match on geometry,
  // which then needs `reid_min_similarity_predicted` (only for a detection away from the border:
  // one touching it may be an outline closed by an inner edge, and needs the plain bar). Measured
  // on the default room from pixels (window, seed 1, with reid_at_confirmation): 0.8 re-identifies
  // 49/54 returns, 7 id switches, ATE 0.85 cm; 0.7: 52/54, 4 switches, but ATE 1.02 cm (every
  // identity right: the window estimator takes the extra loop closures less well). Before the
  // border rule, 0.7 (and 0.6) made one wrong identity in test_apps_pixels' batch run (a window's
  // outline closed at the border re-identified as its look-alike: width error 0.47 -> 1.9 cm).
  double reid_gate_frac = 0.5;
  double reid_min_similarity_predicted = 0.8;
  // ...and the detection's shape may differ from the prediction's by at most this [px]
  // (ShapeDifference: the largest corner difference once the mean offset is removed; a drifting
  // map moves the whole quad, a detection closed by an inner edge moves one side). On the hall
  // flight from pixels a door coming back at the image border was resumed on an outline closed
  // 12 px inside its true side (shape 7.8 px off the prediction) and held there for 9 s. Measured
  // over the resumed detections near a prediction (room, hall flight, ten objects): 0.1-3.7 px
  // when the outline is whole, 6.0-7.8 px and more when not. 0: off.
  double reid_max_shape_px = 5.0;
  // ...and a dormant object whose prediction lies further than this from the detection [fraction of
  // the predicted quad's shortest side] is not that detection, whatever it looks like (a look-alike
  // window elsewhere). Larger tolerates more drift of the online estimate.
  double reid_reject_frac = 2.0;
  // ...and of two look-alikes the one the map predicts at the detection is taken when the other is
  // not predicted there (the margin rule above is then not applied).
  bool reid_map_decides = true;
  // ...and once the map is known, a dormant object is re-identified only where the map predicts it
  // (within reid_gate_frac): a look-alike of another shape whose prediction lies within
  // reid_reject_frac (a framed cabinet beside a framed door on the same wall) is not taken. Default
  // room from pixels, seeds 1/2/3: id switches 3/3/4 -> 1/2/2, returns 51/52/52 -> 53/53/53 of 54,
  // boxes out of view 3/0/0 -> 0. false: a detection away from the border is also compared by
  // appearance with dormant objects predicted up to reid_reject_frac from it.
  bool reid_only_where_predicted = true;
  // Once the map is known, a dormant object the back end predicts wholly in view (corners at least
  // reacquire_margin_px inside the image, clear of live objects) that no detection resumed is
  // looked for at its predicted corners: refined on the edges (ObjectTracker::Reacquire), within
  // reid_gate_frac of the prediction and with an appearance of at least
  // reid_min_similarity_predicted, it resumes there under its old id. Where no edge is found (a
  // thin frame blurred on a small view), at the predicted corners when the appearance there passes
  // the same bar, reporting from the next frame (the prediction is no measurement). A returning
  // object the detector does not report (a poster narrower than its minimum side) is picked up.
  bool reacquire_predicted = true;
  // [px] How far inside the image the predicted corners must be for the re-acquisition. Not
  // border_margin_px: that guards against a detection's outline closed by an inner edge at the
  // border, which a map prediction is not; a returning object was left waiting a frame with a
  // corner 3 px from the border (the blur clip's tag 30) until the detector found it further in.
  double reacquire_margin_px = 2.0;
  // A plain candidate (not confirmed, not a tag) where such an object is predicted is that object
  // seen anew more often than another object: it does not count as a live object there, and is
  // dropped when the dormant object resumes.
  bool reacquire_over_candidates = true;
  // A candidate confirmed in a view at least this many times as sharp as the one it was started
  // from (ObjectTracker::RelearnOutline: a candidate started in a smear, whose side polarities are
  // the smear's) has its polarities relearnt there. 0: off.
  double relearn_outline_sharper = 1.25;
  // A detection matched to a track whose corners differ from the track's by more than this (largest
  // corner distance) [px] replaces the track's corners (the tracker resumes from them, keeping its
  // model): the detector's corners are the better measurement, and a track that slid onto a nearby
  // edge (a window's inner frame) is put back. Larger trusts the tracker more.
  double correct_px = 2.0;
  // The corner noise each observation reports (ObjectObservation::sigma_px) [px]: corners fitted to
  // the object's edges (the tracker's edge refinement, a detection) and corners the keypoints'
  // homography carried alone (no edges found, or smeared by motion); 0: the estimator's own
  // (estimator.factor.sigma_px, 1 px). Fitted corners are better than 1 px (median error 0.11 px on
  // the default room, 0.2 px on the hall flight) but their errors are shared between consecutive
  // frames (a track follows its own edges), so not the residuals' scale; 0.5 px measured best of
  // 0.35 / 0.5 / 1 on the rendered scenes (backend/README.md, "The robust loss").
  double edge_sigma_px = 0.5;
  double keypoint_sigma_px = 1.0;
  // Fitted corners that moved less than this since the previous frame [px] get keypoint_sigma_px:
  // on a still image the refinement finds the same edges again, so its error repeats from frame to
  // frame instead of averaging out (a camera standing still would otherwise measure an object's
  // depth from its vibration). 0: never.
  double edge_sigma_min_motion_px = 0.5;
  // ...unless a corner of the detection lies within this of the image border [px]: there the
  // detector may have closed the quad with an inner edge (the object's side just out of view). Such
  // a detection still corrects a track whose corners were not fitted to the edges in this frame
  // when none of its sides runs along the border (two neighbouring corners within this of the same
  // border): a poster whose corner touches the top of the frame after a fast move, tracked 8 px off
  // by its keypoints alone, is put back.
  double border_margin_px = 8.0;
  // A decoded AprilTag matched to its live track puts the track onto the tag's corners the same way
  // (more than correct_px off; the decoder's corners are exact, the border does not matter).
  bool correct_tags = true;
  // DetectorKind::kRect: the whole frame is also scanned for AprilTags every this many frames (at a
  // frame where the rectangle detector runs) [frames]: tags too small for the rectangle detector's
  // minimum side are found this way. 0: never (tags then come only from tag-like rectangles).
  int tag_scan_every = 6;
  // AprilTag decoding of tag-like rectangles (DetectorKind::kRect): the crop around the rectangle
  // passed to the AprilTag detector extends past its bounding box by this fraction of its size.
  double tag_crop_margin_frac = 0.3;
  // Ids of plain rectangles start here (AprilTags keep their ids, tag36h11 has 587: 0..586).
  int first_rect_id = 1000;
  // A tracked object partly out of the image is reported through the corners inside it
  // (ObjectObservation::seen) when they are at least this many (2..4; 4: whole objects only). The
  // tracker follows an object until less than tracker.min_visible of it is in the image.
  int min_visible_corners = 2;
  RectDetectorOptions rect;
  AprilTagDetectorOptions apriltag;
  ObjectTrackerOptions tracker;
  // Point features (step 6); `points.enabled` turns them on.
  PointTrackerOptions points;
  bool Check(std::string* why) const;
};

struct FrontEndResult {
  std::vector<ObjectObservation> observations;  // confirmed objects tracked in this frame
  std::vector<PointObservation> points;         // live point features (points.enabled), by id
  StageTimes times;       // "track" (with the frame's pyramid), "detect", "associate", "points"
  bool detected = false;  // the detector ran on this frame
  int detections = 0;
  int candidates = 0;    // unconfirmed objects being tracked after this frame
  int started = 0;       // objects confirmed in this frame
  int reidentified = 0;  // dormant objects resumed in this frame
  int corrected = 0;     // tracks put onto a detection's corners
  int lost = 0;          // objects lost in this frame
};

class FrontEnd {
 public:
  using Options = FrontEndOptions;

  // `camera`: calibration of every frame (undistortion of the output; the sizes must match). Throws
  // InputError for an unknown AprilTag family; FSP_CHECKs the other options (check them first).
  FrontEnd(const PinholeRadtan& camera, Options options = Options());
  ~FrontEnd();
  FrontEnd(const FrontEnd&) = delete;
  FrontEnd& operator=(const FrontEnd&) = delete;

  // One frame (8-bit grey, the calibration's size; InputError otherwise) and what the caller
  // predicts for it. Frames in time order.
  FrontEndResult Process(const Frame& frame, const FramePrediction& prediction = {});

  // Class of an object (the most frequent guess so far), kUnknown for an unknown id.
  ObjectClass ClassOf(int object_id) const;
  const Options& options() const { return options_; }

 private:
  struct Impl;
  Options options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fsp::frontend
