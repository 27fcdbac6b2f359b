#include "fsp/common/time.h"

#include <cmath>

namespace fsp {

int64_t SecondsToNs(double s) {
  return static_cast<int64_t>(std::llround(s * 1e9));
}

}  // namespace fsp
