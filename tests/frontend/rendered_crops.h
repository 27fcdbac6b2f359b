// The blur clip's crops in tests/frontend/data (their README says how they were rendered and cut):
// the images, the clip's camera with its principal point moved into the crop, and the rendered
// ground-truth corners (observations_gt.csv, undistorted px) moved into the crop.
#pragma once

#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/types.h"
#include "synthetic.h"

namespace fsp::test {

struct RenderedCrop {
  cv::Mat image;  // CV_8UC1; empty when the file is missing
  Corners gt;     // s1..s4
};

// Poster 4 of `fsp render assets/scenes/clip_blur.yaml --seed 2`, region x 232-362, y 160-310: 43
// px wide with a 1.2 px dark frame, coming to rest (frame 8.95 s, 2 px from its place in the next
// frame) and still (9.25 s).
struct BlurPoster4Crops {
  PinholeRadtan camera = PinholeCamera(130, 150, 458.0, 319.5 - 232.0, 239.5 - 160.0);
  RenderedCrop coming_to_rest = Load(
      "blur_poster4_8950000000_crop.png",
      {Vec2(47.349, 112.250), Vec2(89.873, 110.595), Vec2(89.873, 48.405), Vec2(47.349, 46.750)});
  RenderedCrop still = Load(
      "blur_poster4_9250000000_crop.png",
      {Vec2(45.331, 112.263), Vec2(87.871, 110.594), Vec2(87.871, 48.406), Vec2(45.331, 46.737)});

 private:
  static RenderedCrop Load(const std::string& file, const Corners& gt) {
    return {cv::imread(std::string(FSP_FRONTEND_TEST_DATA) + "/" + file, cv::IMREAD_GRAYSCALE), gt};
  }
};

}  // namespace fsp::test
