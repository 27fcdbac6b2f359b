#include "bench_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "fsp/common/error.h"
#include "fsp/eval/evaluate.h"
#include "fsp/eval/stats.h"

#ifndef FSP_ASSETS_DIR
#define FSP_ASSETS_DIR "assets"
#endif

namespace fsp::apps {

namespace fs = std::filesystem;

namespace {

eval::Metrics EvaluateWith(const eval::EvalPaths& paths, eval::AlignMode align) {
  eval::EvalOptions options;
  options.trajectory.align = align;
  return eval::Evaluate(paths, options);
}

BenchJson Xy(const Vec3& p) {
  return BenchJson::array({p.x(), p.y()});
}

BenchJson Corners(const std::array<Vec3, 4>& c) {
  BenchJson a = BenchJson::array();
  for (const Vec3& p : c) a.push_back({p.x(), p.y(), p.z()});
  return a;
}

// What the plots need of one run: the SE3-aligned trajectory against the truth, the per-step RPE,
// the objects (truth and aligned estimate), the per-object and per-corner errors, the stage times.
BenchJson SeriesJson(const eval::Metrics& m, const BenchJson& run_json) {
  BenchJson s;
  if (m.trajectory) {
    const eval::TrajectoryMetrics::Series& t = m.trajectory->series;
    s["t_s"] = t.t_s;
    s["ate_m"] = t.ate;
    s["rpe_trans_m"] = t.rpe_trans;  // step k: from t_s[k] to t_s[k + 1]
    s["rpe_rot_deg"] = t.rpe_rot;
    BenchJson ref = BenchJson::array(), est = BenchJson::array();
    for (const Vec3& p : t.p_ref) ref.push_back(Xy(p));
    for (const Vec3& p : t.p_est_aligned) est.push_back(Xy(p));
    s["xy_ref"] = ref;
    s["xy_est"] = est;
  }
  std::map<int, std::string> classes;
  if (!m.paths.objects_gt.empty()) {
    BenchJson gt = BenchJson::array();
    for (const eval::ObjectRecord& o : eval::ReadObjectsJson(m.paths.objects_gt)) {
      classes[o.id] = o.object_class;
      gt.push_back({{"id", o.id}, {"class", o.object_class}, {"corners_W", Corners(o.corners_W)}});
    }
    s["objects_gt"] = gt;
  }
  if (m.trajectory && !m.paths.map.empty()) {
    BenchJson est = BenchJson::array();
    for (eval::ObjectRecord o : eval::ReadObjectsJson(m.paths.map)) {
      for (Vec3& c : o.corners_W) c = m.trajectory->alignment.Apply(c);
      est.push_back({{"id", o.id}, {"corners_W", Corners(o.corners_W)}});
    }
    s["objects_est"] = est;  // after the SE3 alignment
  }
  if (m.objects) {
    BenchJson per = BenchJson::array();
    for (const eval::ObjectError& e : m.objects->per_object) {
      per.push_back({{"id", e.id},
                     {"class", classes.count(e.id) ? classes[e.id] : ""},
                     {"est_id", e.est_id},
                     {"corner_err_m", e.corner_err_m},
                     {"width_err_m", e.width_err_m},
                     {"height_err_m", e.height_err_m}});
    }
    s["per_object"] = per;
  }
  if (run_json.contains("stage_ms")) s["stage_ms"] = run_json["stage_ms"];
  return s;
}

// "MEAN" of KEY, with " (MIN-MAX)" when the seeds differ; "-" when no seed has it.
std::string Cell(const BenchJson& agg, const char* key, double scale, int decimals,
                 bool range = true) {
  const BenchJson& mean = agg["mean"];
  if (!mean.contains(key)) return "-";
  std::string s = Num(mean[key].get<double>(), scale, decimals);
  const std::string lo = Num(agg["min"][key].get<double>(), scale, decimals);
  const std::string hi = Num(agg["max"][key].get<double>(), scale, decimals);
  if (range && lo != hi) s += " (" + lo + "-" + hi + ")";
  return s;
}

// The worst seed's value of KEY (its max).
std::string Worst(const BenchJson& agg, const char* key, double scale, int decimals) {
  if (!agg["max"].contains(key)) return "-";
  return Num(agg["max"][key].get<double>(), scale, decimals);
}

const char* kTableHeader =
    "| config | runs | ATE SE3 [cm] | causal ATE [cm] | scale err (Sim3) [%] | RPE [cm / deg per "
    "frame] | corner err mean [cm] | width err mean / max [cm] | height err mean / max [cm] | "
    "objects matched | front end ms/frame median / p90 | back end ms/frame median | real time |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";

}  // namespace

// PATH relative to the repository when it lies inside it, else as it is.
std::string RepoRelative(const std::string& path) {
  const fs::path repo = fs::path(FSP_ASSETS_DIR).parent_path();
  const std::string rel = fs::path(path).lexically_relative(repo).string();
  return rel.empty() || rel.rfind("..", 0) == 0 ? path : rel;
}

std::string FileSafe(std::string s) {
  std::replace(s.begin(), s.end(), '/', '_');
  return s;
}

BenchJson ReadJsonFile(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), 0, "cannot open");
  try {
    return BenchJson::parse(in);
  } catch (const BenchJson::parse_error& e) {
    throw InputError(path.string(), 0, std::string("not valid JSON: ") + e.what());
  }
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f) throw InputError(path.string(), 0, "cannot write");
}

