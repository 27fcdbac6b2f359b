// What `fsp bench` makes of its runs: each run evaluated against its sequence (the metrics named as
// in the gate file, and the series the plots read), the seeds aggregated, and the markdown tables
// and report.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_gate.h"
#include "bench_suite.h"

namespace fsp::apps {

using BenchJson = nlohmann::ordered_json;

// PATH relative to the repository when it lies inside it, else as it is.
std::string RepoRelative(const std::string& path);
// NAME with '/' replaced, for a file name.
std::string FileSafe(std::string name);
// V * SCALE with DECIMALS decimals ("nan" when not finite; exponent form from 1e5 on).
std::string Num(double v, double scale, int decimals);

BenchJson ReadJsonFile(const std::filesystem::path& path);
void WriteText(const std::filesystem::path& path, const std::string& text);

// The metrics of the finished run in OUT / RUN_DIR on SEQUENCE (names as in the gate file: ATE
// after SE3 / position-yaw / Sim3 alignment, the causal trajectory's ATE, object and front-end
// errors (front end only when PIXELS), timings), and its series file OUT / RUN_DIR /
// bench_series.json for the plots.
BenchJson EvaluateBenchRun(const std::string& sequence, const std::filesystem::path& out,
                           const std::filesystem::path& run_dir, bool pixels);

// Mean, min and max over the seeds of every numeric metric of ROWS (rows with "error" skipped).
BenchJson Aggregate(const std::vector<const BenchJson*>& rows);

// One scene's table (a line per configuration) and the gate's table, in markdown.
std::string SceneTable(const BenchJson& scene);
std::string GateTable(const std::vector<GateResult>& results);
// Every run's Sim3 scale error against the estimator's scale σ (the "honest σ" check), or "" when
// no run reports a σ.
std::string ScaleSigmaTable(const BenchJson& metrics);

// What report.md says: how the suite ran, a section per scene with its table and plots, the failed
// runs, the plots' line and the gate.
struct ReportInfo {
  bool quick = false;
  double pixel_sigma = 1.0;
  std::string thresholds;  // the gate file
};
std::string Report(const ReportInfo& info, const BenchJson& metrics, const BenchSuite& suite,
                   const std::vector<std::string>& pngs, const std::string& plot_line,
                   const std::string& gate_table, bool pass);

}  // namespace fsp::apps
