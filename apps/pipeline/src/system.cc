#include "fsp/pipeline/system.h"

#include <string>

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
  return options;
}

}  // namespace

struct System::Impl {
  Calibration calibration;
  backend::Estimator estimator;
  frontend::FrontEnd frontend;
  ImuAttitude attitude;
  bool first_frame = true;

  Impl(const Calibration& c, const SystemOptions& o)
      : calibration(c), estimator(c, Checked(o).estimator), frontend(c.camera, o.frontend) {}

  // The gyroscope's rotation since the previous frame, gravity in the camera frame and where the
  // map's objects should appear: the newest estimate moved by the gyroscope's rotation and its
  // velocity over the frame interval (an IMU-only prediction until the estimator is initialised).
  FramePrediction Predict(int64_t t_ns) {
    FramePrediction p;
    const Rigid3& T_B_C = calibration.T_B_C;
    const Mat3 R_B_C = T_B_C.R();
    const Mat3 R_Bprev_Bcur = attitude.TakeRotationSinceFrame();
    if (!first_frame) p.R_Cprev_Ccur = R_B_C.transpose() * R_Bprev_Bcur * R_B_C;
    first_frame = false;
    const std::optional<StateSample> latest = estimator.Latest();
    if (!latest || !estimator.summary().initialized) {
      if (attitude.level())
        p.gravity_C = R_B_C.transpose() * attitude.R_W_B().transpose() * Vec3(0.0, 0.0, -1.0);
      return p;
    }
    p.map_known = true;
    const double dt = NsToSeconds(t_ns - latest->t_ns);
    const Rigid3 T_W_B(latest->T_W_B.R() * R_Bprev_Bcur,
                       latest->T_W_B.translation() + dt * latest->v_W);
    const Rigid3 T_C_W = (T_W_B * T_B_C).Inverse();
    p.gravity_C = T_C_W.R() * Vec3(0.0, 0.0, -1.0);
    const PinholeRadtan& cam = calibration.camera;
    for (const backend::MapObject& o : estimator.Map()) {
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
};

System::System(const Calibration& calibration, const SystemOptions& options)
    : impl_(std::make_unique<Impl>(calibration, options)) {}

System::~System() = default;

void System::AddImu(const ImuSample& sample) {
  impl_->estimator.AddImu(sample);
  impl_->attitude.Add(sample);
}

FrameOutput System::AddFrame(const Frame& frame) {
  frontend::Stopwatch sw;
  const FramePrediction prediction = impl_->Predict(frame.t_ns);
  frontend::FrontEndResult fe = impl_->frontend.Process(frame, prediction);
  const double frontend_ms = sw.Lap();
  FrameOutput out = AddObservations(frame.t_ns, fe.observations);
  out.frontend_times = std::move(fe.times);
  out.frontend_ms = frontend_ms;
  out.detector_ran = fe.detected;
  out.objects_started = fe.started;
  out.objects_reidentified = fe.reidentified;
  out.objects_lost = fe.lost;
  return out;
}

FrameOutput System::AddObservations(int64_t t_ns,
                                    const std::vector<ObjectObservation>& observations) {
  FrameOutput out;
  frontend::Stopwatch sw;
  out.estimator_initialized = impl_->estimator.AddFrame(t_ns, observations);
  out.backend_ms = sw.Lap();
  out.observations = observations;
  return out;
}

void System::Finish() {
  impl_->estimator.Finish();
}

std::vector<StampedPose> System::CausalTrajectory() const {
  return impl_->estimator.CausalTrajectory();
}

std::vector<StampedPose> System::Trajectory() const {
  return impl_->estimator.Trajectory();
}

std::vector<backend::MapObject> System::Map() const {
  std::vector<backend::MapObject> map = impl_->estimator.Map();
  for (backend::MapObject& o : map) {
    const ObjectClass c = impl_->frontend.ClassOf(o.id);
    if (c != ObjectClass::kUnknown) o.object_class = c;
  }
  return map;
}

std::optional<StateSample> System::Latest() const {
  return impl_->estimator.Latest();
}

const backend::EstimatorSummary& System::summary() const {
  return impl_->estimator.summary();
}

}  // namespace fsp::pipeline
