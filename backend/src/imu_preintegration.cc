#include "fsp/backend/imu_preintegration.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "fsp/backend/state.h"
#include "fsp/common/error.h"

namespace fsp::backend {

bool PreintegrationOptions::Check(std::string* why) const {
  auto fail = [why](const char* what) {
    if (why) *why = what;
    return false;
  };
  // (ImuNoise::Check lives in the calibration module; the fields the integrator uses are checked
  // here.)
  if (!(noise.gyroscope_noise_density > 0.0) || !(noise.accelerometer_noise_density > 0.0))
    return fail("IMU white-noise densities must be > 0");
  if (!(noise.gyroscope_random_walk > 0.0) || !(noise.accelerometer_random_walk > 0.0))
    return fail("IMU random-walk densities must be > 0");
  if (!(gravity > 0.0)) return fail("gravity must be > 0");
  if (!(reintegrate_gyro_bias_threshold > 0.0) || !(reintegrate_acc_bias_threshold > 0.0))
    return fail("re-integration thresholds must be > 0");
  return true;
}

ImuPreintegration::ImuPreintegration(const PreintegrationOptions& options,
                                     const std::vector<ImuSample>& samples, int64_t t_i_ns,
                                     int64_t t_j_ns, const Vec3& bg, const Vec3& ba)
    : options_(options), t_i_ns_(t_i_ns), t_j_ns_(t_j_ns), bg_lin_(bg), ba_lin_(ba) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
  FSP_CHECK(t_j_ns > t_i_ns);
  if (samples.empty()) throw InputError("IMU preintegration: no samples between keyframes");
  for (size_t k = 1; k < samples.size(); ++k) {
    if (samples[k].t_ns <= samples[k - 1].t_ns) {
      throw InputError("IMU preintegration: sample timestamps not strictly increasing at " +
                       std::to_string(samples[k].t_ns) + " ns");
    }
  }
  dt_ = 1e-9 * static_cast<double>(t_j_ns - t_i_ns);
  extrapolated_s_ = 1e-9 * static_cast<double>(std::max<int64_t>(0, samples.front().t_ns - t_i_ns) +
                                               std::max<int64_t>(0, t_j_ns - samples.back().t_ns));