BenchJson EvaluateBenchRun(const std::string& sequence, const fs::path& out,
                           const fs::path& run_dir_rel, bool pixels) {
  BenchJson row;
  const fs::path run_dir = out / run_dir_rel;
  const BenchJson run = ReadJsonFile(run_dir / "run.json");
  const eval::EvalPaths paths = eval::ResolvePaths(sequence, run_dir.string());
  const eval::Metrics se3 = EvaluateWith(paths, eval::AlignMode::kSe3);
  const eval::Metrics posyaw = EvaluateWith(paths, eval::AlignMode::kPosYaw);
  const eval::Metrics sim3 = EvaluateWith(paths, eval::AlignMode::kSim3);
  if (se3.trajectory) {
    row["pairs"] = se3.trajectory->pairs;
    row["ate_se3_m"] = se3.trajectory->ate.rmse;
    row["rpe_trans_m"] = se3.trajectory->rpe_trans.rmse;
    row["rpe_rot_deg"] = se3.trajectory->rpe_rot.rmse;
  }
  if (posyaw.trajectory) row["ate_posyaw_m"] = posyaw.trajectory->ate.rmse;
  if (sim3.trajectory) {
    row["ate_sim3_m"] = sim3.trajectory->ate.rmse;
    row["scale_err"] = sim3.trajectory->scale_error;
  }
  // The estimator's own scale σ and variance factor (FSP with a mapped object; absent otherwise),
  // and the Sim3 scale error in units of that σ: what makes the σ honest or not.
  if (run.contains("estimator") && run["estimator"].is_object()) {
    const BenchJson& est = run["estimator"];
    const double sigma = est.value("scale_sigma", -1.0);
    if (sigma > 0.0) {
      row["scale_sigma"] = sigma;
      if (sim3.trajectory) row["scale_err_sigmas"] = sim3.trajectory->scale_error / sigma;
    }
    const double vf = est.value("variance_factor", -1.0);
    if (vf >= 0.0) row["variance_factor"] = vf;
  }
  // The causal estimate (what a live user had at each frame), when the run wrote one.
  if (fs::exists(run_dir / "trajectory_online.tum")) {
    eval::EvalPaths causal;
    causal.gt_trajectory = paths.gt_trajectory;
    causal.est_trajectory = (run_dir / "trajectory_online.tum").string();
    const eval::Metrics c = EvaluateWith(causal, eval::AlignMode::kSe3);
    if (c.trajectory) row["ate_causal_se3_m"] = c.trajectory->ate.rmse;
  }
  if (se3.objects) {
    const eval::ObjectMetrics& o = *se3.objects;
    row["objects_gt"] = o.gt;
    row["objects_estimated"] = o.estimated;
    row["objects_matched"] = o.matched;
    // Classes say something only from pixels (gt-corners runs take the ground truth's).
    if (pixels) {
      row["objects_classes_right"] = o.classes_right;
      row["objects_classes_wrong"] = o.matched - o.classes_right;
    }
    if (o.matched > 0) {
      row["corner_err_mean_m"] = o.corner_err.mean;
      row["corner_err_median_m"] = o.corner_err.median;
      row["width_err_mean_m"] = o.width_err.mean;
      row["width_err_max_m"] = o.width_err.max;
      row["height_err_mean_m"] = o.height_err.mean;
      row["height_err_max_m"] = o.height_err.max;
    }
  }
  if (se3.frontend && pixels) {
    const eval::FrontendMetrics& f = *se3.frontend;
    if (f.recall) row["frontend_recall"] = *f.recall;
    if (f.precision) row["frontend_precision"] = *f.precision;
    if (f.corner_err_px.count > 0) row["frontend_corner_err_px_median"] = f.corner_err_px.median;
    if (f.reid_rate) row["frontend_reid_rate"] = *f.reid_rate;
  }
  const auto copy = [&](const char* key, const BenchJson& v) {
    if (v.is_number()) row[key] = v;
  };
  copy("frames", run.value("frames", BenchJson()));
  copy("keyframes", run.value("keyframes", BenchJson()));
  if (run.contains("objects_non_finite") && run["objects_non_finite"].is_array())
    row["objects_non_finite"] = run["objects_non_finite"].size();
  if (run.contains("stage_ms")) {
    const BenchJson& st = run["stage_ms"];
    if (st.contains("frontend")) {
      copy("frontend_ms_median", st["frontend"].value("median", BenchJson()));
      copy("frontend_ms_p90", st["frontend"].value("p90", BenchJson()));
    }
    if (st.contains("backend")) {
      copy("backend_ms_median", st["backend"].value("median", BenchJson()));
      copy("backend_ms_p90", st["backend"].value("p90", BenchJson()));
    }
    copy("finish_ms", st.value("finish", BenchJson()));
  }
  if (run.contains("global")) copy("global_ms_total", run["global"].value("ms_total", BenchJson()));
  copy("wall_s", run.value("wall_s", BenchJson()));
  copy("realtime_factor", run.value("realtime_factor", BenchJson()));
  {
    std::ofstream f(run_dir / "bench_series.json");
    f << SeriesJson(se3, run).dump() << "\n";
    if (!f) throw InputError((run_dir / "bench_series.json").string(), 0, "cannot write");
  }
  row["series"] = (run_dir_rel / "bench_series.json").string();
  return row;
}

