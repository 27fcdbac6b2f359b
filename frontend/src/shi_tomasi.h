// Internal to the front end (not installed): the Shi-Tomasi corners both trackers seed their flow
// points with (ObjectTracker inside an object's quad, PointTracker in the grid's cells).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace fsp::frontend {

// Shi-Tomasi corners of IMG (CV_8UC1) inside MASK (CV_8UC1, non-zero: allowed), strongest first
// (ties by row, then column), at least MIN_DIST apart [px], whose weaker structure-tensor
// eigenvalue exceeds both 1 % of the strongest in MASK and the absolute MIN_GRADIENT [grey levels
// / px, rms over 5x5] (a plain surface's pixel noise is not a feature: LK on it wanders); at most
// MAX_COUNT. Local maxima of the eigenvalue (3x3) only, one pixel away from IMG's border.
std::vector<cv::Point2f> ShiTomasiCorners(const cv::Mat& img, const cv::Mat& mask, double min_dist,
                                          double min_gradient, int max_count);

}  // namespace fsp::frontend
