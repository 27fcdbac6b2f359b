// Front-end accuracy: a run's observations.csv against the rendered sequence's observations_gt.csv.
//
// Matching, per frame (frames: see the end). Estimates are matched to ground-truth objects by
// corner proximity, never by id: d(e, g) = min over the 4 cyclic shifts r of 1/4 Σ_j ‖e_{(j+r) mod
// 4} − g_j‖ [px] (so a detection with its corners in the wrong order is still a detection); pairs
// with d ≤ match_gate_px are taken greedily by increasing d, each row at most once.
//  - recall    = matched fully visible ground-truth rows / fully visible ground-truth rows
//  - precision = matched estimated rows / estimated rows (a match to a partly visible object
//  counts)
//  - corner error of a match: ‖e_j − g_j‖ [px] for j = 1..4 in the files' s1..s4 order (the
//    contract's order: a wrongly ordered detection shows up here and in corner_order_errors);
//    median over all.
//  - id switches: for each ground-truth object, its matches in time order; every change of the
//    matched estimate's object_id between consecutive matches is one switch; summed over objects;
//    id_switches_per_1000 = 1000 · id_switches / matched.
// A tracker's ids are its own, so they are mapped, never compared with ground-truth ids directly:
//  - id map: each estimated object_id -> the ground-truth id it is matched to most often (ties: the
//    smaller ground-truth id).
//  - success: for each ground-truth object, its fully visible rows from the first frame it was
//    matched on (once the tracker has confirmed it); a row succeeds when it is matched and all four
//    corners (files' order) are within success_px. success_rate = success_frames / success_total.
//  - boxes_out_of_view: estimated rows whose id maps to a ground-truth object that has no row at
//  all
//    in that frame (not even partly in view): a box held on an object that is not there.
//    unmatched_est_rows = estimated rows matched to nothing (est_rows − matched).
//  - re-identification: an absence of a ground-truth object is a run of ≥ return_gap_frames
//    consecutive frames of the sequence without a fully visible row of it, after it was matched at
//    least once. Its return is the first match at or after its next fully visible row (before any
//    further absence); it is re-identified when that match's estimated id equals the id of the last
//    match before the absence. Matches during the absence are ignored.
//    reid_rate = reidentified / returns.
// Frames: FRAME_TIMES (the sequence's camera times, e.g. mav0/cam0/data.csv); ground-truth rows
// snap to the nearest of them within time_tolerance_ns, estimated rows to the nearest frame so far;
// a row that snaps to none adds its own time (so without FRAME_TIMES, frames are the union of both
// files' t_ns: frames where neither file has a row are then unknown and absences may look shorter).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fsp/common/observations_io.h"
#include "fsp/eval/stats.h"

namespace fsp::eval {

struct FrontendOptions {
  // Largest mean corner distance of a match [px]; larger tolerates sloppier corners but can pair a
  // detection with a neighbouring object.
  double match_gate_px = 20.0;
  // Estimated row to ground-truth frame [ns] (same clock: 0 suffices).
  int64_t time_tolerance_ns = 1'000'000;
  // Largest corner error of a successful frame [px]; smaller demands sub-pixel tracking, larger
  // forgives drift.
  double success_px = 2.0;
  // Frames without a fully visible row that make an absence; smaller counts brief occlusions as
  // returns, larger only long exits from view.
  int return_gap_frames = 10;
  bool Check(std::string* why) const;
};

// How one ground-truth object was tracked: its matches, the worst of a match's four corner errors
// [px] (median and 90th percentile, numpy's linear interpolation), its success (as above) and the
// estimated ids that matched it. Which objects a front end gets wrong, and by how much.
struct ObjectTracking {
  int gt_id = 0;
  size_t matched = 0;
  double worst_corner_median_px = 0.0;
  double worst_corner_p90_px = 0.0;
  size_t success_frames = 0;
  size_t success_total = 0;
  std::vector<int> est_ids;  // ascending
};

struct FrontendMetrics {
  size_t gt_rows = 0;
  size_t gt_fully_visible = 0;
  size_t est_rows = 0;
  size_t matched = 0;                // estimated rows matched to a ground-truth row
  size_t matched_fully_visible = 0;  // ... whose ground-truth row is fully visible
  std::optional<double> recall;      // absent without fully visible ground truth
  std::optional<double> precision;   // absent without estimated rows
  ErrorStats corner_err_px;          // over 4 × matched corners
  // Signed: each matched corner's error along the ray from its ground-truth quad's centre through
  // it [px]; positive outside (the object drawn too large, e.g. a thin dark frame's outer edge
  // pushed out by its inner one), negative inside. A size bias that corner_err_px does not show.
  ErrorStats corner_outward_px;
  size_t corner_order_errors = 0;  // matches whose best cyclic shift is not the identity
  int id_switches = 0;
  std::optional<double> id_switches_per_1000;  // absent without matches
  size_t frames = 0;                           // frames of the sequence (see above)
  std::map<int, int> id_map;                   // estimated object_id -> ground-truth object_id
  size_t success_frames = 0;
  size_t success_total = 0;
  std::optional<double> success_rate;  // absent when success_total is 0
  size_t boxes_out_of_view = 0;
  size_t unmatched_est_rows = 0;
  size_t returns = 0;
  size_t reidentified = 0;
  std::optional<double> reid_rate;         // absent without returns
  std::vector<ObjectTracking> per_object;  // ground-truth objects with a match, ascending id
  double success_px = 0.0;                 // the options' bound the success counts used
};

// FRAME_TIMES: the sequence's frame times [ns], any order (may be empty, see above).
FrontendMetrics EvaluateFrontend(const std::vector<CornerRow>& gt,
                                 const std::vector<CornerRow>& est, const FrontendOptions& options,
                                 const std::vector<int64_t>& frame_times = {});

}  // namespace fsp::eval
