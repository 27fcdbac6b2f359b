// Time is int64 nanoseconds everywhere (t_ns); seconds as double only for a duration dt.
#pragma once

#include <cstdint>

namespace fsp {

constexpr int64_t kNsPerSecond = 1'000'000'000;

inline double NsToSeconds(int64_t ns) {
  return static_cast<double>(ns) * 1e-9;
}
// Rounds to the nearest nanosecond (TUM files store seconds with ~1e-6..1e-9 resolution).
int64_t SecondsToNs(double s);

}  // namespace fsp
