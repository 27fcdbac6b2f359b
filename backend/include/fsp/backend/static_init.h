// Static initialisation from the first still interval of IMU data: gravity direction -> roll and
// pitch of R_W_B (yaw 0: the yaw is a gauge freedom), gyroscope bias = mean angular rate, v = 0,
// p = 0. It REFUSES (success = false with a reason) when the interval is not still or too short.
//
// Stillness is judged on 0.1 s block means, not on raw samples: rotor vibration on a standing MAV
// makes the raw specific force scatter by ~1 m/s² (EuRoC V1_01: raw std 0.3..1.1 m/s²), as much as
// in flight, but it averages out within a block while real motion does not (block-mean std, EuRoC:
// standing gyro ≤ 0.007 rad/s and acc ≤ 0.11 m/s²; flying gyro ≥ 0.08 rad/s).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fsp/common/types.h"

namespace fsp::backend {

struct StaticInitOptions {
  double window_s = 1.0;  // length of the interval examined from its start [s]; longer: better
                          // bias, but the vehicle must stand still for longer
  double block_s = 0.1;   // block length for the block means [s] (vibration filter)
  double max_gyro_block_std = 0.02;  // max norm of the per-axis std of gyro block means [rad/s]
  double max_acc_block_std = 0.25;   // max norm of the per-axis std of acc block means [m/s^2]
  double max_gravity_error =
      0.5;                // max | |mean acc| − gravity | [m/s^2] (accelerometer bias + tilt)
  int min_samples = 50;   // fewer samples in the window -> refuse
  double gravity = 9.81;  // |g| [m/s^2]
  bool Check(std::string* why) const;
};

struct StaticInitSummary {
  bool success = false;
  std::string reason;      // why it refused; empty on success
  int64_t t_start_ns = 0;  // first sample used
  int64_t t_end_ns = 0;    // last sample used
  int num_samples = 0;
  Vec3 gyro_mean = Vec3::Zero(), acc_mean = Vec3::Zero();  // [rad/s], [m/s^2]
  Vec3 gyro_std = Vec3::Zero(), acc_std = Vec3::Zero();    // raw per-axis std
  double gyro_block_std = 0.0, acc_block_std = 0.0;        // the stillness measures
  // σ of gyro_mean per axis (RMS over the axes): the block means' scatter over the root of their
  // number (a vibrating vehicle's included). The IMU's white noise alone gives at least
  // gyroscope_noise_density / √window_s, which the estimator adds as a floor.
  double gyro_mean_sigma = 0.0;  // [rad/s]
  double gravity_error = 0.0;    // |mean acc| − gravity [m/s^2]
  // Body state at t_end_ns: R_W_B with R_W_B · acc_mean/|acc_mean| = e_z and yaw 0, p = 0, v = 0,
  // gyro bias = gyro_mean, acc bias = 0 (not separable from tilt from one attitude).
  StateSample state;
};

// Uses the samples with t_start_ns <= t < t_start_ns + window. t_start_ns < 0: from the first
// sample.
StaticInitSummary StaticInitialize(const std::vector<ImuSample>& imu,
                                   const StaticInitOptions& options, int64_t t_start_ns = -1);

}  // namespace fsp::backend
