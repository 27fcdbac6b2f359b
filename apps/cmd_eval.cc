// fsp eval --gt DATASET_OR_FILE --est RUN_DIR_OR_FILE [--align se3|posyaw|sim3] [--out
// metrics.json]: trajectory, map, front-end and runtime metrics of a run against ground truth
// (field names in docs/outputs.md).
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
  double success_px = 2.0;
  int return_gap_frames = 10;
  double object_gate_m = 0.5;
};

void RunEval(const EvalArgs& args) {
  eval::EvalOptions options;
  if (!eval::ParseAlignMode(args.align, &options.trajectory.align)) {
    throw InputError("--align must be se3, posyaw or sim3, got '" + args.align + "'");
  }
  options.trajectory.association.max_diff_s = args.t_max_diff;
  options.trajectory.association.offset_s = args.t_offset;
  options.frontend.match_gate_px = args.match_gate_px;
  options.frontend.success_px = args.success_px;
  options.frontend.return_gap_frames = args.return_gap_frames;
  options.objects.match_gate_m = args.object_gate_m;
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
                                                     : std::filesystem::path("eval_top_view.png"))
                                  .string();
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
      "Accuracy of a run against ground truth: ATE after alignment and RPE over consecutive\n"
      "frames (pairs associated by nearest timestamp within 0.01 s, as evo does), object\n"
      "corner/size errors, front-end recall/precision/corner error/id switches (and, for a\n"
      "tracker's own ids, the id map, success rate, boxes out of view and re-identification),\n"
      "and runtime. Map objects are matched to ground-truth objects by geometry (mean corner\n"
      "distance after the trajectory alignment), not by id. With --out, writes metrics.json\n"
      "and, beside it, eval_top_view.png (ground truth vs aligned estimate, trajectory and\n"
      "objects).");
  sub->add_option(
         "--gt", args->gt,
         "Ground truth: a TUM file, a EuRoC ground-truth csv, or a sequence folder (EuRoC layout\n"
         "with mav0/state_groundtruth_estimate0/data.csv, objects_gt.json, observations_gt.csv)")
      ->required();
  sub->add_option("--est", args->est,
                  "Estimate: a TUM file or a run folder (trajectory.tum, map.json, "
                  "observations.csv, run.json)")
      ->required();
  sub->add_option(
         "--align", args->align,
         "Trajectory alignment: se3 (rotation + translation), posyaw (yaw + translation, 4-DoF),\n"
         "sim3 (also scale; the scale error |s-1| is reported)")
      ->capture_default_str();
  sub->add_option("--out", args->out, "Write the metrics as JSON to this file (e.g. metrics.json)");
  sub->add_option("--t-max-diff", args->t_max_diff, "Largest |dt| of an associated pose pair [s]")
      ->capture_default_str();
  sub->add_option("--t-offset", args->t_offset,
                  "Added to the estimate's timestamps [s] (evo's --t_offset)")
      ->capture_default_str();
  sub->add_option(
         "--match-gate-px", args->match_gate_px,
         "Largest mean corner distance for a detection to match a ground-truth object [px]")
      ->capture_default_str();
  sub->add_option(
         "--success-px", args->success_px,
         "A tracked frame succeeds when all four corners are within this of the ground truth [px]")
      ->capture_default_str();
  sub->add_option(
         "--return-gap-frames", args->return_gap_frames,
         "Frames without a fully visible row of an object after which its next match is a return")
      ->capture_default_str();
  sub->add_option(
         "--object-gate-m", args->object_gate_m,
         "Largest mean corner distance for a map object to match a ground-truth object [m]")
      ->capture_default_str();
  sub->callback([args] { RunEval(*args); });
}

}  // namespace fsp::apps
