#include "run_config.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <type_traits>
#include <variant>

#include <yaml-cpp/yaml.h>

#include "fsp/common/error.h"
#include "run_config_fields.h"

namespace fsp::apps {

namespace {

using run_config_internal::EstimatorMode;
using run_config_internal::Field;
using run_config_internal::FieldRef;
using run_config_internal::Fields;
using run_config_internal::kInf;
using run_config_internal::LandmarkType;
using run_config_internal::Range;
using run_config_internal::RobustLossOptions;
using run_config_internal::WindowBoundary;

// Names of the enum values as written in the file.
const std::vector<std::pair<EstimatorMode, const char*>> kModes = {
    {EstimatorMode::kWindow, "window"}, {EstimatorMode::kBatch, "batch"}};
const std::vector<std::pair<LandmarkType, const char*>> kLandmarks = {{LandmarkType::kFsp, "fsp"},
                                                                      {LandmarkType::kFhp, "fhp"}};
const std::vector<std::pair<WindowBoundary, const char*>> kBoundaries = {
    {WindowBoundary::kPrior, "prior"}, {WindowBoundary::kFixed, "fixed"}};
const std::vector<std::pair<RobustLossOptions::Type, const char*>> kLosses = {
    {RobustLossOptions::Type::kNone, "none"},
    {RobustLossOptions::Type::kHuber, "huber"},
    {RobustLossOptions::Type::kCauchy, "cauchy"}};

template <typename E>
const std::vector<std::pair<E, const char*>>& EnumNames() {
  if constexpr (std::is_same_v<E, EstimatorMode>) {
    return kModes;
  } else if constexpr (std::is_same_v<E, LandmarkType>) {
    return kLandmarks;
  } else if constexpr (std::is_same_v<E, WindowBoundary>) {
    return kBoundaries;
  } else {
    return kLosses;
  }
}

std::string FormatDouble(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);  // shortest round-trip form
  std::string s(buf, res.ptr);
  // Keep it a float in YAML's eyes ("1" -> "1.0") unless it is in exponent form.
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string FormatValue(const FieldRef& ref) {
  return std::visit(
      [](auto* p) -> std::string {
        using T = std::remove_pointer_t<decltype(p)>;
        if constexpr (std::is_same_v<T, int> || std::is_same_v<T, uint32_t>) {
          return std::to_string(*p);
        } else if constexpr (std::is_same_v<T, double>) {
          return FormatDouble(*p);
        } else if constexpr (std::is_same_v<T, bool>) {
          return *p ? "true" : "false";
        } else if constexpr (std::is_same_v<T, std::string>) {
          return *p;
        } else if constexpr (std::is_same_v<T, std::optional<double>>) {
          return p->has_value() ? FormatDouble(**p) : "null";
        } else {
          for (const auto& [value, name] : EnumNames<T>())
            if (value == *p) return name;
          return "?";
        }
      },
      ref);
}

class ConfigParser {
 public:
  ConfigParser(RunConfig* config, std::string name) : config_(config), name_(std::move(name)) {
    for (Field& f : Fields(*config_)) {
      fields_.emplace(f.key, f);
      // Every proper prefix of a key is a section.
      for (size_t dot = f.key.find('.'); dot != std::string::npos; dot = f.key.find('.', dot + 1))
        sections_.insert(f.key.substr(0, dot));
    }
  }

  void ParseRoot(const YAML::Node& root) {
    if (!root || root.IsNull()) return;  // an empty file: all defaults
    if (!root.IsMap())
      Fail(root, "", "the config must be a map of sections (estimator, imu, frontend)");
    ParseSection(root, "");
  }

 private:
  [[noreturn]] void Fail(const YAML::Node& node, const std::string& key,
                         const std::string& what) const {
    const int line = node.Mark().is_null() ? 0 : node.Mark().line + 1;
    throw InputError(name_, line, key.empty() ? what : key + ": " + what);
  }

