// fsp eval --gt DATASET_OR_FILE --est RUN_DIR_OR_FILE [--align se3|posyaw|sim3] [--out metrics.json]:
// trajectory, map, front-end and runtime metrics of a run against ground truth (CONTRACT.md "Metrics").
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "commands.h"
#include "eval_plot.h"
#include "fsp/common/error.h"
#include "fsp/eval/evaluate.h"

namespace fsp::apps {

namespace {

struct EvalArgs {
  std::string gt;
  std::string est;
  std::string align = "se3";
  std::string out;
  double t_max_diff = 0.01;
  double t_offset = 0.0;
  double match_gate_px = 20.0;
};

void RunEval(const EvalArgs& args) {
  eval::EvalOptions options;
  if (!eval::ParseAlignMode(args.align, &options.trajectory.align)) {
    throw InputError("--align must be se3, posyaw or sim3, got '" + args.align + "'");
  }
  options.trajectory.association.max_diff_s = args.t_max_diff;
  options.trajectory.association.offset_s = args.t_offset;
  options.frontend.match_gate_px = args.match_gate_px;
  std::string why;
  if (!options.Check(&why)) throw InputError(why);

  const eval::Metrics metrics = eval::Evaluate(eval::ResolvePaths(args.gt, args.est), options);
  std::fputs(eval::FormatSummary(metrics).c_str(), stdout);
  if (!args.out.empty()) {
    const std::filesystem::path out(args.out);
    if (out.has_parent_path()) {
      std::error_code ec;
      std::filesystem::create_directories(out.parent_path(), ec);
      if (ec) throw InputError(args.out, 0, "cannot create its folder (" + ec.message() + ")");
    }
    std::ofstream file(args.out);
    if (!file) throw InputError(args.out, 0, "cannot write metrics");
    file << eval::ToJson(metrics).dump(2) << "\n";
    if (!file) throw InputError(args.out, 0, "error while writing metrics");
    std::printf("metrics written to %s\n", args.out.c_str());
    if (metrics.trajectory) {
      const std::string png = (out.has_parent_path() ? out.parent_path() / "eval_top_view.png"
                                                     : std::filesystem::path("eval_top_view.png")).string();
      WriteEvalTopView(metrics, png);
      std::printf("top view written to %s\n", png.c_str());
    }
  }
}

}  // namespace

void AddEvalCommand(CLI::App& root) {
  auto args = std::make_shared<EvalArgs>();
  auto* sub = root.add_subcommand(
      "eval",
      "Accuracy of a run against ground truth: ATE after alignment and RPE over consecutive frames (pairs\n"
      "associated by nearest timestamp within 0.01 s, as evo does), object corner/size errors, front-end\n"
      "recall/precision/corner error/id switches, and runtime. With --out, writes metrics.json and, beside\n"
      "it, eval_top_view.png (ground truth vs aligned estimate, trajectory and objects).");
  sub->add_option("--gt", args->gt,
                  "Ground truth: a TUM file, a EuRoC ground-truth csv, or a sequence folder (EuRoC layout with\n"
                  "mav0/state_groundtruth_estimate0/data.csv, objects_gt.json, observations_gt.csv)")
      ->required();
  sub->add_option("--est", args->est,
                  "Estimate: a TUM file or a run folder (trajectory.tum, map.json, observations.csv, run.json)")
      ->required();
  sub->add_option("--align", args->align,
                  "Trajectory alignment: se3 (rotation + translation), posyaw (yaw + translation, 4-DoF),\n"
                  "sim3 (also scale; the scale error |s-1| is reported)")
      ->capture_default_str();
  sub->add_option("--out", args->out, "Write the metrics as JSON to this file (e.g. metrics.json)");
  sub->add_option("--t-max-diff", args->t_max_diff, "Largest |dt| of an associated pose pair [s]")
      ->capture_default_str();
  sub->add_option("--t-offset", args->t_offset, "Added to the estimate's timestamps [s] (evo's --t_offset)")
      ->capture_default_str();
  sub->add_option("--match-gate-px", args->match_gate_px,
                  "Largest mean corner distance for a detection to match a ground-truth object [px]")
      ->capture_default_str();
  sub->callback([args] { RunEval(*args); });
}

}  // namespace fsp::apps
