// The estimator's initialisation (backend/README.md): from a still start (static_init.h), else in
// motion (motion_init.h), then the first session's keyframes.
#include "estimator_impl.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <optional>
#include <sstream>
#include <thread>
#include <tuple>
#include <unordered_map>

#include <ceres/ceres.h>

#include "fsp/backend/fhp_factor.h"
#include "fsp/backend/imu_factor.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/marginalization.h"
#include "fsp/backend/point_init.h"
#include "fsp/backend/priors.h"
#include "fsp/backend/reanchor.h"
#include "fsp/backend/static_init.h"
#include "fsp/common/error.h"
#include "fsp/common/time.h"

namespace fsp::backend {

bool Estimator::Impl::TryInitialize() {
  if (summary.initialized) return true;
  if (!summary.init_failure.empty() || pending.empty()) return false;
  if (!first_frame_t) first_frame_t = pending.front().first;
  const int64_t t0 = pending.front().first;
  const int64_t t1 = t0 + static_cast<int64_t>(options.static_init.window_s * 1e9);
  if (imu.empty() || imu.back().t_ns < t1) return false;  // wait for the whole still interval
  StaticInitOptions so = options.static_init;
  so.gravity = options.imu.gravity;
  const StaticInitSummary s = StaticInitialize(ImuBetween(t0, t1), so, t0);
  if (!s.success) return TryInitializeInMotion(s.reason);
  KeyframeState first;
  first.t_ns = t0;
  first.SetT_W_B(Rigid3(s.state.T_W_B.rotation(), Vec3::Zero()));
  GyroBiasOf(first.speed_bias) = s.state.gyro_bias;
  // Standing still, the mean rate is the gyroscope bias, known as the start measured it, at least
  // to what the IMU's noise density allows in window_s (backend/README.md, "Standing still").
  const double gyro_bias_sigma =
      std::min(options.prior_gyro_bias_sigma,
               std::max(s.gyro_mean_sigma,
                        options.imu.noise.gyroscope_noise_density / std::sqrt(so.window_s)));
  Gauge gauge;
  gauge.sigma_sb << Vec3::Constant(0.01), Vec3::Constant(gyro_bias_sigma),
      Vec3::Constant(options.prior_acc_bias_sigma);
  summary.init_method = "static";
  summary.init_gyro_bias = s.state.gyro_bias;
  auto frames = std::move(pending);
  pending.clear();
  StartSession(std::move(frames), first, gauge);
  return true;
}

void Estimator::Impl::DropPending(size_t n) {
  n = std::min(n, pending.size());
  pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(n));
  // The points of the frames dropped (pending_points is by time).
  pending_points.erase(
      pending_points.begin(),
      pending.empty() ? pending_points.end() : pending_points.lower_bound(pending.front().first));
}

bool Estimator::Impl::TryInitializeInMotion(const std::string& static_reason) {
  const MotionInitOptions& mo = options.motion_init;
  const PointInitOptions& po = options.point_init;
  const bool with_points =
      po.enabled && std::any_of(pending_points.begin(), pending_points.end(),
                                [](const auto& p) { return !p.second.empty(); });
  if (!mo.enabled && !with_points) {
    summary.init_failure = static_reason;
    return false;
  }
  const int64_t t0 = pending.front().first;
  // The rectangle first (once per window start when the points are in play too: they set the
  // pace of the retries).
  std::string rect_reason;
  if (mo.enabled) {
    const int64_t t1 = t0 + static_cast<int64_t>(mo.window_s * 1e9);
    if (pending.back().first < t1) {
      if (!with_points) return false;  // wait for the window's frames
    } else if (!with_points || rect_tried_t0 != t0) {
      rect_tried_t0 = t0;
      std::vector<BufferedFrame> window;
      for (const auto& f : pending)
        if (f.first <= t1) window.push_back(f);
      const MotionInitSummary m =
          InitializeInMotion(window, imu, K, T_B_C, options.imu, options.init, mo);
      if (m.success) {
        summary.init_method = "rectangle";
        summary.init_scale = m.width;
        summary.init_gravity_error = m.gravity_error;
        char what[200];
        std::snprintf(what, sizeof(what),
                      "initialised in motion from object %d (%d views, width %.3g m, |g| off by "
                      "%.2f m/s^2, speed %.2f m/s)",
                      m.object_id, m.views, m.width, m.gravity_error, m.v_W.norm());
        StartInMotion(m.first, m.T_W_B, m.v_W, m.gyro_bias, Vec3::Zero(), what);
        return true;
      }
      rect_reason = m.reason;
      if (!with_points) {
        if (NsToSeconds(pending.back().first - *first_frame_t) > mo.max_wait_s) {
          summary.init_failure = static_reason + "; in motion: " + m.reason;
          return false;
        }
        DropPending(1);  // try again one frame later
        return false;
      }
    }
  }
  // The points.
  if (pending.back().first < t0 + static_cast<int64_t>(po.window_s * 1e9)) return false;
  std::string reason;
  if (TryInitializeFromPoints(&reason)) return true;
  ++summary.init_attempts_refused;
  summary.init_last_refusal = reason;
  {
    std::string kind = reason.substr(0, reason.find_first_of("0123456789("));
    while (!kind.empty() && (kind.back() == ' ' || kind.back() == ',' || kind.back() == ':'))
      kind.pop_back();
    ++summary.init_refusals[kind];
  }
  if (summary.init_attempts_refused <= kMaxInitWarnings)
    Warn(t0, "initialisation in motion from points refused: " + reason +
                 (summary.init_attempts_refused == kMaxInitWarnings
                      ? " (further refusals are counted in init_attempts_refused, not listed)"
                      : ""));
  if (po.max_wait_s > 0.0 && NsToSeconds(pending.back().first - *first_frame_t) > po.max_wait_s) {
    summary.init_failure = static_reason + "; in motion from points: " + reason;
    if (!rect_reason.empty()) summary.init_failure += "; from a rectangle: " + rect_reason;
  }
  return false;
}