  void ParseSection(const YAML::Node& map, const std::string& prefix) {
    for (const auto& kv : map) {
      const std::string name = kv.first.as<std::string>();
      const std::string key = prefix.empty() ? name : prefix + "." + name;
      const YAML::Node& value = kv.second;
      if (sections_.count(key)) {
        if (value.IsNull()) continue;  // "imu:" with nothing under it
        if (!value.IsMap()) Fail(kv.first, key, "is a section: expected keys under it");
        ParseSection(value, key);
        continue;
      }
      auto it = fields_.find(key);
      if (it == fields_.end()) Fail(kv.first, key, "unknown key" + Suggest(prefix));
      if (!seen_.insert(key).second) Fail(kv.first, key, "given twice");
      ParseValue(it->second, value);
    }
  }

  // "(known keys here: a, b, c)" for an unknown key's message.
  std::string Suggest(const std::string& prefix) const {
    std::string known;
    const std::string p = prefix.empty() ? "" : prefix + ".";
    std::set<std::string> names;
    for (const auto& [key, f] : fields_) {
      if (key.compare(0, p.size(), p) != 0) continue;
      const std::string rest = key.substr(p.size());
      names.insert(rest.substr(0, rest.find('.')));
    }
    for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
    return known.empty() ? std::string()
                         : " (known keys" + (prefix.empty() ? std::string() : " in " + prefix) +
                               ": " + known + ")";
  }

  double ParseNumber(const Field& f, const YAML::Node& node, bool integer) const {
    if (!node.IsScalar()) Fail(node, f.key, "expected a number");
    const std::string text = node.Scalar();
    char* end = nullptr;
    double v = 0.0;
    if (integer) {
      errno = 0;
      const long long i = std::strtoll(text.c_str(), &end, 10);
      if (end == text.c_str() || *end != '\0' || errno == ERANGE)
        Fail(node, f.key, "expected an integer, got '" + text + "'");
      v = static_cast<double>(i);
    } else {
      v = std::strtod(text.c_str(), &end);
      if (end == text.c_str() || *end != '\0' || !std::isfinite(v))
        Fail(node, f.key, "expected a finite number, got '" + text + "'");
    }
    const Range& r = f.range;
    const bool low_ok = r.lo_open ? v > r.lo : v >= r.lo;
    if (!low_ok || v > r.hi) {
      std::ostringstream os;
      os << "must be ";
      if (r.hi == kInf) {
        os << (r.lo_open ? "> " : ">= ") << r.lo;
      } else {
        os << "in " << (r.lo_open ? "(" : "[") << r.lo << ", " << r.hi << "]";
      }
      os << ", got " << text;
      Fail(node, f.key, os.str());
    }
    return v;
  }

  void ParseValue(const Field& f, const YAML::Node& node) {
    std::visit(
        [&](auto* p) {
          using T = std::remove_pointer_t<decltype(p)>;
          if constexpr (std::is_same_v<T, int>) {
            const double v = ParseNumber(f, node, true);
            if (std::abs(v) > std::numeric_limits<int>::max()) Fail(node, f.key, "too large");
            *p = static_cast<int>(v);
          } else if constexpr (std::is_same_v<T, uint32_t>) {
            const double v = ParseNumber(f, node, true);
            if (v < 0 || v > std::numeric_limits<uint32_t>::max())
              Fail(node, f.key, "must be in [0, 4294967295], got " + node.Scalar());
            *p = static_cast<uint32_t>(v);
          } else if constexpr (std::is_same_v<T, double>) {
            *p = ParseNumber(f, node, false);
          } else if constexpr (std::is_same_v<T, std::optional<double>>) {
            if (node.IsNull()) {
              p->reset();
            } else {
              *p = ParseNumber(f, node, false);
            }
          } else if constexpr (std::is_same_v<T, std::string>) {
            if (!node.IsScalar() || node.Scalar().empty()) Fail(node, f.key, "expected a name");
            *p = node.Scalar();
          } else if constexpr (std::is_same_v<T, bool>) {
            const std::string s = node.IsScalar() ? node.Scalar() : "";
            if (s == "true") {
              *p = true;
            } else if (s == "false") {
              *p = false;
            } else {
              Fail(node, f.key, "expected true or false, got '" + s + "'");
            }
          } else {
            const std::string s = node.IsScalar() ? node.Scalar() : "";
            std::string names;
            for (const auto& [value, name] : EnumNames<T>()) {
              if (s == name) {
                *p = value;
                return;
              }
              names += (names.empty() ? "" : ", ") + std::string(name);
            }
            Fail(node, f.key, "expected one of " + names + ", got '" + s + "'");
          }
        },
        f.ref);
  }