// Mean, min and max over the seeds of every numeric metric (eval::ComputeStats: every metric here
// is non-negative).
BenchJson Aggregate(const std::vector<const BenchJson*>& rows) {
  std::map<std::string, std::vector<double>> values;
  std::vector<std::string> order;
  for (const BenchJson* r : rows) {
    if (r->contains("error")) continue;
    for (const auto& [k, v] : r->items()) {
      if (!v.is_number()) continue;
      if (!values.count(k)) order.push_back(k);
      values[k].push_back(v.get<double>());
    }
  }
  BenchJson mean = BenchJson::object(), lo = BenchJson::object(), hi = BenchJson::object();
  for (const std::string& k : order) {
    const eval::ErrorStats st = eval::ComputeStats(values[k]);
    mean[k] = st.mean;
    lo[k] = st.min;
    hi[k] = st.max;
  }
  return {{"mean", mean}, {"min", lo}, {"max", hi}};
}

std::string Num(double v, double scale, int decimals) {
  char buf[64];
  v *= scale;
  if (!std::isfinite(v)) return "nan";
  if (std::abs(v) >= 1e5) {
    std::snprintf(buf, sizeof(buf), "%.1e", v);  // a diverged run: keep the table readable
  } else {
    std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  }
  return buf;
}

namespace {

// The metric columns of a table row (after "config | runs"), from an Aggregate.
std::string Columns(const BenchJson& agg, const std::string& objects) {
  std::ostringstream md;
  md << Cell(agg, "ate_se3_m", 100, 2) << " | " << Cell(agg, "ate_causal_se3_m", 100, 2) << " | "
     << Cell(agg, "scale_err", 100, 2) << " | " << Cell(agg, "rpe_trans_m", 100, 3, false) << " / "
     << Cell(agg, "rpe_rot_deg", 1, 3, false) << " | " << Cell(agg, "corner_err_mean_m", 100, 2)
     << " | " << Cell(agg, "width_err_mean_m", 100, 2, false) << " / "
     << Worst(agg, "width_err_max_m", 100, 2) << " | "
     << Cell(agg, "height_err_mean_m", 100, 2, false) << " / "
     << Worst(agg, "height_err_max_m", 100, 2) << " | " << objects << " | "
     << Cell(agg, "frontend_ms_median", 1, 2, false) << " / "
     << Cell(agg, "frontend_ms_p90", 1, 2, false) << " | "
     << Cell(agg, "backend_ms_median", 1, 2, false) << " | "
     << Cell(agg, "realtime_factor", 1, 1, false)
     << (agg["mean"].contains("realtime_factor") ? "x" : "") << " |\n";
  return md.str();
}

}  // namespace

