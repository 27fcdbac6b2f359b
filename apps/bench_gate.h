// The accuracy gate of `fsp bench`: bounds on benchmark metrics kept in the repository
// (assets/bench/thresholds.yaml). Each check names a scene of the suite (default: default_room), a
// configuration ("fsp-window" is the gt-corners front end's, "rect/fsp-window" another front end's,
// as in assets/bench/suite.yaml), a metric (a key of that configuration's seed mean in
// metrics.json), an enforced bound (max or min), the project's target, and whether crossing the
// bound fails the benchmark. Targets are reported, never enforced. A check on a scene or a
// configuration the benchmark did not run (e.g. one left out of --quick) is skipped.
//
//   checks:
//     - {config: fsp-window, metric: ate_se3_m, max: 0.10, target: 0.03, enforced: true}
//     - {scene: hall_flight, config: fsp-window, metric: scale_err, max: 0.02}
//     - {config: rect/fsp-window, metric: realtime_factor, min: 1.0, target: 5.0, enforced: false}
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace fsp::apps {

struct GateCheck {
  std::string scene = "default_room";
  std::string config;  // canonical (ParseBenchConfig): "gt-corners/fsp-window"
  std::string metric;
  bool upper = true;  // true: value <= bound ("max"); false: value >= bound ("min")
  double bound = 0.0;
  std::optional<double> target;
  bool enforced = true;
  int line = 0;  // in the thresholds file
};

// Throws InputError("FILE:LINE: what") on a malformed file, an unknown key, a configuration that is
// not FRONTEND/LANDMARKS-MODE, or a check without a bound.
std::vector<GateCheck> ReadGate(const std::string& path);

struct GateResult {
  GateCheck check;
  bool skipped = false;  // the benchmark did not run this scene or configuration (no verdict)
  std::optional<double> value;  // nullopt: the metric is missing (a failure unless skipped)
  bool pass = false;            // within the bound
  std::optional<bool> target_met;
};

// ROWS: {"default_room": {"gt-corners/fsp-window": {"ate_se3_m": ..., ...}, ...}, ...}: the
// metrics of each scene and configuration the benchmark ran (an empty object for a configuration
// whose runs all failed).
std::vector<GateResult> EvaluateGate(const std::vector<GateCheck>& checks,
                                     const nlohmann::ordered_json& rows);
// True when every enforced check that is not skipped passes.
bool GatePasses(const std::vector<GateResult>& results);

}  // namespace fsp::apps
