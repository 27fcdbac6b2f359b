// A one-line progress bar on stderr, drawn only when stderr is a terminal (never in logs or CI).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace fsp {

class Progress {
 public:
  // total <= 0 means unknown: the bar shows a count instead of a percentage.
  Progress(std::string label, int64_t total);
  ~Progress();  // finishes the line
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void Update(int64_t done);
  bool enabled() const { return enabled_; }

 private:
  void Draw(bool final);
  std::string label_;
  int64_t total_ = 0;
  int64_t done_ = 0;
  bool enabled_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace fsp
