// Map accuracy: estimated rectangles (a run's map.json) against the ground truth (objects_gt.json),
// matched by object id, after mapping the estimate's world into the reference's with the trajectory
// alignment (so the map is judged in the same gauge as the trajectory).
//
//  - corner error of corner j of a matched object: ‖s R c_est,j + t − c_gt,j‖ [m], corners in s1..s4 order;
//    mean and median over all corners of all matched objects (4 per object).
//  - width / height error: |s w_est − w_gt|, |s h_est − h_gt| [m] (rigid alignment leaves sizes alone;
//    Sim3 scales them by s); mean and max over matched objects.
//  - normal error: angle between R n_est and n_gt [deg], n = (c2 − c1) × (c4 − c1) / ‖…‖ (the face normal z).
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

// Reads {"objects": [{"id", "class", "corners_W": [[x,y,z] x4], "width", "height", ...}]} (objects_gt.json
// and map.json share these keys; others are ignored). Throws InputError naming the file and the object on
// malformed JSON, missing keys, non-finite numbers or repeated ids.
std::vector<ObjectRecord> ReadObjectsJson(const std::string& path);

struct ObjectError {
  int id = -1;
  double corner_err_mean_m = 0.0;
  double width_err_m = 0.0;
  double height_err_m = 0.0;
  double normal_err_deg = 0.0;
};

struct ObjectMetrics {
  size_t gt = 0;         // objects in the ground truth
  size_t estimated = 0;  // objects in the map
  size_t matched = 0;    // ids in both
  ErrorStats corner_err;       // [m], over 4 × matched corners
  ErrorStats width_err;        // [m], over matched objects
  ErrorStats height_err;       // [m]
  ErrorStats normal_err_deg;   // [deg]
  std::vector<ObjectError> per_object;  // matched objects, by increasing id
};

ObjectMetrics EvaluateObjects(const std::vector<ObjectRecord>& gt, const std::vector<ObjectRecord>& est,
                              const Alignment& alignment);

}  // namespace fsp::eval
