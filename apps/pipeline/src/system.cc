#include "fsp/pipeline/system.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "fsp/common/error.h"
#include "fsp/common/geometry.h"
#include "fsp/common/time.h"

namespace fsp::pipeline {

namespace {

// Attitude from the IMU alone, for the front end's predictions: roll and pitch from the mean of the
// first accelerometer samples (the start is still: the estimator refuses otherwise), then the
// gyroscope integrated. Its drift (a few degrees per minute with an uncorrected gyro bias) is far
// below what the predictions need (the rotation between two frames; "down" to +-45 degrees).
class ImuAttitude {
 public:
  void Add(const ImuSample& s) {
    if (acc_samples_ < kAccSamples) {
      acc_sum_ += s.acc;
      if (++acc_samples_ == kAccSamples) {
        // R_W_B with the measured specific force (pointing up in W when still) along +z_W.
        R_W_B_ = Quat::FromTwoVectors(acc_sum_.normalized(), Vec3::UnitZ()).toRotationMatrix();
        level_ = true;
      }
    }
    if (have_last_) {
      const double dt = NsToSeconds(s.t_ns - last_.t_ns);
      if (dt > 0.0 && dt < 0.5) {
        const Mat3 dR = ExpSO3(0.5 * (last_.gyro + s.gyro) * dt);
        R_W_B_ = R_W_B_ * dR;
        R_since_frame_ = R_since_frame_ * dR;
      }
    }
    last_ = s;
    have_last_ = true;
  }
  // R_Bprev_Bcur since the last call (the body's rotation between two frames), then restarts.
  Mat3 TakeRotationSinceFrame() {
    const Mat3 R = R_since_frame_;
    R_since_frame_.setIdentity();
    return R;
  }
  bool level() const { return level_; }
  const Mat3& R_W_B() const { return R_W_B_; }

 private:
  static constexpr int kAccSamples = 20;
  Vec3 acc_sum_ = Vec3::Zero();
  int acc_samples_ = 0;
  bool level_ = false;
  Mat3 R_W_B_ = Mat3::Identity();
  Mat3 R_since_frame_ = Mat3::Identity();
  ImuSample last_;
  bool have_last_ = false;
};

const SystemOptions& Checked(const SystemOptions& options) {
  std::string why;
  if (!options.estimator.Check(&why)) throw InputError("estimator: " + why);
  if (!options.frontend.Check(&why)) throw InputError("frontend: " + why);
  if (options.prediction_lag < 0) throw InputError("prediction_lag must be >= 0");
  return options;
}

}  // namespace

namespace internal {

// The front end, the back end and the predictions between them; System drives it on one thread,
// ThreadedSystem from two (the front-end members on one, the estimator on the other).
struct Core {
  Calibration calibration;
  int lag = 0;
  backend::Estimator estimator;
  frontend::FrontEnd frontend;
  // Front-end side.
  ImuAttitude attitude;
  bool first_frame = true;
  std::deque<Mat3> rotations;  // R_Bprev_Bcur of the last `lag` frames (oldest first)
  // Synchronous with lag > 0: the back end's state after each frame (the last lag + 1 kept).
  std::deque<std::shared_ptr<const BackendState>> states;
  int frames = 0;  // frames given (AddFrame and AddObservations)

  Core(const Calibration& c, const SystemOptions& o)
      : calibration(c),
        lag(o.prediction_lag),
        estimator(c, Checked(o).estimator),
        frontend(c.camera, o.frontend) {}

  BackendState State() const {
    BackendState s;
    s.latest = estimator.Latest();
    s.initialized = estimator.summary().initialized;
    if (s.latest && s.initialized) s.map = estimator.Map();
    return s;
  }

