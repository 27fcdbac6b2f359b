// The median of a set of values, as numpy.median computes it (the one median of the project).
#pragma once

#include <vector>

namespace fsp {

// numpy.median of VALUES: the middle value, the mean of the two middle ones for an even count; 0
// when empty.
double Median(std::vector<double> values);

}  // namespace fsp
