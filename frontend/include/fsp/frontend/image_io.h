// Reading images for the detectors, with the checks a user needs when a file is wrong.
#pragma once

#include <string>

#include <opencv2/core/mat.hpp>

namespace fsp::frontend {

// Reads PATH as an 8-bit grey image (colour is converted to grey). Throws InputError naming the
// file when it does not exist, is empty (0 bytes), does not decode, or is not 8-bit per channel (a
// 16-bit PNG, a float TIFF): silently scaling those would move edges and thresholds.
cv::Mat ReadGray8(const std::string& path);

}  // namespace fsp::frontend
