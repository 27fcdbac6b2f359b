// The SLAM system as a library: images and IMU samples in, trajectory and map of rectangles out.
// The front end (detection, tracking, association) and the back end (the visual-inertial estimator)
// joined, with the predictions that flow back (the gyroscope's rotation between frames, gravity in
// the camera frame, where the map's objects should appear). `fsp run`, the tests and the
// benchmarks all drive these classes; they draw nothing, write no file and read no clock but the
// stage timers.
//
// System: synchronous, on the caller's thread.
//
//   fsp::pipeline::System slam(calibration, options);
//   for each measurement in time order:
//     slam.AddImu(sample)                     // IMU samples
//     slam.AddFrame(frame)                    // images: front end + back end
//     (or slam.AddObservations(t_ns, obs)     // corners from elsewhere: back end only)
//   slam.Finish();  slam.Trajectory();  slam.Map();
//
// ThreadedSystem: the same with the front end and the back end each on its own thread (live use:
// `fsp run --realtime / --follow`). The caller's Add* calls queue and return; a bounded queue of
// frames waits for the front end, and a full queue either blocks the caller or drops its oldest
// frame (a live camera's behaviour). Results come back through TakeResults().
//
// Predictions and determinism: the front end's predictions for frame k come from the back end's
// state after frame k - 1 - prediction_lag. With lag 0 (System's default) the front end of frame k
// waits for the back end of frame k - 1; with lag 1 (what `fsp run` uses, threaded or not) the
// front end of frame k runs while the back end solves frame k - 1, and the predictions are one
// frame older (one more frame of gyroscope-and-velocity extrapolation before the map gates a
// re-identification; on the rendered rooms, the 60 s default room from pixels included, this
// changed no output byte; where the map's prediction decides a return it could). Either way the
// outputs depend only on the measurements and the frames given, not on timing: System and
// ThreadedSystem with the same lag give byte-identical outputs when no frame is dropped.
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
  // The front end's predictions for frame k use the back end's state after frame k - 1 - lag (0 or
  // more; see above). ThreadedSystem needs 1 for its two threads to overlap.
  int prediction_lag = 0;
};

// What the back end knew right after one frame: the front end's predictions start from it, and a
// viewer draws it.
struct BackendState {
  std::optional<StateSample> latest;    // the newest frame's estimate (Estimator::Latest)
  bool initialized = false;             // the estimator is initialised
  std::vector<backend::MapObject> map;  // Estimator::Map() once initialised (else empty)
};

// What one frame produced.
struct FrameOutput {
  std::vector<ObjectObservation> observations;  // what the back end was given
  // The front end's point features (frontend.points.enabled; AddFrame only), what the back end was
  // given beside the observations: landmarks in the window (estimator.points) and the
  // initialisation in motion from points (estimator.point_init).
  std::vector<PointObservation> points;
  frontend::StageTimes frontend_times;  // track, detect, associate (empty for AddObservations)
  double frontend_ms = 0.0;
  double backend_ms = 0.0;
  bool estimator_initialized = false;
  // Front end lifecycle in this frame (AddFrame only).
  bool detector_ran = false;
  int objects_started = 0, objects_reidentified = 0, objects_lost = 0;
};

namespace internal {
struct Core;
}

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
  // Observations made elsewhere (undistorted corners, s1..s4; point features), for the back end
  // alone.
  FrameOutput AddObservations(int64_t t_ns, const std::vector<ObjectObservation>& observations,
                              const std::vector<PointObservation>& points = {});
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
  // The back end on OUT's observations and points; fills OUT's back-end fields.
  void Back(int64_t t_ns, FrameOutput* out);
  std::unique_ptr<internal::Core> core_;
};

// One frame's result from ThreadedSystem, in the order the frames were given.
struct FrameResult {
  Frame frame;  // as given (its image only with ThreadOptions::keep_images; t_ns for observations)
  FrameOutput output;
  std::shared_ptr<const BackendState> state;  // the back end right after this frame
};

struct ThreadOptions {
  // Frames waiting for the front end at most (>= 1). When full, AddFrame blocks or drops the
  // oldest waiting frame (see AddFrame). IMU samples are never dropped and not counted.
  int queue_frames = 2;
  // Keep each frame's image in its FrameResult (for drawing); otherwise it is released after the
  // front end.
  bool keep_images = false;
};

class ThreadedSystem {
 public:
  // Starts the two threads. OPTIONS.prediction_lag is used as given (1 lets the threads overlap).
  // Throws InputError as System does.
  ThreadedSystem(const Calibration& calibration, const SystemOptions& options,
                 const ThreadOptions& threads = ThreadOptions());
  // Stops the threads (work still queued is discarded) when Finish() was not called.
  ~ThreadedSystem();
  ThreadedSystem(const ThreadedSystem&) = delete;
  ThreadedSystem& operator=(const ThreadedSystem&) = delete;

  // Queue IMU samples and frames in time order, as System takes them. When queue_frames frames
  // already wait, AddFrame and AddObservations block until one is taken (DROP_OLDEST false), or
  // drop the oldest waiting frame to make room (DROP_OLDEST true: a live camera's newest frame
  // matters most); they return the number of frames dropped (0 or 1). An error raised on a
  // worker thread (an IMU sample out of order) is rethrown by the next call.
  void AddImu(const ImuSample& sample);
  int AddFrame(Frame frame, bool drop_oldest);
  int AddObservations(int64_t t_ns, std::vector<ObjectObservation> observations, bool drop_oldest);
  // The results of the frames the back end has finished since the last call, in order.
  std::vector<FrameResult> TakeResults();
  // True once the back end refused its initialisation: later frames change nothing (the caller
  // may stop feeding).
  bool stopped() const;
  // Processes every queued frame, stops the threads and ends the sequence (System::Finish). The
  // accessors below are valid after it.
  void Finish();

  std::vector<StampedPose> Trajectory() const;
  std::vector<StampedPose> CausalTrajectory() const;
  std::vector<backend::MapObject> Map() const;
  const backend::EstimatorSummary& summary() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fsp::pipeline
