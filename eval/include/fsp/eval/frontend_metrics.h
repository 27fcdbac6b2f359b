// Front-end accuracy: a run's observations.csv against the rendered sequence's observations_gt.csv.
//
// Matching, per frame (estimated rows belong to the ground-truth frame nearest in time, within
// time_tolerance_ns; others match nothing). Estimates are matched to ground-truth objects by corner
// proximity, never by id: d(e, g) = min over the 4 cyclic shifts r of 1/4 Σ_j ‖e_{(j+r) mod 4} − g_j‖ [px]
// (so a detection with its corners in the wrong order is still a detection); pairs with d ≤ match_gate_px
// are taken greedily by increasing d, each row at most once.
//  - recall    = matched fully visible ground-truth rows / fully visible ground-truth rows
//  - precision = matched estimated rows / estimated rows (a match to a partly visible object counts)
//  - corner error of a match: ‖e_j − g_j‖ [px] for j = 1..4 in the files' s1..s4 order (the contract's
//    order: a wrongly ordered detection shows up here and in corner_order_errors); median over all.
//  - id switches: for each ground-truth object, its matches in time order; every change of the matched
//    estimate's object_id between consecutive matches is one switch; summed over objects.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fsp/common/observations_io.h"
#include "fsp/eval/stats.h"

namespace fsp::eval {

struct FrontendOptions {
  double match_gate_px = 20.0;  // largest mean corner distance of a match [px]; larger tolerates sloppier corners
                                // but can pair a detection with a neighbouring object
  int64_t time_tolerance_ns = 1'000'000;  // estimated row to ground-truth frame [ns] (same clock: 0 suffices)
  bool Check(std::string* why) const;
};

struct FrontendMetrics {
  size_t gt_rows = 0;
  size_t gt_fully_visible = 0;
  size_t est_rows = 0;
  size_t matched = 0;                 // estimated rows matched to a ground-truth row
  size_t matched_fully_visible = 0;   // ... whose ground-truth row is fully visible
  std::optional<double> recall;       // absent without fully visible ground truth
  std::optional<double> precision;    // absent without estimated rows
  ErrorStats corner_err_px;           // over 4 × matched corners
  size_t corner_order_errors = 0;     // matches whose best cyclic shift is not the identity
  int id_switches = 0;
};

FrontendMetrics EvaluateFrontend(const std::vector<CornerRow>& gt, const std::vector<CornerRow>& est,
                                 const FrontendOptions& options);

}  // namespace fsp::eval
