// Multi-object rectangle tracker, CMT in spirit (Nebehay & Pflugfelder, "Consensus-based Matching
// and Tracking of Keypoints for Object Tracking", WACV 2014), but made for planar rectangles: the
// output is the object's four corners, not a box.
//
// Model of one object (built by Start from one view): keypoints inside its quad with binary
// descriptors, stored in object-plane coordinates (through the homography of its corners), and a
// reference view (the image warped into a fronto-parallel patch of the object) for the appearance
// check.
//
// Per frame (Track): forward-backward pyramidal optical flow of each object's keypoints from the
// previous frame, plus descriptor matching against the model where flow is short of points;
// consensus by a robust homography fit (object plane -> image; a rectangle is planar, so its
// corners follow exactly); the corners refined on the image edges with the detector's refinement
// (edge_refine.h), unless the object's sides are smeared by its motion (blur_sharpness_ratio: the
// keypoints' corners then stand); where keypoints are few (a plain door), the predicted quad
// (caller's prediction, or the last motion) refined on the edges carries the corners. Last, the
// appearance check: the frame warped into the reference view through the new homography is compared
// with the reference patch by normalised cross-correlation; below `min_appearance` the object is
// reported lost, so no corners are reported for an object that is not there.
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
#include "fsp/frontend/flow_pyramid.h"
#include "fsp/frontend/rect_detector.h"

