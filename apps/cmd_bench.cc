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
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_gate.h"
#include "bench_jobs.h"
#include "bench_report.h"
#include "bench_suite.h"
#include "commands.h"
#include "fsp/common/error.h"
#include "fsp/sim/cslam_flight.h"
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
  // Real data the suite reads (the C-SLAM logs of `cslam_logs` scenes): --data, else
  // $FSP_TEST_DATA.
  std::string data;
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

// The suite's scenes made from the C-SLAM authors' logs (BenchScene::cslam_logs): converted into
// OUT/scenes/NAME/ (as `fsp convert-cslam`); a scene whose logs are absent is left out of SUITE.
// Returns the scenes left out, {name: why}.
Json PrepareLogScenes(const BenchArgs& args, const fs::path& out, BenchSuite* suite) {
  Json skipped = Json::object();
  std::vector<BenchScene> kept;
  for (BenchScene& scene : suite->scenes) {
    if (scene.cslam_logs.empty()) {
      kept.push_back(scene);
      continue;
    }
    const fs::path logs = fs::path(args.data) / scene.cslam_logs;
    if (args.data.empty() || !fs::exists(logs / "LandmarksGT.log")) {
      const std::string why =
          args.data.empty()
              ? "no data folder (--data or $FSP_TEST_DATA) with " + scene.cslam_logs + "/"
              : (logs / "LandmarksGT.log").string() + " not found";
      skipped[scene.name] = why +
                            ": the C-SLAM authors' LandmarksGT.log and PoseSE3(W)_GT.log "
                            "(github.com/AIRLab-POLIMI/C-SLAM, c_slam_roamfree/scripts/gt/)";
      std::printf("bench: %s skipped: %s\n", scene.name.c_str(),
                  skipped[scene.name].get<std::string>().c_str());
      continue;
    }
    const sim::CslamFlight flight = sim::ReadCslamFlight(logs.string());
    scene.scene = sim::WriteCslamScene(flight, (out / "scenes" / scene.name).string());
    kept.push_back(scene);
  }
  if (kept.empty())
    throw InputError(args.suite + ": no scene left to run (" + skipped.dump() + ")");
  suite->scenes = kept;
  return skipped;
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
  // gt-corners-Spx configurations: the same configuration with their own corner noise.
  const auto config_of = [&](const BenchConfig& c) {
    if (!c.pixel_sigma) return config_path;
    const std::string path = (out / ("config_" + Num(*c.pixel_sigma, 1, 2) + "px.yaml")).string();
    if (!fs::exists(path)) {
      RunConfig own = base;
      own.gt_corners.pixel_sigma = *c.pixel_sigma;
      WriteText(path, ToYaml(own));
    }
    return path;
  };
  const std::string self = SelfExecutable();
  const Json skipped = PrepareLogScenes(args, out, &suite);

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
                    config_of(config)};
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
          spec.row = EvaluateBenchRun(spec.sequence, out, spec.run_dir,
                                      spec.config.frontend != "gt-corners");
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
    if (!scene.reference.empty()) {
      Json ref = Json::object();
      for (const auto& [metric, value] : scene.reference) ref[metric] = value;
      s["reference"] = {{"label", scene.reference_label}, {"metrics", ref}};
    }
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
  metrics["scenes_skipped"] = skipped;
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
  WriteText(out / "report.md", Report({args.quick, args.pixel_sigma, args.thresholds}, metrics,
                                      suite, pngs, plot_line, gate_table, pass));

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
  if (const char* env = std::getenv("FSP_TEST_DATA"); env && *env) args->data = env;
  sub->add_option("--data", args->data,
                  "folder of real data the suite reads (cslam_paper_flight/: the C-SLAM authors' "
                  "logs for the paper's flight); default $FSP_TEST_DATA; scenes whose data is "
                  "absent are skipped");
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
