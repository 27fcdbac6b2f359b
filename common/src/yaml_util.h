// Line-numbered access to YAML files for the calibration readers (private to fsp_common).
#pragma once

#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "fsp/common/geometry.h"

namespace fsp::internal {

// A parsed YAML file that turns every problem into InputError "FILE:LINE: what".
class YamlFile {
 public:
  // Loads PATH. A first line starting with "%YAML" (OpenCV's "%YAML:1.0", which yaml-cpp rejects)
  // is skipped; line numbers in messages still refer to the file as written.
  explicit YamlFile(const std::string& path, const std::string& what = "YAML file");

  const YAML::Node& root() const { return root_; }
  const std::string& path() const { return path_; }

  // 1-based line of NODE in the file (0 when unknown).
  int Line(const YAML::Node& node) const;
  [[noreturn]] void Fail(const YAML::Node& node, const std::string& what) const;

  // MAP[key], or Fail naming the key (at MAP's line) when absent.
  YAML::Node Require(const YAML::Node& map, const std::string& key) const;
  // A finite number.
  double Double(const YAML::Node& node, const std::string& name) const;
  int Int(const YAML::Node& node, const std::string& name) const;
  std::string String(const YAML::Node& node, const std::string& name) const;
  // A sequence of exactly N finite numbers.
  std::vector<double> Doubles(const YAML::Node& node, const std::string& name, size_t n) const;
  // A 4x4 matrix as a flat list of 16, a list of 4 rows of 4, or an OpenCV-style {rows, cols,
  // data}.
  Mat4 Matrix4(const YAML::Node& node, const std::string& name) const;
  // Matrix4 that must be a rigid transform.
  Rigid3 Transform(const YAML::Node& node, const std::string& name) const;

 private:
  std::string path_;
  YAML::Node root_;
};

}  // namespace fsp::internal
