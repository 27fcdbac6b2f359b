// The table of every key of the run configuration (run_config.h), bound to the members of a
// RunConfig, with the accepted range of each value: what run_config.cc parses, checks, lists and
// writes. Internal to the apps.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "run_config.h"

namespace fsp::apps::run_config_internal {

using backend::EstimatorMode;
using backend::LandmarkType;
using backend::RobustLossOptions;
using backend::WindowBoundary;

using FieldRef =
    std::variant<int*, double*, bool*, uint32_t*, std::string*, EstimatorMode*, LandmarkType*,
                 RobustLossOptions::Type*, WindowBoundary*, std::optional<double>*>;

// Accepted numeric range of a field: lo < x (lo_open) or lo <= x, and x <= hi.
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  bool lo_open = false;
  double hi = std::numeric_limits<double>::infinity();
};
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr Range kAny{};
inline constexpr Range kPositive{0.0, true, kInf};
inline constexpr Range kNonNegative{0.0, false, kInf};
inline constexpr Range kAtLeastOne{1.0, false, kInf};

struct Field {
  std::string key;  // dotted path
  FieldRef ref;
  Range range;
};

// The table of every config key, bound to the members of C. The order is the order of ToYaml
// (--print-config). A new Options field needs one line in run_config_fields.cc (and one in
// assets/config/default.yaml when a user may change it).
std::vector<Field> Fields(RunConfig& c);

}  // namespace fsp::apps::run_config_internal
