// Summary statistics of a set of non-negative errors, computed as numpy/evo do.
#pragma once

#include <cstddef>
#include <vector>

#include "fsp/common/median.h"

namespace fsp::eval {

struct ErrorStats {
  size_t count = 0;
  double rmse = 0.0;  // sqrt(mean(e^2))
  double mean = 0.0;
  double median =
      0.0;           // middle value; mean of the two middle values for an even count (numpy.median)
  double std = 0.0;  // population standard deviation (numpy.std, ddof = 0)
  double min = 0.0;
  double max = 0.0;
};

// Statistics of ERRORS; all zero (count 0) when empty.
ErrorStats ComputeStats(std::vector<double> errors);

// numpy.median of VALUES (0 when empty): fsp::Median (fsp/common/median.h).
using ::fsp::Median;

}  // namespace fsp::eval
