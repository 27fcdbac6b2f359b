// Test helpers for the inertial tests: an analytic 3-D trajectory with rotating attitude (exact
// angular velocity and specific force), ideal/noisy IMU sampling, and EuRoC csv readers.
#pragma once

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "fsp/backend/state.h"
#include "fsp/common/csv.h"
#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::test {

// p_W(t) = (a sin(0.9 t), b cos(0.7 t) + c, 0.3 sin(1.3 t)),
// R_W_B(t) = Rz(ψ) Ry(θ) Rx(φ), ψ = 0.8 sin(0.5 t) + 0.3 t, θ = 0.25 sin(0.9 t), φ = 0.3 sin(1.1
// t). Body angular velocity ω_B = φ̇ e_x + Rx(φ)ᵀ(θ̇ e_y + Ry(θ)ᵀ ψ̇ e_z) (from Rᵀ Ṙ = [ω_B]×);
// specific force a_B = R_W_Bᵀ (p̈_W − g_W), g_W = (0, 0, −9.81).
struct AnalyticTrajectory {
  double a = 1.5, b = 1.0, c = 0.5;
  double gravity = 9.81;

  Vec3 Position(double t) const {
    return Vec3(a * std::sin(0.9 * t), b * std::cos(0.7 * t) + c, 0.3 * std::sin(1.3 * t));
  }
  Vec3 Velocity(double t) const {
    return Vec3(0.9 * a * std::cos(0.9 * t), -0.7 * b * std::sin(0.7 * t),
                0.39 * std::cos(1.3 * t));
  }
  Vec3 Acceleration(double t) const {
    return Vec3(-0.81 * a * std::sin(0.9 * t), -0.49 * b * std::cos(0.7 * t),
                -0.507 * std::sin(1.3 * t));
  }
  void Angles(double t, Vec3* e, Vec3* e_dot) const {
    *e = Vec3(0.3 * std::sin(1.1 * t), 0.25 * std::sin(0.9 * t), 0.8 * std::sin(0.5 * t) + 0.3 * t);
    *e_dot =
        Vec3(0.33 * std::cos(1.1 * t), 0.225 * std::cos(0.9 * t), 0.4 * std::cos(0.5 * t) + 0.3);
  }
  Mat3 Rotation(double t) const {
    Vec3 e, ed;
    Angles(t, &e, &ed);
    return RotFromRpy(e.x(), e.y(), e.z());
  }
  Vec3 Omega(double t) const {
    Vec3 e, ed;
    Angles(t, &e, &ed);
    return ed.x() * Vec3::UnitX() +
           RotX(e.x()).transpose() *
               (ed.y() * Vec3::UnitY() + RotY(e.y()).transpose() * (ed.z() * Vec3::UnitZ()));
  }
  Vec3 SpecificForce(double t) const {
    return Rotation(t).transpose() * (Acceleration(t) - Vec3(0.0, 0.0, -gravity));
  }
  Rigid3 Pose(double t) const { return Rigid3(Rotation(t), Position(t)); }

  // State at t with biases (bg, ba).
  backend::KeyframeState State(double t, const Vec3& bg = Vec3::Zero(),
                               const Vec3& ba = Vec3::Zero()) const {
    backend::KeyframeState k;
    k.t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    k.SetT_W_B(Pose(t));
    backend::VelocityOf(k.speed_bias) = Velocity(t);
    backend::GyroBiasOf(k.speed_bias) = bg;
    backend::AccBiasOf(k.speed_bias) = ba;
    return k;
  }
};

// IMU samples from t0 to t1 [s] at nominal `rate_hz`, each interval jittered by ±jitter·dt (unequal
// dt) when `rng` is given, measured = true + bias (+ white noise σ = density·√rate when noise_rng).
struct ImuSamplingOptions {
  double rate_hz = 200.0;
  double jitter = 0.0;  // fraction of dt, uniform
  Vec3 bg = Vec3::Zero(), ba = Vec3::Zero();
  double gyro_density = 0.0, acc_density = 0.0;  // white noise [rad/s/√Hz], [m/s²/√Hz]
};

inline std::vector<ImuSample> SampleImu(const AnalyticTrajectory& traj, double t0, double t1,
                                        const ImuSamplingOptions& o, std::mt19937* rng = nullptr) {
  std::vector<ImuSample> out;
  const double dt = 1.0 / o.rate_hz;
  std::uniform_real_distribution<double> u(-o.jitter, o.jitter);
  std::normal_distribution<double> n(0.0, 1.0);
  const double sg = o.gyro_density * std::sqrt(o.rate_hz),
               sa = o.acc_density * std::sqrt(o.rate_hz);
  for (double t = t0; t <= t1 + 1e-12;) {
    ImuSample s;
    s.t_ns = static_cast<int64_t>(std::llround(t * 1e9));
    const double ts = 1e-9 * static_cast<double>(s.t_ns);
    s.gyro = traj.Omega(ts) + o.bg;
    s.acc = traj.SpecificForce(ts) + o.ba;
    if (rng && (sg > 0.0 || sa > 0.0)) {
      s.gyro += sg * Vec3(n(*rng), n(*rng), n(*rng));
      s.acc += sa * Vec3(n(*rng), n(*rng), n(*rng));
    }
    out.push_back(s);
    t += dt * (1.0 + (rng && o.jitter > 0.0 ? u(*rng) : 0.0));
  }
  return out;
}

// EuRoC imu0/data.csv: t_ns, gyro xyz, acc xyz.
inline std::vector<ImuSample> ReadEurocImu(const std::string& path) {
  TableReader reader(path, "IMU csv");
  std::vector<std::string> f;
  std::vector<ImuSample> out;
  while (reader.NextRow(&f)) {
    ImuSample s;
    s.t_ns = reader.Int64(f, 0, "t_ns");
    s.gyro = Vec3(reader.Double(f, 1, "wx"), reader.Double(f, 2, "wy"), reader.Double(f, 3, "wz"));
    s.acc = Vec3(reader.Double(f, 4, "ax"), reader.Double(f, 5, "ay"), reader.Double(f, 6, "az"));
    out.push_back(s);
  }
  return out;
}

// EuRoC ground-truth csv: t_ns, p xyz, q wxyz, v xyz, bg xyz, ba xyz.
inline std::vector<StateSample> ReadEurocGt(const std::string& path) {
  TableReader reader(path, "ground truth csv");
  std::vector<std::string> f;
  std::vector<StateSample> out;
  while (reader.NextRow(&f)) {
    StateSample s;
    s.t_ns = reader.Int64(f, 0, "t_ns");
    auto d = [&](size_t i) { return reader.Double(f, i, "value"); };
    s.T_W_B = Rigid3(Quat(d(4), d(5), d(6), d(7)), Vec3(d(1), d(2), d(3)));
    s.v_W = Vec3(d(8), d(9), d(10));
    s.gyro_bias = Vec3(d(11), d(12), d(13));
    s.acc_bias = Vec3(d(14), d(15), d(16));
    out.push_back(s);
  }
  return out;
}

}  // namespace fsp::test
