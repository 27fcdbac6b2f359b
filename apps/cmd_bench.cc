// fsp bench [--quick] --out DIR: the benchmark suite (assets/bench/suite.yaml). Renders each scene
// once per seed, runs every configuration of the scene on each sequence (front end gt-corners, rect
// or apriltag; FSP or FHP landmarks; window or batch), all as child processes of this binary (`fsp
// render`, `fsp run`), at most --jobs at a time; evaluates each run (eval library) and writes its
// series (bench_series.json, for the plots), then DIR/metrics.json, the plots
// (scripts/bench_plots.py through python3 + matplotlib) and DIR/report.md; finally checks the
// accuracy gate (assets/bench/thresholds.yaml) on the seed means and exits 3 when an enforced bound
// is crossed.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_gate.h"
#include "bench_jobs.h"
#include "bench_suite.h"
#include "commands.h"
#include "fsp/common/error.h"
#include "fsp/eval/evaluate.h"
#include "fsp/eval/stats.h"
#include "fsp/sim/scene.h"
#include "pipeline.h"
#include "run_config.h"

#ifndef FSP_ASSETS_DIR
#define FSP_ASSETS_DIR "assets"
#endif
#ifndef FSP_SCRIPTS_DIR
#define FSP_SCRIPTS_DIR "scripts"
#endif

namespace fsp::apps {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

struct BenchArgs {
  bool quick = false;
  std::string out;
  std::string suite = std::string(FSP_ASSETS_DIR) + "/bench/suite.yaml";
  std::string thresholds = std::string(FSP_ASSETS_DIR) + "/bench/thresholds.yaml";
  std::string sequence;  // an already rendered sequence (skips rendering; the first scene only)
  std::string config;    // base configuration (default: built-in defaults)
  double pixel_sigma = 1.0;
  int jobs = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  std::string python = "/usr/bin/python3";
  std::string plot_script = std::string(FSP_SCRIPTS_DIR) + "/bench_plots.py";
  bool no_plots = false;
};

// One `fsp run` of the suite.
struct RunSpec {
  size_t scene = 0;
  unsigned seed = 0;
  BenchConfig config;
  std::string sequence;
  fs::path run_dir;  // relative to --out
  size_t job = 0;
  Json row;  // its metrics (names as in the gate file), or {"error": ...}
};

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

eval::Metrics EvaluateWith(const eval::EvalPaths& paths, eval::AlignMode align) {
  eval::EvalOptions options;
  options.trajectory.align = align;
  return eval::Evaluate(paths, options);
}

Json Xy(const Vec3& p) {
  return Json::array({p.x(), p.y()});
}

Json Corners(const std::array<Vec3, 4>& c) {
  Json a = Json::array();
  for (const Vec3& p : c) a.push_back({p.x(), p.y(), p.z()});
  return a;
}

// What the plots need of one run: the SE3-aligned trajectory against the truth, the per-step RPE,
// the objects (truth and aligned estimate), the per-object and per-corner errors, the stage times.
Json SeriesJson(const eval::Metrics& m, const Json& run_json) {
  Json s;
  if (m.trajectory) {
    const eval::TrajectoryMetrics::Series& t = m.trajectory->series;
    s["t_s"] = t.t_s;
    s["ate_m"] = t.ate;
    s["rpe_trans_m"] = t.rpe_trans;  // step k: from t_s[k] to t_s[k + 1]
    s["rpe_rot_deg"] = t.rpe_rot;
    Json ref = Json::array(), est = Json::array();
    for (const Vec3& p : t.p_ref) ref.push_back(Xy(p));
    for (const Vec3& p : t.p_est_aligned) est.push_back(Xy(p));
    s["xy_ref"] = ref;
    s["xy_est"] = est;
  }
  std::map<int, std::string> classes;
  if (!m.paths.objects_gt.empty()) {
    Json gt = Json::array();
    for (const eval::ObjectRecord& o : eval::ReadObjectsJson(m.paths.objects_gt)) {
      classes[o.id] = o.object_class;
      gt.push_back({{"id", o.id}, {"class", o.object_class}, {"corners_W", Corners(o.corners_W)}});
    }
    s["objects_gt"] = gt;
  }
  if (m.trajectory && !m.paths.map.empty()) {
    Json est = Json::array();
    for (eval::ObjectRecord o : eval::ReadObjectsJson(m.paths.map)) {
      for (Vec3& c : o.corners_W) c = m.trajectory->alignment.Apply(c);
      est.push_back({{"id", o.id}, {"corners_W", Corners(o.corners_W)}});
    }
    s["objects_est"] = est;  // after the SE3 alignment
  }
  if (m.objects) {
    Json per = Json::array();
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

Json ReadJsonFile(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), 0, "cannot open");
  try {
    return Json::parse(in);
  } catch (const Json::parse_error& e) {
    throw InputError(path.string(), 0, std::string("not valid JSON: ") + e.what());
  }
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f) throw InputError(path.string(), 0, "cannot write");
}

