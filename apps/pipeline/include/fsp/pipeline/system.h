// The SLAM system as a library: images and IMU samples in, trajectory and map of rectangles out.
// The front end (detection, tracking, association) and the back end (the visual-inertial estimator)
// joined, with the predictions that flow back (the gyroscope's rotation between frames, gravity in
// the camera frame). `fsp run`, the tests and the benchmarks all drive this class; it draws
// nothing, writes no file and reads no clock but the stage timers.
//
//   fsp::pipeline::System slam(calibration, options);
//   for each measurement in time order:
//     slam.AddImu(sample)                     // IMU samples
//     slam.AddFrame(frame)                    // images: front end + back end
//     (or slam.AddObservations(t_ns, obs)     // corners from elsewhere: back end only)
//   slam.Finish();  slam.Trajectory();  slam.Map();
//
// Synchronous and deterministic: the same measurements give the same outputs.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "fsp/backend/estimator.h"
#include "fsp/common/calibration.h"
#include "fsp/common/types.h"
#include "fsp/frontend/detection.h"
#include "fsp/frontend/frontend.h"

namespace fsp::pipeline {

struct SystemOptions {
  backend::EstimatorOptions estimator;
  frontend::FrontEndOptions frontend;
};

// What one frame produced.
struct FrameOutput {
  std::vector<ObjectObservation> observations;  // what the back end was given
  frontend::StageTimes frontend_times;  // track, detect, associate (empty for AddObservations)
  double frontend_ms = 0.0;
  double backend_ms = 0.0;
  bool estimator_initialized = false;
  // Front end lifecycle in this frame (AddFrame only).
  bool detector_ran = false;
  int objects_started = 0, objects_reidentified = 0, objects_lost = 0;
};

class System {
 public:
  // Throws InputError when an option is out of range (naming it) or the AprilTag family is unknown.
  System(const Calibration& calibration, const SystemOptions& options);
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  // IMU samples in time order (an older sample throws InputError).
  void AddImu(const ImuSample& sample);
  // A camera frame (8-bit grey, the calibration's size): front end, then back end.
  FrameOutput AddFrame(const Frame& frame);
  // Observations made elsewhere (undistorted corners, s1..s4), for the back end alone.
  FrameOutput AddObservations(int64_t t_ns, const std::vector<ObjectObservation>& observations);
  // Ends the sequence (the final window or batch solve).
  void Finish();

  std::vector<StampedPose> Trajectory() const;
  // What a live user had at each frame (the estimate right after the frame's own update).
  std::vector<StampedPose> CausalTrajectory() const;
  std::vector<backend::MapObject> Map() const;  // classes as the front end named them
  // The newest frame's estimate (nullopt before the first), O(1).
  std::optional<StateSample> Latest() const;
  const backend::EstimatorSummary& summary() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fsp::pipeline
