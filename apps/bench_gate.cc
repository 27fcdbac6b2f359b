#include "bench_gate.h"

#include <cmath>
#include <set>

#include <yaml-cpp/yaml.h>

#include "bench_suite.h"
#include "fsp/common/error.h"

namespace fsp::apps {

std::vector<GateCheck> ReadGate(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw InputError(path, 0, "cannot open the thresholds file");
  } catch (const YAML::Exception& e) {
    throw InputError(path, e.mark.is_null() ? 0 : e.mark.line + 1, "not valid YAML: " + e.msg);
  }
  if (!root.IsMap() || !root["checks"] || !root["checks"].IsSequence())
    throw InputError(path, 0, "expected a list under \"checks\"");
  for (const auto& kv : root) {
    if (kv.first.as<std::string>() != "checks")
      throw InputError(path, kv.first.Mark().line + 1,
                       "unknown key '" + kv.first.as<std::string>() + "'");
  }
  std::vector<GateCheck> checks;
  for (const YAML::Node& n : root["checks"]) {
    GateCheck c;
    c.line = n.Mark().line + 1;
    if (!n.IsMap()) throw InputError(path, c.line, "each check is a map");
    const auto number = [&](const YAML::Node& v, const std::string& key) {
      try {
        const double x = v.as<double>();
        if (!std::isfinite(x)) throw YAML::Exception(v.Mark(), "not finite");
        return x;
      } catch (const YAML::Exception&) {
        throw InputError(path, c.line, key + ": expected a finite number");
      }
    };
    bool has_bound = false;
    for (const auto& kv : n) {
      const std::string key = kv.first.as<std::string>();
      if (key == "config") {
        BenchConfig config;
        std::string why;
        if (!ParseBenchConfig(kv.second.as<std::string>(), &config, &why))
          throw InputError(path, c.line, "config: " + why);
        c.config = config.name;
      } else if (key == "scene") {
        c.scene = kv.second.as<std::string>();
      } else if (key == "metric") {
        c.metric = kv.second.as<std::string>();
      } else if (key == "max" || key == "min") {
        if (has_bound) throw InputError(path, c.line, "give one of max and min");
        has_bound = true;
        c.upper = key == "max";
        c.bound = number(kv.second, key);
      } else if (key == "target") {
        c.target = number(kv.second, key);
      } else if (key == "enforced") {
        const std::string s = kv.second.as<std::string>();
        if (s != "true" && s != "false")
          throw InputError(path, c.line, "enforced: expected true or false");
        c.enforced = s == "true";
      } else {
        throw InputError(
            path, c.line,
            "unknown key '" + key + "' (known: scene, config, metric, max, min, target, enforced)");
      }
    }
    if (c.config.empty() || c.metric.empty())
      throw InputError(path, c.line, "a check needs config and metric");
    if (!has_bound) throw InputError(path, c.line, "a check needs max or min");
    checks.push_back(c);
  }
  return checks;
}

std::vector<GateResult> EvaluateGate(const std::vector<GateCheck>& checks,
                                     const nlohmann::ordered_json& rows) {
  std::vector<GateResult> results;
  for (const GateCheck& c : checks) {
    GateResult r;
    r.check = c;
    if (!rows.contains(c.scene) || !rows[c.scene].contains(c.config)) {
      r.skipped = true;
    } else if (rows[c.scene][c.config].contains(c.metric) &&
               rows[c.scene][c.config][c.metric].is_number()) {
      const double v = rows[c.scene][c.config][c.metric].get<double>();
      r.value = v;
      r.pass = c.upper ? v <= c.bound : v >= c.bound;
      if (c.target) r.target_met = c.upper ? v <= *c.target : v >= *c.target;
    }
    results.push_back(r);
  }
  return results;
}

bool GatePasses(const std::vector<GateResult>& results) {
  for (const GateResult& r : results)
    if (r.check.enforced && !r.skipped && !r.pass) return false;
  return true;
}

}  // namespace fsp::apps
