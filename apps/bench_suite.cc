#include "bench_suite.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>

#include <yaml-cpp/yaml.h>

#include "fsp/common/error.h"

namespace fsp::apps {

namespace {

int LineOf(const YAML::Node& n) {
  return n.Mark().is_null() ? 0 : n.Mark().line + 1;
}

bool IsToken(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-' || c == '.';
    if (!ok) return false;
  }
  return s != "." && s != "..";
}

// One part (full or quick) of a scene.
void ReadPart(const std::string& path, const YAML::Node& part, BenchScene* scene) {
  if (!part.IsMap())
    throw InputError(path, LineOf(part), "expected a map (duration_s, seeds, configs)");
  bool has_duration = false, has_seeds = false, has_configs = false;
  for (const auto& kv : part) {
    const std::string key = kv.first.as<std::string>();
    const int line = LineOf(kv.first);
    if (key == "duration_s") {
      double d = 0.0;
      try {
        d = kv.second.as<double>();
      } catch (const YAML::Exception&) {
        throw InputError(path, line, "duration_s: expected a number of seconds");
      }
      if (!(d > 0.0) || !std::isfinite(d))
        throw InputError(path, line, "duration_s: must be a positive number of seconds");
      scene->duration_s = d;
      has_duration = true;
    } else if (key == "seeds") {
      if (!kv.second.IsSequence() || kv.second.size() == 0)
        throw InputError(path, line, "seeds: expected a non-empty list of integers");
      std::set<unsigned> seen;
      for (const YAML::Node& s : kv.second) {
        long long v = -1;
        try {
          v = s.as<long long>();
        } catch (const YAML::Exception&) {
        }
        if (v < 0 || v > 0xffffffffLL)
          throw InputError(path, LineOf(s), "seeds: expected integers in [0, 2^32)");
        if (!seen.insert(static_cast<unsigned>(v)).second)
          throw InputError(path, LineOf(s), "seeds: seed " + std::to_string(v) + " repeated");
        scene->seeds.push_back(static_cast<unsigned>(v));
      }
      has_seeds = true;
    } else if (key == "configs") {
      if (!kv.second.IsSequence() || kv.second.size() == 0)
        throw InputError(path, line, "configs: expected a non-empty list");
      std::set<std::string> seen;
      for (const YAML::Node& c : kv.second) {
        BenchConfig config;
        std::string why = "expected a name or {config: NAME, seeds: [...]}";
        // (yaml-cpp: assigning a node to another writes through it; bind each name once.)
        const YAML::Node name = c.IsMap() ? c["config"] : c;
        if (c.IsMap()) {
          for (const auto& ckv : c) {
            const std::string ckey = ckv.first.as<std::string>();
            if (ckey != "config" && ckey != "seeds")
              throw InputError(path, LineOf(ckv.first),
                               "configs: unknown key '" + ckey + "' (known: config, seeds)");
          }
          if (c["seeds"]) {
            if (!c["seeds"].IsSequence() || c["seeds"].size() == 0)
              throw InputError(path, LineOf(c), "configs: seeds: expected a non-empty list");
            for (const YAML::Node& sn : c["seeds"]) {
              long long v = -1;
              try {
                v = sn.as<long long>();
              } catch (const YAML::Exception&) {
              }
              if (v < 0 || v > 0xffffffffLL)
                throw InputError(path, LineOf(sn), "configs: seeds: expected integers");
              config.seeds.push_back(static_cast<unsigned>(v));
            }
          }
        }
        if (!name || !name.IsScalar() || !ParseBenchConfig(name.as<std::string>(), &config, &why))
          throw InputError(path, LineOf(c), "configs: " + why);
        config.line = LineOf(c);
        if (!seen.insert(config.name).second)
          throw InputError(path, LineOf(c), "configs: " + config.name + " repeated");
        scene->configs.push_back(config);
      }
      has_configs = true;
    } else {
      throw InputError(path, line, "unknown key '" + key + "' (known: duration_s, seeds, configs)");
    }
  }
  if (!has_duration || !has_seeds || !has_configs)
    throw InputError(path, LineOf(part), "a part needs duration_s, seeds and configs");
  for (BenchConfig& c : scene->configs) {
    if (c.seeds.empty()) c.seeds = scene->seeds;
    for (unsigned seed : c.seeds) {
      if (std::find(scene->seeds.begin(), scene->seeds.end(), seed) == scene->seeds.end())
        throw InputError(path, c.line,
                         "configs: " + c.name + ": seed " + std::to_string(seed) +
                             " is not one of the scene's seeds");
    }
  }
}

}  // namespace