// The metrics of one finished run (names as in the gate file), and its series file.
Json EvaluateRun(const RunSpec& spec, const fs::path& out) {
  Json row;
  const fs::path run_dir = out / spec.run_dir;
  const Json run = ReadJsonFile(run_dir / "run.json");
  const eval::EvalPaths paths = eval::ResolvePaths(spec.sequence, run_dir.string());
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
  if (se3.objects) {
    const eval::ObjectMetrics& o = *se3.objects;
    row["objects_gt"] = o.gt;
    row["objects_estimated"] = o.estimated;
    row["objects_matched"] = o.matched;
    if (o.matched > 0) {
      row["corner_err_mean_m"] = o.corner_err.mean;
      row["corner_err_median_m"] = o.corner_err.median;
      row["width_err_mean_m"] = o.width_err.mean;
      row["width_err_max_m"] = o.width_err.max;
      row["height_err_mean_m"] = o.height_err.mean;
      row["height_err_max_m"] = o.height_err.max;
    }
  }
  if (se3.frontend && spec.config.frontend != "gt-corners") {
    const eval::FrontendMetrics& f = *se3.frontend;
    if (f.recall) row["frontend_recall"] = *f.recall;
    if (f.precision) row["frontend_precision"] = *f.precision;
    if (f.corner_err_px.count > 0) row["frontend_corner_err_px_median"] = f.corner_err_px.median;
    if (f.reid_rate) row["frontend_reid_rate"] = *f.reid_rate;
  }
  const auto copy = [&](const char* key, const Json& v) {
    if (v.is_number()) row[key] = v;
  };
  copy("frames", run.value("frames", Json()));
  copy("keyframes", run.value("keyframes", Json()));
  if (run.contains("objects_non_finite") && run["objects_non_finite"].is_array())
    row["objects_non_finite"] = run["objects_non_finite"].size();
  if (run.contains("stage_ms")) {
    const Json& st = run["stage_ms"];
    if (st.contains("frontend")) {
      copy("frontend_ms_median", st["frontend"].value("median", Json()));
      copy("frontend_ms_p90", st["frontend"].value("p90", Json()));
    }
    if (st.contains("backend")) {
      copy("backend_ms_median", st["backend"].value("median", Json()));
      copy("backend_ms_p90", st["backend"].value("p90", Json()));
    }
    copy("finish_ms", st.value("finish", Json()));
  }
  if (run.contains("global")) copy("global_ms_total", run["global"].value("ms_total", Json()));
  copy("wall_s", run.value("wall_s", Json()));
  copy("realtime_factor", run.value("realtime_factor", Json()));
  {
    std::ofstream f(run_dir / "bench_series.json");
    f << SeriesJson(se3, run).dump() << "\n";
    if (!f) throw InputError((run_dir / "bench_series.json").string(), 0, "cannot write");
  }
  row["series"] = (spec.run_dir / "bench_series.json").string();
  return row;
}

