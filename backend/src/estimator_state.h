// The estimator's state per keyframe, object and point track (the parts of Estimator::Impl that
// the files implementing it share; estimator_impl.h). Internal: not installed.
#pragma once

#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "fsp/backend/estimator.h"
#include "fsp/backend/imu_preintegration.h"
#include "landmark_model.h"

namespace fsp::backend {

namespace internal {

using Clock = std::chrono::steady_clock;
inline double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// The priors that fix a session's gauge at its first keyframe: pose (position and yaw pinned, roll
// and pitch as well as known) and speed/biases.
struct Gauge {
  Rigid3 T_W_B0;
  double sigma_p = 1e-3, sigma_roll_pitch = 0.02, sigma_yaw = 1e-3;
  Eigen::Matrix<double, 9, 1> sb0 = Eigen::Matrix<double, 9, 1>::Zero();
  Eigen::Matrix<double, 9, 1> sigma_sb = Eigen::Matrix<double, 9, 1>::Ones();
};

struct Keyframe {
  int index = 0;  // position in Impl::keyframes
  int frame = 0;  // position in Impl::output (the frame's reported state)
  // False for a window-mode frame that is solved with the window and dropped when the next frame
  // arrives (it is always the newest state).
  bool keyframe = true;
  KeyframeState state;
  // Preintegrated IMU from the previous keyframe (null for the first keyframe of a session and
  // across an IMU gap).
  std::shared_ptr<ImuPreintegration> preint;
  // > 0: the IMU has a hole between the previous keyframe and this one, which are linked by the
  // motion prior over this interval instead [s].
  double imu_gap_s = 0.0;
  // Set on the first keyframe of a session (the start, and every restart): no link to the
  // previous keyframe, its gauge priors instead.
  std::optional<Gauge> gauge;
  std::vector<ObjectObservation> observations;
  // The frame's point features (PointOptions; empty when disabled or none given).
  std::vector<PointObservation> points;
  // It saw live points: the global step (which holds no points) ties it to its neighbours by the
  // window's estimate of their relative pose, whole through a stretch without objects, by its shape
  // elsewhere (PointOptions::global_shape_links; backend/README.md, "Points").
  bool sees_points = false;
  bool PointsOnly() const { return observations.empty() && sees_points; }
  // The window's estimate of T_Bprev_B (the previous keyframe's body to this one's), taken when the
  // previous keyframe left the window with points in use.
  std::optional<Rigid3> window_motion;
  // Standing still since the previous keyframe (ZeroVelocityOptions): a zero-velocity prior.
  bool still = false;
};

// The first whole view of an object not in the map yet (EstimatorOptions::start_agree_px).
struct StartView {
  Keyframe* kf;
  ObjectObservation observation;
};

struct Object {
  int id = -1;
  ObjectClass object_class = ObjectClass::kUnknown;
  Keyframe* anchor = nullptr;  // F = camera frame of this keyframe
  Landmark landmark;
  double width_prior_m = 1.0;  // the class's typical width (the single-view initialisation's)
  int observations = 0;
  int first_seen = -1;  // index of the keyframe that first saw it (its first anchor)
  int last_seen = -1;   // index of the newest keyframe that saw it
  // Its views' σ are their own times this (>= 1): how far its views in the window typically lie
  // from it, in their σ (Estimator::Impl::DropInconsistentObjects; backend/README.md, "Objects on
  // probation").
  double noise_scale = 1.0;
  // Observations from keyframes that left the window (pose constant), newest last, capped.
  struct PastView {
    Keyframe* keyframe;
    Corners corners;
    CornerMask seen;
    double sigma_px;  // ObjectObservation::sigma_px
  };
  std::deque<PastView> past;
};

// A point feature seen by keyframes in the window (PointOptions, backend/README.md "Points"). Live:
// a variable of the window (inverse depth `rho` along `bearing_F` in its anchor's camera).
struct PointTrack {
  struct View {
    Keyframe* kf;
    Vec2 uv;  // undistorted pixels
  };
  std::vector<View> views;  // window keyframes that saw it, oldest first
  bool live = false;
  bool used = false;       // entered the window once (summary.points_used)
  bool dead = false;       // dropped as an outlier: never enters again
  bool accounted = false;  // its track length is in summary.point_track_keyframes
  int keyframes_seen = 0;  // keyframes that saw it
  Keyframe* anchor = nullptr;
  Vec3 bearing_F = Vec3::UnitZ();  // (x, y, 1), the anchor view's normalised bearing
  double rho = 0.0;                // inverse depth along F's optical axis [1/m]
  double sigma_scale = 1.0;        // PointObservation::sigma_scale
};

using Keyframes = std::deque<std::unique_ptr<Keyframe>>;
using Objects = std::map<int, std::unique_ptr<Object>>;

}  // namespace internal

}  // namespace fsp::backend
