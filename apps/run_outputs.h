// Writers of a run's output folder (docs/outputs.md): map.json and run.json, plus the
// timing statistics they report. trajectory.tum and observations.csv use the common writers
// (WriteTum, WriteCornerRows).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "fsp/backend/estimator.h"

namespace fsp::apps {

// Median and 90th percentile of a list of durations [ms] (linear interpolation between order
// statistics; 0 for an empty list).
struct StageStats {
  double median = 0.0;
  double p90 = 0.0;
  double mean = 0.0;
  double max = 0.0;
  int count = 0;
};
StageStats ComputeStageStats(std::vector<double> ms);

// One mapped object for a person: "ID CLASS  W +- σw x H +- σh m" (without +- when σ is unknown).
std::string MapObjectLine(const backend::MapObject& o);

// What a run measured, for run.json and the summary line.
struct RunReport {
  int frames = 0;            // frames read from the input
  int frames_processed = 0;  // frames given to the estimator
  int frames_dropped = 0;    // --realtime: frames the pipeline could not keep up with
  int images_skipped = 0;    // --follow: images not read (undecodable, wrong size, late, duplicate)
  int imu_dropped = 0;       // --follow: IMU samples that arrived after a later frame
  bool follow = false;
  bool threaded = false;  // front end and back end on their own threads (realtime, follow)
  // How the input ended: "complete" (read to its end), "idle" (--follow: no new image for the
  // idle time), "stopped" (SIGINT/SIGTERM), "folder-gone" (the followed folder or IMU csv
  // disappeared), "error" (a malformed line of a followed IMU csv; end_message says more) or
  // "refused" (the static initialisation was refused).
  std::string end = "complete";
  std::string end_message;
  int imu_samples = 0;
  int keyframes = 0;
  int objects = 0;  // objects in map.json
  std::vector<int>
      objects_non_finite_ids;  // objects the estimator returned with non-finite values (left out)
  std::vector<backend::MapObject> map;  // what map.json holds
  int observations = 0;          // object observations produced by the front end (processed frames)
  double duration_s = 0.0;       // sequence span, first to last frame [s]
  double wall_s = 0.0;           // wall time of reading + front end + back end + finish [s]
  double realtime_factor = 0.0;  // duration_s / wall_s
  double finish_ms = 0.0;        // Estimator::Finish (final window solve or the batch solve) [ms]
  StageStats frontend_ms, backend_ms;  // per processed frame
  // Front end from images: per-stage time ("track", "detect" over the frames it ran on,
  // "associate") and its object lifecycle counts.
  std::vector<std::pair<std::string, StageStats>> frontend_stages;
  int detector_runs = 0, objects_started = 0, objects_reidentified = 0, objects_lost = 0;
  std::string input, frontend, mode, landmarks, config;
  bool realtime = false;
  uint32_t seed = 0;
  double pixel_sigma = 0.0;
  backend::EstimatorSummary summary;
};

// {"objects": [{"id", "class", "corners_W", "width", "height", "width_sigma", "height_sigma",
// "T_W_O" (16, row-major), "observations"}]}; an unknown σ (negative) is written as null.
nlohmann::ordered_json MapToJson(const std::vector<backend::MapObject>& objects);
nlohmann::ordered_json RunReportToJson(const RunReport& report);

// Writes JSON to PATH (2-space indent); throws InputError when PATH cannot be written.
void WriteJson(const nlohmann::ordered_json& json, const std::string& path);

}  // namespace fsp::apps
