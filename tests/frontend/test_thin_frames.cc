// Thin dark frames on rendered crops (tests/frontend/data/README.md): a poster's side found on one
// edge of its 1.2 px frame is moved to the frame (RectDetectorOptions::band_thin_px,
// band_thin_inside_max_dip). Synthetic thin frames: test_edge_refine.cc.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "fsp/frontend/rect_detector.h"
#include "fsp/frontend/rect_geometry.h"
#include "rendered_crops.h"

namespace fsp::frontend {
namespace {

// A crop (x 300-410, y 180-300) of frame 12.40 s of `fsp render assets/scenes/clip_zoom_roll.yaml
// --seed 1`: poster 4, 40 px wide, its dark frame 1.2 px, a line of text near its bottom. The
// bottom side's edge is the paper's (the stronger), with the frame outside it and the text's edge
// inside it; the thin-band rule (band_thin_px) moves it onto the frame whatever lies inside.
// Before (the rule after the "edges on both sides" check) the bottom was 1.6 px above the outline.
TEST(RectDetector, ThinFramedPosterBottomAboveItsTextLine) {
  const cv::Mat img = cv::imread(
      std::string(FSP_FRONTEND_TEST_DATA) + "/zoom_roll_poster4_crop.png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(img.empty());
  // The rendered ground truth (observations_gt.csv) moved into the crop.
  const Corners gt = {Vec2(35.945, 88.793), Vec2(75.401, 87.863), Vec2(75.401, 31.137),
                      Vec2(35.945, 30.207)};
  const auto dets = RectDetector().Detect(img).detections;
  double best = 1e9;
  for (const Detection& d : dets) best = std::min(best, MaxCornerDistance(d.corners_px, gt));
  std::printf("thin-framed poster above its text line: worst corner %.2f px\n", best);
  EXPECT_LT(best, 0.8);  // measured 0.67 (1.74 before)
}

// Poster 4 of the blur clip (render seed 2), 43 px wide with a 1.2 px dark frame, coming to rest
// (8.95 s) and still (9.25 s): the crops of rendered_crops.h. Its sides are found on the frame's
// outer edge, which the stronger inner edge (the bright paper) pushes outward, and the two-edge
// model's fit is refused; with band_thin_inside_max_dip they move to the frame's darkest point.
TEST(RectDetector, ThinFrameSeenOnItsOuterEdgeIsNotDrawnLarger) {
  const test::BlurPoster4Crops crops;
  RectDetectorOptions off;
  off.band_thin_inside_max_dip = 0.0;
  for (const auto& [name, crop] :
       {std::pair{"8.95 s", &crops.coming_to_rest}, std::pair{"9.25 s", &crops.still}}) {
    ASSERT_FALSE(crop->image.empty()) << name;
    auto worst = [&](const RectDetectorOptions& o) {
      double best = 1e9;
      for (const Detection& d : RectDetector(o).Detect(crop->image, &crops.camera).detections)
        best = std::min(best, MaxCornerDistance(d.corners_undistorted, crop->gt));
      return best;
    };
    const double before = worst(off), after = worst(RectDetectorOptions());
    std::printf("blur clip's poster 4 at %s: worst corner %.2f px without the rule, %.2f with it\n",
                name, before, after);
    EXPECT_GT(before, 1.0) << name;  // the push the rule is for
    EXPECT_LT(after, 0.8) << name;
  }
}

}  // namespace
}  // namespace fsp::frontend
