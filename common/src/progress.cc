#include "fsp/common/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace fsp {

Progress::Progress(std::string label, int64_t total)
    : label_(std::move(label)),
      total_(total),
      enabled_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

Progress::~Progress() {
  if (enabled_) Draw(true);
}

void Progress::Update(int64_t done) {
  done_ = done;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  Draw(false);
}

void Progress::Draw(bool final) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (total_ > 0) {
    const double frac =
        std::clamp(static_cast<double>(done_) / static_cast<double>(total_), 0.0, 1.0);
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(frac * kWidth);
    const double eta = frac > 0.0 ? elapsed * (1.0 - frac) / frac : 0.0;
    std::fprintf(stderr, "\r%s [%.*s%*s] %3d%% %lld/%lld  %.1fs%s", label_.c_str(), filled,
                 "##############################", kWidth - filled, "",
                 static_cast<int>(100.0 * frac), static_cast<long long>(done_),
                 static_cast<long long>(total_), final ? elapsed : eta, final ? "   \n" : " left ");
  } else {
    std::fprintf(stderr, "\r%s %lld  %.1fs%s", label_.c_str(), static_cast<long long>(done_),
                 elapsed, final ? "\n" : "");
  }
  std::fflush(stderr);
}

}  // namespace fsp