bool Estimator::Impl::TryInitializeFromPoints(std::string* reason) {
  const PointInitOptions& po = options.point_init;
  const int64_t t0 = pending.front().first;
  const int64_t t1 = t0 + static_cast<int64_t>(po.window_s * 1e9);
  std::vector<SfmFrame> window;
  for (size_t k = 0; k < pending.size() && pending[k].first <= t1; ++k) {
    const auto it = pending_points.find(pending[k].first);
    window.push_back({pending[k].first,
                      it == pending_points.end() ? std::vector<PointObservation>{} : it->second});
  }
  const PointInitSummary p = InitializeFromPoints(window, imu, K, T_B_C, options.imu, po);
  if (!p.success) {
    *reason = p.reason;
    // The next attempt retry_step_s later.
    size_t n = 0;
    const int64_t next = t0 + static_cast<int64_t>(po.retry_step_s * 1e9);
    while (n < pending.size() && pending[n].first < next) ++n;
    DropPending(std::max<size_t>(n, 1));
    return false;
  }
  summary.init_method = "points";
  summary.init_scale = p.scale;
  summary.init_gravity_error = p.gravity_error;
  summary.init_baseline_m = p.baseline_m;
  summary.init_baseline_end_t_s = NsToSeconds(p.t_last_ns - *first_frame_t);
  char what[320];
  std::snprintf(what, sizeof(what),
                "initialised in motion from points (%d keyframes, %d points, scale %.3g m/unit, "
                "baseline %.3f m, |g| off by %.2f m/s^2 before refinement, gyro bias %.4f rad/s, "
                "speed %.2f m/s; %d attempts refused before)",
                p.keyframes, p.points, p.scale, p.baseline_m, p.gravity_error, p.gyro_bias.norm(),
                p.v_W.norm(), summary.init_attempts_refused);
  StartInMotion(p.first, p.T_W_B, p.v_W, p.gyro_bias, p.acc_bias, what);
  return true;
}

void Estimator::Impl::StartInMotion(size_t first_index, const Rigid3& T_W_B, const Vec3& v_W,
                                    const Vec3& gyro_bias, const Vec3& acc_bias,
                                    const std::string& what) {
  summary.init_in_motion = true;
  summary.init_gyro_bias = gyro_bias;
  summary.init_acc_bias = acc_bias;
  summary.init_speed = v_W.norm();
  KeyframeState first;
  first.t_ns = pending[first_index].first;
  first.SetT_W_B(T_W_B);
  VelocityOf(first.speed_bias) = v_W;
  GyroBiasOf(first.speed_bias) = gyro_bias;
  AccBiasOf(first.speed_bias) = acc_bias;
  Gauge gauge;
  gauge.sigma_sb << Vec3::Constant(options.motion_init_velocity_sigma),
      Vec3::Constant(options.prior_gyro_bias_sigma), Vec3::Constant(options.prior_acc_bias_sigma);
  auto frames = std::move(pending);
  pending.clear();
  frames.erase(frames.begin(), frames.begin() + static_cast<std::ptrdiff_t>(first_index));
  Warn(first.t_ns, what);
  StartSession(std::move(frames), first, gauge);
}

void Estimator::Impl::StartSession(
    std::vector<std::pair<int64_t, std::vector<ObjectObservation>>> frames,
    const KeyframeState& first, const Gauge& gauge_sigmas) {
  summary.initialized = true;
  summary.init_t_s = NsToSeconds(first.t_ns - *first_frame_t);
  T_W_B0 = first.T_W_B();
  sb0 = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(first.speed_bias);
  Gauge gauge = gauge_sigmas;
  gauge.T_W_B0 = T_W_B0;
  gauge.sb0 = sb0;
  bool first_frame = true;
  for (auto& [t_ns, obs] : frames) {
    std::vector<PointObservation> points;
    if (auto it = pending_points.find(t_ns); it != pending_points.end())
      points = std::move(it->second);
    if (first_frame) {
      AddKeyframe(t_ns, std::move(obs), &first, gauge, std::move(points));
      first_frame = false;
    } else {
      AddKeyframe(t_ns, std::move(obs), nullptr, std::nullopt, std::move(points));
    }
  }
  pending_points.clear();
}

}  // namespace fsp::backend
