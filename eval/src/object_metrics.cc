#include "fsp/eval/object_metrics.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>

#include <nlohmann/json.hpp>

#include "fsp/common/error.h"

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

Vec3 UnitNormal(const std::array<Vec3, 4>& c) { return (c[1] - c[0]).cross(c[3] - c[0]).normalized(); }

}  // namespace

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
    if (!o.contains("id") || !o.at("id").is_number_integer()) throw InputError(where + ": \"id\" missing or not an integer");
    r.id = o.at("id").get<int>();
    where += " (id " + std::to_string(r.id) + ")";
    if (!ids.insert(r.id).second) throw InputError(where + ": id repeated");
    if (o.contains("class") && o.at("class").is_string()) r.object_class = o.at("class").get<std::string>();
    if (!o.contains("corners_W") || !o.at("corners_W").is_array() || o.at("corners_W").size() != 4) {
      throw InputError(where + ": \"corners_W\" must be 4 points [x, y, z]");
    }
    for (size_t j = 0; j < 4; ++j) {
      const nlohmann::json& c = o.at("corners_W")[j];
      if (!c.is_array() || c.size() != 3) throw InputError(where + ": corners_W[" + std::to_string(j) + "] is not [x, y, z]");
      for (size_t k = 0; k < 3; ++k) {
        if (!c[k].is_number() || !std::isfinite(c[k].get<double>())) {
          throw InputError(where + ": corners_W[" + std::to_string(j) + "] has a non-finite coordinate");
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

ObjectMetrics EvaluateObjects(const std::vector<ObjectRecord>& gt, const std::vector<ObjectRecord>& est,
                              const Alignment& alignment) {
  ObjectMetrics m;
  m.gt = gt.size();
  m.estimated = est.size();
  std::map<int, const ObjectRecord*> est_by_id;
  for (const ObjectRecord& e : est) est_by_id[e.id] = &e;
  std::vector<const ObjectRecord*> gt_sorted;
  for (const ObjectRecord& g : gt) gt_sorted.push_back(&g);
  std::sort(gt_sorted.begin(), gt_sorted.end(), [](const ObjectRecord* a, const ObjectRecord* b) { return a->id < b->id; });

  std::vector<double> corner, width, height, normal;
  for (const ObjectRecord* g : gt_sorted) {
    const auto it = est_by_id.find(g->id);
    if (it == est_by_id.end()) continue;
    const ObjectRecord& e = *it->second;
    ObjectError oe;
    oe.id = g->id;
    // Corner j: ‖s R c_est,j + t − c_gt,j‖ [m] (same s1..s4 index).
    std::array<Vec3, 4> aligned;
    for (size_t j = 0; j < 4; ++j) {
      aligned[j] = alignment.Apply(e.corners_W[j]);
      const double err = (aligned[j] - g->corners_W[j]).norm();
      corner.push_back(err);
      oe.corner_err_mean_m += 0.25 * err;
    }
    // Sizes: |s w_est − w_gt|, |s h_est − h_gt| [m].
    oe.width_err_m = std::abs(alignment.scale * e.width - g->width);
    oe.height_err_m = std::abs(alignment.scale * e.height - g->height);
    // Face normal n = (c2 − c1) × (c4 − c1) normalised; angle between the aligned and the true one [deg].
    const double cos_angle = std::clamp(UnitNormal(aligned).dot(UnitNormal(g->corners_W)), -1.0, 1.0);
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