std::string SceneTable(const BenchJson& scene) {
  std::ostringstream md;
  md << kTableHeader;
  for (const auto& [name, c] : scene["configs"].items()) {
    const BenchJson& agg = c["aggregate"];
    md << "| " << name << " | " << c["runs_ok"].get<int>() << "/" << c["runs"].size();
    if (c["seeds"] != scene["seeds"]) {  // a configuration on some of the seeds only
      md << " (seed" << (c["seeds"].size() > 1 ? "s" : "");
      for (const auto& seed : c["seeds"]) md << " " << seed.get<unsigned>();
      md << ")";
    }
    md << " | ";
    if (c["runs_ok"].get<int>() == 0) {
      md << "all runs failed (see below) ||||||||||\n";
      continue;
    }
    std::string objects = "-";
    if (agg["mean"].contains("objects_matched")) {
      const std::string lo = Num(agg["min"]["objects_matched"].get<double>(), 1, 0);
      const std::string hi = Num(agg["max"]["objects_matched"].get<double>(), 1, 0);
      objects =
          (lo == hi ? lo : lo + "-" + hi) + "/" + Num(agg["max"].value("objects_gt", 0.0), 1, 0);
      if (agg["min"].contains("objects_classes_right"))
        objects +=
            ", classes right " + Num(agg["min"]["objects_classes_right"].get<double>(), 1, 0);
    }
    md << Columns(agg, objects);
  }
  // A published result beside ours: its metrics in the same columns.
  if (scene.contains("reference")) {
    const BenchJson& ref = scene["reference"];
    const BenchJson m = ref["metrics"];
    md << "| " << ref["label"].get<std::string>() << " | published | "
       << Columns({{"mean", m}, {"min", m}, {"max", m}}, "-");
  }
  return md.str();
}

std::string GateTable(const std::vector<GateResult>& results) {
  std::ostringstream md;
  md << "| scene | config | metric (seed mean) | value | bound | target | enforced | result "
        "|\n|---|---|---|---|---|---|---|---|\n";
  char buf[64];
  for (const GateResult& r : results) {
    const GateCheck& c = r.check;
    const char* op = c.upper ? "<=" : ">=";
    md << "| " << c.scene << " | " << c.config << " | " << c.metric << " | ";
    if (r.value) {
      std::snprintf(buf, sizeof(buf), "%.4g", *r.value);
      md << buf;
    } else {
      md << (r.skipped ? "not run" : "missing");
    }
    std::snprintf(buf, sizeof(buf), "%s %.4g", op, c.bound);
    md << " | " << buf << " | ";
    if (c.target) {
      std::snprintf(buf, sizeof(buf), "%s %.4g", op, *c.target);
      md << buf << (r.target_met ? (*r.target_met ? " (met)" : " (not met)") : "");
    } else {
      md << "-";
    }
    md << " | " << (c.enforced ? "yes" : "no") << " | "
       << (r.skipped ? "skipped"
           : r.pass  ? "pass"
                     : (c.enforced ? "FAIL" : "outside"))
       << " |\n";
  }
  return md.str();
}

std::string ScaleSigmaTable(const BenchJson& metrics) {
  std::ostringstream md;
  int runs = 0, within = 0, without_sigma = 0;
  std::ostringstream rows;
  for (const auto& [scene, sc] : metrics["scenes"].items()) {
    for (const auto& [config, c] : sc["configs"].items()) {
      for (const auto& [seed, r] : c["runs"].items()) {
        if (r.contains("error") || !r.contains("scale_err")) continue;
        if (!r.contains("scale_err_sigmas")) {
          ++without_sigma;
          continue;
        }
        const double k = r["scale_err_sigmas"].get<double>();
        ++runs;
        within += k <= 3.0;
        rows << "| " << scene << " | " << config << " | " << seed << " | "
             << Num(r["scale_err"].get<double>(), 100, 2) << " | "
             << Num(r["scale_sigma"].get<double>(), 100, 2) << " | " << Num(k, 1, 1) << " | "
             << (r.contains("variance_factor") ? Num(r["variance_factor"].get<double>(), 1, 2)
                                               : "-")
             << " | " << (k <= 3.0 ? "yes" : "**no**") << " |\n";
      }
    }
  }
  if (runs == 0) return "";
  md << "## Scale error against its sigma\n\n"
     << "Every run whose estimator reports a scale sigma (`run.json` `estimator.scale_sigma`: FSP "
        "with mapped objects, scaled by the final solve's sigma0 when its variance factor is "
        "above 1): the Sim3 scale error in units of that sigma. "
     << within << " of " << runs << " runs within 3 sigma";
  if (without_sigma > 0)
    md << "; " << without_sigma << " runs report no sigma (FHP: no metric size, no scale sigma)";
  md << ".\n\n| scene | config | seed | scale err [%] | scale sigma [%] | err / sigma | variance "
        "factor | within 3 sigma |\n|---|---|---|---|---|---|---|---|\n"
     << rows.str() << "\n";
  return md.str();
}

