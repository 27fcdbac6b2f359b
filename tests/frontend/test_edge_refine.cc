// The detector's edge refinement as a function of its own (RefineCornersOnEdges): a quad given with
// corners a pixel or two off (what a tracker's homography predicts) is pulled onto the image edges.
#include <cstdio>
#include <utility>

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

// The refinement from START on SMOOTH with the frame and shadow rule (frame_band_max_frac) off,
// then with the defaults.
std::pair<EdgeRefinement, EdgeRefinement> WithoutAndWithFrameRule(const cv::Mat& smooth,
                                                                  const Corners& start) {
  RectDetectorOptions off;
  off.frame_band_max_frac = 0.0;
  return {RefineCornersOnEdges(smooth, nullptr, start, 2.0, off),
          RefineCornersOnEdges(smooth, nullptr, start, 2.0, RectDetectorOptions())};
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

// A framed object on a floor of its frame's grey (RectDetectorOptions::frame_band_max_frac): a
// cabinet's dark frame (62) round a light panel (160) on a light wall (150-170), its bottom on a
// dark floor (55). The bottom outline has a 7-grey-level step; the refinement finds the panel's
// edge 6 px above it, and the frame seen on the top side puts it back on the outline.
TEST(EdgeRefine, FramedObjectOnAFloorOfItsFramesGreyGetsItsOutline) {
  // A rectangle turned by 0.57 deg, its panel inset by 6 px, the floor's edge on its bottom side.
  const Vec2 u(220.3, -2.2), v(-2.2, -237.5);  // along the bottom, up the left side
  const Vec2 s1(200.3, 360.4);
  const Corners outline = {s1, s1 + u, s1 + u + v, s1 + v};
  const Vec2 iu = u.normalized() * 6.0, iv = v.normalized() * 6.0;
  const Corners panel = {s1 + iu + iv, s1 + u - iu + iv, s1 + u + v - iu - iv, s1 + v + iu - iv};
  const double slope = u.y() / u.x();
  const Corners floor = {Vec2(-1.0, 479.5), Vec2(640.0, 479.5),
                         Vec2(640.0, s1.y() + slope * (640.0 - s1.x())),
                         Vec2(-1.0, s1.y() + slope * (-1.0 - s1.x()))};
  const cv::Mat framed = test::RenderQuads(640, 480, {{floor, 55}, {outline, 62}, {panel, 160}},
                                           0.8, 2.0, /*seed=*/3, /*background=*/150);
  const cv::Mat smooth = EdgeRefineImage(framed);
  // Started on the panel's bottom edge (what the detector's segments give).
  Corners start = outline;
  start[0] = s1 + iv;
  start[1] = s1 + u + iv;
  const auto [inner, r] = WithoutAndWithFrameRule(smooth, start);
  ASSERT_TRUE(inner.ok);
  EXPECT_GT(MaxError(inner.corners_undistorted, outline), 5.0);  // without the rule: the panel's
  ASSERT_TRUE(r.ok);
  EXPECT_LT(MaxError(r.corners_undistorted, outline), 0.5)
      << "bottom corners " << r.corners_undistorted[0].transpose() << ", "
      << r.corners_undistorted[1].transpose();
  // Started on the outline it stays there (the rule does not move an outline twice).
  const EdgeRefinement again =
      RefineCornersOnEdges(smooth, nullptr, r.corners_undistorted, 2.0, RectDetectorOptions());
  if (again.ok) {
    EXPECT_LT(MaxError(again.corners_undistorted, outline), 0.5);
  }
  // A plain object (no frame, darker than the wall, lighter than the floor: its bottom side is the
  // odd one too) keeps its bottom where it is.
  const cv::Mat plain = test::RenderQuads(640, 480, {{floor, 55}, {outline, 100}}, 0.8, 2.0,
                                          /*seed=*/3, /*background=*/150);
  const EdgeRefinement p =
      RefineCornersOnEdges(EdgeRefineImage(plain), nullptr, outline, 2.0, RectDetectorOptions());
  ASSERT_TRUE(p.ok);
  EXPECT_LT(MaxError(p.corners_undistorted, outline), 0.3);
}

// A wall plate's shadow (RectDetectorOptions::frame_band_max_frac, the shadow case): a bright plate
// (215) on a wall (150) casts a dark band (110) 3.5 px wide below it. Started on the band's outer
// edge (where the detector's segment of that side lies on a real plate: the DM-VIO walk's switch
// plates came out 2-4 px too tall), the bottom side moves up onto the plate's edge: a shadow falls
// on one side, a frame runs round.
TEST(EdgeRefine, PlatesShadowIsNotPartOfThePlate) {
  const Vec2 u(45.3, -0.6), v(-0.6, -44.8), s1(300.4, 260.3);
  const Corners plate = {s1, s1 + u, s1 + u + v, s1 + v};
  const Vec2 down = -3.5 * v.normalized();
  const Corners shadow = {s1 + down, s1 + u + down, s1 + u + v, s1 + v};
  const cv::Mat img = test::RenderQuads(640, 480, {{shadow, 110}, {plate, 215}}, 0.8, 2.0,
                                        /*seed=*/4, /*background=*/150);
  const cv::Mat smooth = EdgeRefineImage(img);
  Corners start = plate;
  start[0] = s1 + down;
  start[1] = s1 + u + down;
  const auto [on_shadow, r] = WithoutAndWithFrameRule(smooth, start);
  ASSERT_TRUE(on_shadow.ok);
  EXPECT_GT(MaxError(on_shadow.corners_undistorted, plate), 2.5);  // without the rule
  ASSERT_TRUE(r.ok);
  EXPECT_LT(MaxError(r.corners_undistorted, plate), 0.5)
      << "bottom corners " << r.corners_undistorted[0].transpose() << ", "
      << r.corners_undistorted[1].transpose();
  // Without a shadow the plate keeps its outline.
  const cv::Mat plain =
      test::RenderQuads(640, 480, {{plate, 215}}, 0.8, 2.0, /*seed=*/4, /*background=*/150);
  const EdgeRefinement p =
      RefineCornersOnEdges(EdgeRefineImage(plain), nullptr, plate, 2.0, RectDetectorOptions());
  ASSERT_TRUE(p.ok);
  EXPECT_LT(MaxError(p.corners_undistorted, plate), 0.3);
}

// A poster with a thin dark frame `w` px wide: paper 228 in a frame of 40, on a wall of 150, seen
// at a slight angle (blur 0.8 px, noise 2 grey levels).
struct ThinFramedPoster {
  const Vec2 u{220.3, -2.2}, v{-2.2, -237.5}, s1{200.3, 360.4};
  const Corners outline = {s1, s1 + u, s1 + u + v, s1 + v};
  Corners paper;
  cv::Mat smooth;  // EdgeRefineImage of the frame
  explicit ThinFramedPoster(double w) {
    const Vec2 iu = u.normalized() * w, iv = v.normalized() * w;
    paper = {s1 + iu + iv, s1 + u - iu + iv, s1 + u + v - iu - iv, s1 + v + iu - iv};
    smooth = EdgeRefineImage(test::RenderQuads(640, 480, {{outline, 40}, {paper, 228}}, 0.8, 2.0,
                                               /*seed=*/5, /*background=*/150));
  }
  // Mean signed error of corners C along the rays from the centre (> 0: drawn too large).
  double Outward(const Corners& c) const {
    const Vec2 centre = s1 + 0.5 * (u + v);
    double sum = 0.0;
    for (int i = 0; i < 4; ++i) sum += (c[i] - outline[i]).dot((outline[i] - centre).normalized());
    return sum / 4.0;
  }
};

// The thin frame (RectDetectorOptions::band_max_px), 1-3 px. The blur pushes the frame's outer and
// inner gradient peaks apart, so the outline's peak lies outside it: measured along the diagonals,
// 2.11 px at 1 px, 1.64 at 1.5, 1.15 at 2 and 0.52 at 3 without the two-edge model; 0.49, 0.37,
// 0.07 and -0.01 px with it (a band thinner than the blur fixes its centre better than its width).
TEST(EdgeRefine, ThinFrameIsNotDrawnLarger) {
  RectDetectorOptions off;
  off.band_max_px = 0.0;
  for (const double w : {1.0, 1.5, 2.0, 3.0}) {
    const ThinFramedPoster p(w);
    // The outline's polarity (the side's left normal points out, to the brighter wall), as the
    // tracker and the detector's segments give it: the paper's edge is the stronger one.
    const std::array<int, 4> outer = {1, 1, 1, 1};
    const EdgeRefinement before =
        RefineCornersOnEdges(p.smooth, nullptr, p.outline, 2.0, off, outer);
    const EdgeRefinement after =
        RefineCornersOnEdges(p.smooth, nullptr, p.outline, 2.0, RectDetectorOptions(), outer);
    ASSERT_TRUE(before.ok && after.ok) << "frame " << w << " px";
    const double e0 = p.Outward(before.corners_undistorted),
                 e1 = p.Outward(after.corners_undistorted);
    std::printf("frame %.1f px: outward %.3f px without the band model, %.3f with it\n", w, e0, e1);
    EXPECT_GT(e0, 0.4) << "frame " << w << " px";  // the push this model is for
    EXPECT_LT(std::abs(e1), 0.3 * e0) << "frame " << w << " px";
    if (w >= 2.0) {
      EXPECT_LT(std::abs(e1), 0.1) << "frame " << w << " px";
    }
  }
  // A plain object (no band) is not moved by it.
  const ThinFramedPoster p(1.0);
  const cv::Mat plain = test::RenderQuads(640, 480, {{p.outline, 40}}, 0.8, 2.0, 5, 150);
  const cv::Mat smooth = EdgeRefineImage(plain);
  const EdgeRefinement a = RefineCornersOnEdges(smooth, nullptr, p.outline, 2.0, off);
  const EdgeRefinement b =
      RefineCornersOnEdges(smooth, nullptr, p.outline, 2.0, RectDetectorOptions());
  ASSERT_TRUE(a.ok && b.ok);
  EXPECT_EQ(MaxError(a.corners_undistorted, b.corners_undistorted), 0.0);
}

// The same poster refined with the paper's polarity (the inner edge: how a far, blurred first view
// can teach it to the tracker): the side lands on the frame's inner edge and the blur pushes it
// further in. With band_thin_px the side moves to the thin frame's centre instead, within half the
// frame of the outline. Measured (mean along the diagonals, > 0 drawn too large): 1 / 1.5 / 2 px
// frames -1.85 / -2.37 / -2.89 px without it, -0.10 / -0.09 / -0.73 px with it. (A line of text
// inside the side as well: RectDetector.ThinFramedPosterBottomAboveItsTextLine, on a rendered
// frame.)
TEST(EdgeRefine, ThinFrameSeenOnItsInnerEdgeMovesToItsCentre) {
  RectDetectorOptions off;
  off.band_thin_px = 0.0;
  for (const double w : {1.0, 1.5, 2.0}) {
    const ThinFramedPoster p(w);
    const std::array<int, 4> inner = {-1, -1, -1, -1};
    const EdgeRefinement before = RefineCornersOnEdges(p.smooth, nullptr, p.paper, 2.0, off, inner);
    const EdgeRefinement after =
        RefineCornersOnEdges(p.smooth, nullptr, p.paper, 2.0, RectDetectorOptions(), inner);
    ASSERT_TRUE(before.ok && after.ok) << "frame " << w << " px";
    const double e0 = p.Outward(before.corners_undistorted),
                 e1 = p.Outward(after.corners_undistorted);
    std::printf(
        "frame %.1f px, inner edge: outward %.3f px without the thin-band rule, %.3f with it\n", w,
        e0, e1);
    EXPECT_LT(e0, -w) << "frame " << w << " px";  // on the inner edge, pushed further in
    EXPECT_GT(e1, -0.5 * w - 0.1) << "frame " << w << " px";
    EXPECT_LT(e1, 0.3) << "frame " << w << " px";
  }
}

}  // namespace
}  // namespace fsp::frontend
