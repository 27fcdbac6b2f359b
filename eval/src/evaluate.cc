#include "fsp/eval/evaluate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fsp/common/error.h"

namespace fsp::eval {

namespace fs = std::filesystem;

namespace {

std::string IfFile(const fs::path& p) {
  return fs::is_regular_file(p) ? p.string() : std::string();
}

std::string Format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

// "  map ids: 7->1 9->2" for the matches whose map id differs from the ground truth's (empty when
// none).
std::string ObjectIdLine(const ObjectMetrics& o) {
  std::string line;
  for (const ObjectError& e : o.per_object) {
    if (e.est_id != e.id) line += " " + std::to_string(e.est_id) + "->" + std::to_string(e.id);
  }
  if (o.corner_order_errors > 0)
    line += " (" + std::to_string(o.corner_order_errors) + " with corners out of order)";
  return line.empty() ? line : "  map ids matched by geometry:" + line + "\n";
}

// "  worst tracked (median of a frame's worst corner): object 10 29.7 px (ids 1018), ..." for the
// three objects tracked worst, of those matched in at least 10 frames, when above the success
// bound (`--success-px`; empty when none).
std::string WorstTrackedLine(const FrontendMetrics& f) {
  std::vector<const ObjectTracking*> worst;
  for (const ObjectTracking& o : f.per_object)
    if (o.matched >= 10) worst.push_back(&o);
  std::sort(worst.begin(), worst.end(), [](const ObjectTracking* a, const ObjectTracking* b) {
    return a->worst_corner_median_px > b->worst_corner_median_px;
  });
  std::string line;
  for (size_t i = 0; i < std::min<size_t>(3, worst.size()); ++i) {
    const ObjectTracking& o = *worst[i];
    if (o.worst_corner_median_px <= f.success_px) break;
    std::string ids;
    for (int id : o.est_ids) ids += (ids.empty() ? "" : " ") + std::to_string(id);
    line += (line.empty() ? " " : ", ") + std::string("object ") + std::to_string(o.gt_id) + " " +
            Format("%.1f", o.worst_corner_median_px) + " px (ids " + ids + ")";
  }
  return line.empty() ? line : "  worst tracked (median of a frame's worst corner):" + line + "\n";
}

}  // namespace

EvalPaths ResolvePaths(const std::string& gt, const std::string& est) {
  EvalPaths p;
  if (gt.empty() || !fs::exists(gt)) throw InputError(gt, 0, "ground truth not found");
  if (fs::is_directory(gt)) {
    // DIR/mav0/... (a sequence) or DIR being mav0 itself (its sequence files one level up).
    fs::path seq = gt, mav0 = fs::path(gt) / "mav0";
    if (!fs::is_directory(mav0)) {
      mav0 = gt;
      seq = fs::path(gt).lexically_normal().parent_path();
      if (fs::is_regular_file(fs::path(gt) / "objects_gt.json") ||
          fs::is_regular_file(fs::path(gt) / "observations_gt.csv")) {
        seq = gt;
      }
    }
    p.gt_trajectory = IfFile(mav0 / "state_groundtruth_estimate0" / "data.csv");
    p.objects_gt = IfFile(seq / "objects_gt.json");
    p.observations_gt = IfFile(seq / "observations_gt.csv");
    p.frame_times = IfFile(mav0 / "cam0" / "data.csv");
    if (p.gt_trajectory.empty() && p.objects_gt.empty() && p.observations_gt.empty()) {
      throw InputError(
          gt, 0,
          "no ground truth in this folder (expected mav0/state_groundtruth_estimate0/data.csv, "
          "objects_gt.json or observations_gt.csv)");
    }
  } else {
    p.gt_trajectory = gt;
  }

  if (est.empty() || !fs::exists(est)) throw InputError(est, 0, "estimate not found");
  if (fs::is_directory(est)) {
    p.est_trajectory = IfFile(fs::path(est) / "trajectory.tum");
    p.map = IfFile(fs::path(est) / "map.json");
    p.observations = IfFile(fs::path(est) / "observations.csv");
    p.run_json = IfFile(fs::path(est) / "run.json");
    if (p.est_trajectory.empty() && p.map.empty() && p.observations.empty() && p.run_json.empty()) {
      throw InputError(
          est, 0,
          "no run output in this folder (expected trajectory.tum, map.json, observations.csv or "
          "run.json)");
    }
  } else {
    p.est_trajectory = est;
  }
  return p;
}

bool EvalOptions::Check(std::string* why) const {
  return trajectory.Check(why) && frontend.Check(why) && objects.Check(why);
}

std::vector<int64_t> ReadFrameTimes(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open frame list");
  std::vector<int64_t> times;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#' || line == "\r") continue;
    size_t used = 0;
    try {
      times.push_back(std::stoll(line, &used));
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || (used < line.size() && line[used] != ',')) {
      throw InputError(path, n, "expected t_ns,filename");
    }
  }
  return times;
}

