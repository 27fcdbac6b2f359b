#include "fsp/backend/static_init.h"

#include <cmath>
#include <cstdio>

#include "fsp/common/error.h"

namespace fsp::backend {

bool StaticInitOptions::Check(std::string* why) const {
  auto fail = [why](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (!(window_s > 0.0)) return fail("window_s must be > 0");
  if (!(block_s > 0.0) || block_s * 2.0 > window_s)
    return fail("block_s must be > 0 and <= window_s / 2");
  if (!(max_gyro_block_std > 0.0) || !(max_acc_block_std > 0.0) || !(max_gravity_error > 0.0))
    return fail("stillness thresholds must be > 0");
  if (min_samples < 2) return fail("min_samples must be >= 2");
  if (!(gravity > 0.0)) return fail("gravity must be > 0");
  return true;
}

namespace {

std::string Format(const char* fmt, double a, double b) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), fmt, a, b);
  return buf;
}

}  // namespace

StaticInitSummary StaticInitialize(const std::vector<ImuSample>& imu,
                                   const StaticInitOptions& options, int64_t t_start_ns) {
  std::string why;
  FSP_CHECK(options.Check(&why));
  StaticInitSummary s;
  if (imu.empty()) {
    s.reason = "no IMU samples";
    return s;
  }
  const int64_t t0 = t_start_ns < 0 ? imu.front().t_ns : t_start_ns;
  const int64_t t1 = t0 + static_cast<int64_t>(std::llround(options.window_s * 1e9));
  const int64_t block_ns = static_cast<int64_t>(std::llround(options.block_s * 1e9));
  const int num_blocks = static_cast<int>((t1 - t0) / block_ns);

  Vec3 gs = Vec3::Zero(), as = Vec3::Zero(), gss = Vec3::Zero(), ass = Vec3::Zero();
  std::vector<Vec3> gb(num_blocks, Vec3::Zero()), ab(num_blocks, Vec3::Zero());
  std::vector<int> nb(num_blocks, 0);
  for (const ImuSample& m : imu) {
    if (m.t_ns < t0 || m.t_ns >= t1) continue;
    if (s.num_samples == 0) s.t_start_ns = m.t_ns;
    s.t_end_ns = m.t_ns;
    ++s.num_samples;
    gs += m.gyro;
    as += m.acc;
    gss += m.gyro.cwiseProduct(m.gyro);
    ass += m.acc.cwiseProduct(m.acc);
    const int b = static_cast<int>((m.t_ns - t0) / block_ns);
    if (b < num_blocks) {
      gb[b] += m.gyro;
      ab[b] += m.acc;
      ++nb[b];
    }
  }
  if (s.num_samples < options.min_samples) {
    s.reason =
        Format("too few IMU samples: %.0f in the %.2f s window", s.num_samples, options.window_s) +
        " (need " + std::to_string(options.min_samples) + ")";
    return s;
  }
  const double n = s.num_samples;
  s.gyro_mean = gs / n;
  s.acc_mean = as / n;
  s.gyro_std = (gss / n - s.gyro_mean.cwiseProduct(s.gyro_mean)).cwiseMax(0.0).cwiseSqrt();
  s.acc_std = (ass / n - s.acc_mean.cwiseProduct(s.acc_mean)).cwiseMax(0.0).cwiseSqrt();

  // Spread of the block means (blocks with samples only).
  Vec3 gm = Vec3::Zero(), am = Vec3::Zero(), gv = Vec3::Zero(), av = Vec3::Zero();
  int used = 0;
  for (int b = 0; b < num_blocks; ++b) {
    if (nb[b] == 0) continue;
    gb[b] /= nb[b];
    ab[b] /= nb[b];
    gm += gb[b];
    am += ab[b];
    ++used;
  }
  if (used < 2) {
    s.reason = "too few IMU samples: fewer than two blocks of block_s contain samples";
    return s;
  }
  gm /= used;
  am /= used;
  for (int b = 0; b < num_blocks; ++b) {
    if (nb[b] == 0) continue;
    gv += (gb[b] - gm).cwiseAbs2();
    av += (ab[b] - am).cwiseAbs2();
  }
  s.gyro_block_std = (gv / used).cwiseSqrt().norm();
  s.gyro_mean_sigma = s.gyro_block_std / std::sqrt(3.0 * used);
  s.acc_block_std = (av / used).cwiseSqrt().norm();
  s.gravity_error = s.acc_mean.norm() - options.gravity;

  if (s.gyro_block_std > options.max_gyro_block_std) {
    s.reason =
        Format("too much motion: gyro block-mean std %.4f rad/s > %.4f (the start is not still)",
               s.gyro_block_std, options.max_gyro_block_std);
    return s;
  }
  if (s.acc_block_std > options.max_acc_block_std) {
    s.reason = Format(
        "too much motion: accelerometer block-mean std %.3f m/s^2 > %.3f (the start is not still)",
        s.acc_block_std, options.max_acc_block_std);
    return s;
  }
  if (std::abs(s.gravity_error) > options.max_gravity_error) {
    s.reason = Format(
        "mean specific force %.3f m/s^2 is not gravity (%.3f): accelerating or miscalibrated",
        s.acc_mean.norm(), options.gravity);
    return s;
  }

  // Standing still: the accelerometer measures a_B = R_W_Bᵀ (0, 0, +|g|), so R_W_B maps the mean
  // specific-force direction onto e_z. Of all such rotations take the one with yaw 0
  // (R = Rz(−ψ) R0, ψ = atan2(R0(1,0), R0(0,0)) the ZYX yaw; Rz keeps e_z fixed).
  const Mat3 R0 = Quat::FromTwoVectors(s.acc_mean.normalized(), Vec3::UnitZ()).toRotationMatrix();
  const double yaw = std::atan2(R0(1, 0), R0(0, 0));
  const Mat3 R = RotZ(-yaw) * R0;
  s.state.t_ns = s.t_end_ns;
  s.state.T_W_B = Rigid3(R, Vec3::Zero());
  s.state.v_W = Vec3::Zero();
  s.state.gyro_bias = s.gyro_mean;
  s.state.acc_bias = Vec3::Zero();
  s.success = true;
  return s;
}

}  // namespace fsp::backend
