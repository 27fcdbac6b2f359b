// Point features beside the objects: corners tracked from frame to frame for the visual-inertial
// estimator (frontend/README.md, "Point features"; after VINS-Mono's feature tracker, OpenVINS's
// TrackKLT and Basalt's frame-to-frame flow).
//
// Per frame (Track):
//  1. flow: every live point is followed by pyramidal Lucas-Kanade from the previous frame, started
//     where the gyroscope's rotation puts it (the infinite homography K R_Ccur_Cprev K^-1 in
//     undistorted pixels), and checked backwards (the flow from the new position back to the
//     previous frame must land within max_fb_error_px of where the point was);
//  2. geometry: the survivors must agree on one camera motion. With the gyroscope's rotation, a
//     2-point RANSAC on the translation's direction (the epipolar constraint with that rotation,
//     on normalised undistorted coordinates); without it, or when that leaves points out, a
//     RANSAC fundamental matrix on undistorted pixels, the larger consensus kept;
//  3. spread: the points are visited oldest first (a long track is worth most); one closer than
//     min_distance_px to a point kept, or in a grid cell already holding cell_overflow times
//     cell_capacity() points, is dropped;
//  4. detection: when fewer than refill_fraction of max_points() are live, Shi-Tomasi corners are
//     added in the cells short of points (the neediest first, each up to its share, then up to
//     what a cell may hold), away from the live points, until max_points() are live. New points get
//     the next id (never reused) and age 0.
//
// Pixels: the tracker works on the image as stored (distorted), on the pyramid level no wider than
// max_image_width_px (1280x720: level 1, 640x360); the options' pixel sizes are that level's. Its
// output is in undistorted full-resolution pixels through the camera given at construction.
// Deterministic: the same frames and rotations give the same ids and positions. Not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/types.h"
#include "fsp/frontend/detection.h"
#include "fsp/frontend/flow_pyramid.h"