  // The gyroscope's rotation since the previous frame, gravity in the camera frame and where the
  // map's objects should appear: the back end's newest estimate (STATE; nullptr: the estimator's
  // current one) moved by the gyroscope's rotation and its velocity up to this frame (an IMU-only
  // prediction until the estimator is initialised).
  FramePrediction Predict(int64_t t_ns, const BackendState* state) {
    FramePrediction p;
    const Rigid3& T_B_C = calibration.T_B_C;
    const Mat3 R_B_C = T_B_C.R();
    const Mat3 R_Bprev_Bcur = attitude.TakeRotationSinceFrame();
    if (!first_frame) p.R_Cprev_Ccur = R_B_C.transpose() * R_Bprev_Bcur * R_B_C;
    first_frame = false;
    // The rotation from the state's frame to this one.
    Mat3 R_Bstate_Bcur = R_Bprev_Bcur;
    if (lag > 0) {
      Mat3 R = Mat3::Identity();
      for (const Mat3& r : rotations) R = R * r;
      R_Bstate_Bcur = R * R_Bprev_Bcur;
      rotations.push_back(R_Bprev_Bcur);
      while (static_cast<int>(rotations.size()) > lag) rotations.pop_front();
    }
    std::optional<StateSample> latest;
    bool initialized = false;
    if (state) {
      latest = state->latest;
      initialized = state->initialized;
    } else {
      latest = estimator.Latest();
      initialized = estimator.summary().initialized;
    }
    if (!latest || !initialized) {
      if (attitude.level())
        p.gravity_C = R_B_C.transpose() * attitude.R_W_B().transpose() * Vec3(0.0, 0.0, -1.0);
      return p;
    }
    p.map_known = true;
    const double dt = NsToSeconds(t_ns - latest->t_ns);
    const Rigid3 T_W_B(latest->T_W_B.R() * R_Bstate_Bcur,
                       latest->T_W_B.translation() + dt * latest->v_W);
    const Rigid3 T_C_W = (T_W_B * T_B_C).Inverse();
    p.gravity_C = T_C_W.R() * Vec3(0.0, 0.0, -1.0);
    const PinholeRadtan& cam = calibration.camera;
    const std::vector<backend::MapObject> map = state ? state->map : estimator.Map();
    for (const backend::MapObject& o : map) {
      Corners c;
      bool ok = true;
      for (int j = 0; j < 4 && ok; ++j) {
        const Vec3 p_C = T_C_W * o.corners_W[j];
        ok = p_C.z() > 0.1;
        c[j] = Vec2(cam.fx * p_C.x() / p_C.z() + cam.cx, cam.fy * p_C.y() / p_C.z() + cam.cy);
      }
      if (ok) {
        p.objects.emplace_back(o.id, c);
      } else {
        p.objects_behind.push_back(o.id);
      }
    }
    return p;
  }

  // The front end on one frame with the predictions from STATE (see Predict).
  FrameOutput Front(const Frame& frame, const BackendState* state) {
    frontend::Stopwatch sw;
    const FramePrediction prediction = Predict(frame.t_ns, state);
    frontend::FrontEndResult fe = frontend.Process(frame, prediction);
    FrameOutput out;
    out.frontend_ms = sw.Lap();
    out.observations = std::move(fe.observations);
    out.points = std::move(fe.points);
    out.frontend_times = std::move(fe.times);
    out.detector_ran = fe.detected;
    out.objects_started = fe.started;
    out.objects_reidentified = fe.reidentified;
    out.objects_lost = fe.lost;
    return out;
  }

  // The back end on one frame's observations (OUT.observations); fills OUT's back-end fields.
  void Back(int64_t t_ns, FrameOutput* out) {
    frontend::Stopwatch sw;
    out->estimator_initialized = estimator.AddFrame(t_ns, out->observations, out->points);
    out->backend_ms = sw.Lap();
  }

  std::vector<backend::MapObject> ClassifiedMap() const {
    std::vector<backend::MapObject> map = estimator.Map();
    for (backend::MapObject& o : map) {
      const ObjectClass c = frontend.ClassOf(o.id);
      if (c != ObjectClass::kUnknown) o.object_class = c;
    }
    return map;
  }
};

}  // namespace internal

namespace {

const BackendState& NothingKnown() {
  static const BackendState kNothing;
  return kNothing;
}

}  // namespace

System::System(const Calibration& calibration, const SystemOptions& options)
    : core_(std::make_unique<internal::Core>(calibration, options)) {}

System::~System() = default;

void System::AddImu(const ImuSample& sample) {
  core_->estimator.AddImu(sample);
  core_->attitude.Add(sample);
}

FrameOutput System::AddFrame(const Frame& frame) {
  internal::Core& c = *core_;
  const BackendState* state = nullptr;  // lag 0: the estimator as it is now
  if (c.lag > 0) {
    // The state after frame frames - 1 - lag; states holds those after frames - 1 - lag .. - 1.
    state = static_cast<int>(c.states.size()) > c.lag ? c.states.front().get() : &NothingKnown();
  }
  FrameOutput out = c.Front(frame, state);
  Back(frame.t_ns, &out);
  return out;
}

FrameOutput System::AddObservations(int64_t t_ns,
                                    const std::vector<ObjectObservation>& observations,
                                    const std::vector<PointObservation>& points) {
  FrameOutput out;
  out.observations = observations;
  out.points = points;
  Back(t_ns, &out);
  return out;
}

void System::Back(int64_t t_ns, FrameOutput* out) {
  internal::Core& c = *core_;
  c.Back(t_ns, out);
  ++c.frames;
  if (c.lag > 0) {
    c.states.push_back(std::make_shared<const BackendState>(c.State()));
    while (static_cast<int>(c.states.size()) > c.lag + 1) c.states.pop_front();
  }
}

void System::Finish() {
  core_->estimator.Finish();
}

std::vector<StampedPose> System::CausalTrajectory() const {
  return core_->estimator.CausalTrajectory();
}

std::vector<StampedPose> System::Trajectory() const {
  return core_->estimator.Trajectory();
}

std::vector<backend::MapObject> System::Map() const {
  return core_->ClassifiedMap();
}

std::optional<StateSample> System::Latest() const {
  return core_->estimator.Latest();
}

const backend::EstimatorSummary& System::summary() const {
  return core_->estimator.summary();
}

// ---------------------------------------------------------------------------------------------
// ThreadedSystem: the caller queues measurements (in), the front-end thread turns frames into
// observations and passes everything on in order (back), the back-end thread runs the estimator
// and publishes its state after each frame (states) and the frame's result (results). One mutex
// guards every queue and flag; each wait is on a condition variable.

struct ThreadedSystem::Impl {
  enum class Kind { kImu, kFrame, kObservations };
  struct Item {
    Kind kind = Kind::kImu;
    ImuSample imu;
    Frame frame;         // kFrame; t_ns also for kObservations
    FrameOutput output;  // kObservations: the observations; after the front end: its output
  };