// Mean, min and max over the seeds of every numeric metric (eval::ComputeStats: every metric here
// is non-negative).
Json Aggregate(const std::vector<const Json*>& rows) {
  std::map<std::string, std::vector<double>> values;
  std::vector<std::string> order;
  for (const Json* r : rows) {
    if (r->contains("error")) continue;
    for (const auto& [k, v] : r->items()) {
      if (!v.is_number()) continue;
      if (!values.count(k)) order.push_back(k);
      values[k].push_back(v.get<double>());
    }
  }
  Json mean = Json::object(), lo = Json::object(), hi = Json::object();
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

// "MEAN" of KEY, with " (MIN-MAX)" when the seeds differ; "-" when no seed has it.
std::string Cell(const Json& agg, const char* key, double scale, int decimals, bool range = true) {
  const Json& mean = agg["mean"];
  if (!mean.contains(key)) return "-";
  std::string s = Num(mean[key].get<double>(), scale, decimals);
  const std::string lo = Num(agg["min"][key].get<double>(), scale, decimals);
  const std::string hi = Num(agg["max"][key].get<double>(), scale, decimals);
  if (range && lo != hi) s += " (" + lo + "-" + hi + ")";
  return s;
}

// The worst seed's value of KEY (its max).
std::string Worst(const Json& agg, const char* key, double scale, int decimals) {
  if (!agg["max"].contains(key)) return "-";
  return Num(agg["max"][key].get<double>(), scale, decimals);
}

const char* kTableHeader =
    "| config | runs | ATE SE3 [cm] | scale err (Sim3) [%] | RPE [cm / deg per frame] | corner err "
    "mean [cm] | width err mean / max [cm] | height err mean / max [cm] | objects matched | back "
    "end "
    "ms/frame median | real time |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|\n";

std::string SceneTable(const Json& scene) {
  std::ostringstream md;
  md << kTableHeader;
  for (const auto& [name, c] : scene["configs"].items()) {
    const Json& agg = c["aggregate"];
    md << "| " << name << " | " << c["runs_ok"].get<int>() << "/" << c["runs"].size();
    if (c["seeds"] != scene["seeds"]) {  // a configuration on some of the seeds only
      md << " (seed" << (c["seeds"].size() > 1 ? "s" : "");
      for (const auto& seed : c["seeds"]) md << " " << seed.get<unsigned>();
      md << ")";
    }
    md << " | ";
    if (c["runs_ok"].get<int>() == 0) {
      md << "all runs failed (see below) ||||||||\n";
      continue;
    }
    std::string objects = "-";
    if (agg["mean"].contains("objects_matched")) {
      const std::string lo = Num(agg["min"]["objects_matched"].get<double>(), 1, 0);
      const std::string hi = Num(agg["max"]["objects_matched"].get<double>(), 1, 0);
      objects =
          (lo == hi ? lo : lo + "-" + hi) + "/" + Num(agg["max"].value("objects_gt", 0.0), 1, 0);
    }
    md << Cell(agg, "ate_se3_m", 100, 2) << " | " << Cell(agg, "scale_err", 100, 2) << " | "
       << Cell(agg, "rpe_trans_m", 100, 3, false) << " / " << Cell(agg, "rpe_rot_deg", 1, 3, false)
       << " | " << Cell(agg, "corner_err_mean_m", 100, 2) << " | "
       << Cell(agg, "width_err_mean_m", 100, 2, false) << " / "
       << Worst(agg, "width_err_max_m", 100, 2) << " | "
       << Cell(agg, "height_err_mean_m", 100, 2, false) << " / "
       << Worst(agg, "height_err_max_m", 100, 2) << " | " << objects << " | "
       << Cell(agg, "backend_ms_median", 1, 2, false) << " | "
       << Cell(agg, "realtime_factor", 1, 1, false) << "x |\n";
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

bool RunsOn(const BenchConfig& c, unsigned seed) {
  return std::find(c.seeds.begin(), c.seeds.end(), seed) != c.seeds.end();
}

// Expected cost of a job [s on one core], for the order only (measured on the 2-core machine).
double RenderCost(const sim::Scene& scene, double duration_s) {
  const double frames = duration_s * scene.camera_rate_hz;
  const double pixels = static_cast<double>(scene.camera.width * scene.camera.height) / 307200.0;
  return 0.5 + frames * pixels / 30.0;
}
double RunCost(const BenchConfig& c, double duration_s) {
  if (c.mode == backend::EstimatorMode::kBatch) return 0.5 * duration_s * duration_s / 20.0;
  return c.frontend == "gt-corners" ? 0.2 * duration_s : 0.5 * duration_s;
}

// The plots: runs the plotting script; returns the line for report.md and the console.
std::string MakePlots(const BenchArgs& args, const fs::path& out, std::vector<std::string>* pngs) {
  if (args.no_plots) return "Plots: not made (--no-plots).";
  Job job;
  job.argv = {args.python, args.plot_script, (out / "metrics.json").string(),
              (out / "plots").string()};
  job.log = (out / "logs" / "plots.log").string();
  const JobResult r = RunJobs({job}, 1).front();
  const std::string last = LastLine(job.log);
  if (!r.started || r.exit_code == 127)
    return "Plots: not made: " + args.python + " cannot be started (" + last + ").";
  if (r.exit_code == 3) return "Plots: not made: " + last;  // the script's own one line
  if (r.exit_code != 0)
    return "Plots: the plotting script failed (exit " + std::to_string(r.exit_code) + "): " + last +
           " (see logs/plots.log).";
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(out / "plots"))
    if (e.path().extension() == ".png") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& p : files) pngs->push_back(fs::relative(p, out).string());
  return "Plots: " + std::to_string(pngs->size()) + " PNG files in plots/ (" +
         RepoRelative(args.plot_script) + ", matplotlib).";
}

std::string Report(const BenchArgs& args, const Json& metrics, const BenchSuite& suite,
                   const std::vector<std::string>& pngs, const std::string& plot_line,
                   const std::string& gate_table, bool pass) {
  std::ostringstream md;
  const Json& meta = metrics["meta"];
  md << "# FSP-SLAM benchmark" << (args.quick ? " (--quick)" : "") << "\n\n";
  md << "`fsp bench" << (args.quick ? " --quick" : "") << "`: suite `"
     << RepoRelative(meta["suite"].get<std::string>()) << "`, " << meta["runs"].get<int>()
     << " runs on " << meta["sequences"].get<int>() << " rendered sequences, "
     << meta["jobs"].get<int>() << " parallel jobs, " << Num(meta["wall_s"].get<double>(), 1, 0)
     << " s wall. Front end gt-corners: the rendered ground-truth corners plus "
     << Num(args.pixel_sigma, 1, 1)
     << " px noise (the paper's experiment); rect / apriltag: from the rendered images.\n\n";
  md << "Each cell is the mean over the seeds, with (min-max) when they differ; width and height: "
        "mean error / the worst seed's largest error. ATE after SE3 alignment, scale error after "
        "Sim3, RPE over consecutive frames (rmse). Back end: milliseconds per frame (median); real "
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

void RunBench(const BenchArgs& args) {
  const auto t0 = std::chrono::steady_clock::now();
  // The gate and the suite first: a broken file should not cost a whole benchmark.
  const std::vector<GateCheck> checks = ReadGate(args.thresholds);
  BenchSuite suite = ReadBenchSuite(args.suite, args.quick);
  if (!args.sequence.empty()) {
    // One given sequence: the first scene's configurations on it, its first seed.
    suite.scenes.resize(1);
    suite.scenes[0].seeds.resize(1);
    for (BenchConfig& c : suite.scenes[0].configs) c.seeds = suite.scenes[0].seeds;
  }
  RunConfig base = args.config.empty() ? RunConfig() : ReadRunConfig(args.config);
  base.gt_corners.pixel_sigma = args.pixel_sigma;

  const fs::path out(args.out);
  std::error_code ec;
  fs::create_directories(out / "logs", ec);
  if (ec) throw InputError(args.out + ": cannot create the output folder");
  const std::string config_path = (out / "config.yaml").string();
  WriteText(config_path, ToYaml(base));
  const std::string self = SelfExecutable();

  // The jobs: each scene and seed rendered, then each configuration run on it.
  std::vector<Job> jobs;
  std::vector<RunSpec> runs;
  std::vector<std::string> job_names;
  int sequences = 0;
  for (size_t si = 0; si < suite.scenes.size(); ++si) {
    const BenchScene& scene = suite.scenes[si];
    std::optional<sim::Scene> loaded;
    if (args.sequence.empty()) loaded = sim::LoadScene(scene.scene);
    for (unsigned seed : scene.seeds) {
      const std::string tag = scene.name + "_s" + std::to_string(seed);
      std::string sequence = args.sequence;
      int render_job = -1;
      if (sequence.empty()) {
        sequence = (out / "sequences" / tag).string();
        Job render;
        render.argv = {self,
                       "render",
                       scene.scene,
                       "--out",
                       sequence,
                       "--seed",
                       std::to_string(seed),
                       "--duration",
                       Num(scene.duration_s, 1, 3),
                       "--threads",
                       "1",
                       "--no-video"};
        // Images only when a front end reads pixels: gt-corners needs the frame list alone.
        const bool pixels = std::any_of(
            scene.configs.begin(), scene.configs.end(),
            [&](const BenchConfig& c) { return c.frontend != "gt-corners" && RunsOn(c, seed); });
        if (!pixels) render.argv.push_back("--no-images");
        render.log = (out / "logs" / ("render_" + tag + ".log")).string();
        render.cost = pixels ? RenderCost(*loaded, scene.duration_s) : 0.5;
        render_job = static_cast<int>(jobs.size());
        jobs.push_back(render);
        job_names.push_back("render " + tag);
        ++sequences;
      }
      for (const BenchConfig& config : scene.configs) {
        if (!RunsOn(config, seed)) continue;
        RunSpec spec;
        spec.scene = si;
        spec.seed = seed;
        spec.config = config;
        spec.sequence = sequence;
        spec.run_dir = fs::path("runs") / tag / FileSafe(config.name);
        Job run;
        run.argv = {self,
                    "run",
                    sequence,
                    "--out",
                    (out / spec.run_dir).string(),
                    "--frontend",
                    config.frontend,
                    "--landmarks",
                    LandmarkName(config.landmarks),
                    "--mode",
                    ModeName(config.mode),
                    "--seed",
                    std::to_string(seed),
                    "--config",
                    config_path};
        run.log = (out / "logs" / (tag + "_" + FileSafe(config.name) + ".log")).string();
        run.after = render_job;
        run.cost = RunCost(config, scene.duration_s);
        spec.job = jobs.size();
        jobs.push_back(run);
        job_names.push_back(tag + " " + config.name);
        runs.push_back(spec);
      }
    }
  }
  std::printf("bench: %s%s: %d sequences to render, %zu runs, %d parallel jobs; logs in %s\n",
              args.suite.c_str(), args.quick ? " (quick)" : "", sequences, runs.size(), args.jobs,
              (out / "logs").c_str());
  std::fflush(stdout);

  std::map<size_t, size_t> run_of_job;
  for (size_t k = 0; k < runs.size(); ++k) run_of_job[runs[k].job] = k;
  size_t finished = 0;
  std::vector<bool> job_ok(jobs.size(), false);
  const auto on_done = [&](size_t j, const JobResult& r) {
    ++finished;
    job_ok[j] = r.ok();
    std::string what;
    if (r.started && !r.ok()) {
      what = "failed (exit " + std::to_string(r.exit_code) + "): " + LastLine(jobs[j].log);
    } else if (!r.started) {
      const int after = jobs[j].after;
      what = after >= 0 && !job_ok[static_cast<size_t>(after)]
                 ? "not run: its sequence was not rendered"
                 : "not started: " + LastLine(jobs[j].log);
    }
    if (run_of_job.count(j)) {
      RunSpec& spec = runs[run_of_job[j]];
      if (r.ok()) {
        try {
          spec.row = EvaluateRun(spec, out);
        } catch (const std::exception& e) {  // one run's bad output must not stop the suite
          spec.row = {{"error", std::string("evaluation: ") + e.what()}};
        }
      } else {
        spec.row = {{"error", what}};
      }
      spec.row["log"] = fs::relative(jobs[j].log, out).string();
      spec.row["job_wall_s"] = r.wall_s;
      if (r.ok() && spec.row.contains("ate_se3_m"))
        what = "ATE " + Num(spec.row["ate_se3_m"].get<double>(), 100, 2) + " cm";
      else if (r.ok() && spec.row.contains("error"))
        what = spec.row["error"].get<std::string>();
    }
    std::printf("bench: [%zu/%zu] %s: %s%s(%.1f s)\n", finished, jobs.size(), job_names[j].c_str(),
                what.c_str(), what.empty() ? "" : " ", r.wall_s);
    std::fflush(stdout);
  };
  RunJobs(jobs, args.jobs, on_done);

  // Per scene and configuration: the runs by seed and their aggregate.
  Json scenes = Json::object();
  Json gate_rows = Json::object();
  for (size_t si = 0; si < suite.scenes.size(); ++si) {
    const BenchScene& scene = suite.scenes[si];
    Json s;
    s["scene_file"] = args.sequence.empty() ? RepoRelative(scene.scene) : args.sequence;
    s["duration_s"] = scene.duration_s;
    s["seeds"] = scene.seeds;
    s["why"] = scene.why;
    Json configs = Json::object();
    for (const BenchConfig& config : scene.configs) {
      Json c;
      c["frontend"] = config.frontend;
      c["landmarks"] = LandmarkName(config.landmarks);
      c["mode"] = ModeName(config.mode);
      c["seeds"] = config.seeds;
      Json by_seed = Json::object();
      std::vector<const Json*> rows;
      int ok = 0;
      for (const RunSpec& r : runs) {
        if (r.scene != si || r.config.name != config.name) continue;
        by_seed[std::to_string(r.seed)] = r.row;
        rows.push_back(&r.row);
        ok += r.row.contains("error") ? 0 : 1;
      }
      c["runs_ok"] = ok;
      c["runs"] = by_seed;
      c["aggregate"] = Aggregate(rows);
      gate_rows[scene.name][config.name] = c["aggregate"]["mean"];
      configs[config.name] = c;
    }
    s["configs"] = configs;
    scenes[scene.name] = s;
  }
  const std::vector<GateResult> gate = EvaluateGate(checks, gate_rows);
  const bool pass = GatePasses(gate);
  Json gate_json = Json::array();
  for (const GateResult& r : gate) {
    Json g;
    g["scene"] = r.check.scene;
    g["config"] = r.check.config;
    g["metric"] = r.check.metric;
    g["value"] = r.value ? Json(*r.value) : Json();
    g[r.check.upper ? "max" : "min"] = r.check.bound;
    g["target"] = r.check.target ? Json(*r.check.target) : Json();
    g["target_met"] = r.target_met ? Json(*r.target_met) : Json();
    g["enforced"] = r.check.enforced;
    g["skipped"] = r.skipped;
    g["pass"] = r.pass;
    gate_json.push_back(g);
  }
  Json metrics;
  Json meta;
  meta["suite"] = args.suite;
  meta["quick"] = args.quick;
  meta["jobs"] = args.jobs;
  meta["runs"] = static_cast<int>(runs.size());
  meta["sequences"] = sequences;
  meta["pixel_sigma"] = args.pixel_sigma;
  meta["config"] = args.config.empty() ? "defaults" : args.config;
  meta["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  metrics["meta"] = meta;
  metrics["scenes"] = scenes;
  metrics["gate"] = {{"thresholds", args.thresholds}, {"pass", pass}, {"checks", gate_json}};
  WriteJson(metrics, (out / "metrics.json").string());

  std::vector<std::string> pngs;
  const std::string plot_line = MakePlots(args, out, &pngs);
  metrics["meta"]["wall_s"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  metrics["plots"] = pngs;
  metrics["plots_note"] = plot_line;
  WriteJson(metrics, (out / "metrics.json").string());
  const std::string gate_table = GateTable(gate);
  WriteText(out / "report.md", Report(args, metrics, suite, pngs, plot_line, gate_table, pass));

  for (const auto& [name, scene] : metrics["scenes"].items())
    std::printf("\n%s (%s s):\n%s", name.c_str(),
                Num(scene["duration_s"].get<double>(), 1, 0).c_str(), SceneTable(scene).c_str());
  std::printf("\n%s\n\n%s\n", plot_line.c_str(), gate_table.c_str());
  std::printf("bench: wrote %s, %s (%.0f s)\n", (out / "report.md").c_str(),
              (out / "metrics.json").c_str(), metrics["meta"]["wall_s"].get<double>());
  if (!pass) {
    std::fprintf(stderr, "fsp: error: accuracy gate failed (%s): see %s\n", args.thresholds.c_str(),
                 (out / "report.md").c_str());
    throw CLI::RuntimeError(3);
  }
}

}  // namespace

void AddBenchCommand(CLI::App& root) {
  auto args = std::make_shared<BenchArgs>();
  auto* sub = root.add_subcommand(
      "bench",
      "Benchmark suite (assets/bench/suite.yaml): renders each scene once per seed and runs each "
      "of\n"
      "its configurations (front end gt-corners / rect / apriltag, FSP / FHP landmarks, window /\n"
      "batch) as child processes (`fsp render`, `fsp run`), at most --jobs at a time; evaluates "
      "every\n"
      "run and writes DIR/report.md (a table per scene, seeds aggregated: mean (min-max)),\n"
      "DIR/metrics.json, DIR/plots/*.png (top view, RPE per step, corner and size errors per "
      "object,\n"
      "time per stage; python3 + matplotlib) and DIR/runs, DIR/sequences, DIR/logs. Then checks "
      "the\n"
      "accuracy gate (assets/bench/thresholds.yaml) on the seed means: exit 3 when an enforced "
      "bound\n"
      "is crossed.");
  sub->add_option("--out", args->out, "output folder (created)")->required();
  sub->add_flag("--quick", args->quick,
                "the suite's quick part (shorter sequences, fewer seeds and configurations; a few "
                "minutes on 2 cores)");
  sub->add_option("--suite", args->suite, "suite file")->default_str(args->suite);
  sub->add_option("--jobs,-j", args->jobs, "child processes at a time (default: the cores)")
      ->check(CLI::Range(1, 256));
  sub->add_option("--sequence", args->sequence,
                  "run the first scene's configurations on this rendered sequence (its first seed) "
                  "instead of rendering the suite");
  sub->add_option("--thresholds", args->thresholds, "accuracy gate file")
      ->default_str(args->thresholds);
  sub->add_option("--config", args->config, "base run configuration (YAML, as for fsp run)");
  sub->add_option("--pixel-sigma", args->pixel_sigma,
                  "corner noise of the gt-corners front end [px]")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--python", args->python,
                  "the python3 with matplotlib that draws the plots (Debian's python3-matplotlib)")
      ->default_str(args->python);
  sub->add_flag("--no-plots", args->no_plots, "write report.md and metrics.json without plots");
  sub->callback([args] { RunBench(*args); });
}

}  // namespace fsp::apps