namespace fsp::frontend {

struct PointTrackerOptions {
  // The FrontEnd tracks points (FrontEndResult::points) only when this is set; the PointTracker
  // itself ignores it.
  bool enabled = true;
  // The tracker works on the first pyramid level no wider than this [px]: a 1280x720 camera is
  // tracked at 640x360, where the flow survives blur better (the DM-VIO walk's first 10 s: 54 %
  // of the points kept per frame at full resolution, 82-87 % at half) at a quarter of the cost.
  int max_image_width_px = 800;
  // Live points wanted in a 640x480 working image, scaled with its area (640x360: 113) [points].
  // More: more constraints for the estimator, linear cost in the flow.
  int max_points = 150;
  // Side of the grid's cells [px]; each cell holds at most cell_capacity() points (the wanted
  // points over the cells, rounded up). Smaller: a more even spread, but textureless cells then
  // leave more of the wanted points undetected.
  int cell_px = 80;
  // A cell may hold more than its share when other cells have no texture (their search found no
  // corner): the wanted points are shared among the cells that have, up to this many times the
  // share (detection fills every cell to its share first). A room of plain walls has its texture
  // in a few cells (DM-VIO walk, 640x360: 28 points live at 1x, 63 at 4x).
  double cell_overflow = 4.0;
  // Least distance between two live points [px]; of two closer ones the younger is dropped (and
  // no new point is detected closer to a live one). Larger: points spread further, but converging
  // points (the camera backing away) end tracks sooner.
  double min_distance_px = 15.0;
  // New points are detected only while fewer than this fraction of max_points() are live (0..1]:
  // 1 tops up every frame, lower detects less often (the detector is the costliest stage).
  double refill_fraction = 0.9;
  // A cell where detection found no corner is not searched again for this many frames (a plain
  // wall would be searched in vain on every frame) [frames].
  int empty_cell_retry_frames = 5;
  // Least gradient of a new point's weaker structure direction [grey levels / px, rms over 5x5]
  // (and at least 1 % of the strongest corner in its cell). Lower: more points on faint texture,
  // which the flow follows less well: on the default room (faint wall texture, 2 grey levels of
  // pixel noise; 4 s from 2 s) 4 gives ~28 live points with 0.30 / 0.82 px drift (median / p90
  // over the tracked views), 3 ~51 with 0.36 / 1.45 px, 2 all 150 with 0.64 / 2.75 px (points on
  // edges with faint texture across them slide along the edge).
  double min_corner_gradient = 4.0;
  // The same, for a cell where min_corner_gradient found no corner: it gets up to its share of
  // points on fainter texture (Basalt lowers its FAST threshold per cell the same way). Without
  // them a camera facing a plain wall has no point for seconds and the estimator dead-reckons
  // (the default room without objects, seed 2: 7 s without a point, ATE 3.7 m; with them 13 cm).
  // 0: off.
  double faint_corner_gradient = 2.0;
  // ...only while the first threshold leaves fewer than this fraction of max_points() live: where
  // there is texture enough the points stay on it (faint points drift about twice as much).
  double faint_below_fraction = 0.1;
  // Their pixel noise relative to the others' (PointObservation::sigma_scale, the estimator's
  // weight): on the default room a faint point drifts 0.92 / 3.3 px (median / p90 over its views)
  // against 0.29 / 0.80 px.
  double faint_sigma_scale = 4.0;
  // A new point is moved onto its corner's vertex (cv::cornerSubPix over a window of 2 x this + 1
  // px, kept when it moves at most this far) [px]; 0: off (the Shi-Tomasi pixel). The flow's
  // translation-only window drifts with the view's deformation by the point's offset from the
  // structure it locks onto; at the vertex that offset is ~0: on the default room (gradient 6)
  // drift p90 1.92 -> 0.80 px.
  int subpixel_px = 3;
  // Points (new and tracked) stay at least this far inside the image border [px].
  double border_px = 4.0;
  // LK window [px] (odd; at most the shared pyramid's padding) and pyramid levels above the full
  // image (3: motion up to ~60 px per frame beyond the prediction). Larger windows: steadier on
  // faint texture but slower (quadratic) and drifting more as the view deforms the patch (default
  // room, 4 s: drift median 0.42 / 0.51 / 0.71 px at 11 / 15 / 21 px before subpixel_px). 11 is
  // the object tracker's: the shared pyramid then needs no more padding.
  int lk_window = 11;
  int lk_levels = 3;
  // LK iterations per level (stops earlier below 0.01 px of update). 20 costs ~15 % more time for
  // the same drift on the default room.
  int lk_iterations = 10;
  // Forward-backward error above which a point is dropped [px] (Basalt: 0.2). Lower: fewer wrong
  // matches (patches whose pattern changes: 34 / 19 / 9 of 111 pass at 0.5 / 0.25 / 0.1), shorter
  // tracks under noise and blur (the default room's 4 s: 209 / 224 / 247 tracks).
  double max_fb_error_px = 0.25;
  // Epipolar inlier distance of the geometry check [undistorted px]. Lower: stricter, more good
  // points lost to the flow's own noise.
  double ransac_px = 1.0;
  // RANSAC confidence (stops once an all-inlier sample was drawn with this probability) and cap
  // on its draws.
  double ransac_confidence = 0.99;
  int ransac_max_iterations = 200;
  // Use the gyroscope's rotation (when given): as the flow's initial guess and as the rotation of
  // the 2-point RANSAC. Off: no prediction, the fundamental-matrix RANSAC always.
  bool use_rotation_prior = true;
  uint32_t seed = 1;  // seeds the 2-point RANSAC's draws (reset every frame: deterministic)
  bool Check(std::string* why) const;
};

// One frame's outcome.
struct PointTrackerResult {
  std::vector<PointObservation> points;  // live points in this frame, by id
  std::vector<Vec2> points_px;           // the same in the image as stored (distorted px)
  int tracked = 0;             // points carried from the previous frame (after every check)
  int lost_flow = 0;           // lost by the flow: not converged, left the image, forward-backward
  int lost_geometry = 0;       // rejected by the RANSAC (not on the camera's motion)
  int dropped_spread = 0;      // dropped for the spread (too close to an older point, cell full)
  int detected = 0;            // new points
  bool used_rotation = false;  // the geometry check used the gyroscope's rotation (2-point RANSAC)
  StageTimes times;            // "flow", "geometry", "detect"
};

class PointTracker {
 public:
  using Options = PointTrackerOptions;

  // `camera`: the calibration of every frame. Throws InputError on bad options or camera.
  PointTracker(const PinholeRadtan& camera, Options options = Options());
  ~PointTracker();
  PointTracker(const PointTracker&) = delete;
  PointTracker& operator=(const PointTracker&) = delete;

  // One frame (its flow pyramid, padded for at least lk_window; the calibration's size, else
  // InputError), frames in time order. R_Cprev_Ccur: the camera's rotation since the previous
  // frame (gyroscope), when known.
  PointTrackerResult Track(const FlowPyramid& frame, int64_t t_ns,
                           const std::optional<Mat3>& R_Cprev_Ccur = std::nullopt);
  // The same, building the frame's pyramid.
  PointTrackerResult Track(const cv::Mat& gray, int64_t t_ns,
                           const std::optional<Mat3>& R_Cprev_Ccur = std::nullopt);

  // max_points scaled with the image area, the grid (cells across and down) and the most points
  // a cell holds.
  int max_points() const;
  cv::Size grid() const;
  int cell_capacity() const;
  // The grid cell (index row * grid().width + column) of a distorted full-resolution pixel inside
  // the image.
  int CellOf(const Vec2& px) const;
  const Options& options() const { return options_; }
  // The pyramid level it works on and the levels a shared pyramid must hold for it (that level
  // plus lk_levels above it).
  int working_level() const;
  int pyramid_levels() const;

 private:
  struct Impl;
  Options options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fsp::frontend
