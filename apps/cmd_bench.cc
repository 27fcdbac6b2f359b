// fsp bench [--quick] --out DIR: renders the default scene, runs {fsp, fhp} x {window, batch} with
// the gt-corners front end (σ = 1 px), evaluates each run and writes DIR/bench.json and
// DIR/bench.md (a markdown table for the README); then checks the accuracy gate
// (assets/bench/thresholds.yaml) and exits non-zero when an enforced bound is crossed.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_gate.h"
#include "commands.h"
#include "fsp/common/error.h"
#include "fsp/eval/evaluate.h"
#include "fsp/sim/scene.h"
#include "fsp/sim/sequence_writer.h"
#include "pipeline.h"
#include "run_config.h"

#ifndef FSP_ASSETS_DIR
#define FSP_ASSETS_DIR "assets"
#endif

namespace fsp::apps {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

struct BenchArgs {
  bool quick = false;
  std::string out;
  std::string scene = std::string(FSP_ASSETS_DIR) + "/scenes/default_room.yaml";
  std::string thresholds = std::string(FSP_ASSETS_DIR) + "/bench/thresholds.yaml";
  std::string sequence;  // an already rendered sequence (skips rendering)
  std::string config;    // base configuration (default: built-in defaults)
  double quick_duration_s = 20.0;
  double pixel_sigma = 1.0;
};

struct Variant {
  const char* name;
  backend::LandmarkType landmarks;
  backend::EstimatorMode mode;
};
const Variant kVariants[] = {
    {"fsp-window", backend::LandmarkType::kFsp, backend::EstimatorMode::kWindow},
    {"fsp-batch", backend::LandmarkType::kFsp, backend::EstimatorMode::kBatch},
    {"fhp-window", backend::LandmarkType::kFhp, backend::EstimatorMode::kWindow},
    {"fhp-batch", backend::LandmarkType::kFhp, backend::EstimatorMode::kBatch}};

// Trajectory block of one alignment.
eval::Metrics EvaluateWith(const eval::EvalPaths& paths, eval::AlignMode align) {
  eval::EvalOptions options;
  options.trajectory.align = align;
  return eval::Evaluate(paths, options);
}

// One configuration's row of bench.json: the metrics (names as in the gate file) or an "error".
Json RunVariant(const Variant& v, const std::string& sequence, const fs::path& run_dir,
                const RunConfig& base) {
  Json row;
  RunConfig config = base;
  config.estimator.landmarks = v.landmarks;
  config.estimator.mode = v.mode;
  RunRequest request;
  request.source.input = sequence;
  request.frontend = "gt-corners";
  request.out_dir = run_dir.string();
  request.progress = true;
  std::printf("bench: running %s ...\n", v.name);
  std::fflush(stdout);
  RunReport r;
  try {
    r = RunPipeline(request, config);
  } catch (const InputError& e) {
    row["error"] = e.what();
    return row;
  }
  row["run_dir"] = run_dir.string();
  if (!r.summary.init_failure.empty()) {
    row["error"] = "static initialisation refused: " + r.summary.init_failure;
    return row;
  }
  try {
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
    if (se3.objects) {
      const eval::ObjectMetrics& o = *se3.objects;
      row["objects_gt"] = o.gt;
      row["objects_estimated"] = o.estimated;
      row["objects_matched"] = o.matched;
      row["corner_err_mean_m"] = o.corner_err.mean;
      row["corner_err_median_m"] = o.corner_err.median;
      row["width_err_mean_m"] = o.width_err.mean;
      row["width_err_max_m"] = o.width_err.max;
      row["height_err_mean_m"] = o.height_err.mean;
      row["height_err_max_m"] = o.height_err.max;
    }
  } catch (const InputError& e) {
    row["error"] = std::string("evaluation: ") + e.what();
  }
  row["frames"] = r.frames;
  row["keyframes"] = r.keyframes;
  row["objects_non_finite"] = r.objects_non_finite_ids.size();
  row["backend_ms_median"] = r.backend_ms.median;
  row["backend_ms_p90"] = r.backend_ms.p90;
  row["finish_ms"] = r.finish_ms;
  row["wall_s"] = r.wall_s;
  row["realtime_factor"] = r.realtime_factor;
  return row;
}

// "1.23" of VALUE * SCALE, or "-" when the row lacks KEY.
std::string Cell(const Json& row, const char* key, double scale, int decimals) {
  if (!row.contains(key) || !row[key].is_number()) return "-";
  char buf[64];
  const double v = row[key].get<double>() * scale;
  if (std::abs(v) >= 1e5) {
    std::snprintf(buf, sizeof(buf), "%.1e", v);  // a diverged run: keep the table readable
  } else {
    std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  }
  return buf;
}

std::string MarkdownTable(const Json& rows, const Json& meta) {
  std::ostringstream md;
  md << "| config | ATE SE3 [cm] | ATE posyaw [cm] | scale err [%] | RPE [cm/frame] | RPE "
        "[deg/frame] | "
        "corner err mean / median [cm] | width err mean / max [cm] | height err mean / max [cm] | "
        "objects | back end ms/kf median / p90 | real time |\n";
  md << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& [name, row] : rows.items()) {
    md << "| " << name;
    if (row.contains("error")) {
      md << " | error: " << row["error"].get<std::string>() << " |||||||||||\n";
      continue;
    }
    md << " | " << Cell(row, "ate_se3_m", 100, 2) << " | " << Cell(row, "ate_posyaw_m", 100, 2)
       << " | " << Cell(row, "scale_err", 100, 2) << " | " << Cell(row, "rpe_trans_m", 100, 3)
       << " | " << Cell(row, "rpe_rot_deg", 1, 3) << " | " << Cell(row, "corner_err_mean_m", 100, 2)
       << " / " << Cell(row, "corner_err_median_m", 100, 2) << " | "
       << Cell(row, "width_err_mean_m", 100, 2) << " / " << Cell(row, "width_err_max_m", 100, 2)
       << " | " << Cell(row, "height_err_mean_m", 100, 2) << " / "
       << Cell(row, "height_err_max_m", 100, 2) << " | " << Cell(row, "objects_matched", 1, 0)
       << "/" << Cell(row, "objects_gt", 1, 0) << " | " << Cell(row, "backend_ms_median", 1, 2)
       << " / " << Cell(row, "backend_ms_p90", 1, 2) << " | " << Cell(row, "realtime_factor", 1, 1)
       << "x |\n";
  }
  md << "\n" << meta["sequence_note"].get<std::string>() << "\n";
  return md.str();
}

