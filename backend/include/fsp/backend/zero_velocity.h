// The image half of the zero-velocity detection (ZeroVelocityOptions, backend/README.md, "Standing
// still"): did the corners of the objects seen by two keyframes move more than their noise
// explains?
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

}  // namespace fsp::backend
