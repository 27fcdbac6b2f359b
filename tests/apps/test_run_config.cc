// The `fsp run` configuration: default.yaml holds the user's options with the C++ defaults,
// --print-config lists every key; bad files fail with the file, line and key named.
#include <functional>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "fsp/common/error.h"
#include "run_config.h"

namespace fsp::apps {
namespace {

const std::string kDefaultYaml = std::string(FSP_SOURCE_DIR) + "/assets/config/default.yaml";

// Error message of parsing TEXT, or "" when it parses.
std::string ParseError(const std::string& text) {
  try {
    ParseRunConfig(text, "cfg.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

void CollectKeys(const YAML::Node& node, const std::string& prefix, std::set<std::string>* keys) {
  for (const auto& kv : node) {
    const std::string key = (prefix.empty() ? "" : prefix + ".") + kv.first.as<std::string>();
    if (kv.second.IsMap()) {
      CollectKeys(kv.second, key, keys);
    } else {
      keys->insert(key);
    }
  }
}

TEST(RunConfig, DefaultYamlParsesToTheDefaultOptions) {
  const RunConfig parsed = ReadRunConfig(kDefaultYaml);
  std::string diff;
  EXPECT_TRUE(SameValues(parsed, RunConfig(), &diff))
      << "default.yaml differs from the C++ default: " << diff;
  // Spot checks against the structs themselves (not through the config table).
  const backend::EstimatorOptions defaults;
  EXPECT_EQ(parsed.estimator.window_size, defaults.window_size);
  EXPECT_EQ(parsed.estimator.robust.type, defaults.robust.type);
  EXPECT_EQ(parsed.estimator.static_init.window_s, defaults.static_init.window_s);
  EXPECT_EQ(parsed.estimator.init.width_tag_m, defaults.init.width_tag_m);
  EXPECT_EQ(parsed.gt_corners.pixel_sigma, 1.0);
  EXPECT_FALSE(parsed.imu.gyroscope_noise_density.has_value());
  EXPECT_FALSE(parsed.camera_time_offset_s.has_value());
  // A camera-IMU time offset set in a config (seconds; `fsp run` hands it to the source).
  const RunConfig offset = ParseRunConfig("camera:\n  time_offset_s: -0.045\n", "offset.yaml");
  ASSERT_TRUE(offset.camera_time_offset_s.has_value());
  EXPECT_DOUBLE_EQ(*offset.camera_time_offset_s, -0.045);
}

// default.yaml holds the options a user may change, not every key: each key in it must be one the
// config knows (its values are checked above).
TEST(RunConfig, DefaultYamlHoldsKnownKeysOnly) {
  std::set<std::string> in_file;
  CollectKeys(YAML::LoadFile(kDefaultYaml), "", &in_file);
  const std::vector<std::string> keys = RunConfigKeys();
  const std::set<std::string> known(keys.begin(), keys.end());
  EXPECT_EQ(known.size(), keys.size());
  EXPECT_FALSE(in_file.empty());
  for (const std::string& k : in_file)
    EXPECT_TRUE(known.count(k)) << k << " in default.yaml is not a key";
  EXPECT_LT(in_file.size(), keys.size()) << "default.yaml lists every key again";
}

// Every key is listed by ToYaml (`fsp run --print-config`), once, and parses back to the defaults.
TEST(RunConfig, PrintedConfigListsEveryKey) {
  const std::string text = ToYaml(RunConfig());
  std::set<std::string> printed;
  CollectKeys(YAML::Load(text), "", &printed);
  const std::vector<std::string> keys = RunConfigKeys();
  EXPECT_EQ(printed, std::set<std::string>(keys.begin(), keys.end()));
  std::string diff;
  EXPECT_TRUE(SameValues(ParseRunConfig(text, "printed"), RunConfig(), &diff)) << diff;
}

// A tripwire, not a law: the config table (apps/run_config_fields.cc Fields) lists the Options
// fields by hand. When an Options struct grows, this fails: add the new field to Fields() (and to
// default.yaml if a user may change it), then update the size here.
TEST(RunConfig, OptionsStructsHaveTheFieldsTheConfigKnows) {
  EXPECT_EQ(sizeof(backend::EstimatorOptions), 1096u) << "EstimatorOptions changed";
  EXPECT_EQ(sizeof(backend::FspFactorOptions), 16u) << "FspFactorOptions changed";
  EXPECT_EQ(sizeof(backend::RobustLossOptions), 16u) << "RobustLossOptions changed";
  EXPECT_EQ(sizeof(backend::PreintegrationOptions), 64u) << "PreintegrationOptions changed";
  EXPECT_EQ(sizeof(backend::SingleViewInitOptions), 96u) << "SingleViewInitOptions changed";
  EXPECT_EQ(sizeof(backend::StaticInitOptions), 56u) << "StaticInitOptions changed";
  EXPECT_EQ(sizeof(backend::MotionInitOptions), 72u) << "MotionInitOptions changed";
  // VisualSfmOptions::max_gyro_bias is no key: the point init sets it from its own.
  EXPECT_EQ(sizeof(backend::PointInitOptions), 224u) << "PointInitOptions changed";
  EXPECT_EQ(sizeof(backend::VisualSfmOptions), 120u) << "VisualSfmOptions changed";
  EXPECT_EQ(sizeof(backend::FaultOptions), 96u) << "FaultOptions changed";
  EXPECT_EQ(sizeof(backend::GlobalOptions), 104u) << "GlobalOptions changed";
  EXPECT_EQ(sizeof(backend::ZeroVelocityOptions), 48u) << "ZeroVelocityOptions changed";
  EXPECT_EQ(sizeof(backend::PointOptions), 136u) << "PointOptions changed";
}

TEST(RunConfig, ValuesAreApplied) {
  const RunConfig c = ParseRunConfig(
      "estimator:\n  window_size: 7\n  mode: batch\n  landmarks: fhp\n  robust: {type: huber, "
      "k_sigma: 3}\n"
      "  single_view_init:\n    refine: false\nimu:\n  gyroscope_noise_density: 1.0e-3\n"
      "frontend:\n  gt_corners:\n    pixel_sigma: 0\n    seed: 42\n",
      "cfg.yaml");
  EXPECT_EQ(c.estimator.window_size, 7);
  EXPECT_EQ(c.estimator.mode, backend::EstimatorMode::kBatch);
  EXPECT_EQ(c.estimator.landmarks, backend::LandmarkType::kFhp);
  EXPECT_EQ(c.estimator.robust.type, backend::RobustLossOptions::Type::kHuber);
  EXPECT_EQ(c.estimator.robust.k_sigma, 3.0);
  EXPECT_FALSE(c.estimator.init.refine);
  EXPECT_EQ(c.gt_corners.pixel_sigma, 0.0);
  EXPECT_EQ(c.gt_corners.seed, 42u);
  ASSERT_TRUE(c.imu.gyroscope_noise_density.has_value());
  EXPECT_EQ(*c.imu.gyroscope_noise_density, 1e-3);
  // Untouched keys keep their defaults; the override replaces only the set density.
  EXPECT_EQ(c.estimator.window_max_iterations, backend::EstimatorOptions().window_max_iterations);
  const ImuNoise noise = c.imu.Apply(ImuNoise());
  EXPECT_EQ(noise.gyroscope_noise_density, 1e-3);
  EXPECT_EQ(noise.accelerometer_noise_density, ImuNoise().accelerometer_noise_density);
}

TEST(RunConfig, ToYamlRoundTripsExactly) {
  RunConfig c;
  c.estimator.window_size = 11;
  c.estimator.prior_acc_bias_sigma = 0.1 + 0.2;  // not a short decimal
  c.estimator.mode = backend::EstimatorMode::kBatch;
  c.imu.accelerometer_random_walk = 4e-3;
  c.gt_corners.seed = 4000000000u;
  const RunConfig back = ParseRunConfig(ToYaml(c), "dump");
  std::string diff;
  EXPECT_TRUE(SameValues(c, back, &diff)) << diff << "\n" << ToYaml(c);
  EXPECT_FALSE(SameValues(c, RunConfig(), &diff));
  EXPECT_NE(diff.find("estimator.mode"), std::string::npos) << diff;
}

TEST(RunConfig, EmptyFileGivesDefaults) {
  EXPECT_TRUE(SameValues(ParseRunConfig("", "empty.yaml"), RunConfig()));
  EXPECT_TRUE(SameValues(ParseRunConfig("imu:\n", "e.yaml"), RunConfig()));
}

TEST(RunConfig, UnknownKeyIsNamedWithFileAndLine) {
  const std::string e = ParseError("estimator:\n  window_size: 5\n  windw_size: 3\n");
  EXPECT_NE(e.find("cfg.yaml:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("estimator.windw_size"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key"), std::string::npos) << e;
  EXPECT_NE(e.find("window_size"), std::string::npos) << e;  // the known keys are suggested
  EXPECT_NE(ParseError("frontend:\n  rect:\n    x: 1\n").find("frontend.rect"), std::string::npos);
  EXPECT_NE(ParseError("estimatr:\n  window_size: 5\n").find("estimatr"), std::string::npos);
}

TEST(RunConfig, BadValuesNameTheKey) {
  std::string e = ParseError("estimator:\n  window_size: -3\n");
  EXPECT_NE(e.find("cfg.yaml:2:"), std::string::npos) << e;
  EXPECT_NE(e.find("estimator.window_size"), std::string::npos) << e;
  EXPECT_NE(e.find("-3"), std::string::npos) << e;

  e = ParseError("estimator:\n  window_size: 2.5\n");
  EXPECT_NE(e.find("expected an integer"), std::string::npos) << e;
  e = ParseError("frontend:\n  gt_corners:\n    pixel_sigma: -1\n");
  EXPECT_NE(e.find("frontend.gt_corners.pixel_sigma"), std::string::npos) << e;
  e = ParseError("frontend:\n  gt_corners:\n    seed: abc\n");
  EXPECT_NE(e.find("frontend.gt_corners.seed"), std::string::npos) << e;
  e = ParseError("estimator:\n  mode: online\n");
  EXPECT_NE(e.find("expected one of window, batch"), std::string::npos) << e;
  e = ParseError("estimator:\n  robust:\n    type: tukey\n");
  EXPECT_NE(e.find("estimator.robust.type"), std::string::npos) << e;
  e = ParseError("estimator:\n  single_view_init:\n    refine: maybe\n");
  EXPECT_NE(e.find("true or false"), std::string::npos) << e;
  e = ParseError("estimator:\n  static_init:\n    window_s: .nan\n");
  EXPECT_NE(e.find("finite"), std::string::npos) << e;
  e = ParseError("estimator:\n  keyframe_min_frames: -1\n");
  EXPECT_NE(e.find("estimator.keyframe_min_frames"), std::string::npos) << e;
  e = ParseError("estimator:\n  global:\n    function_tolerance: 0\n");
  EXPECT_NE(e.find("estimator.global.function_tolerance"), std::string::npos) << e;
  e = ParseError("estimator: 3\n");
  EXPECT_NE(e.find("is a section"), std::string::npos) << e;
  e = ParseError("estimator:\n  window_size: 5\n  window_size: 6\n");
  EXPECT_FALSE(e.empty());
  e = ParseError("estimator: [1, 2\n");
  EXPECT_NE(e.find("not valid YAML"), std::string::npos) << e;
}

TEST(RunConfig, MissingFileIsAnInputError) {
  EXPECT_THROW(ReadRunConfig("/nonexistent/fsp.yaml"), InputError);
}

}  // namespace
}  // namespace fsp::apps