std::string Report(const ReportInfo& args, const BenchJson& metrics, const BenchSuite& suite,
                   const std::vector<std::string>& pngs, const std::string& plot_line,
                   const std::string& gate_table, bool pass) {
  std::ostringstream md;
  const BenchJson& meta = metrics["meta"];
  md << "# FSP-SLAM benchmark" << (args.quick ? " (--quick)" : "") << "\n\n";
  md << "`fsp bench" << (args.quick ? " --quick" : "") << "`: suite `"
     << RepoRelative(meta["suite"].get<std::string>()) << "`, " << meta["runs"].get<int>()
     << " runs on " << meta["sequences"].get<int>() << " rendered sequences, "
     << meta["jobs"].get<int>() << " parallel jobs, " << Num(meta["wall_s"].get<double>(), 1, 0)
     << " s wall. Front end gt-corners: the rendered ground-truth corners plus "
     << Num(args.pixel_sigma, 1, 1)
     << " px noise (the paper's experiment); rect / apriltag: from the rendered images.\n\n";
  md << "Each cell is the mean over the seeds, with (min-max) when they differ; width and height: "
        "mean error / the worst seed's largest error. ATE after SE3 alignment (causal: the "
        "estimate each frame had when it was processed, trajectory_online.tum), scale error after "
        "Sim3, RPE over consecutive frames (rmse). Front end and back end: milliseconds per frame "
        "(median, and the front end's 90th percentile: the frames the detector runs on); real "
        "time: sequence duration / wall time of the run (runs share the machine: compare within "
        "one table).\n\n";
  md << "Why this matrix: each scene's line below, and the comments of the suite file (not every "
        "cross product is run: batch is too slow on the long flight, images are slow to "
        "render).\n\n";
  const auto embed = [&](const std::string& name, const std::string& alt) {
    for (const std::string& p : pngs)
      if (fs::path(p).filename() == name) md << "![" << alt << "](" << p << ")\n\n";
  };
  size_t i = 0;
  for (const auto& [name, scene] : metrics["scenes"].items()) {
    const BenchScene& s = suite.scenes[i++];
    md << "## " << name << "\n\n";
    md << "`" << scene["scene_file"].get<std::string>() << "`, "
       << Num(scene["duration_s"].get<double>(), 1, 0) << " s, seed"
       << (s.seeds.size() > 1 ? "s" : "");
    for (size_t k = 0; k < s.seeds.size(); ++k) md << (k ? ", " : " ") << s.seeds[k];
    md << ". Why: " << s.why << ".\n\n";
    md << SceneTable(scene) << "\n";
    const std::string base = FileSafe(name);
    embed(base + "_top_view.png", name + ": top view");
    embed(base + "_rpe.png", name + ": relative error per step (Fig. 3)");
    embed(base + "_corners.png", name + ": corner error per corner (Fig. 4)");
    embed(base + "_sizes.png", name + ": width and height error per object (Fig. 5)");
    embed(base + "_timing.png", name + ": time per stage");
    md << "\n";
    bool header = false;
    for (const auto& [config, c] : scene["configs"].items()) {
      for (const auto& [seed, r] : c["runs"].items()) {
        if (!r.contains("error")) continue;
        if (!header) md << "Failed runs:\n\n";
        header = true;
        md << "- " << config << ", seed " << seed << ": " << r.at("error").get<std::string>();
        if (r.contains("log") && r.at("log").is_string())
          md << " (" << r.at("log").get<std::string>() << ")";
        md << "\n";
      }
    }
    if (header) md << "\n";
  }
  if (metrics.contains("scenes_skipped") && !metrics["scenes_skipped"].empty()) {
    md << "## Scenes not run\n\n";
    for (const auto& [name, why] : metrics["scenes_skipped"].items())
      md << "- " << name << ": " << why.get<std::string>() << "\n";
    md << "\n";
  }
  md << ScaleSigmaTable(metrics);
  md << "## Plots\n\n" << plot_line << "\n\n";
  md << "Per scene (the first seed of each configuration): `*_top_view.png` the trajectory and the "
        "map from above against the ground truth (SE3-aligned); `*_rpe.png` the relative "
        "translation and rotation error per step, FSP against FHP (the paper's Fig. 3); "
        "`*_corners.png` the 3D error of every corner of every matched object (Fig. 4); "
        "`*_sizes.png` the width and height error per object (Fig. 5); `*_timing.png` the time per "
        "stage and frame.\n\n";
  md << "## Accuracy gate\n\n`" << RepoRelative(args.thresholds)
     << "` on the seed means: " << (pass ? "**pass**" : "**FAIL**") << ".\n\n"
     << gate_table;
  return md.str();
}

}  // namespace fsp::apps
