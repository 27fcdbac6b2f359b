#include "fsp/eval/stats.h"

#include <algorithm>
#include <cmath>

namespace fsp::eval {

ErrorStats ComputeStats(std::vector<double> errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) return s;
  const double n = static_cast<double>(errors.size());
  double sum = 0.0, sum_sq = 0.0;
  s.min = errors.front();
  s.max = errors.front();
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  // rmse = sqrt(Σ e² / n), mean = Σ e / n, std = sqrt(Σ (e − mean)² / n).
  s.rmse = std::sqrt(sum_sq / n);
  s.mean = sum / n;
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  s.median = Median(std::move(errors));
  return s;
}

}  // namespace fsp::eval
