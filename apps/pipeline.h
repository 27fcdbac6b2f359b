// The `fsp run` pipeline as a function (shared by `fsp run` and `fsp bench`): input source -> front
// end
// -> estimator -> the run folder (trajectory.tum, map.json, observations.csv, run.json).
#pragma once

#include <string>

#include "fsp/common/dataset.h"
#include "run_config.h"
#include "run_outputs.h"

namespace fsp::apps {

struct RunRequest {
  SourceOptions source;           // INPUT, --calib, --imu
  std::string out_dir;            // created when missing
  std::string frontend = "rect";  // rect | apriltag (from images) | gt-corners | corners
  std::string corners;            // --frontend corners: the corners file (ExternalCornersFrontend)
  std::string objects;            // --frontend corners: optional object classes
  // Pace the input at its recorded rate and drop the frames the pipeline cannot keep up with (a
  // frame is dropped when the next one is already due by the time the pipeline is ready for it).
  bool realtime = false;
  bool progress = true;  // progress bar on a terminal
  std::string video;     // --video: the annotated video (AnnotatedVideo), empty for none
};

// Runs the whole pipeline with CONFIG (mode, landmarks, seed already applied) and writes the
// outputs. Throws InputError on bad input. A refused static initialisation is not thrown: the
// report's summary.init_failure says why (the outputs are still written; the caller decides the
// exit code).
RunReport RunPipeline(const RunRequest& request, const RunConfig& config);

const char* ModeName(backend::EstimatorMode mode);          // "window", "batch"
const char* LandmarkName(backend::LandmarkType landmarks);  // "fsp", "fhp"

}  // namespace fsp::apps