std::string GateTable(const std::vector<GateResult>& results) {
  std::ostringstream md;
  md << "| config | metric | value | bound | target | enforced | result "
        "|\n|---|---|---|---|---|---|---|\n";
  char buf[64];
  for (const GateResult& r : results) {
    const GateCheck& c = r.check;
    const char* op = c.upper ? "<=" : ">=";
    md << "| " << c.config << " | " << c.metric << " | ";
    if (r.value) {
      std::snprintf(buf, sizeof(buf), "%.4g", *r.value);
      md << buf;
    } else {
      md << "missing";
    }
    std::snprintf(buf, sizeof(buf), "%s %.4g", op, c.bound);
    md << " | " << buf << " | ";
    if (c.target) {
      std::snprintf(buf, sizeof(buf), "%s %.4g", op, *c.target);
      md << buf << (r.target_met && *r.target_met ? " (met)" : " (not met)");
    } else {
      md << "-";
    }
    md << " | " << (c.enforced ? "yes" : "no") << " | "
       << (r.pass ? "pass" : (c.enforced ? "FAIL" : "outside")) << " |\n";
  }
  return md.str();
}

void RunBench(const BenchArgs& args) {
  const auto t0 = std::chrono::steady_clock::now();
  // The gate first: a broken thresholds file should not cost a whole benchmark.
  const std::vector<GateCheck> checks = ReadGate(args.thresholds);
  RunConfig base = args.config.empty() ? RunConfig() : ReadRunConfig(args.config);
  base.gt_corners.pixel_sigma = args.pixel_sigma;

  const fs::path out(args.out);
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) throw InputError(args.out + ": cannot create the output folder");

  Json meta;
  std::string sequence = args.sequence;
  if (sequence.empty()) {
    sim::Scene scene = sim::LoadScene(args.scene);
    if (args.quick) scene.duration_s = std::min(scene.duration_s, args.quick_duration_s);
    sim::SequenceOptions options;
    options.video = false;  // gt-corners reads the EuRoC layout; the video is not needed
    sequence = (out / "sequence").string();
    std::printf("bench: rendering %s (%.0f s) into %s ...\n", args.scene.c_str(), scene.duration_s,
                sequence.c_str());
    std::fflush(stdout);
    const sim::SequenceSummary s = sim::WriteSequence(scene, sequence, options);
    meta["scene"] = args.scene;
    meta["duration_s"] = scene.duration_s;
    meta["render_wall_s"] = s.render_wall_s;
    meta["objects"] = s.objects;
    meta["sequence_note"] = "Scene " + fs::path(args.scene).filename().string() + ", " +
                            std::to_string(static_cast<int>(scene.duration_s)) + " s, " +
                            std::to_string(s.frames) + " frames, " + std::to_string(s.objects) +
                            " objects; gt-corners front end, sigma " +
                            std::to_string(args.pixel_sigma).substr(0, 4) + " px; `fsp bench" +
                            (args.quick ? " --quick" : "") + "`.";
  } else {
    meta["sequence_note"] = "Sequence " + sequence + "; gt-corners front end, sigma " +
                            std::to_string(args.pixel_sigma).substr(0, 4) + " px.";
  }
  meta["sequence"] = sequence;
  meta["quick"] = args.quick;
  meta["pixel_sigma"] = args.pixel_sigma;
  meta["seed"] = base.gt_corners.seed;

  Json rows = Json::object();
  for (const Variant& v : kVariants)
    rows[v.name] = RunVariant(v, sequence, out / "runs" / v.name, base);

  const std::vector<GateResult> gate = EvaluateGate(checks, rows);
  const bool pass = GatePasses(gate);
  Json gate_json = Json::array();
  for (const GateResult& r : gate) {
    Json g;
    g["config"] = r.check.config;
    g["metric"] = r.check.metric;
    g["value"] = r.value ? Json(*r.value) : Json();
    g[r.check.upper ? "max" : "min"] = r.check.bound;
    g["target"] = r.check.target ? Json(*r.check.target) : Json();
    g["target_met"] = r.target_met ? Json(*r.target_met) : Json();
    g["enforced"] = r.check.enforced;
    g["pass"] = r.pass;
    gate_json.push_back(g);
  }
  meta["wall_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Json bench;
  bench["meta"] = meta;
  bench["configs"] = rows;
  bench["gate"] = {{"thresholds", args.thresholds}, {"pass", pass}, {"checks", gate_json}};
  {
    std::ofstream f(out / "bench.json");
    f << bench.dump(2) << "\n";
    if (!f) throw InputError((out / "bench.json").string() + ": cannot write");
  }
  const std::string table = MarkdownTable(rows, meta);
  const std::string gate_table = GateTable(gate);
  {
    std::ofstream f(out / "bench.md");
    f << table << "\nAccuracy gate (" << args.thresholds << "):\n\n" << gate_table;
    if (!f) throw InputError((out / "bench.md").string() + ": cannot write");
  }
  std::printf("\n%s\n%s\n", table.c_str(), gate_table.c_str());
  std::printf("bench: wrote %s and %s (%.0f s)\n", (out / "bench.json").c_str(),
              (out / "bench.md").c_str(), meta["wall_s"].get<double>());
  if (!pass) {
    std::fprintf(stderr, "fsp: error: accuracy gate failed (%s): see %s\n", args.thresholds.c_str(),
                 (out / "bench.md").c_str());
    throw CLI::RuntimeError(3);
  }
}

}  // namespace

