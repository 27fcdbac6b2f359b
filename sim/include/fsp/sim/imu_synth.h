// IMU synthesis from an analytic trajectory (gtsam ScenarioRunner-like): ideal readings from the
// trajectory's derivatives, then white noise and bias random walk with Kalibr-named densities.
//
// Measurement model (body frame B = IMU, g_W = (0, 0, -9.81)):
//   gyro_k = w_B(t_k) + b_g,k + n_g,k,            n_g ~ N(0, (sigma_g,c * sqrt(rate_hz))^2)
//   acc_k  = R_B_W(t_k) (a_W(t_k) - g_W) + b_a,k + n_a,k,   n_a likewise with the accelerometer
//   density b_k    = b_{k-1} + N(0, (random_walk * sqrt(dt))^2),    b_0 = the initial bias
// where sigma_c are the continuous noise densities (Kalibr gyroscope_noise_density, ...), so the
// discrete white-noise standard deviation is density / sqrt(dt) = density * sqrt(rate_hz).
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "fsp/common/calibration.h"
#include "fsp/common/types.h"
#include "fsp/sim/trajectory.h"

namespace fsp::sim {

struct ImuSynthOptions {
  ImuNoise noise;                  // densities and rate_hz (sample times k / rate_hz from t = 0)
  bool add_noise = true;           // false: exact readings, biases stay at their initial values
  Vec3 gyro_bias0 = Vec3::Zero();  // initial gyroscope bias [rad/s]
  Vec3 acc_bias0 = Vec3::Zero();   // initial accelerometer bias [m/s^2]
  bool Check(std::string* why) const;
};

struct ImuSequence {
  std::vector<ImuSample> samples;  // t_ns = round(k * 1e9 / rate_hz), k = 0, 1, ... while <= t_end
  std::vector<Vec3> gyro_bias;     // true bias in each sample (ground truth)
  std::vector<Vec3> acc_bias;
};

// Sample time of IMU (or camera) sample k at RATE_HZ, starting at t = 0: round(k * 1e9 / rate_hz).
int64_t SampleTimeNs(int64_t k, double rate_hz);

// The noise-free, bias-free reading at t_ns.
ImuSample IdealImu(const Trajectory& trajectory, int64_t t_ns);

// Readings from t = 0 to t_end_ns inclusive. RNG draws happen in a fixed order (per sample: gyro
// bias step, acc bias step, gyro noise, acc noise), so a seeded rng gives the same sequence every
// time. rng may be null when options.add_noise is false.
ImuSequence SynthesizeImu(const Trajectory& trajectory, int64_t t_end_ns,
                          const ImuSynthOptions& options, std::mt19937* rng);

}  // namespace fsp::sim
