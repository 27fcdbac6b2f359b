// Up-to-scale structure from motion over a short buffer of frames with tracked points (the first
// step of the initialisation in motion from points, point_init.h; VINS-Mono's initial_sfm).
//
// 1. Keyframes by parallax: a frame becomes a keyframe when the median parallax of the points it
//    shares with the last keyframe, after removing the gyroscope's rotation between them (bias 0),
//    reaches keyframe_parallax_px, when max_keyframe_interval_s has passed, or when fewer than
//    keyframe_min_tracked of the last keyframe's points are still tracked.
// 2. The initial pair: the keyframe pairs sharing min_points whose median parallax that no
//    rotation explains (the bearings' residual angle after the rotation that best aligns them,
//    Kabsch; not the gyroscope's rotation: an unknown bias of 0.02 rad/s over 1.5 s is 17 px at
//    f = 400) reaches min_parallax_px are candidates, most parallax first; steps 2-4 run from
//    each in turn (at most max_pairs) until one succeeds. The pair with the most parallax is
//    often the one that barely shares min_points, and a few outliers then refuse it where a
//    closer pair succeeds. The pair's relative pose from the essential matrix (OpenCV
//    findEssentialMat + recoverPose, RANSAC on normalised points), whose rotation must agree with
//    the gyroscope's within max_rotation_error_deg plus what a bias of max_gyro_bias could add
//    over the interval.
// 3. Triangulation (linear, every posed view of a point; cheirality, reprojection and a minimum
//    ray angle), then PnP (OpenCV solvePnPRansac) for the other keyframes outwards from the pair,
//    each followed by the triangulation of the points it makes possible; a direction stops at the
//    first keyframe that cannot be posed, and the posed ones must span min_span_s.
// 4. A bundle adjustment (Ceres, Huber loss on pixel residuals) over the keyframes and points; the
//    pair's first keyframe is held and its second kept at unit distance from it (the scale's
//    gauge).
// S, the result's frame, is the pair's first camera frame; lengths are in units of the initial
// pair's baseline. It REFUSES (success = false, reason) with too little parallax, too few points,
// an essential matrix that disagrees with the gyroscope, or a bundle adjustment that leaves a
// large reprojection error.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::backend {

struct VisualSfmOptions {
  // A new keyframe once the rotation-compensated median parallax to the last keyframe reaches
  // this [px], or this long passed [s]. Smaller: more keyframes (more IMU intervals for the
  // alignment, more CPU); the IMU terms want the keyframes close, the triangulation far apart.
  double keyframe_parallax_px = 10.0;
  double max_keyframe_interval_s = 0.25;
  // ...or when fewer than this fraction of the last keyframe's points are still tracked: on the
  // DM-VIO walk (1280x720, turning fast) a third of the points are lost per frame, and consecutive
  // keyframes must share points for the PnP chain.
  double keyframe_min_tracked = 0.5;
  // The initial pair's median parallax that no rotation explains at least [px]: the essential
  // matrix and the triangulation need the translation to show. A pure rotation leaves the tracking
  // noise (0.8 px with 0.5 px noise on the rendered start); 0.8 m sideways past points 3-8 m away
  // gave 12 px at f = 400. (VINS-Mono: 30 px at f = 460, of the raw parallax.)
  double min_parallax_px = 8.0;
  // Points shared by the initial pair (after RANSAC), and triangulated in the end, at least. (15
  // agreeing with the essential matrix, as VINS-Mono's 12, let wrong pairs through on the DM-VIO
  // walk: a gyroscope bias of 0.108 rad/s came out of one.)
  int min_points = 30;
  // Candidate initial pairs tried at most per attempt (each one more essential matrix, PnP chain
  // and bundle adjustment).
  int max_pairs = 6;
  // Points with a 3-D position a keyframe must see for its PnP; fewer: the keyframe is skipped.
  int min_pnp_points = 12;
  // Posed keyframes at least (the alignment needs several IMU intervals), spanning at least this
  // [s] (the acceleration must show).
  int min_keyframes = 4;
  double min_span_s = 1.0;
  // RANSAC threshold of the essential matrix and PnP [px]. This and max_reprojection_px,
  // max_rms_px, huber_px are for points of unit PointObservation::sigma_scale: they are multiplied
  // by the buffer's median sigma_scale (2 for a 1280x720 camera tracked at 640x360).
  double ransac_px = 1.0;
  // The essential matrix's rotation may differ from the gyroscope's by this [deg], plus
  // max_gyro_bias x the interval (the bias is not known yet).
  double max_rotation_error_deg = 2.0;
  double max_gyro_bias = 0.1;  // [rad/s]
  // A point is triangulated when the rays of its first and last posed views are this far apart
  // [deg]; with less, its depth is noise.
  double min_ray_angle_deg = 1.0;
  // A view is an outlier when its reprojection error exceeds this [px] (after triangulation and
  // after the bundle adjustment).
  double max_reprojection_px = 3.0;
  // Refuse when the bundle adjustment's RMS reprojection error of the inliers exceeds this [px].
  double max_rms_px = 1.5;
  int ba_iterations = 30;
  double huber_px = 1.0;  // robust loss of the bundle adjustment [px]
  bool Check(std::string* why) const;
};

// A frame of the buffer: its time and its tracked points (undistorted pixels).
struct SfmFrame {
  int64_t t_ns = 0;
  std::vector<PointObservation> points;
};

struct VisualSfmSummary {
  bool success = false;
  std::string reason;          // why it refused; empty on success
  std::vector<size_t> frames;  // the posed keyframes (indices into the input), in time order
  std::vector<Rigid3> T_S_C;   // their camera poses in S (up to scale)
  std::vector<Vec3> points_S;  // the triangulated points
  int keyframes = 0;           // keyframes chosen (posed or not)
  size_t pair_first = 0, pair_second = 0;  // the initial pair (indices into the input)
  double pair_parallax_px = 0.0;           // its median parallax no rotation explains [px]
  double max_parallax_px = 0.0;            // the largest such parallax of any pair [px]
  int pairs_tried = 0;                     // candidate initial pairs tried
  double rotation_error_deg = 0.0;         // essential matrix's rotation vs the gyroscope's
  double rms_px = 0.0;                     // bundle adjustment's RMS reprojection error (inliers)
  double median_depth = 0.0;               // points' median depth in the first keyframe [units]
};

// FRAMES in time order; IMU covering them (for the rotation between frames); K the ideal pinhole
// of the undistorted pixels; T_B_C the camera mount.
VisualSfmSummary SolveVisualSfm(const std::vector<SfmFrame>& frames,
                                const std::vector<ImuSample>& imu, const Mat3& K,
                                const Rigid3& T_B_C, const VisualSfmOptions& options);

}  // namespace fsp::backend
