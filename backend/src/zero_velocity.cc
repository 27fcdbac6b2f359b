#include "fsp/backend/zero_velocity.h"

#include <cmath>

namespace fsp::backend {
namespace {

// P(X > x) for X ~ χ²(dof), dof even: e^(-x/2) Σ_{i < dof/2} (x/2)^i / i!.
double ChiSquareSurvival(double x, int dof) {
  double term = 1.0, sum = 1.0;
  for (int i = 1; i < dof / 2; ++i) {
    term *= 0.5 * x / i;
    sum += term;
  }
  return std::exp(-0.5 * x) * sum;
}

}  // namespace

double ChiSquareQuantile(double probability, int dof) {
  double lo = 0.0, hi = dof + 20.0 * std::sqrt(2.0 * dof) + 50.0;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (1.0 - ChiSquareSurvival(mid, dof) < probability ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

CornerMotionTest TestCornerMotion(const std::vector<std::pair<Corners, Corners>>& pairs,
                                  double sigma_px, double confidence) {
  CornerMotionTest t;
  const double var = 2.0 * sigma_px * sigma_px;  // of each coordinate of a displacement
  for (const auto& [before, after] : pairs) {
    Vec2 mean = Vec2::Zero();
    for (int j = 0; j < 4; ++j) {
      const Vec2 d = after[j] - before[j];
      mean += d / 4.0;
      t.whole_chi2 += d.squaredNorm() / var;
    }
    t.shift_chi2 += 4.0 * mean.squaredNorm() / var;
    ++t.objects;
  }
  t.still = t.objects > 0 && t.shift_chi2 <= ChiSquareQuantile(confidence, 2 * t.objects) &&
            t.whole_chi2 <= ChiSquareQuantile(confidence, 8 * t.objects);
  return t;
}

PointMotionTest TestPointMotion(const std::vector<Vec2>& displacements_sigma, int min_points,
                                double confidence) {
  PointMotionTest t;
  t.points = static_cast<int>(displacements_sigma.size());
  if (t.points == 0) return t;
  Vec2 mean = Vec2::Zero();
  for (const Vec2& d : displacements_sigma) {
    mean += d / t.points;
    t.whole_chi2 += 0.5 * d.squaredNorm();
  }
  t.shift_chi2 = 0.5 * t.points * mean.squaredNorm();
  t.still = t.points >= min_points && t.shift_chi2 <= ChiSquareQuantile(confidence, 2) &&
            t.whole_chi2 <= ChiSquareQuantile(confidence, 2 * t.points);
  return t;
}

ImuStillTest TestImuStill(const std::vector<ImuSample>& samples, const Vec3& gyro_bias,
                          const Vec3& rest_force, double turn_rate_floor, double acc_floor,
                          double confidence) {
  ImuStillTest t;
  t.samples = static_cast<int>(samples.size());
  if (t.samples < 3) return t;
  const double n = t.samples;
  Vec3 mean_w = Vec3::Zero(), mean_a = Vec3::Zero();
  for (const ImuSample& s : samples) {
    mean_w += s.gyro / n;
    mean_a += s.acc / n;
  }
  Vec3 var_w = Vec3::Zero(), var_a = Vec3::Zero();  // of the means
  for (const ImuSample& s : samples) {
    var_w += (s.gyro - mean_w).cwiseAbs2() / ((n - 1.0) * n);
    var_a += (s.acc - mean_a).cwiseAbs2() / ((n - 1.0) * n);
  }
  const Vec3 var_w_total = var_w + Vec3::Constant(turn_rate_floor * turn_rate_floor);
  const Vec3 var_a_total = var_a + Vec3::Constant(acc_floor * acc_floor);
  t.chi2 = ((mean_w - gyro_bias).cwiseAbs2().cwiseQuotient(var_w_total)).sum() +
           ((mean_a - rest_force).cwiseAbs2().cwiseQuotient(var_a_total)).sum();
  t.still = t.chi2 <= ChiSquareQuantile(confidence, 6);
  return t;
}

}  // namespace fsp::backend