  // Sample at time t: linear interpolation between the bracketing samples, the nearest one outside.
  auto at = [&samples](int64_t t) {
    const auto it = std::lower_bound(samples.begin(), samples.end(), t,
                                     [](const ImuSample& s, int64_t tt) { return s.t_ns < tt; });
    Knot k{t, Vec3::Zero(), Vec3::Zero()};
    if (it == samples.begin()) {
      k.gyro = it->gyro;
      k.acc = it->acc;
    } else if (it == samples.end()) {
      k.gyro = samples.back().gyro;
      k.acc = samples.back().acc;
    } else {
      const ImuSample& a = *(it - 1);
      const ImuSample& b = *it;
      const double alpha = static_cast<double>(t - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
      k.gyro = (1.0 - alpha) * a.gyro + alpha * b.gyro;
      k.acc = (1.0 - alpha) * a.acc + alpha * b.acc;
    }
    return k;
  };
  knots_.push_back(at(t_i_ns));
  for (const ImuSample& s : samples) {
    if (s.t_ns > t_i_ns && s.t_ns < t_j_ns) knots_.push_back({s.t_ns, s.gyro, s.acc});
  }
  knots_.push_back(at(t_j_ns));
  Integrate();
}

void ImuPreintegration::Reintegrate(const Vec3& bg, const Vec3& ba) {
  bg_lin_ = bg;
  ba_lin_ = ba;
  ++num_reintegrations_;
  Integrate();
}

bool ImuPreintegration::ReintegrateIfNeeded(const Vec3& bg, const Vec3& ba) {
  if ((bg - bg_lin_).norm() <= options_.reintegrate_gyro_bias_threshold &&
      (ba - ba_lin_).norm() <= options_.reintegrate_acc_bias_threshold) {
    return false;
  }
  Reintegrate(bg, ba);
  return true;
}

void ImuPreintegration::Integrate() {
  Mat3 dR = Mat3::Identity();
  Vec3 dv = Vec3::Zero(), dp = Vec3::Zero();
  Mat9 cov = Mat9::Zero();
  Eigen::Matrix<double, 9, 6> J = Eigen::Matrix<double, 9, 6>::Zero();  // d(δφ, δv, δp)/d(b_g, b_a)
  const double sg2 =
      options_.noise.gyroscope_noise_density * options_.noise.gyroscope_noise_density;
  const double sa2 =
      options_.noise.accelerometer_noise_density * options_.noise.accelerometer_noise_density;

  for (size_t k = 0; k + 1 < knots_.size(); ++k) {
    const Knot& k0 = knots_[k];
    const Knot& k1 = knots_[k + 1];
    const double dt = 1e-9 * static_cast<double>(k1.t_ns - k0.t_ns);
    if (dt <= 0.0) continue;
    const double dt2 = dt * dt;
    const Vec3 w = 0.5 * (k0.gyro + k1.gyro) - bg_lin_;
    const Vec3 a0 = k0.acc - ba_lin_;
    const Vec3 a1 = k1.acc - ba_lin_;
    const Mat3 dRk = ExpSO3(w * dt);
    const Mat3 Jr = RightJacobianSO3(w * dt);
    const Mat3 R0 = dR;
    const Mat3 R1 = dR * dRk;
    const Vec3 aW = 0.5 * (R0 * a0 + R1 * a1);

    // Linearisation of the step. With ΔR_k → ΔR_k Exp(δφ_k), ω → ω + δω, a → a + δa:
    //   δφ_k+1 = dRᵀ δφ_k + Jr(ω dt) dt δω
    //   δa_W   = A_aφ δφ_k + A_aω δω + A_aa δa
    //     A_aφ = −½ (ΔR_k [a_k]× + ΔR_k+1 [a_k+1]× dRᵀ),  A_aω = −½ ΔR_k+1 [a_k+1]× Jr dt,
    //     A_aa = ½ (ΔR_k + ΔR_k+1)
    //   δv_k+1 = δv_k + δa_W dt,  δp_k+1 = δp_k + δv_k dt + ½ δa_W dt²
    const Mat3 A_aphi = -0.5 * (R0 * Skew(a0) + R1 * Skew(a1) * dRk.transpose());
    const Mat3 A_aw = -0.5 * R1 * Skew(a1) * Jr * dt;
    const Mat3 A_aa = 0.5 * (R0 + R1);

    Mat9 A = Mat9::Identity();
    A.block<3, 3>(0, 0) = dRk.transpose();
    A.block<3, 3>(3, 0) = A_aphi * dt;
    A.block<3, 3>(6, 0) = 0.5 * A_aphi * dt2;
    A.block<3, 3>(6, 3) = Mat3::Identity() * dt;
    Eigen::Matrix<double, 9, 6> B = Eigen::Matrix<double, 9, 6>::Zero();
    B.block<3, 3>(0, 0) = Jr * dt;
    B.block<3, 3>(3, 0) = A_aw * dt;
    B.block<3, 3>(3, 3) = A_aa * dt;
    B.block<3, 3>(6, 0) = 0.5 * A_aw * dt2;
    B.block<3, 3>(6, 3) = 0.5 * A_aa * dt2;

    // Discrete white noise of one interval: σ_d² = density² / dt (Forster eq. 38 / Appendix).
    Eigen::Matrix<double, 6, 1> q;
    q << Vec3::Constant(sg2 / dt), Vec3::Constant(sa2 / dt);
    cov = A * cov * A.transpose() + B * q.asDiagonal() * B.transpose();
    // A bias increment acts like −δω, −δa.
    J = A * J - B;

    dp += dv * dt + 0.5 * aW * dt2;
    dv += aW * dt;
    dR = Orthonormalize(R1);
  }

  dR_ = Quat(dR).normalized();
  dv_ = dv;
  dp_ = dp;
  dR_dbg_ = J.block<3, 3>(0, 0);
  dv_dbg_ = J.block<3, 3>(3, 0);
  dv_dba_ = J.block<3, 3>(3, 3);
  dp_dbg_ = J.block<3, 3>(6, 0);
  dp_dba_ = J.block<3, 3>(6, 3);
  cov_ = 0.5 * (cov + cov.transpose());

  // 15x15 residual covariance: preintegration noise + bias random walk over Δt.
  cov15_.setZero();
  cov15_.topLeftCorner<9, 9>() = cov_;
  const double gw = options_.noise.gyroscope_random_walk,
               aw = options_.noise.accelerometer_random_walk;
  cov15_.block<3, 3>(9, 9) = Mat3::Identity() * gw * gw * dt_;
  cov15_.block<3, 3>(12, 12) = Mat3::Identity() * aw * aw * dt_;
  // Information Σ⁻¹ = L Lᵀ (Cholesky); whitening with Lᵀ: |Lᵀ r|² = rᵀ Σ⁻¹ r.
  Mat15 info = cov15_.ldlt().solve(Mat15::Identity());
  info = 0.5 * (info + info.transpose());
  Eigen::LLT<Mat15> llt(info);
  // A single integration step (one IMU interval between the keyframes: IMU at the camera rate, or
  // samples missing at the end) gives a 9 x 9 covariance of rank 6 (velocity and position driven by
  // the same accelerometer noise): the information does not exist. Then a small diagonal floor
  // (relative to the largest variance, raised until the factorisation succeeds) stands in for the
  // unmodelled intra-step noise. Covariances that factor are left exactly as they are.
  for (double floor = 1e-9; llt.info() != Eigen::Success && floor <= 1.0; floor *= 100.0) {
    Mat15 cov_floor = cov15_;
    cov_floor.diagonal().array() += floor * cov15_.diagonal().maxCoeff() + 1e-30;
    info = cov_floor.ldlt().solve(Mat15::Identity());
    info = 0.5 * (info + info.transpose());
    llt.compute(info);
    if (llt.info() == Eigen::Success) cov15_ = cov_floor;
  }
  if (llt.info() != Eigen::Success)
    throw InputError("IMU preintegration: the noise covariance is singular between " +
                     std::to_string(t_i_ns_) + " and " + std::to_string(t_j_ns_) + " ns");
  sqrt_info_ = llt.matrixL().transpose();
}

PreintegratedDelta ImuPreintegration::Corrected(const Vec3& bg, const Vec3& ba) const {
  const Vec3 dbg = bg - bg_lin_, dba = ba - ba_lin_;
  PreintegratedDelta d;
  d.dR = (dR_ * ExpQuat(dR_dbg_ * dbg)).normalized();
  d.dv = dv_ + dv_dbg_ * dbg + dv_dba_ * dba;
  d.dp = dp_ + dp_dbg_ * dbg + dp_dba_ * dba;
  return d;
}

void ImuPreintegration::Predict(const Rigid3& T_W_Bi, const Vec3& v_i, const Vec3& bg,
                                const Vec3& ba, Rigid3* T_W_Bj, Vec3* v_j) const {
  const PreintegratedDelta d = Corrected(bg, ba);
  const Vec3 g = GravityW(options_.gravity);
  const Quat& q_i = T_W_Bi.rotation();
  const Vec3& p_i = T_W_Bi.translation();
  // R_j = R_i ΔR,  v_j = v_i + g Δt + R_i Δv,  p_j = p_i + v_i Δt + ½ g Δt² + R_i Δp  (Forster eq.
  // 33).
  if (T_W_Bj) *T_W_Bj = Rigid3(q_i * d.dR, p_i + v_i * dt_ + 0.5 * g * dt_ * dt_ + q_i * d.dp);
  if (v_j) *v_j = v_i + g * dt_ + q_i * d.dv;
}

std::vector<ImuSample> ImuSamplesFor(const std::vector<ImuSample>& samples, int64_t t0,
                                     int64_t t1) {
  auto lo = std::lower_bound(samples.begin(), samples.end(), t0,
                             [](const ImuSample& s, int64_t t) { return s.t_ns < t; });
  if (lo != samples.begin()) --lo;
  auto hi = std::upper_bound(samples.begin(), samples.end(), t1,
                             [](int64_t t, const ImuSample& s) { return t < s.t_ns; });
  if (hi != samples.end()) ++hi;
  return std::vector<ImuSample>(lo, hi);
}

}  // namespace fsp::backend