namespace fsp::frontend {

struct ObjectTrackerOptions {
  // --- model (Start) ---
  // Longest side of the object part of the reference patch [px of the patch]; the other side
  // follows the quad's aspect. Larger: finer appearance check, slower warp.
  int patch_size = 48;
  // Ring of the surroundings included in the reference patch on each side [fraction of the
  // object's width / height]. A plain object (a white door) has no structure of its own: its
  // outline against the surroundings is what the appearance check compares. 0: the object only.
  double appearance_margin = 0.125;
  // Quads with a side shorter than this are not started [px].
  double min_side_px = 16.0;
  // Descriptors of the model (ORB in the quad at Start), matched when optical flow loses the
  // object (fast motion). More: better recovery, slower recovery frames.
  int model_keypoints = 300;
  // --- optical flow ---
  // Flow points kept per object (Shi-Tomasi corners inside the quad plus its four corners). More:
  // a steadier consensus, linear cost.
  int max_points = 50;
  // Least gradient of a flow point's weaker structure direction [grey levels / px, rms over 5x5].
  // Below, pixel noise on a plain surface would be taken for texture.
  double min_corner_gradient = 4.0;
  // LK window [px] and pyramid levels above the full image (level 3: motion up to ~60 px/frame
  // beyond the prediction).
  int lk_window = 11;
  int lk_levels = 3;
  // LK iterations per level (stops earlier below 0.03 px of update). Fewer: faster, less accurate
  // under large prediction errors.
  int lk_iterations = 10;
  // Forward-backward error above which a flow point is dropped [px].
  double max_fb_error_px = 1.0;
  // Descriptor matching runs when fewer than this fraction of the points tracked into the frame
  // survive the flow (and the model has descriptors).
  double recover_fraction = 0.5;
  // Lowe's ratio of the best to the second best Hamming distance for a model match.
  double match_ratio = 0.8;
  // --- consensus ---
  // RANSAC inlier distance of the object-plane -> image homography [undistorted px].
  double ransac_px = 2.0;
  // Inliers for a keypoint homography to be trusted on its own [points]; with fewer (a plain
  // object) the prediction refined on the edges carries the corners, and an object whose edges are
  // not found either is lost.
  int min_inliers = 10;
  // --- edge refinement ---
  // Edge refinement of the tracked corners (the detector's refinement options are used).
  RectDetectorOptions refine;
  // Edge search of a first, coarse refinement pass when the keypoints did not fix the quad (a plain
  // object moving on the prediction) [px]; the fine pass (refine.search_px) follows. Larger: more
  // capture range, more risk of jumping to a parallel edge (the side's polarity guards).
  double coarse_search_px = 6.0;
  // Least edge gradient for an edge point [grey levels / px].
  double min_edge_gradient = 3.0;
  // With a trusted keypoint homography, edge-refined corners are kept only when no corner moved
  // more than this from the homography's [px] (a side caught by a nearby edge is refused).
  double max_refine_shift_px = 2.0;
  // Motion blur: a side smeared by the motion has its edge towards the smear's end, not at the
  // object's outline (a thin dark frame smeared over 13 px: ~4 px outside), and the detector finds
  // it there too. A side is smeared when it moved more than 8 px across itself since the last frame
  // and its sharpness (the median, along it, of the largest grey-level step over 1 px across it,
  // either polarity, within 10 px) is below this fraction of its sharpest view so far (decaying by
  // 2 % per frame, so that slow changes of light and background follow). A side that only loses
  // contrast (a thin frame thinning with the view, its outer edge fading into its inner one) keeps
  // the step of its other edge. The object is then blurred in that frame: a trusted keypoint
  // homography keeps its corners (the flow follows the smeared texture's centre) and a detection
  // does not correct the track. Without a trusted homography (few keypoints agree: a plain object,
  // or the first frame of a fast turn) the smeared edges are not used either (at the start of the
  // blur clip's turns they put the corners 3-8 px off): the object is looked for as in a fast move
  // (fast_align_*) or lost, and found again once the motion slows. 0: off.
  double blur_sharpness_ratio = 0.5;
  // In a blurred frame the flow drifts (the smear changes the texture it follows, frame after
  // frame: a poster through 1 s of zoom under blur drifted 2 -> 6 px). Its homography is then
  // aligned to the reference patch (Gauss-Newton on the quad's corners, normalised residuals of the
  // warped frame: a sharp reference against a symmetric smear is matched at the smear's centre,
  // where the ground truth of a frame exposed around its timestamp is) when the flow's homography
  // matches the reference by at least this NCC (a periodic object far off, a window matched a pane
  // away, is left alone), and the object's points then follow the aligned homography. 0: off.
  double blur_align_min_appearance = 0.85;
  // The alignment is kept only when it moves no corner further than this [px] (a jump is the
  // alignment finding another optimum, not the flow's drift).
  double blur_align_max_shift_px = 5.0;
  // When that alignment is refused, the flow on the smear holds the homography's perspective and
  // roll poorly (the blur clip's poster in a vertical dash: one corner 6-15 px off, the others
  // within 2). The prediction (the last quad turned by the gyroscope's rotation) has the shape:
  // it is scaled and shifted onto the flow's inliers (least squares) and replaces the flow's
  // homography when it matches the reference better.
  bool blur_shape_from_prediction = true;
  // Fast motion: an object the keypoints lose while its predicted corners move at least
  // `fast_align_min_motion_px` since the previous frame (a fast turn smears it over tens of pixels,
  // where neither the flow nor the sharp reference can follow) is looked for at the prediction: the
  // reference patch smeared along the predicted motion (the exposure's share of the frame interval
  // taken from 0.25 / 0.5 / 0.75 / 1, whichever matches best) is aligned to the frame from there.
  // It is kept when no corner moves further than `fast_align_max_shift_px` and the smeared
  // reference then matches the frame by `fast_align_min_ncc`. The gyroscope's prediction of a
  // rotation is good to a pixel, but translation is not in it. 0 (min motion): off.
  double fast_align_min_motion_px = 15.0;
  double fast_align_max_shift_px = 5.0;
  double fast_align_min_ncc = 0.9;
  // --- outline check ---
  // Keypoints can slide off an object while the appearance check still passes: on a glossy
  // screen they follow the reflections, which move with the viewpoint (seen on the DM-VIO walk:
  // the quad seconds off its screen, tens of px into the wall). So the object's sides must stay on
  // the image's edges: a side is supported when at a third or more of 9 places along its middle
  // the grey level changes across it by at least min_edge_gradient per px within outline_px of it
  // (either polarity; a smeared edge is a ramp without a peak) [px of the image scaled to 640 px
  // on its longer side: 3 px on a 1280 x 720 frame, whose corners the detector finds at half
  // size]. An object whose outline is known with two or more of its sides in view unsupported is
  // not reported in that frame (outline_off); after max_unsupported_frames sharp frames in a row
  // so, it is lost (the detector finds it again where it is). Rendered scenes from pixels (room,
  // hall, paper flight, hand-held walk, blur clip): no frame so; the walk's sliding screens: up to
  // a dozen frames in a row (frontend/README.md, "Outline check"). 0: off.
  double outline_px = 1.5;
  int max_unsupported_frames = 8;
  // --- appearance check ---
  // Appearance check: least normalised cross-correlation between the reference patch and the frame
  // warped into it through the tracked homography [-1, 1]. Measured on synthetic sequences: right
  // homographies >= 0.97 (0.79 with part of the object covered by another), another object at the
  // same corners -0.06. Higher: loses occluded or blurred objects sooner.
  double min_appearance = 0.7;
  // Least fraction of the reference patch that must be in the image; below, the object is lost
  // (it is leaving the view).
  double min_visible = 0.6;
  // --- refresh ---
  // Every this many frames, on a confident frame (appearance >= refresh_appearance and edge-refined
  // or a trusted homography), new flow points are found inside the tracked quad [frames].
  int refresh_every = 8;
  double refresh_appearance = 0.85;
  bool Check(std::string* why) const;
};

// One object's outcome in one frame.
struct TrackedObject {
  int id = -1;
  bool tracked = false;         // false: lost in this frame (moved to the dormant models)
  Corners corners_undistorted;  // s1..s4, undistorted px (valid when tracked)
  Corners corners_px;           // s1..s4, distorted image px (valid when tracked)
  int keypoints = 0;            // consensus size (homography inliers)
  bool in_view = false;         // all four corners inside the image (valid when tracked)
  CornerMask seen{};            // which corners are inside the image (valid when tracked)
  bool recovered = false;       // descriptor matching against the model was run in this frame
  bool edge_refined = false;    // corners came from the edge refinement
  bool blurred = false;         // its sides are smeared in this frame (blur_sharpness_ratio)
  bool aligned = false;         // corners from the alignment to the reference (blur_align_*)
  bool fast = false;         // lost by the keypoints in a fast move, found by the smeared reference
  bool outline_off = false;  // two or more sides in view off the image's edges (outline check)
  double appearance = 0.0;   // NCC of the appearance check
  double score = 0.0;        // confidence in [0, 1]
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
  // leaves the image (nothing is started). The side polarities the object's edges are refined with
  // later are found on `gray` with either polarity per side; where that fails (a thin frame offers
  // both, and a fit that mixes them is refused), `side_sign` (optional, per side as
  // EdgeRefinement::side_sign, e.g. Detection::side_sign) is tried.
  bool Start(int id, const cv::Mat& gray, const Corners& corners_undistorted,
             const std::array<int, 4>& side_sign = {0, 0, 0, 0});

