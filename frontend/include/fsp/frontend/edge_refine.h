// Sub-pixel corner refinement of a quadrilateral on the image edges: the rectangle detector's stage
// 4 ("refine", see rect_detector.h) offered for quads that come from elsewhere, such as the
// tracker's homography prediction. One implementation serves both.
//
// Per side, edge points are found as 1-D gradient peaks along the side's normal within
// +-options.search_px (in the distorted image, then undistorted), a RANSAC line is fitted with a
// gradient-weighted total least-squares refit, and a bent side gets a line per half; the corners
// are the intersections of adjacent lines. The refinement fails (ok = false) when a side has too
// little edge support (options.min_side_support), a corner would move more than 0.2 x the
// shortest side + 2 search_px, or the result is not convex.
#pragma once

#include <array>

#include <opencv2/core/mat.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/types.h"
#include "fsp/frontend/rect_detector.h"

namespace fsp::frontend {

// The image the refinement reads: the grey image smoothed with a 5x5 Gaussian of sigma 1 px (the
// detector's own smoothing). Build it once per frame and refine any number of quads on it.
cv::Mat EdgeRefineImage(const cv::Mat& gray);

// The same image built only inside `region` (clipped to the image) of `*smooth`, which is allocated
// at the grey image's size when it is not: the filter reads the real neighbours outside the region,
// so the values there equal EdgeRefineImage's. For refining a few quads on a large image, whose
// whole-frame smoothing would cost more than the refinement. Returns false for an empty region.
bool SmoothForEdgeRefine(const cv::Mat& gray, cv::Rect region, cv::Mat* smooth);

struct EdgeRefinement {
  bool ok = false;
  Corners corners_undistorted;  // refined corners, same order as the input (undistorted px)
  // Mean fraction of each side's samples on its fitted line(s) [0, 1] (the detector's score before
  // the rectangle test scales it).
  double support = 0.0;
  // Per side (side i joins corners i-1 and i): polarity of its edge (+1: brighter towards the
  // side's left normal (-u.y, u.x), u = direction from corner i-1 to corner i) and the median
  // gradient of its inliers [grey levels / px].
  std::array<int, 4> side_sign = {0, 0, 0, 0};
  std::array<double, 4> side_gradient = {0.0, 0.0, 0.0, 0.0};
};

// Refines a convex quad's corners (undistorted px, any cyclic order) on SMOOTH (EdgeRefineImage of
// the distorted grey image). `camera` (optional) maps between undistorted and distorted pixels; its
// size must match. Edge points weaker than `min_gradient` [grey levels / px] are ignored.
// `want_sign` (optional, per side as in EdgeRefinement::side_sign; 0 = either) restricts each
// side's search to one polarity, so that a side stays on the edge it was first found on. The RANSAC
// draws are seeded with options.seed: the same inputs give the same corners.
EdgeRefinement RefineCornersOnEdges(const cv::Mat& smooth, const PinholeRadtan* camera,
                                    const Corners& corners_undistorted, double min_gradient,
                                    const RectDetectorOptions& options,
                                    const std::array<int, 4>& want_sign = {0, 0, 0, 0});

}  // namespace fsp::frontend