std::optional<RuntimeMetrics> ReadRuntime(const std::string& run_json) {
  std::ifstream in(run_json);
  if (!in) throw InputError(run_json, 0, "cannot open run.json");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(run_json, 0, std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object()) throw InputError(run_json, 0, "expected a JSON object");
  RuntimeMetrics r;
  auto get = [&](const char* key, std::optional<double>* out) {
    if (!j.contains(key)) return;
    if (!j.at(key).is_number() || !std::isfinite(j.at(key).get<double>())) {
      throw InputError(run_json, 0, std::string("\"") + key + "\" is not a finite number");
    }
    *out = j.at(key).get<double>();
  };
  get("frames", &r.frames);
  get("wall_s", &r.wall_s);
  get("realtime_factor", &r.realtime_factor);
  if (!r.frames && !r.wall_s && !r.realtime_factor) return std::nullopt;
  return r;
}

Metrics Evaluate(const EvalPaths& paths, const EvalOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InputError("eval options: " + why);
  Metrics m;
  m.paths = paths;

  if (!paths.gt_trajectory.empty() && !paths.est_trajectory.empty()) {
    m.trajectory = EvaluateTrajectory(ReadTrajectory(paths.gt_trajectory),
                                      ReadTrajectory(paths.est_trajectory), options.trajectory);
  } else {
    m.notes.push_back(paths.gt_trajectory.empty() ? "no ground-truth trajectory"
                                                  : "no estimated trajectory");
  }

  if (!paths.objects_gt.empty() && !paths.map.empty()) {
    const std::vector<ObjectRecord> gt = ReadObjectsJson(paths.objects_gt);
    const std::vector<ObjectRecord> est = ReadObjectsJson(paths.map);
    if (gt.empty()) {
      m.notes.push_back("objects: the ground truth has no objects");
    } else if (!m.trajectory) {
      m.notes.push_back(
          "objects: need both trajectories to bring the map into the ground truth's frame");
    } else {
      m.objects = EvaluateObjects(gt, est, m.trajectory->alignment, options.objects);
    }
  }

  if (!paths.observations_gt.empty() && !paths.observations.empty()) {
    const std::vector<CornerRow> gt = ReadCornerRows(paths.observations_gt);
    const std::vector<CornerRow> est = ReadCornerRows(paths.observations);
    if (gt.empty()) {
      m.notes.push_back("front end: the ground truth has no observations");
    } else {
      const std::vector<int64_t> frames =
          paths.frame_times.empty() ? std::vector<int64_t>() : ReadFrameTimes(paths.frame_times);
      m.frontend = EvaluateFrontend(gt, est, options.frontend, frames);
    }
  }

  if (!paths.run_json.empty()) m.runtime = ReadRuntime(paths.run_json);

  if (!m.trajectory && !m.objects && !m.frontend && !m.runtime) {
    std::string msg =
        "nothing to evaluate: ground truth and estimate share no trajectory, objects, "
        "observations or runtime";
    for (const std::string& n : m.notes) msg += "; " + n;
    throw InputError(msg);
  }
  return m;
}

