#include "fsp/frontend/detection.h"

#include <chrono>
#include <cstdio>

namespace fsp::frontend {

ObjectObservation Detection::ToObservation(int64_t t_ns) const {
  ObjectObservation obs;
  obs.t_ns = t_ns;
  obs.object_id = tag_id;
  obs.object_class = object_class;
  obs.corners = corners_undistorted;
  obs.score = score;
  return obs;
}

void StageTimes::Add(const std::string& stage, double milliseconds) {
  ms.emplace_back(stage, milliseconds);
}

double StageTimes::Total() const {
  double total = 0.0;
  for (const auto& [name, t] : ms) total += t;
  return total;
}

std::string StageTimes::ToString() const {
  std::string s;
  char buf[64];
  for (const auto& [name, t] : ms) {
    std::snprintf(buf, sizeof(buf), "%s%s=%.2f", s.empty() ? "" : " ", name.c_str(), t);
    s += buf;
  }
  return s;
}

namespace {
long long NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
}  // namespace

Stopwatch::Stopwatch() : start_ns_(NowNs()) {}

double Stopwatch::Lap() {
  const long long now = NowNs();
  const double ms = 1e-6 * static_cast<double>(now - start_ns_);
  start_ns_ = now;
  return ms;
}

}  // namespace fsp::frontend
