#include "fsp/frontend/flow_pyramid.h"

#include <algorithm>

#include <opencv2/video/tracking.hpp>

#include "fsp/common/error.h"

namespace fsp::frontend {

std::vector<cv::Mat> FlowPyramid::Levels(int max_level_wanted) const {
  const size_t n = 2 * static_cast<size_t>(std::clamp(max_level_wanted, 0, max_level) + 1);
  return std::vector<cv::Mat>(levels.begin(), levels.begin() + std::min(n, levels.size()));
}

FlowPyramid BuildFlowPyramid(const cv::Mat& gray, int window, int max_level) {
  FSP_CHECK(!gray.empty() && gray.type() == CV_8UC1 && window >= 3 && max_level >= 0);
  FlowPyramid p;
  p.image = gray;
  p.window = window;
  // tryReuseInputImage false: level 0 is always a padded copy, never the caller's buffer.
  p.max_level =
      cv::buildOpticalFlowPyramid(gray, p.levels, cv::Size(window, window), max_level, true,
                                  cv::BORDER_REFLECT_101, cv::BORDER_CONSTANT, false);
  return p;
}

}  // namespace fsp::frontend