  internal::Core core;
  ThreadOptions options;

  std::mutex m;
  std::condition_variable in_ready, in_room, back_ready, back_room, state_ready;
  std::deque<Item> in;
  int in_frames = 0;
  std::deque<Item> back;
  int back_frames = 0;
  // The back end's state after frame states_first + i (the last lag + 1 kept).
  std::deque<std::shared_ptr<const BackendState>> states;
  int back_done = 0;  // frames the back end has finished
  std::vector<FrameResult> results;
  bool closing = false;     // Finish: no more input; the threads drain the queues and end
  bool front_done = false;  // the front-end thread has passed on everything
  bool abort = false;       // destructor, or an error on a worker thread
  std::exception_ptr error;
  std::atomic<bool> init_failed{false};
  std::thread front_thread, back_thread;

  Impl(const Calibration& c, const SystemOptions& o, const ThreadOptions& t)
      : core(c, o), options(t) {
    if (options.queue_frames < 1) throw InputError("queue_frames must be >= 1");
    front_thread = std::thread([this] { Guard([this] { FrontLoop(); }); });
    back_thread = std::thread([this] { Guard([this] { BackLoop(); }); });
  }

  // Runs FN; an exception ends both threads and is kept for the caller.
  void Guard(const std::function<void()>& fn) {
    try {
      fn();
    } catch (...) {
      std::lock_guard<std::mutex> lock(m);
      if (!error) error = std::current_exception();
      abort = true;
      NotifyAll();
    }
  }

  void NotifyAll() {
    in_ready.notify_all();
    in_room.notify_all();
    back_ready.notify_all();
    back_room.notify_all();
    state_ready.notify_all();
  }

  void RethrowLocked() {
    if (error) std::rethrow_exception(error);
  }

  int Push(Item item, bool drop_oldest) {
    std::unique_lock<std::mutex> lock(m);
    RethrowLocked();
    int dropped = 0;
    if (in_frames >= options.queue_frames) {
      if (drop_oldest) {
        const auto oldest =
            std::find_if(in.begin(), in.end(), [](const Item& i) { return i.kind != Kind::kImu; });
        in.erase(oldest);
        --in_frames;
        dropped = 1;
      } else {
        in_room.wait(lock, [&] { return in_frames < options.queue_frames || abort; });
        RethrowLocked();
      }
    }
    in.push_back(std::move(item));
    ++in_frames;
    in_ready.notify_one();
    return dropped;
  }

  void FrontLoop() {
    int k = 0;  // frames passed on
    for (;;) {
      Item item;
      {
        std::unique_lock<std::mutex> lock(m);
        in_ready.wait(lock, [&] { return !in.empty() || closing || abort; });
        if (abort) return;
        if (in.empty()) {
          front_done = true;
          back_ready.notify_all();
          return;
        }
        item = std::move(in.front());
        in.pop_front();
        if (item.kind != Kind::kImu) {
          --in_frames;
          in_room.notify_all();
        }
      }
      if (item.kind == Kind::kImu) {
        core.attitude.Add(item.imu);
      } else {
        if (item.kind == Kind::kFrame) {
          // The back end's state after frame k - 1 - lag (waits for it).
          std::shared_ptr<const BackendState> state;
          const int wanted = k - 1 - core.lag;
          if (wanted >= 0) {
            std::unique_lock<std::mutex> lock(m);
            state_ready.wait(lock, [&] { return back_done > wanted || abort; });
            if (abort) return;
            state = states.at(
                static_cast<size_t>(wanted - (back_done - static_cast<int>(states.size()))));
          }
          item.output = core.Front(item.frame, state ? state.get() : &NothingKnown());
          if (!options.keep_images) item.frame.image.release();
        }
        ++k;
      }
      std::unique_lock<std::mutex> lock(m);
      if (item.kind != Kind::kImu) {
        back_room.wait(lock, [&] { return back_frames < core.lag + 1 || abort; });
        if (abort) return;
        ++back_frames;
      }
      back.push_back(std::move(item));
      back_ready.notify_one();
    }
  }

