#include "fsp/eval/object_metrics.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <tuple>

#include <nlohmann/json.hpp>

#include "fsp/common/error.h"
#include "fsp/common/types.h"

namespace fsp::eval {

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

double FiniteNumber(const nlohmann::json& j, const std::string& where, const char* key) {
  if (!j.contains(key)) throw InputError(where + ": missing \"" + key + "\"");
  const nlohmann::json& v = j.at(key);
  if (!v.is_number() || !std::isfinite(v.get<double>())) {
    throw InputError(where + ": \"" + key + "\" is not a finite number");
  }
  return v.get<double>();
}

Vec3 UnitNormal(const std::array<Vec3, 4>& c) {
  return (c[1] - c[0]).cross(c[3] - c[0]).normalized();
}

using Quad = std::array<Vec3, 4>;

Quad Aligned(const ObjectRecord& e, const Alignment& alignment) {
  Quad a;
  for (size_t j = 0; j < 4; ++j) a[j] = alignment.Apply(e.corners_W[j]);
  return a;
}

// 1/4 Σ_j ‖e_{(j+r) mod 4} − g_j‖ [m].
double ShiftedDistance(const Quad& e, const Quad& g, int r) {
  double sum = 0.0;
  for (int j = 0; j < 4; ++j)
    sum += (e[static_cast<size_t>((j + r) % 4)] - g[static_cast<size_t>(j)]).norm();
  return 0.25 * sum;
}

struct Pair {
  double distance;
  size_t gt, est;  // indices
  int shift;
};

// Greedy one-to-one pairs by increasing shift-tolerant distance within the gate.
std::vector<Pair> MatchByGeometry(const std::vector<ObjectRecord>& gt,
                                  const std::vector<Quad>& est_aligned, double gate_m) {
  std::vector<Pair> candidates;
  for (size_t gi = 0; gi < gt.size(); ++gi) {
    for (size_t ei = 0; ei < est_aligned.size(); ++ei) {
      Pair p{ShiftedDistance(est_aligned[ei], gt[gi].corners_W, 0), gi, ei, 0};
      for (int r = 1; r < 4; ++r) {
        const double d = ShiftedDistance(est_aligned[ei], gt[gi].corners_W, r);
        if (d < p.distance) std::tie(p.distance, p.shift) = std::make_pair(d, r);
      }
      if (p.distance <= gate_m) candidates.push_back(p);
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Pair& a, const Pair& b) {
    return std::tie(a.distance, a.gt, a.est) < std::tie(b.distance, b.gt, b.est);
  });
  std::vector<Pair> pairs;
  std::set<size_t> used_gt, used_est;
  for (const Pair& p : candidates) {
    if (used_gt.count(p.gt) || used_est.count(p.est)) continue;
    used_gt.insert(p.gt);
    used_est.insert(p.est);
    pairs.push_back(p);
  }
  return pairs;
}

// The class a file names (unknown when it names none the front end knows).
ObjectClass ClassOf(const std::string& name) {
  ObjectClass c = ObjectClass::kUnknown;
  return ParseObjectClass(name, &c) ? c : ObjectClass::kUnknown;
}

}  // namespace

bool ObjectOptions::Check(std::string* why) const {
  if (!(match_gate_m > 0.0) || !std::isfinite(match_gate_m)) {
    *why = "match_gate_m must be finite and > 0";
    return false;
  }
  return true;
}