nlohmann::ordered_json ToJson(const Metrics& m) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  if (m.trajectory) {
    const TrajectoryMetrics& t = *m.trajectory;
    nlohmann::ordered_json b;
    // The fields of docs/outputs.md first, then the rest of the statistics.
    b["pairs"] = t.pairs;
    b["align"] = ToString(t.alignment.mode);
    b["ate_rmse_m"] = t.ate.rmse;
    b["ate_median_m"] = t.ate.median;
    if (t.rpe_trans.count > 0) {
      b["rpe_trans_rmse_m"] = t.rpe_trans.rmse;
      b["rpe_rot_rmse_deg"] = t.rpe_rot.rmse;
    }
    b["ate_mean_m"] = t.ate.mean;
    b["ate_std_m"] = t.ate.std;
    b["ate_min_m"] = t.ate.min;
    b["ate_max_m"] = t.ate.max;
    if (t.rpe_trans.count > 0) {
      b["rpe_pairs"] = t.rpe_trans.count;
      b["rpe_trans_median_m"] = t.rpe_trans.median;
      b["rpe_rot_median_deg"] = t.rpe_rot.median;
    }
    b["ref_poses"] = t.ref_poses;
    b["est_poses"] = t.est_poses;
    if (t.alignment.mode == AlignMode::kSim3) {
      b["scale"] = t.alignment.scale;
      b["scale_err"] = t.scale_error;
    }
    // The alignment itself, p_ref = s R p_est + t, as a 4x4 row-major matrix [s R, t; 0 0 0 1].
    Mat4 S = Mat4::Identity();
    S.topLeftCorner<3, 3>() = t.alignment.scale * t.alignment.R;
    S.topRightCorner<3, 1>() = t.alignment.t;
    std::vector<double> flat;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) flat.push_back(S(r, c));
    }
    b["S_ref_est"] = flat;
    j["trajectory"] = b;
  }
  if (m.objects) {
    const ObjectMetrics& o = *m.objects;
    nlohmann::ordered_json b;
    b["gt"] = o.gt;
    b["estimated"] = o.estimated;
    b["matched"] = o.matched;
    b["corner_order_errors"] = o.corner_order_errors;
    b["classes_right"] = o.classes_right;
    if (o.matched > 0) {
      b["corner_err_mean_m"] = o.corner_err.mean;
      b["corner_err_median_m"] = o.corner_err.median;
      b["width_err_mean_m"] = o.width_err.mean;
      b["width_err_max_m"] = o.width_err.max;
      b["height_err_mean_m"] = o.height_err.mean;
      b["height_err_max_m"] = o.height_err.max;
      b["normal_err_mean_deg"] = o.normal_err_deg.mean;
      nlohmann::ordered_json per = nlohmann::ordered_json::array();
      for (const ObjectError& e : o.per_object) {
        per.push_back({{"id", e.id},
                       {"est_id", e.est_id},
                       {"corner_err_mean_m", e.corner_err_mean_m},
                       {"width_err_m", e.width_err_m},
                       {"height_err_m", e.height_err_m},
                       {"normal_err_deg", e.normal_err_deg}});
      }
      b["per_object"] = per;
    }
    // The geometric matching itself: which map object stands for which ground-truth object.
    nlohmann::ordered_json matches = nlohmann::ordered_json::array();
    for (const ObjectError& e : o.per_object) {
      matches.push_back({{"est_id", e.est_id},
                         {"gt_id", e.id},
                         {"corner_err_m", e.corner_err_mean_m},
                         {"corner_shift", e.corner_shift}});
    }
    b["matches"] = matches;
    j["objects"] = b;
  }
  if (m.frontend) {
    const FrontendMetrics& f = *m.frontend;
    nlohmann::ordered_json b;
    if (f.recall) b["recall"] = *f.recall;
    if (f.precision) b["precision"] = *f.precision;
    if (f.corner_err_px.count > 0) b["corner_err_px_median"] = f.corner_err_px.median;
    b["id_switches"] = f.id_switches;
    if (f.success_rate) b["success_rate"] = *f.success_rate;
    b["success_frames"] = f.success_frames;
    b["success_total"] = f.success_total;
    b["boxes_out_of_view"] = f.boxes_out_of_view;
    b["unmatched_est_rows"] = f.unmatched_est_rows;
    b["returns"] = f.returns;
    b["reidentified"] = f.reidentified;
    if (f.reid_rate) b["reid_rate"] = *f.reid_rate;
    if (f.id_switches_per_1000) b["id_switches_per_1000"] = *f.id_switches_per_1000;
    if (f.corner_err_px.count > 0) b["corner_err_px_mean"] = f.corner_err_px.mean;
    if (f.corner_outward_px.count > 0) {
      b["corner_outward_px_median"] = f.corner_outward_px.median;
      b["corner_outward_px_mean"] = f.corner_outward_px.mean;
    }
    b["gt_rows"] = f.gt_rows;
    b["gt_fully_visible"] = f.gt_fully_visible;
    b["est_rows"] = f.est_rows;
    b["matched"] = f.matched;
    b["corner_order_errors"] = f.corner_order_errors;
    b["frames"] = f.frames;
    // Estimated id -> ground-truth id (JSON keys are strings).
    nlohmann::ordered_json id_map = nlohmann::ordered_json::object();
    for (const auto& [est_id, gt_id] : f.id_map) id_map[std::to_string(est_id)] = gt_id;
    b["id_map"] = id_map;
    nlohmann::ordered_json per_object = nlohmann::ordered_json::array();
    for (const ObjectTracking& o : f.per_object) {
      per_object.push_back({{"gt_id", o.gt_id},
                            {"est_ids", o.est_ids},
                            {"matched", o.matched},
                            {"worst_corner_px_median", o.worst_corner_median_px},
                            {"worst_corner_px_p90", o.worst_corner_p90_px},
                            {"success_frames", o.success_frames},
                            {"success_total", o.success_total}});
    }
    b["per_object"] = per_object;
    j["frontend"] = b;
  }
  if (m.runtime) {
    nlohmann::ordered_json b = nlohmann::ordered_json::object();
    if (m.runtime->frames) {
      const double fr = *m.runtime->frames;
      if (fr == std::floor(fr) && std::abs(fr) < 9e15)
        b["frames"] = static_cast<int64_t>(fr);
      else
        b["frames"] = fr;
    }
    if (m.runtime->wall_s) b["wall_s"] = *m.runtime->wall_s;
    if (m.runtime->realtime_factor) b["realtime_factor"] = *m.runtime->realtime_factor;
    j["runtime"] = b;
  }
  return j;
}