void AddBenchCommand(CLI::App& root) {
  auto args = std::make_shared<BenchArgs>();
  auto* sub = root.add_subcommand(
      "bench",
      "Benchmark: render the default scene, run {fsp, fhp} x {window, batch} with the gt-corners "
      "front end\n"
      "(sigma 1 px), evaluate each (ATE SE3/posyaw, Sim3 scale, RPE, corner/width/height errors, "
      "back-end time,\n"
      "real-time factor), write DIR/bench.json and DIR/bench.md, and check the accuracy gate\n"
      "(assets/bench/thresholds.yaml): exit 3 when an enforced bound is crossed.");
  sub->add_option("--out", args->out, "output folder (created)")->required();
  sub->add_flag("--quick", args->quick, "a shorter sequence (--quick-duration seconds)");
  sub->add_option("--quick-duration", args->quick_duration_s, "duration of --quick [s]")
      ->check(CLI::PositiveNumber);
  sub->add_option("--scene", args->scene, "scene file to render")->default_str(args->scene);
  sub->add_option("--sequence", args->sequence,
                  "use this rendered sequence instead of rendering one");
  sub->add_option("--thresholds", args->thresholds, "accuracy gate file")
      ->default_str(args->thresholds);
  sub->add_option("--config", args->config, "base run configuration (YAML, as for fsp run)");
  sub->add_option("--pixel-sigma", args->pixel_sigma,
                  "corner noise of the gt-corners front end [px]")
      ->check(CLI::NonNegativeNumber);
  sub->callback([args] { RunBench(*args); });
}

}  // namespace fsp::apps
