// The accuracy gate of `fsp bench`: bounds on benchmark metrics kept in the repository
// (assets/bench/thresholds.yaml). Each check names a configuration ("fsp-window", ...), a metric (a
// key of that configuration's row in bench.json), an enforced bound (max or min), the project's
// target, and whether crossing the bound fails the benchmark. Targets are reported, never enforced.
//
//   checks:
//     - {config: fsp-window, metric: ate_se3_m, max: 0.10, target: 0.03, enforced: true}
//     - {config: fsp-window, metric: realtime_factor, min: 2.0, target: 5.0, enforced: true}
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace fsp::apps {

struct GateCheck {
  std::string config;
  std::string metric;
  bool upper = true;  // true: value <= bound ("max"); false: value >= bound ("min")
  double bound = 0.0;
  std::optional<double> target;
  bool enforced = true;
  int line = 0;  // in the thresholds file
};

// Throws InputError("FILE:LINE: what") on a malformed file, an unknown key, or a check without a
// bound.
std::vector<GateCheck> ReadGate(const std::string& path);

struct GateResult {
  GateCheck check;
  std::optional<double> value;  // nullopt: the configuration or the metric is missing (a failure)
  bool pass = false;            // within the bound
  std::optional<bool> target_met;
};

// ROWS: {"fsp-window": {"ate_se3_m": ..., ...}, ...}.
std::vector<GateResult> EvaluateGate(const std::vector<GateCheck>& checks,
                                     const nlohmann::ordered_json& rows);
// True when every enforced check passes.
bool GatePasses(const std::vector<GateResult>& results);

}  // namespace fsp::apps
