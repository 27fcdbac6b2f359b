// The detector's edge refinement as a function of its own (RefineCornersOnEdges): a quad given with
// corners a pixel or two off (what a tracker's homography predicts) is pulled onto the image edges.
#include <gtest/gtest.h>

#include "fsp/frontend/edge_refine.h"
#include "synthetic.h"

namespace fsp::frontend {
namespace {

const Corners kTruth = {Vec2(200.3, 330.6), Vec2(431.2, 318.4), Vec2(420.7, 121.9),
                        Vec2(212.5, 140.2)};

cv::Mat Frame() {
  return test::RenderQuads(640, 480, {{kTruth, 200}}, 0.8, 2.0, /*seed=*/7);
}

double MaxError(const Corners& a, const Corners& b) {
  double e = 0.0;
  for (int i = 0; i < 4; ++i) e = std::max(e, (a[i] - b[i]).norm());
  return e;
}

TEST(EdgeRefine, PullsOffsetCornersOntoTheEdges) {
  const cv::Mat smooth = EdgeRefineImage(Frame());
  Corners start = kTruth;
  const Vec2 offsets[4] = {Vec2(1.5, -1.0), Vec2(-1.2, 1.4), Vec2(0.8, 1.6), Vec2(-1.7, -0.6)};
  for (int i = 0; i < 4; ++i) start[i] += offsets[i];
  const EdgeRefinement r = RefineCornersOnEdges(smooth, nullptr, start, 2.0, RectDetectorOptions());
  ASSERT_TRUE(r.ok);
  EXPECT_LT(MaxError(r.corners_undistorted, kTruth),
            0.25)  // measured 0.16 px (2 grey levels noise)
      << "start error " << MaxError(start, kTruth);
  EXPECT_GT(r.support, 0.9);
  // A bright quad on a darker background, corners counter-clockwise on screen (y down): the left
  // normal (-u.y, u.x) of every side points out of the quad, to the darker side: polarity -1.
  for (int i = 0; i < 4; ++i) EXPECT_EQ(r.side_sign[i], -1) << "side " << i;
  EXPECT_GT(r.side_gradient[0], 10.0);

  // The same polarity forced gives the same corners; the opposite one finds no edge.
  const EdgeRefinement same =
      RefineCornersOnEdges(smooth, nullptr, start, 2.0, RectDetectorOptions(), r.side_sign);
  ASSERT_TRUE(same.ok);
  EXPECT_LT(MaxError(same.corners_undistorted, r.corners_undistorted), 1e-9);
  std::array<int, 4> opposite;
  for (int i = 0; i < 4; ++i) opposite[i] = -r.side_sign[i];
  EXPECT_FALSE(
      RefineCornersOnEdges(smooth, nullptr, start, 2.0, RectDetectorOptions(), opposite).ok);
}

TEST(EdgeRefine, FailsWhereThereIsNoRectangle) {
  const cv::Mat smooth = EdgeRefineImage(Frame());
  Corners elsewhere = kTruth;
  for (Vec2& c : elsewhere) c += Vec2(0.0, 90.0);  // top side on no edge, bottom side off the quad
  for (Vec2& c : elsewhere) c.x() += 60.0;
  EXPECT_FALSE(RefineCornersOnEdges(smooth, nullptr, elsewhere, 2.0, RectDetectorOptions()).ok);
}

}  // namespace
}  // namespace fsp::frontend