std::vector<ObjectRecord> ReadObjectsJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open objects json");
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path, 0, std::string("not valid JSON: ") + e.what());
  }
  if (!root.is_object() || !root.contains("objects") || !root.at("objects").is_array()) {
    throw InputError(path, 0, "expected {\"objects\": [...]}");
  }
  std::vector<ObjectRecord> objects;
  std::set<int> ids;
  const nlohmann::json& list = root.at("objects");
  for (size_t i = 0; i < list.size(); ++i) {
    const nlohmann::json& o = list[i];
    std::string where = path + ": objects[" + std::to_string(i) + "]";
    if (!o.is_object()) throw InputError(where + ": not an object");
    ObjectRecord r;
    if (!o.contains("id") || !o.at("id").is_number_integer())
      throw InputError(where + ": \"id\" missing or not an integer");
    r.id = o.at("id").get<int>();
    where += " (id " + std::to_string(r.id) + ")";
    if (!ids.insert(r.id).second) throw InputError(where + ": id repeated");
    if (o.contains("class") && o.at("class").is_string())
      r.object_class = o.at("class").get<std::string>();
    if (!o.contains("corners_W") || !o.at("corners_W").is_array() ||
        o.at("corners_W").size() != 4) {
      throw InputError(where + ": \"corners_W\" must be 4 points [x, y, z]");
    }
    for (size_t j = 0; j < 4; ++j) {
      const nlohmann::json& c = o.at("corners_W")[j];
      if (!c.is_array() || c.size() != 3)
        throw InputError(where + ": corners_W[" + std::to_string(j) + "] is not [x, y, z]");
      for (size_t k = 0; k < 3; ++k) {
        if (!c[k].is_number() || !std::isfinite(c[k].get<double>())) {
          throw InputError(where + ": corners_W[" + std::to_string(j) +
                           "] has a non-finite coordinate");
        }
        r.corners_W[j][static_cast<int>(k)] = c[k].get<double>();
      }
    }
    r.width = FiniteNumber(o, where, "width");
    r.height = FiniteNumber(o, where, "height");
    if (r.width < 0.0 || r.height < 0.0) throw InputError(where + ": negative width or height");
    objects.push_back(r);
  }
  return objects;
}

ObjectMetrics EvaluateObjects(const std::vector<ObjectRecord>& gt,
                              const std::vector<ObjectRecord>& est, const Alignment& alignment,
                              const ObjectOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InputError("object options: " + why);
  ObjectMetrics m;
  m.gt = gt.size();
  m.estimated = est.size();
  std::vector<Quad> est_aligned;
  for (const ObjectRecord& e : est) est_aligned.push_back(Aligned(e, alignment));
  std::vector<Pair> pairs = MatchByGeometry(gt, est_aligned, options.match_gate_m);
  std::sort(pairs.begin(), pairs.end(),
            [&](const Pair& a, const Pair& b) { return gt[a.gt].id < gt[b.gt].id; });

  std::vector<double> corner, width, height, normal;
  for (const Pair& p : pairs) {
    const ObjectRecord& g = gt[p.gt];
    const ObjectRecord& e = est[p.est];
    const Quad& aligned = est_aligned[p.est];
    ObjectError oe;
    oe.id = g.id;
    oe.est_id = e.id;
    oe.corner_shift = p.shift;
    m.corner_order_errors += p.shift != 0 ? 1 : 0;
    oe.est_class = e.object_class;
    oe.gt_class = g.object_class;
    oe.class_right = ClassOf(e.object_class) == ClassOf(g.object_class);
    m.classes_right += oe.class_right ? 1 : 0;
    // Corner j: ‖s R c_est,j + t − c_gt,j‖ [m] (same s1..s4 index).
    for (size_t j = 0; j < 4; ++j) {
      const double err = (aligned[j] - g.corners_W[j]).norm();
      corner.push_back(err);
      oe.corner_err_m[j] = err;
      oe.corner_err_mean_m += 0.25 * err;
    }
    // Sizes: |s w_est − w_gt|, |s h_est − h_gt| [m].
    oe.width_err_m = std::abs(alignment.scale * e.width - g.width);
    oe.height_err_m = std::abs(alignment.scale * e.height - g.height);
    // Face normal n = (c2 − c1) × (c4 − c1) normalised; angle between the aligned and the true one
    // [deg].
    const double cos_angle =
        std::clamp(UnitNormal(aligned).dot(UnitNormal(g.corners_W)), -1.0, 1.0);
    oe.normal_err_deg = std::acos(cos_angle) * kRadToDeg;
    width.push_back(oe.width_err_m);
    height.push_back(oe.height_err_m);
    normal.push_back(oe.normal_err_deg);
    m.per_object.push_back(oe);
  }
  m.matched = m.per_object.size();
  m.corner_err = ComputeStats(std::move(corner));
  m.width_err = ComputeStats(std::move(width));
  m.height_err = ComputeStats(std::move(height));
  m.normal_err_deg = ComputeStats(std::move(normal));
  return m;
}

}  // namespace fsp::eval
