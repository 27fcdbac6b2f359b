#include "gt_corners.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>

#include <nlohmann/json.hpp>

#include "fsp/common/error.h"

namespace fsp::apps {

namespace fs = std::filesystem;

std::map<int, ObjectClass> ReadObjectClasses(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open");
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path, 0, std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object() || !j.contains("objects") || !j["objects"].is_array())
    throw InputError(path, 0, "expected {\"objects\": [...]}");
  std::map<int, ObjectClass> classes;
  int index = 0;
  for (const auto& o : j["objects"]) {
    const std::string where = "objects[" + std::to_string(index++) + "]";
    if (!o.is_object() || !o.contains("id") || !o["id"].is_number_integer())
      throw InputError(path, 0, where + ": missing integer \"id\"");
    const int id = o["id"].get<int>();
    ObjectClass c = ObjectClass::kUnknown;
    if (o.contains("class")) {
      if (!o["class"].is_string() || !ParseObjectClass(o["class"].get<std::string>(), &c))
        throw InputError(
            path, 0,
            where + " (id " + std::to_string(id) + "): unknown class " + o["class"].dump());
    }
    if (!classes.emplace(id, c).second)
      throw InputError(path, 0, "object id " + std::to_string(id) + " repeated");
  }
  return classes;
}

namespace {

std::string RequireFile(const fs::path& root, const char* name) {
  const fs::path p = root / name;
  if (!fs::is_regular_file(p))
    throw InputError("gt-corners needs a rendered sequence: " + p.string() + " not found");
  return p.string();
}

}  // namespace

std::string SequenceRootOf(const std::string& input) {
  const fs::path p(input);
  if (fs::is_directory(p)) {
    if (!fs::exists(p / "observations_gt.csv") && p.filename() == "mav0" && p.has_parent_path())
      return p.parent_path().string();
    if (!fs::exists(p / "observations_gt.csv") && p.filename().empty() &&
        p.parent_path().filename() == "mav0")
      return p.parent_path().parent_path().string();  // "DIR/mav0/"
    return p.string();
  }
  return p.has_parent_path() ? p.parent_path().string() : ".";
}

GtCornersFrontend::GtCornersFrontend(const std::string& input, const GtCornersOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InputError(why);
  const fs::path root = SequenceRootOf(input);
  observations_path_ = RequireFile(root, "observations_gt.csv");
  const std::string objects_path = RequireFile(root, "objects_gt.json");
  const std::vector<CornerRow> rows = ReadCornerRows(observations_path_);
  const std::map<int, ObjectClass> classes = ReadObjectClasses(objects_path);

  // Corner noise: u_j += σ n, v_j += σ n', n ~ N(0, 1), drawn in file order (u1, v1, ..., v4 per
  // row).
  // Rows of objects partly in view draw from their own stream, so that the fully visible rows'
  // noise does not depend on them.
  std::mt19937 rng(options.seed), rng_partial(options.seed + 1);
  std::normal_distribution<double> normal(0.0, 1.0);
  stats_.rows = static_cast<int>(rows.size());
  for (const CornerRow& row : rows) {
    if (!Keep(row, options.min_visible_corners)) continue;
    const auto cls = classes.find(row.object_id);
    if (cls == classes.end()) {
      throw InputError(observations_path_, 0,
                       "object " + std::to_string(row.object_id) + " is not in " + objects_path);
    }
    ObjectObservation obs;
    obs.t_ns = row.t_ns;
    obs.object_id = row.object_id;
    obs.object_class = cls->second;
    obs.corners = row.corners;
    obs.seen = row.visible;
    if (options.pixel_sigma > 0.0) {
      std::mt19937& r = row.FullyVisible() ? rng : rng_partial;
      for (Vec2& c : obs.corners) {
        c.x() += options.pixel_sigma * normal(r);
        c.y() += options.pixel_sigma * normal(r);
      }
    }
    by_time_[row.t_ns].push_back(obs);
  }
}

ExternalCornersFrontend::ExternalCornersFrontend(const std::string& corners,
                                                 const std::string& objects,
                                                 const Calibration& calibration,
                                                 const std::vector<int64_t>& frame_times,
                                                 int min_visible_corners) {
  observations_path_ = corners;
  if (!fs::is_regular_file(corners)) throw InputError(corners, 0, "corners file not found");
  const std::vector<CornerRow> rows = ReadCornerRows(corners);  // columns, numbers, time order
  if (rows.empty()) {
    throw InputError(corners, 0,
                     "no rows (expected "
                     "t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4[,fully_visible[,visible_corners]])");
  }
  std::map<int, ObjectClass> classes;
  if (!objects.empty()) classes = ReadObjectClasses(objects);
  const std::set<int64_t> frames(frame_times.begin(), frame_times.end());
  const PinholeRadtan& camera = calibration.camera;
  stats_.rows = static_cast<int>(rows.size());
  for (const CornerRow& row : rows) {
    const auto fail = [&](const std::string& what) { throw InputError(corners, row.line, what); };
    const int64_t t_ns = row.t_ns + calibration.time_offset_ns;
    if (!frames.count(t_ns)) {
      std::string what = "t_ns " + std::to_string(row.t_ns) + " matches no frame of the input";
      if (calibration.time_offset_ns != 0)
        what += " (with time_offset_ns " + std::to_string(calibration.time_offset_ns) + ")";
      if (!frames.empty()) {
        what += "; its frames span [" + std::to_string(*frames.begin()) + ", " +
                std::to_string(*frames.rbegin()) + "] ns";
      }
      fail(what);
    }
    if (!Keep(row, min_visible_corners)) continue;
    ObjectObservation obs;
    obs.t_ns = t_ns;
    obs.seen = row.visible;
    obs.object_id = row.object_id;
    if (!objects.empty()) {
      const auto cls = classes.find(row.object_id);
      if (cls == classes.end())
        fail("object " + std::to_string(row.object_id) + " is not in " + objects);
      obs.object_class = cls->second;
    }
    for (int j = 0; j < 4; ++j) {
      obs.corners[j] = camera.HasDistortion() && obs.seen[j] ? camera.UndistortPixel(row.corners[j])
                                                             : row.corners[j];
    }
    std::vector<ObjectObservation>& frame = by_time_[t_ns];
    if (std::any_of(frame.begin(), frame.end(),
                    [&](const ObjectObservation& o) { return o.object_id == obs.object_id; })) {
      fail("object " + std::to_string(obs.object_id) + " appears twice at t_ns " +
           std::to_string(row.t_ns));
    }
    frame.push_back(obs);
  }
}

bool CornerFileFrontend::Keep(const CornerRow& row, int min_visible_corners) {
  if (row.FullyVisible()) return true;
  const bool keep = CountSeen(row.visible) >= min_visible_corners;
  ++(keep ? stats_.rows_partial : stats_.rows_not_visible);
  return keep;
}

std::vector<ObjectObservation> CornerFileFrontend::Process(int64_t t_ns) {
  const auto it = by_time_.find(t_ns);
  if (it == by_time_.end()) return {};
  ++stats_.frames_matched;
  stats_.observations += static_cast<int>(it->second.size());
  return it->second;
}

CornerRow ToCornerRow(const ObjectObservation& observation) {
  CornerRow row;
  row.t_ns = observation.t_ns;
  row.object_id = observation.object_id;
  row.corners = observation.corners;
  return row;
}

}  // namespace fsp::apps