std::string FormatSummary(const Metrics& m) {
  std::ostringstream os;
  if (m.trajectory) {
    const TrajectoryMetrics& t = *m.trajectory;
    os << "trajectory: " << t.pairs << " pairs (" << t.ref_poses << " reference, " << t.est_poses
       << " estimated poses), " << ToString(t.alignment.mode) << " alignment";
    if (t.alignment.mode == AlignMode::kSim3) os << ", scale " << Format("%.6f", t.alignment.scale);
    if (2 * t.pairs < t.possible_pairs)
      os << "\n  warning: only " << t.pairs << " of the " << t.possible_pairs
         << " pairs the two time spans allow: are the stamps of different clocks? (--t-offset; a "
            "camera-IMU time offset moves the estimate's stamps)";
    os << "\n  ATE rmse " << Format("%.6f", t.ate.rmse) << " m, mean " << Format("%.6f", t.ate.mean)
       << " m, median " << Format("%.6f", t.ate.median) << " m, max " << Format("%.6f", t.ate.max)
       << " m\n";
    if (t.rpe_trans.count > 0) {
      os << "  RPE (1 frame) rmse " << Format("%.6f", t.rpe_trans.rmse) << " m, "
         << Format("%.4f", t.rpe_rot.rmse) << " deg over " << t.rpe_trans.count << " steps\n";
    }
  }
  if (m.objects) {
    const ObjectMetrics& o = *m.objects;
    os << "objects: " << o.matched << " matched (" << o.gt << " in the ground truth, "
       << o.estimated << " in the map)";
    if (o.matched > 0) {
      os << "\n  corner error mean " << Format("%.4f", o.corner_err.mean) << " m, median "
         << Format("%.4f", o.corner_err.median) << " m; width error mean "
         << Format("%.4f", o.width_err.mean) << " m, max " << Format("%.4f", o.width_err.max)
         << " m; height error mean " << Format("%.4f", o.height_err.mean) << " m, max "
         << Format("%.4f", o.height_err.max) << " m";
      os << "\n  classes right " << o.classes_right << "/" << o.matched;
      std::string wrong;
      for (const ObjectError& e : o.per_object)
        if (!e.class_right)
          wrong += " " + std::to_string(e.id) + " " + e.gt_class + "->" + e.est_class;
      if (!wrong.empty()) os << " (wrong:" << wrong << ")";
    }
    os << "\n" << ObjectIdLine(o);
  }
  if (m.frontend) {
    const FrontendMetrics& f = *m.frontend;
    os << "front end: recall " << (f.recall ? Format("%.4f", *f.recall) : std::string("n/a"))
       << ", precision " << (f.precision ? Format("%.4f", *f.precision) : std::string("n/a"));
    if (f.corner_err_px.count > 0)
      os << ", corner error median " << Format("%.3f", f.corner_err_px.median) << " px";
    if (f.corner_outward_px.count > 0)
      os << " (outwards " << Format("%+.3f", f.corner_outward_px.median) << ")";
    os << ", " << f.id_switches << " id switches";
    if (f.id_switches_per_1000)
      os << " (" << Format("%.2f", *f.id_switches_per_1000) << " per 1000 matches)";
    os << "\n  success " << f.success_frames << "/" << f.success_total
       << (f.success_rate ? " (" + Format("%.4f", *f.success_rate) + ")" : std::string())
       << ", boxes out of view " << f.boxes_out_of_view << ", unmatched rows "
       << f.unmatched_est_rows << ", re-identified " << f.reidentified << "/" << f.returns
       << " returns, " << f.id_map.size() << " track ids over " << f.frames << " frames\n";
    os << WorstTrackedLine(f);
  }
  if (m.runtime) {
    os << "runtime:";
    if (m.runtime->frames) os << " " << Format("%.0f", *m.runtime->frames) << " frames";
    if (m.runtime->wall_s) os << " in " << Format("%.2f", *m.runtime->wall_s) << " s";
    if (m.runtime->realtime_factor)
      os << " (" << Format("%.2f", *m.runtime->realtime_factor) << "x real time)";
    os << "\n";
  }
  for (const std::string& n : m.notes) os << "(" << n << ")\n";
  return os.str();
}

}  // namespace fsp::eval
