// The `fsp run` pipeline as a function (shared by `fsp run` and `fsp bench`): input source -> front
// end -> estimator -> the run folder (trajectory.tum, map.json, observations.csv, run.json).
#pragma once

#include <atomic>
#include <functional>
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
  // Follow an image folder a camera driver fills (FolderFollower): until no new image arrived for
  // idle_s, STOP is set, or the folder disappears. Every frame is processed (the folder is a
  // buffer) unless `realtime` also asks to drop what the pipeline cannot keep up with.
  bool follow = false;
  double idle_s = 5.0;
  // > 0: only the measurements within this many seconds of the first frame (frames and IMU samples
  // up to the first frame's time + until_s); not with `follow`.
  double until_s = 0.0;
  double poll_s = 0.02;
  // The front end and the back end run on their own threads (pipeline::ThreadedSystem) unless
  // `synchronous` asks for one thread (the live modes always use threads). Both schedules give the
  // front end the back end's state one frame old (prediction lag 1), so their outputs are
  // byte-identical.
  bool synchronous = false;
  // Set from outside (a signal handler): stop reading, process what is queued, write the outputs.
  const std::atomic<bool>* stop = nullptr;
  // Warnings while running (an image skipped, no display for --show); may be empty.
  std::function<void(const std::string&)> warn;
  bool progress = true;  // progress bar on a terminal
  std::string video;     // --video: the annotated video (AnnotatedVideo), empty for none
  bool show = false;     // --show: the annotated frame in a window (where a display exists)
};

// Runs the whole pipeline with CONFIG (mode, landmarks, seed already applied) and writes the
// outputs (each file written to a temporary name and renamed: a reader never sees half a file).
// Throws InputError on bad input. A refused static initialisation is not thrown: the report's
// summary.init_failure says why (the outputs are still written; the caller decides the exit code).
// Neither is a followed folder that disappeared or a malformed line of a growing IMU csv: the
// outputs of what was processed are written, and the report's `end` and `end_message` say what
// happened.
RunReport RunPipeline(const RunRequest& request, const RunConfig& config);

const char* ModeName(backend::EstimatorMode mode);          // "window", "batch"
const char* LandmarkName(backend::LandmarkType landmarks);  // "fsp", "fhp"

}  // namespace fsp::apps
