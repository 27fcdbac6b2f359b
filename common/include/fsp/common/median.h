// The median and the percentiles of a set of values, as numpy computes them (the project's one
// home for both).
#pragma once

#include <vector>

namespace fsp {

// numpy.median of VALUES: the middle value, the mean of the two middle ones for an even count; 0
// when empty.
double Median(std::vector<double> values);

// numpy.percentile of VALUES at Q in [0, 1] (its default, linear interpolation between the order
// statistics at floor and ceil of Q (n - 1)); 0 when empty.
double Percentile(std::vector<double> values, double q);

}  // namespace fsp
