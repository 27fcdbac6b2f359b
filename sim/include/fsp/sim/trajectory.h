// An analytic body trajectory for simulation (in the spirit of gtsam's Scenario): pose T_W_B(t),
// world velocity and acceleration, and body angular velocity at any time, all from closed-form
// derivatives, so ideal IMU samples and ground truth agree exactly.
//
// Flight model (hexacopter-like, differential flatness as in Mellinger & Kumar, ICRA 2011): the
// flat outputs are position p_W(t) and yaw psi(t). The thrust axis (body z) is along the specific
// force
//     b3 = (a_W - g_W) / |a_W - g_W|,   g_W = (0, 0, -9.81),
// and the heading fixes the rest:  x_c = (cos psi, sin psi, 0),  b2 = b3 x x_c / |b3 x x_c|,  b1 =
// b2 x b3,
//     R_W_B = [b1 b2 b3].
// So roll and pitch follow the acceleration, and yaw the waypoints (body y is horizontal,
// perpendicular to the heading x_c; body x projected on the floor is along psi up to O(tilt^2)).
// The angular velocity is exact: d/dt of each column follows from the jerk and the yaw rate (see
// trajectory.cc), and
//     [w_B]x = R_W_B^T dR_W_B/dt.
//
// Time t is in seconds since the start of the sequence (t = 0 is the first frame and IMU sample).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::sim {

constexpr double kGravity = 9.81;  // [m/s^2]
// Gravity in W (z up).
inline Vec3 GravityW() {
  return Vec3(0.0, 0.0, -kGravity);
}

// A waypoint of the flight: where the body is at time t_s, and its heading.
struct Waypoint {
  double t_s = 0.0;         // [s] since the start; strictly increasing along the list
  Vec3 p_W = Vec3::Zero();  // body position [m]
  double yaw_rad = 0.0;     // heading about world z [rad] (body x axis projected on the floor)
};

// Everything the IMU and the ground truth need at one instant.
struct TrajectoryState {
  Rigid3 T_W_B;
  Vec3 v_W = Vec3::Zero();  // [m/s]
  Vec3 a_W = Vec3::Zero();  // [m/s^2], gravity not included
  Vec3 w_B = Vec3::Zero();  // body angular velocity in B [rad/s]
};

struct TrajectoryOptions {
  // Pose files: positions and yaw are smoothed with a Gaussian of this standard deviation [s]
  // before resampling. Larger removes more jitter (hand-held recordings) but cuts corners of fast
  // motion.
  double pose_smoothing_s = 0.15;
  // Pose files: control-point spacing of the B-spline [s]. Smaller follows the file more closely
  // but keeps more of the file's noise in the acceleration (and so in roll/pitch and the IMU).
  double pose_knot_s = 0.1;
  // Smallest thrust (|a_W - g_W|) the flight may demand [m/s^2]: below it the attitude is undefined
  // (free fall). Trajectories that need less are rejected.
  double min_thrust = 2.0;
  bool Check(std::string* why) const;
};

// Most knots a pose file may be resampled into (FromPoses): 2.8 hours at the default 0.1 s.
constexpr int kMaxPoseKnots = 100'000;

// A C3 trajectory (continuous position, velocity, acceleration and jerk, hence continuous angular
// velocity) through waypoints: one degree-7 Hermite polynomial per segment in (x, y, z, yaw),
// matching position, velocity, acceleration and jerk at both ends. Waypoint derivatives: velocity
// and acceleration of the parabola through the waypoint and its two neighbours; jerk zero; all
// derivatives zero at the first and last waypoint and at both ends of a still segment (equal
// consecutive waypoints), so a repeated waypoint is an exact hover.
class Trajectory {
 public:
  // Throws InputError (no file prefix; callers add it) when there are fewer than 2 waypoints, times
  // do not increase, or the flight would need less thrust than options.min_thrust.
  static Trajectory FromWaypoints(const std::vector<Waypoint>& waypoints,
                                  const TrajectoryOptions& options = TrajectoryOptions());
  // Poses (e.g. a TUM file), shifted so the first is at t = 0, smoothed (a Gaussian of
  // pose_smoothing_s) and sampled every pose_knot_s into the control points of a uniform quintic
  // B-spline in (x, y, z, yaw): C4, so jerk and angular velocity are smooth, and no derivative is
  // imposed at the knots. (Hermite segments through such dense knots, with their jerk zero at every
  // knot, shook the attitude at the knot rate: a recorded flight became a 10-30 Hz roll and pitch
  // vibration of 0.3 rad/s rms that a 100 Hz IMU cannot integrate, 0.07 deg of gyro-integration
  // error per 0.1 s, 20 times the gyro noise; the estimator took it for a 12 % scale error.) The
  // first and last control points are repeated, so the flight starts and ends with a hover of 3
  // knots: the curve passes the pose of file time t at t + 3 pose_knot_s (0.3 s at the default)
  // and ends 6 knots after the file. Roll and pitch are not taken from
  // the file: they follow the flight model. Throws InputError as above, or when the poses span
  // less than two knots or more than kMaxPoseKnots (or more than 292 years).
  static Trajectory FromPoses(const std::vector<StampedPose>& poses,
                              const TrajectoryOptions& options = TrajectoryOptions());

  double t_begin() const { return knots_.front().t_s; }
  double t_end() const { return knots_.back().t_s; }
  const std::vector<Waypoint>& waypoints() const { return knots_; }

  // State at time t (clamped to [t_begin, t_end]: outside, the body hovers at the end pose).
  TrajectoryState State(double t) const;
  Rigid3 Pose(double t) const { return State(t).T_W_B; }
  // Derivatives of the flat outputs, exposed for tests: k-th derivative (k = 0..4) of (x, y, z,
  // yaw).
  Vec4 FlatDerivative(double t, int k) const;

 private:
  struct Segment {
    double t0 = 0.0, duration = 1.0;
    // Coefficients of s^0..s^7 in the normalised time s = (t - t0) / duration, one column per
    // output.
    Eigen::Matrix<double, 8, 4> c;
  };
  std::vector<Waypoint> knots_;
  std::vector<Segment> segments_;
  const Segment& SegmentAt(double t) const;
  // FromPoses' B-spline through the smoothed knots (control points every options.pose_knot_s).
  static Trajectory FromControlPoints(const std::vector<Waypoint>& control,
                                      const TrajectoryOptions& options);
  // Throws InputError where the flight needs less thrust than options.min_thrust.
  void CheckThrust(const TrajectoryOptions& options) const;
};

}  // namespace fsp::sim
