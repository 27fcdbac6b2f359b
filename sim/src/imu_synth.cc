#include "fsp/sim/imu_synth.h"

#include <cmath>

#include "fsp/common/error.h"
#include "fsp/common/time.h"

namespace fsp::sim {

bool ImuSynthOptions::Check(std::string* why) const {
  if (!noise.Check(why)) return false;
  if (!gyro_bias0.allFinite() || !acc_bias0.allFinite()) {
    if (why) *why = "initial biases must be finite";
    return false;
  }
  return true;
}

int64_t SampleTimeNs(int64_t k, double rate_hz) {
  return static_cast<int64_t>(std::llround(static_cast<double>(k) * 1e9 / rate_hz));
}

ImuSample IdealImu(const Trajectory& trajectory, int64_t t_ns) {
  const TrajectoryState s = trajectory.State(NsToSeconds(t_ns));
  ImuSample sample;
  sample.t_ns = t_ns;
  sample.gyro = s.w_B;
  // Specific force in B: R_B_W (a_W - g_W).
  sample.acc = s.T_W_B.rotation().conjugate() * (s.a_W - GravityW());
  return sample;
}

ImuSequence SynthesizeImu(const Trajectory& trajectory, int64_t t_end_ns,
                          const ImuSynthOptions& options, std::mt19937* rng) {
  std::string why;
  FSP_CHECK(options.Check(&why));
  FSP_CHECK(!options.add_noise || rng != nullptr);
  const double rate = options.noise.rate_hz;
  const double dt = 1.0 / rate;
  // Discrete standard deviations: white noise density * sqrt(rate), bias step random_walk *
  // sqrt(dt).
  const double sigma_g = options.noise.gyroscope_noise_density * std::sqrt(rate);
  const double sigma_a = options.noise.accelerometer_noise_density * std::sqrt(rate);
  const double sigma_bg = options.noise.gyroscope_random_walk * std::sqrt(dt);
  const double sigma_ba = options.noise.accelerometer_random_walk * std::sqrt(dt);

  std::normal_distribution<double> normal(0.0, 1.0);
  auto gauss3 = [&](double sigma) {
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = sigma * normal(*rng);
    return v;
  };

  ImuSequence out;
  Vec3 bg = options.gyro_bias0, ba = options.acc_bias0;
  for (int64_t k = 0;; ++k) {
    const int64_t t_ns = SampleTimeNs(k, rate);
    if (t_ns > t_end_ns) break;
    ImuSample s = IdealImu(trajectory, t_ns);
    if (options.add_noise) {
      if (k > 0) {
        bg += gauss3(sigma_bg);
        ba += gauss3(sigma_ba);
      }
      s.gyro += bg + gauss3(sigma_g);
      s.acc += ba + gauss3(sigma_a);
    } else {
      s.gyro += bg;
      s.acc += ba;
    }
    out.samples.push_back(s);
    out.gyro_bias.push_back(bg);
    out.acc_bias.push_back(ba);
  }
  return out;
}

}  // namespace fsp::sim
