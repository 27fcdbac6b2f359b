// Drawing detections for people: an observer of the detector's output, never called by it.
#pragma once

#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "fsp/frontend/detection.h"

namespace fsp::frontend {

// The colour (BGR) every drawing uses for an object class.
cv::Scalar ClassColour(ObjectClass c);

// Returns a BGR copy of `image` (grey or BGR) with each detection's outline (green for tags, colour
// by class otherwise), its corners numbered 1..4 (s1..s4) and a label "id/class score". Uses
// corners_px (distorted pixels, i.e. the image as stored). Line widths and fonts scale with the
// image size.
cv::Mat DrawDetections(const cv::Mat& image, const std::vector<Detection>& detections);

}  // namespace fsp::frontend