  // Tracks every active object into `gray`. `predicted` (optional) holds predicted corners per id
  // (undistorted px), e.g. the previous corners moved by the IMU's rotation; without an entry the
  // tracker predicts from its own motion. Returns one entry per object active before the call; an
  // object that is lost becomes dormant (its model kept for Similarity and Resume).
  std::vector<TrackedObject> Track(const cv::Mat& gray,
                                   const std::map<int, Corners>& predicted = {});
  // The same on a frame whose flow pyramid the caller built (BuildFlowPyramid, shared with other
  // trackers: the FrontEnd's one pyramid per frame): padded for at least lk_window, its first
  // lk_levels levels used. The same results as Track(frame.image, predicted).
  std::vector<TrackedObject> Track(const FlowPyramid& frame,
                                   const std::map<int, Corners>& predicted = {});

  // Appearance of candidate corners (undistorted px, s1..s4) in `gray` against object `id`'s model
  // (active or dormant): the NCC of the appearance check [-1, 1] (-1 when less than min_visible
  // of the patch is in view or the quad is not convex), or nullopt for an unknown id.
  // Used to re-identify a returning object.
  std::optional<double> Similarity(int id, const cv::Mat& gray, const Corners& corners) const;

  // Where object `id` (its model, active or dormant) is near corners the caller predicts
  // (undistorted px, s1..s4, e.g. the map projected): those corners refined on the image's edges (a
  // coarse pass, then the fine one, with the side polarities learnt at Start: the detector's
  // refinement) into `corners`, and the appearance check there (as Similarity) into `similarity`.
  // Returns false for an unknown id, a quad not wholly in the image, or edges not found. Used to
  // pick up a returning object the detector does not report (too small, say). With `motion` (the
  // predicted corners' motion since the previous frame) of at least fast_align_min_motion_px, the
  // object is first looked for as in a fast move (fast_align_*: its reference smeared along the
  // motion, `similarity` then the smeared reference's NCC, and `smeared` true), and on the edges
  // when not found so.
  bool Reacquire(int id, const cv::Mat& gray, const Corners& predicted, Corners* corners,
                 double* similarity, const Corners* motion = nullptr, bool* smeared = nullptr);

  // Makes a dormant (or active) object active again at `corners` in `gray` (the frame last given to
  // Track), keeping its model (re-identification). Returns false for an unknown id.
  bool Resume(int id, const cv::Mat& gray, const Corners& corners_undistorted);

  // Relearns object `id`'s side polarities at `corners` (undistorted px) in `gray` (the frame last
  // given to Track) when this view is at least `min_sharper` times as sharp as the one it was
  // started from (summed SideSharpness of the four sides): an object started in a smeared view has
  // the smear's polarities, on which its edges are then never found again. The track keeps its
  // corners. Returns whether the polarities were relearnt (false for an unknown id, a view not
  // sharper, or edges not found on all four sides).
  bool RelearnOutline(int id, const cv::Mat& gray, const Corners& corners_undistorted,
                      double min_sharper);

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
