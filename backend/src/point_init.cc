#include "fsp/backend/point_init.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "fsp/backend/vi_alignment.h"

namespace fsp::backend {

bool PointInitOptions::Check(std::string* why) const {
  std::ostringstream os;
  std::string sfm_why;
  if (!(window_s > 0.0) || !(retry_step_s > 0.0) || !(max_wait_s >= 0.0))
    os << "window_s and retry_step_s must be > 0, max_wait_s >= 0";
  else if (max_wait_s > 0.0 && max_wait_s < window_s)
    os << "max_wait_s must be 0 (never give up) or >= window_s";
  else if (!(max_gyro_bias > 0.0) || !(max_rotation_rms_deg > 0.0) ||
           !(max_gravity_error_frac > 0.0) || !(max_speed > 0.0))
    os << "max_gyro_bias, max_rotation_rms_deg, max_gravity_error_frac and max_speed must be > 0";
  else if (!(acc_bias_sigma >= 0.0) || !(max_acc_bias > 0.0))
    os << "acc_bias_sigma must be >= 0, max_acc_bias > 0";
  else if (!(min_depth_m > 0.0) || !(max_depth_m > min_depth_m) || !(min_motion_m >= 0.0))
    os << "min_depth_m must be > 0, max_depth_m > min_depth_m, min_motion_m >= 0";
  else if (!sfm.Check(&sfm_why))
    os << "sfm: " << sfm_why;
  if (why) *why = os.str();
  return os.str().empty();
}

namespace {

std::string Fmt(const char* fmt, double a, double b = 0.0, double c = 0.0) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), fmt, a, b, c);
  return buf;
}

}  // namespace

PointInitSummary InitializeFromPoints(const std::vector<SfmFrame>& frames,
                                      const std::vector<ImuSample>& imu, const Mat3& K,
                                      const Rigid3& T_B_C, const PreintegrationOptions& preint,
                                      const PointInitOptions& options) {
  PointInitSummary out;
  VisualSfmOptions so = options.sfm;
  so.max_gyro_bias = options.max_gyro_bias;
  out.sfm = SolveVisualSfm(frames, imu, K, T_B_C, so);
  const VisualSfmSummary& sfm = out.sfm;
  if (!sfm.success) {
    out.reason = "structure from motion: " + sfm.reason;
    return out;
  }
  out.keyframes = static_cast<int>(sfm.frames.size());
  out.points = static_cast<int>(sfm.points_S.size());
  const Mat3 R_C_B = T_B_C.R().transpose();
  std::vector<AlignmentView> views;
  for (const Rigid3& T : sfm.T_S_C) views.push_back({T.R() * R_C_B, T.translation()});
  std::vector<std::unique_ptr<ImuPreintegration>> pre;
  for (size_t k = 0; k + 1 < sfm.frames.size(); ++k) {
    const int64_t t0 = frames[sfm.frames[k]].t_ns, t1 = frames[sfm.frames[k + 1]].t_ns;
    const std::vector<ImuSample> s = ImuSamplesFor(imu, t0, t1);
    if (s.empty()) {
      out.reason = "no IMU samples between the keyframes";
      return out;
    }
    pre.push_back(
        std::make_unique<ImuPreintegration>(preint, s, t0, t1, Vec3::Zero(), Vec3::Zero()));
  }
  // 2. Gyroscope bias.
  double rot_rms = 0.0;
  out.gyro_bias = EstimateGyroBias(views, pre, 2, &rot_rms);
  out.rotation_rms_deg = rot_rms * 180.0 / M_PI;
  if (!(out.gyro_bias.norm() <= options.max_gyro_bias)) {
    out.reason = Fmt("the gyroscope bias comes out implausible (%.3f rad/s, allowed %.3f)",
                     out.gyro_bias.norm(), options.max_gyro_bias);
    return out;
  }
  if (!(out.rotation_rms_deg <= options.max_rotation_rms_deg)) {
    out.reason =
        Fmt("the visual rotations disagree with the gyroscope by %.2f deg RMS (allowed "
            "%.2f) after the bias fit",
            out.rotation_rms_deg, options.max_rotation_rms_deg);
    return out;
  }
  // 3. Velocities, gravity, scale.
  const Vec3 p_B_C = T_B_C.translation();
  AlignmentOptions ao;
  ao.acc_bias_sigma = options.acc_bias_sigma;
  const Alignment al =
      AlignWithGravityMagnitude(views, pre, p_B_C, preint.gravity, 4, &out.gravity_error, ao);
  out.acc_bias = al.acc_bias;
  out.scale = al.s;
  out.alignment_rms = al.residual_rms;
  if (!(out.gravity_error <= options.max_gravity_error_frac * preint.gravity)) {
    out.reason =
        Fmt("gravity's magnitude comes out %.2f m/s^2 off (allowed %.2f): too little "
            "acceleration, or inconsistent data",
            out.gravity_error, options.max_gravity_error_frac * preint.gravity);
    return out;
  }
  if (!(al.s > 0.0) || !std::isfinite(al.s)) {
    out.reason = Fmt("the scale is not positive (%.3g)", al.s);
    return out;
  }
  if (!(al.acc_bias.norm() <= options.max_acc_bias)) {
    out.reason = Fmt("the accelerometer bias comes out implausible (%.3f m/s^2, allowed %.3f)",
                     al.acc_bias.norm(), options.max_acc_bias);
    return out;
  }
  double speed = 0.0;
  for (const Vec3& v : al.v) speed = std::max(speed, v.norm());
  out.median_depth_m = al.s * sfm.median_depth;
  if (!(speed <= options.max_speed) || !(out.median_depth_m >= options.min_depth_m) ||
      !(out.median_depth_m <= options.max_depth_m)) {
    out.reason =
        Fmt("the scale is implausible (%.3g m per unit: speed %.2f m/s, the points' "
            "median depth %.2f m)",
            al.s, speed, out.median_depth_m);
    return out;
  }
  double motion_m = 0.0;
  for (const auto& v : views)
    motion_m = std::max(motion_m, al.s * (v.c_hat - views.front().c_hat).norm());
  if (!(motion_m >= options.min_motion_m)) {
    out.reason =
        Fmt("the camera moved %.3f m at most from the first keyframe (needs %.3f m): too "
            "little to tell the scale from the accelerometer",
            motion_m, options.min_motion_m);
    return out;
  }
  // 4. The world frame: z up, p = 0 at the first keyframe.
  const Quat q_W_S = Quat::FromTwoVectors(al.g.normalized(), -Vec3::UnitZ());
  out.success = true;
  out.first = sfm.frames.front();
  out.T_W_B = Rigid3(q_W_S * Quat(views.front().R_S_B), Vec3::Zero());
  out.v_W = q_W_S * al.v.front();
  out.baseline_m = al.s * (views.back().c_hat - views.front().c_hat).norm();
  out.t_last_ns = frames[sfm.frames.back()].t_ns;
  return out;
}

}  // namespace fsp::backend