bool ParseBenchConfig(const std::string& text, BenchConfig* config, std::string* why) {
  const size_t slash = text.find('/');
  std::string frontend = slash == std::string::npos ? "gt-corners" : text.substr(0, slash);
  // gt-corners-Spx: the ground-truth corners with S px of noise.
  std::optional<double> pixel_sigma;
  const std::string gt = "gt-corners-";
  if (frontend.size() > gt.size() + 2 && frontend.compare(0, gt.size(), gt) == 0 &&
      frontend.compare(frontend.size() - 2, 2, "px") == 0) {
    const std::string number = frontend.substr(gt.size(), frontend.size() - gt.size() - 2);
    char* end = nullptr;
    const double v = std::strtod(number.c_str(), &end);
    if (end == number.c_str() + number.size() && std::isfinite(v) && v >= 0.0 &&
        number.find_first_not_of("0123456789.") == std::string::npos) {
      pixel_sigma = v;
      frontend = "gt-corners";
    }
  }
  const std::string rest = slash == std::string::npos ? text : text.substr(slash + 1);
  const size_t dash = rest.find('-');
  const std::string landmarks = dash == std::string::npos ? "" : rest.substr(0, dash);
  const std::string mode = dash == std::string::npos ? "" : rest.substr(dash + 1);
  const bool ok = (frontend == "gt-corners" || frontend == "rect" || frontend == "apriltag") &&
                  (landmarks == "fsp" || landmarks == "fhp") &&
                  (mode == "window" || mode == "batch");
  if (!ok) {
    *why = "'" + text +
           "' is not FRONTEND/LANDMARKS-MODE (front end gt-corners, gt-corners-Spx, rect or "
           "apriltag; landmarks fsp or fhp; mode window or batch), e.g. rect/fsp-window, fsp-batch "
           "or gt-corners-0px/fsp-batch";
    return false;
  }
  config->frontend = frontend;
  config->pixel_sigma = pixel_sigma;
  config->landmarks =
      landmarks == "fsp" ? backend::LandmarkType::kFsp : backend::LandmarkType::kFhp;
  config->mode =
      mode == "window" ? backend::EstimatorMode::kWindow : backend::EstimatorMode::kBatch;
  config->name = (slash == std::string::npos ? frontend : text.substr(0, slash)) + "/" + landmarks +
                 "-" + mode;
  return true;
}

BenchSuite ReadBenchSuite(const std::string& path, bool quick) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw InputError(path, 0, "cannot open the suite file");
  } catch (const YAML::Exception& e) {
    throw InputError(path, e.mark.is_null() ? 0 : e.mark.line + 1, "not valid YAML: " + e.msg);
  }
  if (!root.IsMap() || !root["scenes"] || !root["scenes"].IsSequence())
    throw InputError(path, 0, "expected a list under \"scenes\"");
  for (const auto& kv : root) {
    if (kv.first.as<std::string>() != "scenes")
      throw InputError(path, LineOf(kv.first), "unknown key '" + kv.first.as<std::string>() + "'");
  }
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  const std::string part_key = quick ? "quick" : "full";
  BenchSuite suite;
  suite.source = path;
  std::set<std::string> names;
  for (const YAML::Node& n : root["scenes"]) {
    const int line = LineOf(n);
    if (!n.IsMap()) throw InputError(path, line, "each scene is a map");
    BenchScene scene;
    YAML::Node part;
    bool has_part = false;
    for (const auto& kv : n) {
      const std::string key = kv.first.as<std::string>();
      if (key == "name") {
        scene.name = kv.second.as<std::string>();
      } else if (key == "scene") {
        const std::filesystem::path p(kv.second.as<std::string>());
        scene.scene = (p.is_absolute() ? p : folder / p).lexically_normal().string();
      } else if (key == "cslam_logs") {
        scene.cslam_logs = kv.second.as<std::string>();
      } else if (key == "why") {
        scene.why = kv.second.as<std::string>();
      } else if (key == "reference") {
        if (!kv.second.IsMap())
          throw InputError(path, LineOf(kv.second),
                           "reference: expected {label: ..., METRIC: value}");
        for (const auto& r : kv.second) {
          const std::string metric = r.first.as<std::string>();
          if (metric == "label") {
            scene.reference_label = r.second.as<std::string>();
            continue;
          }
          double v = 0.0;
          try {
            v = r.second.as<double>();
          } catch (const YAML::Exception&) {
            throw InputError(path, LineOf(r.first), "reference: " + metric + ": expected a number");
          }
          scene.reference.emplace_back(metric, v);
        }
        if (scene.reference_label.empty())
          throw InputError(path, LineOf(kv.second), "reference: needs a label");
      } else if (key == "full" || key == "quick") {
        if (key == part_key) {
          part.reset(kv.second);
          has_part = true;
        }
      } else {
        throw InputError(path, LineOf(kv.first),
                         "unknown key '" + key +
                             "' (known: name, scene, cslam_logs, why, reference, full, quick)");
      }
    }
    if (!IsToken(scene.name))
      throw InputError(
          path, line, "a scene needs a name of letters, digits, '_', '-' and '.' (it names files)");
    if (scene.scene.empty() == scene.cslam_logs.empty())
      throw InputError(path, line,
                       "scene " + scene.name + ": needs either a scene file or cslam_logs");
    if (!names.insert(scene.name).second)
      throw InputError(path, line, "scene name " + scene.name + " repeated");
    if (!has_part) continue;  // not part of this benchmark
    ReadPart(path, part, &scene);
    suite.scenes.push_back(scene);
  }
  if (suite.scenes.empty()) throw InputError(path, 0, "no scene has a \"" + part_key + "\" part");
  return suite;
}

}  // namespace fsp::apps
