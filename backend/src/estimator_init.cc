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
  Gauge gauge;
  gauge.sigma_sb << Vec3::Constant(0.01), Vec3::Constant(options.prior_gyro_bias_sigma),
      Vec3::Constant(options.prior_acc_bias_sigma);
  auto frames = std::move(pending);
  pending.clear();
  StartSession(std::move(frames), first, gauge);
  return true;
}

bool Estimator::Impl::TryInitializeInMotion(const std::string& static_reason) {
  const MotionInitOptions& mo = options.motion_init;
  if (!mo.enabled) {
    summary.init_failure = static_reason;
    return false;
  }
  const int64_t t0 = pending.front().first;
  const int64_t t1 = t0 + static_cast<int64_t>(mo.window_s * 1e9);
  if (pending.back().first < t1) return false;  // wait for the window's frames
  std::vector<BufferedFrame> window;
  for (const auto& f : pending)
    if (f.first <= t1) window.push_back(f);
  const MotionInitSummary m =
      InitializeInMotion(window, imu, K, T_B_C, options.imu, options.init, mo);
  if (!m.success) {
    if (NsToSeconds(pending.back().first - *first_frame_t) > mo.max_wait_s) {
      summary.init_failure = static_reason + "; in motion: " + m.reason;
      return false;
    }
    pending.erase(pending.begin());  // try again one frame later
    return false;
  }
  summary.init_in_motion = true;
  KeyframeState first;
  first.t_ns = window[m.first].first;
  first.SetT_W_B(m.T_W_B);
  VelocityOf(first.speed_bias) = m.v_W;
  GyroBiasOf(first.speed_bias) = m.gyro_bias;
  Gauge gauge;
  gauge.sigma_sb << Vec3::Constant(options.motion_init_velocity_sigma),
      Vec3::Constant(options.prior_gyro_bias_sigma), Vec3::Constant(options.prior_acc_bias_sigma);
  auto frames = std::move(pending);
  pending.clear();
  frames.erase(frames.begin(), frames.begin() + static_cast<std::ptrdiff_t>(m.first));
  char what[200];
  std::snprintf(what, sizeof(what),
                "initialised in motion from object %d (%d views, width %.3g m, |g| off by %.2f "
                "m/s^2, speed %.2f m/s)",
                m.object_id, m.views, m.width, m.gravity_error, m.v_W.norm());
  Warn(first.t_ns, what);
  StartSession(std::move(frames), first, gauge);
  return true;
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