  void BackLoop() {
    for (;;) {
      Item item;
      {
        std::unique_lock<std::mutex> lock(m);
        back_ready.wait(lock, [&] { return !back.empty() || front_done || abort; });
        if (abort) return;
        if (back.empty()) return;  // front_done and drained
        item = std::move(back.front());
        back.pop_front();
        if (item.kind != Kind::kImu) {
          --back_frames;
          back_room.notify_all();
        }
      }
      if (item.kind == Kind::kImu) {
        core.estimator.AddImu(item.imu);
        continue;
      }
      FrameResult result;
      result.output = std::move(item.output);
      result.frame = std::move(item.frame);
      core.Back(result.frame.t_ns, &result.output);
      auto state = std::make_shared<const BackendState>(core.State());
      result.state = state;
      if (!core.estimator.summary().init_failure.empty()) init_failed = true;
      std::lock_guard<std::mutex> lock(m);
      states.push_back(std::move(state));
      while (static_cast<int>(states.size()) > core.lag + 1) states.pop_front();
      ++back_done;
      results.push_back(std::move(result));
      state_ready.notify_all();
    }
  }

  void Stop() {
    {
      std::lock_guard<std::mutex> lock(m);
      abort = true;
      NotifyAll();
    }
    Join();
  }

  void Join() {
    if (front_thread.joinable()) front_thread.join();
    if (back_thread.joinable()) back_thread.join();
  }
};

ThreadedSystem::ThreadedSystem(const Calibration& calibration, const SystemOptions& options,
                               const ThreadOptions& threads)
    : impl_(std::make_unique<Impl>(calibration, options, threads)) {}

ThreadedSystem::~ThreadedSystem() {
  impl_->Stop();
}

void ThreadedSystem::AddImu(const ImuSample& sample) {
  std::lock_guard<std::mutex> lock(impl_->m);
  impl_->RethrowLocked();
  Impl::Item item;
  item.kind = Impl::Kind::kImu;
  item.imu = sample;
  impl_->in.push_back(std::move(item));
  impl_->in_ready.notify_one();
}

int ThreadedSystem::AddFrame(Frame frame, bool drop_oldest) {
  Impl::Item item;
  item.kind = Impl::Kind::kFrame;
  item.frame = std::move(frame);
  return impl_->Push(std::move(item), drop_oldest);
}

int ThreadedSystem::AddObservations(int64_t t_ns, std::vector<ObjectObservation> observations,
                                    bool drop_oldest) {
  Impl::Item item;
  item.kind = Impl::Kind::kObservations;
  item.frame.t_ns = t_ns;
  item.output.observations = std::move(observations);
  return impl_->Push(std::move(item), drop_oldest);
}

std::vector<FrameResult> ThreadedSystem::TakeResults() {
  std::lock_guard<std::mutex> lock(impl_->m);
  std::vector<FrameResult> out;
  out.swap(impl_->results);
  return out;
}

bool ThreadedSystem::stopped() const {
  return impl_->init_failed;
}

void ThreadedSystem::Finish() {
  {
    std::lock_guard<std::mutex> lock(impl_->m);
    impl_->closing = true;
    impl_->in_ready.notify_all();
  }
  impl_->Join();
  {
    std::lock_guard<std::mutex> lock(impl_->m);
    impl_->RethrowLocked();
  }
  impl_->core.estimator.Finish();
}

std::vector<StampedPose> ThreadedSystem::Trajectory() const {
  return impl_->core.estimator.Trajectory();
}

std::vector<StampedPose> ThreadedSystem::CausalTrajectory() const {
  return impl_->core.estimator.CausalTrajectory();
}

std::vector<backend::MapObject> ThreadedSystem::Map() const {
  return impl_->core.ClassifiedMap();
}

const backend::EstimatorSummary& ThreadedSystem::summary() const {
  return impl_->core.estimator.summary();
}

}  // namespace fsp::pipeline
