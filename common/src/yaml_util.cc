#include "yaml_util.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "fsp/common/error.h"

namespace fsp::internal {

YamlFile::YamlFile(const std::string& path, const std::string& what) : path_(path) {
  if (!std::filesystem::exists(path)) throw InputError(path, 0, what + " not found");
  if (std::filesystem::is_directory(path))
    throw InputError(path, 0, "is a directory, expected a " + what);
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open " + what);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  if (text.find_first_not_of(" \t\r\n") == std::string::npos)
    throw InputError(path, 0, what + " is empty");
  if (text.rfind("%YAML", 0) == 0) {
    // Keep the line count: replace the directive line by an empty one.
    const size_t eol = text.find('\n');
    text = eol == std::string::npos ? std::string() : text.substr(eol);
  }
  try {
    root_ = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(path, e.mark.is_null() ? 0 : e.mark.line + 1, "not valid YAML: " + e.msg);
  }
  if (!root_.IsMap()) throw InputError(path, 0, what + " is not a YAML map of keys");
}

int YamlFile::Line(const YAML::Node& node) const {
  if (!node.IsDefined()) return 0;
  const YAML::Mark m = node.Mark();
  return m.is_null() ? 0 : m.line + 1;
}

void YamlFile::Fail(const YAML::Node& node, const std::string& what) const {
  throw InputError(path_, Line(node), what);
}

YAML::Node YamlFile::Require(const YAML::Node& map, const std::string& key) const {
  if (!map.IsMap()) Fail(map, "expected a map containing '" + key + "'");
  YAML::Node v = map[key];
  if (!v.IsDefined() || v.IsNull()) Fail(map, "missing key '" + key + "'");
  return v;
}

double YamlFile::Double(const YAML::Node& node, const std::string& name) const {
  if (!node.IsScalar()) Fail(node, "'" + name + "' is not a number");
  const std::string& s = node.Scalar();
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size())
    Fail(node, "'" + name + "' is not a number: '" + s + "'");
  if (!std::isfinite(v)) Fail(node, "'" + name + "' is not finite: '" + s + "'");
  return v;
}

int YamlFile::Int(const YAML::Node& node, const std::string& name) const {
  const double v = Double(node, name);
  if (v != std::floor(v) || std::abs(v) > 1e9)
    Fail(node, "'" + name + "' is not an integer: '" + node.Scalar() + "'");
  return static_cast<int>(v);
}

std::string YamlFile::String(const YAML::Node& node, const std::string& name) const {
  if (!node.IsScalar()) Fail(node, "'" + name + "' is not a string");
  return node.Scalar();
}

std::vector<double> YamlFile::Doubles(const YAML::Node& node, const std::string& name,
                                      size_t n) const {
  if (!node.IsSequence() || node.size() != n) {
    Fail(node, "'" + name + "' must be a list of " + std::to_string(n) + " numbers");
  }
  std::vector<double> out;
  for (size_t i = 0; i < n; ++i)
    out.push_back(Double(node[i], name + "[" + std::to_string(i) + "]"));
  return out;
}

Mat4 YamlFile::Matrix4(const YAML::Node& node, const std::string& name) const {
  std::vector<double> v;
  if (node.IsMap()) {
    // OpenCV / EuRoC style: {rows: 4, cols: 4, data: [16]}
    if (node["rows"] && Int(node["rows"], name + ".rows") != 4)
      Fail(node, "'" + name + "' must have 4 rows");
    if (node["cols"] && Int(node["cols"], name + ".cols") != 4)
      Fail(node, "'" + name + "' must have 4 cols");
    v = Doubles(Require(node, "data"), name + ".data", 16);
  } else if (node.IsSequence() && node.size() == 4 && node[0].IsSequence()) {
    for (size_t r = 0; r < 4; ++r) {
      const std::vector<double> row = Doubles(node[r], name + "[" + std::to_string(r) + "]", 4);
      v.insert(v.end(), row.begin(), row.end());
    }
  } else if (node.IsSequence() && node.size() == 16) {
    v = Doubles(node, name, 16);
  } else {
    Fail(node,
         "'" + name + "' must be a 4x4 matrix (16 numbers, 4 rows of 4, or {rows, cols, data})");
  }
  Mat4 M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = v[static_cast<size_t>(4 * r + c)];
  return M;
}

Rigid3 YamlFile::Transform(const YAML::Node& node, const std::string& name) const {
  const Mat4 M = Matrix4(node, name);
  try {
    return Rigid3::FromMatrix(M);
  } catch (const std::invalid_argument&) {
    Fail(node,
         "'" + name +
             "' is not a rigid transform (rotation block not orthonormal or last row not 0 0 0 1)");
  }
}

}  // namespace fsp::internal
