// Map accuracy: estimated rectangles (a run's map.json) against the ground truth (objects_gt.json),
// after mapping the estimate's world into the reference's with the trajectory alignment (so the map
// is judged in the same gauge as the trajectory).
//
// Matching is by geometry, never by id (a tracker's ids are its own): the distance of an estimated
// and a ground-truth object is d = min over the 4 cyclic shifts r of
// 1/4 Σ_j ‖A(c_est,(j+r) mod 4) − c_gt,j‖ [m] with A the alignment (so corners listed from the
// wrong corner still match; such a match counts in corner_order_errors); pairs with d ≤
// match_gate_m are taken greedily by increasing d (ties: ground-truth then estimated index), each
// object at most once. With the ground truth's own ids in the map (gt-corners runs) and objects
// placed better than half their spacing, this pairs equal ids.
//
//  - corner error of corner j of a matched object: ‖s R c_est,j + t − c_gt,j‖ [m], corners in the
//    files' s1..s4 order (a wrongly ordered corner set shows up here); mean and median over all
//    corners of all matched objects (4 per object).
//  - width / height error: |s w_est − w_gt|, |s h_est − h_gt| [m] (rigid alignment leaves sizes
//    alone; Sim3 scales them by s); mean and max over matched objects.
//  - normal error: angle between R n_est and n_gt [deg], n = (c2 − c1) × (c4 − c1) / ‖…‖ (the face
//    normal z).
//  - class: a match's class is right when both name the same ObjectClass (common/types.h: a
//    painting is a poster); a class neither side can name counts as unknown.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "fsp/common/geometry.h"
#include "fsp/eval/alignment.h"
#include "fsp/eval/stats.h"

namespace fsp::eval {

struct ObjectRecord {
  int id = -1;
  std::string object_class;
  std::array<Vec3, 4> corners_W;  // s1..s4 [m]
  double width = 0.0;             // [m]
  double height = 0.0;            // [m]
};

// Reads {"objects": [{"id", "class", "corners_W": [[x,y,z] x4], "width", "height", ...}]}
// (objects_gt.json and map.json share these keys; others are ignored). Throws InputError naming the
// file and the object on malformed JSON, missing keys, non-finite numbers or repeated ids.
std::vector<ObjectRecord> ReadObjectsJson(const std::string& path);

struct ObjectOptions {
  double match_gate_m = 0.5;  // largest mean corner distance of a match [m]; larger accepts badly
                              // placed objects but can pair an estimate with a neighbouring object
  bool Check(std::string* why) const;
};

struct ObjectError {
  int id = -1;           // ground-truth id
  int est_id = -1;       // the map's id matched to it
  int corner_shift = 0;  // cyclic shift r of the match's distance (0: corners in the same order)
  double corner_err_mean_m = 0.0;
  std::array<double, 4> corner_err_m{};  // per corner s1..s4 (their mean is corner_err_mean_m)
  double width_err_m = 0.0;
  double height_err_m = 0.0;
  double normal_err_deg = 0.0;
  bool class_right = false;
  std::string est_class, gt_class;  // as the files spell them
};

struct ObjectMetrics {
  size_t gt = 0;                        // objects in the ground truth
  size_t estimated = 0;                 // objects in the map
  size_t matched = 0;                   // matched pairs (see above)
  size_t corner_order_errors = 0;       // matches whose best cyclic shift is not the identity
  size_t classes_right = 0;             // matches whose classes agree (see above)
  ErrorStats corner_err;                // [m], over 4 × matched corners
  ErrorStats width_err;                 // [m], over matched objects
  ErrorStats height_err;                // [m]
  ErrorStats normal_err_deg;            // [deg]
  std::vector<ObjectError> per_object;  // matched objects, by increasing ground-truth id
};

ObjectMetrics EvaluateObjects(const std::vector<ObjectRecord>& gt,
                              const std::vector<ObjectRecord>& est, const Alignment& alignment,
                              const ObjectOptions& options = {});

}  // namespace fsp::eval
