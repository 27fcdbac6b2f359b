// The zero-velocity detection (ZeroVelocityOptions, backend/README.md, "Standing still"): did the
// corners of the objects seen by two keyframes move more than their noise explains, and does the
// IMU between them agree with standing still?
//
// Standing still, a corner seen twice with independent noise σ per coordinate is displaced by
// d ~ N(0, 2σ² I). Two chi-square tests over the objects both keyframes see, each accepted below
// its `confidence` quantile:
//  - the shift: each object's mean corner displacement d̄ ~ N(0, σ²/2 I), Σ 4|d̄|²/(2σ²) ~ χ²(2N);
//    what a translation or a turn of the camera does to an object, tested with its four corners'
//    noise averaged out (the most sensitive test for a slow motion);
//  - the whole: every corner's displacement, Σ|d|²/(2σ²) ~ χ²(8N); also catches what leaves the
//    mean in place (an approach: the object grows about its centre).
// No fixed pixel bound: with the corner noise the estimator assumes (FspFactorOptions::sigma_px) a
// still camera passes whatever the noise, and the smallest motion it can tell grows with σ.
//
// Without an object in both keyframes, the tracked points both see stand in (TestPointMotion): the
// shift is their mean displacement, N|d̄|²/(2σ²) ~ χ²(2) (a turn or a sideways move shifts them
// all), the whole Σ|d|²/(2σ²) ~ χ²(2N), each point in its own σ.
//
// The IMU half (TestImuStill, as OpenVINS's zero-velocity update gates itself): standing still, the
// mean turn rate between the keyframes is the gyroscope bias and the mean specific force is gravity
// seen in the body plus the accelerometer bias. Each mean's σ per axis is the samples' own scatter
// over the root of their number (a vibrating vehicle, motors running on the ground, has a wide one
// and no mean motion) and a floor: what the still priors tolerate (the turn rate σ of the still
// link; velocity_sigma / Δt: a mean acceleration that builds the velocity prior's σ in Δt). One
// χ²(6) over both. A hovering vehicle turning at 0.01 rad/s, or a take-off's first 0.2 s, fails it
// though the image may barely move.
#pragma once

#include <utility>
#include <vector>

#include "fsp/common/types.h"

namespace fsp::backend {

// The `probability` quantile of the chi-square distribution with an even number `dof` of degrees
// of freedom (exact: bisection on its closed-form CDF; every dof here is even).
double ChiSquareQuantile(double probability, int dof);

struct CornerMotionTest {
  int objects = 0;          // objects seen by both keyframes
  double shift_chi2 = 0.0;  // Σ over objects of 4|d̄|²/(2σ²), dof 2 x objects
  double whole_chi2 = 0.0;  // Σ over corners of |d|²/(2σ²), dof 8 x objects
  bool still = false;       // objects > 0 and both below their quantile
};

// The two tests on the corners of the same objects in two keyframes (pairs: earlier, later), at
// corner noise sigma_px [px] per coordinate and the given confidence (e.g. 0.99).
CornerMotionTest TestCornerMotion(const std::vector<std::pair<Corners, Corners>>& pairs,
                                  double sigma_px, double confidence);

struct PointMotionTest {
  int points = 0;           // points seen by both keyframes
  double shift_chi2 = 0.0;  // N|d̄|²/(2σ²) of the mean displacement in σ units, dof 2
  double whole_chi2 = 0.0;  // Σ|d|²/(2σ²), dof 2N
  bool still = false;       // points >= min_points and both below their quantile
};

// The two tests on the displacements of the same points between two keyframes, each divided by
// its point's noise σ [px] per coordinate (so in σ units), at the given confidence.
PointMotionTest TestPointMotion(const std::vector<Vec2>& displacements_sigma, int min_points,
                                double confidence);

struct ImuStillTest {
  int samples = 0;
  double chi2 = 0.0;   // dof 6
  bool still = false;  // at least 3 samples and chi2 below its quantile
};

// The IMU samples between two keyframes against standing still: GYRO_BIAS the estimated bias,
// REST_FORCE the specific force the accelerometer reads at rest (R_W_Bᵀ (−g_W) + b_a), the floors
// [rad/s], [m/s²] per axis.
ImuStillTest TestImuStill(const std::vector<ImuSample>& samples, const Vec3& gyro_bias,
                          const Vec3& rest_force, double turn_rate_floor, double acc_floor,
                          double confidence);

}  // namespace fsp::backend
