// One image pyramid per frame for pyramidal Lucas-Kanade flow, shared by the trackers that follow
// the frame: the FrontEnd builds it once and hands it to the ObjectTracker and the PointTracker
// (each LK call on it is then as if the tracker had built its own: the levels do not depend on
// the padding, and a tracker uses as many levels as it asks for).
#pragma once

#include <vector>

#include <opencv2/core/mat.hpp>

namespace fsp::frontend {

struct FlowPyramid {
  cv::Mat image;  // the frame as given (CV_8UC1; shares its pixels, no copy)
  // cv::buildOpticalFlowPyramid's output with derivatives: per level the image and its Scharr
  // derivatives, each padded by `window` px (BORDER_REFLECT_101 / zeros).
  std::vector<cv::Mat> levels;
  int window = 0;     // padding [px]: LK windows up to this size can run on it
  int max_level = 0;  // levels above the full image built (fewer than asked on a small image)

  bool empty() const { return levels.empty(); }
  // The first max_level + 1 levels (image and derivatives each): what a tracker using at most
  // MAX_LEVEL levels above the image sees (all there are when fewer).
  std::vector<cv::Mat> Levels(int max_level) const;
};

// The pyramid of GRAY (CV_8UC1) with levels up to MAX_LEVEL above it, padded for LK windows up to
// WINDOW px (odd, >= 3).
FlowPyramid BuildFlowPyramid(const cv::Mat& gray, int window, int max_level);

}  // namespace fsp::frontend
