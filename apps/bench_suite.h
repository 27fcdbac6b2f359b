// The benchmark suite of `fsp bench` (assets/bench/suite.yaml): which scenes are rendered, with
// which seeds and durations, and which configurations (front end, landmarks, estimator mode) run on
// each, for the full benchmark and for `--quick`.
//
//   scenes:
//     - name: default_room  # names the scene in report.md, metrics.json and the gate
//       scene: ../scenes/default_room.yaml  # relative to the suite file
//       why: "..."  # one line for report.md: why these configurations
//       full: {duration_s: 60, seeds: [1, 2, 3], configs: [fsp-window, rect/fsp-window]}
//       quick:
//         duration_s: 20
//         seeds: [1, 2]
//         configs: [fsp-window, {config: rect/fsp-window, seeds: [1]}]
//
// Instead of `scene:`, `cslam_logs: FOLDER` names the C-SLAM authors' two logs (LandmarksGT.log,
// PoseSE3(W)_GT.log) in the data folder (`fsp bench --data`): the bench converts them into a scene
// (`fsp convert-cslam`) and leaves the scene out, saying why, when they are absent. `reference:`
// puts a published result beside the scene's table: {label: "...", METRIC: value, ...} with the
// metric names of the gate file.
//
// A configuration is FRONTEND/LANDMARKS-MODE (rect/fsp-window, apriltag/fhp-batch,
// gt-corners/fsp-window); without "FRONTEND/" it is gt-corners (fsp-window). The front end
// gt-corners-Spx (gt-corners-0px/fsp-batch) is gt-corners with S px of corner noise instead of
// `fsp bench --pixel-sigma`'s. It runs on every seed
// of the part, or on the seeds it lists (a subset). A sequence whose configurations all read no
// pixels (gt-corners) is rendered without images, which is much faster. A seed is the render seed
// of the sequence (`fsp render --seed`) and the gt-corners noise seed (`fsp run --seed`). A part
// (full or quick) may be left out: the scene is then not part of that benchmark.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fsp/backend/estimator.h"

namespace fsp::apps {

struct BenchConfig {
  std::string name;  // canonical: "gt-corners/fsp-window"
  std::string frontend;
  backend::LandmarkType landmarks = backend::LandmarkType::kFsp;
  backend::EstimatorMode mode = backend::EstimatorMode::kWindow;
  std::optional<double> pixel_sigma;  // gt-corners-Spx: S; else the bench's --pixel-sigma
  std::vector<unsigned> seeds;  // the seeds it runs on (ReadBenchSuite: the scene's when not given)
  int line = 0;                 // in the suite file
};

// Parses "fsp-window", "rect/fhp-batch", ...; false (with WHY) for anything else.
bool ParseBenchConfig(const std::string& text, BenchConfig* config, std::string* why);

struct BenchScene {
  std::string name;
  std::string scene;       // the scene file (resolved against the suite file's folder)
  std::string cslam_logs;  // or the C-SLAM logs' folder, relative to the data folder
  std::string why;
  std::string reference_label;  // a published result: its label and metrics (gate names)
  std::vector<std::pair<std::string, double>> reference;
  double duration_s = 0.0;
  std::vector<unsigned> seeds;
  std::vector<BenchConfig> configs;
};

struct BenchSuite {
  std::string source;  // the file it was read from
  std::vector<BenchScene> scenes;
};

// Reads the part QUICK ? "quick" : "full" of the suite file. Throws InputError("FILE:LINE: what")
// on a missing file, bad YAML, an unknown key, a bad configuration name, a repeated scene name,
// an empty seed or configuration list, a non-positive duration, or a suite without a scene.
BenchSuite ReadBenchSuite(const std::string& path, bool quick);

}  // namespace fsp::apps