  RunConfig* config_;
  std::string name_;
  std::map<std::string, Field> fields_;
  std::set<std::string> sections_;
  std::set<std::string> seen_;
};

}  // namespace

bool GtCornersOptions::Check(std::string* why) const {
  if (!(pixel_sigma >= 0.0) || !std::isfinite(pixel_sigma)) {
    if (why) *why = "frontend.gt_corners.pixel_sigma must be finite and >= 0";
    return false;
  }
  if (min_visible_corners < 2 || min_visible_corners > 4) {
    if (why) *why = "frontend.gt_corners.min_visible_corners must be 2, 3 or 4";
    return false;
  }
  return true;
}

ImuNoise ImuNoiseOverrides::Apply(ImuNoise noise) const {
  if (gyroscope_noise_density) noise.gyroscope_noise_density = *gyroscope_noise_density;
  if (accelerometer_noise_density) noise.accelerometer_noise_density = *accelerometer_noise_density;
  if (gyroscope_random_walk) noise.gyroscope_random_walk = *gyroscope_random_walk;
  if (accelerometer_random_walk) noise.accelerometer_random_walk = *accelerometer_random_walk;
  return noise;
}

RunConfig ParseRunConfig(const std::string& yaml_text, const std::string& name) {
  RunConfig config;
  config.source = name;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw InputError(name, e.mark.is_null() ? 0 : e.mark.line + 1, "not valid YAML: " + e.msg);
  }
  ConfigParser parser(&config, name);
  try {
    parser.ParseRoot(root);
  } catch (const YAML::Exception& e) {
    throw InputError(name, e.mark.is_null() ? 0 : e.mark.line + 1, e.msg);
  }
  std::string why;
  if (!config.gt_corners.Check(&why) || !config.estimator.Check(&why))
    throw InputError(name, 0, why);
  if (!config.frontend.Check(&why)) throw InputError(name, 0, "frontend: " + why);
  return config;
}

RunConfig ReadRunConfig(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open the config file");
  std::stringstream ss;
  ss << in.rdbuf();
  return ParseRunConfig(ss.str(), path);
}

std::vector<std::string> RunConfigKeys() {
  RunConfig c;
  std::vector<std::string> keys;
  for (const Field& f : Fields(c)) keys.push_back(f.key);
  return keys;
}

bool SameValues(const RunConfig& a, const RunConfig& b, std::string* first_difference) {
  RunConfig ca = a, cb = b;
  const std::vector<Field> fa = Fields(ca), fb = Fields(cb);
  for (size_t i = 0; i < fa.size(); ++i) {
    const std::string va = FormatValue(fa[i].ref), vb = FormatValue(fb[i].ref);
    if (va != vb) {
      if (first_difference) *first_difference = fa[i].key + ": " + va + " vs " + vb;
      return false;
    }
  }
  return true;
}

std::string ToYaml(const RunConfig& config) {
  RunConfig c = config;
  std::ostringstream os;
  std::vector<std::string> open;  // sections currently open
  for (const Field& f : Fields(c)) {
    std::vector<std::string> parts;
    std::stringstream ks(f.key);
    for (std::string part; std::getline(ks, part, '.');) parts.push_back(part);
    size_t common = 0;
    while (common < open.size() && common + 1 < parts.size() && open[common] == parts[common])
      ++common;
    open.resize(common);
    for (size_t i = common; i + 1 < parts.size(); ++i) {
      os << std::string(2 * i, ' ') << parts[i] << ":\n";
      open.push_back(parts[i]);
    }
    os << std::string(2 * (parts.size() - 1), ' ') << parts.back() << ": " << FormatValue(f.ref)
       << "\n";
  }
  return os.str();
}

}  // namespace fsp::apps
