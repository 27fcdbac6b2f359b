// `fsp eval`: finds what a ground truth and an estimate hold, computes every metric block that both
// sides allow, and writes metrics.json (field names in docs/outputs.md). A block that cannot be
// computed is absent.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fsp/eval/frontend_metrics.h"
#include "fsp/eval/object_metrics.h"
#include "fsp/eval/trajectory_metrics.h"

namespace fsp::eval {

// Files found for one evaluation; empty strings for absent parts.
struct EvalPaths {
  // Ground truth: a TUM file, a EuRoC ground-truth csv, or a sequence folder (DIR or DIR/mav0) with
  // mav0/state_groundtruth_estimate0/data.csv, objects_gt.json and observations_gt.csv when
  // present.
  std::string gt_trajectory;
  std::string objects_gt;
  std::string observations_gt;
  std::string frame_times;  // mav0/cam0/data.csv: the sequence's frames (the front end's absences
                            // need them)
  // Estimate: a TUM file (or EuRoC csv), or a run folder with trajectory.tum, map.json,
  // observations.csv, run.json when present.
  std::string est_trajectory;
  std::string map;
  std::string observations;
  std::string run_json;
};

// Throws InputError when a path does not exist or a folder holds nothing to evaluate.
EvalPaths ResolvePaths(const std::string& gt, const std::string& est);

struct EvalOptions {
  TrajectoryOptions trajectory;
  FrontendOptions frontend;
  ObjectOptions objects;
  bool Check(std::string* why) const;
};

// Copied from run.json; each field is absent when the file lacks it.
struct RuntimeMetrics {
  std::optional<double> frames;
  std::optional<double> wall_s;
  std::optional<double> realtime_factor;
};
// Reads run.json; nullopt when it holds none of the three fields. Throws InputError on malformed
// JSON.
std::optional<RuntimeMetrics> ReadRuntime(const std::string& run_json);

struct Metrics {
  EvalPaths paths;
  std::optional<TrajectoryMetrics> trajectory;
  std::optional<ObjectMetrics> objects;  // needs the trajectory alignment and both object files
  std::optional<FrontendMetrics> frontend;
  std::optional<RuntimeMetrics> runtime;
  std::vector<std::string> notes;  // why a block is absent, for the human summary
};

// First column (t_ns) of a EuRoC cam0/data.csv ("#timestamp [ns],filename"; '#' lines skipped).
// Throws InputError "FILE:LINE: what" on a row that does not start with an integer.
std::vector<int64_t> ReadFrameTimes(const std::string& path);

// Reads and evaluates. Throws InputError on bad input, on too few pose pairs, or when no block at
// all can be computed.
Metrics Evaluate(const EvalPaths& paths, const EvalOptions& options);

// metrics.json content: {"trajectory": {...}, "objects": {...}, "frontend": {...}, "runtime":
// {...}}, keys in a fixed, readable order.
nlohmann::ordered_json ToJson(const Metrics& metrics);
// A few lines for a person.
std::string FormatSummary(const Metrics& metrics);

}  // namespace fsp::eval
