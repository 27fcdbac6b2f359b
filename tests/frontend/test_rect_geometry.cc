// Zhang-He rectangle test and s1..s4 ordering.
#include <gtest/gtest.h>

#include "fsp/frontend/rect_geometry.h"
#include "synthetic.h"

namespace fsp::frontend {
namespace {

TEST(ZhangHe, TrueRectangleUnderPerspectiveIsPerpendicularWithRightAspect) {
  const double f = 500, cx = 319.5, cy = 239.5;
  Mat3 K;
  K << f, 0, cx, 0, f, cy, 0, 0, 1;
  const Corners c = test::ProjectRect(1.2, 0.8, Vec3(0.3, -0.2, 3.0), 0.6, -0.4, 0.2, f, cx, cy);
  const RectangleTest t = ZhangHeTest(c, K);
  ASSERT_TRUE(t.valid);
  EXPECT_LT(t.abs_cos, 1e-9);
  EXPECT_NEAR(t.aspect_12_14, 1.2 / 0.8, 1e-9);
}

TEST(ZhangHe, ParallelogramFailsTheTest) {
  Mat3 K = DefaultK(640, 480, 60.0);
  // A sheared quad seen fronto-parallel: 3-D angle = image angle (~63 deg).
  const Corners c = {Vec2(200, 300), Vec2(400, 300), Vec2(450, 200), Vec2(250, 200)};
  const RectangleTest t = ZhangHeTest(c, K);
  ASSERT_TRUE(t.valid);
  EXPECT_GT(t.abs_cos, 0.4);
}

TEST(CanonicalOrder, ImagePositionWithoutGravity) {
  // Any start, either orientation -> bottom-left, bottom-right, top-right, top-left (y down).
  const Corners expected = {Vec2(100, 300), Vec2(300, 310), Vec2(290, 100), Vec2(110, 90)};
  for (int shift = 0; shift < 4; ++shift)
    for (bool reverse : {false, true}) {
      Corners in;
      for (int i = 0; i < 4; ++i) in[i] = expected[(i + shift) % 4];
      if (reverse) std::swap(in[1], in[3]);
      const Corners out = CanonicalOrder(in);
      for (int i = 0; i < 4; ++i)
        EXPECT_LT((out[i] - expected[i]).norm(), 1e-12) << shift << reverse << i;
    }
  EXPECT_LT(SignedArea(expected), 0.0);  // s1..s4 is counter-clockwise on screen
}

TEST(CanonicalOrder, GravityDecidesForARolledCamera) {
  // Camera rolled by 90 deg: gravity points along image +x. The object's bottom is then on the
  // right.
  const Mat3 K = DefaultK(640, 480, 60.0);
  const Vec3 g_C(9.81, 0.0, 0.0);
  const Corners in = {Vec2(200, 100), Vec2(400, 100), Vec2(400, 300), Vec2(200, 300)};
  const Corners out = CanonicalOrder(in, &K, &g_C);
  // "down" = +x: s1 (bottom-left) is the right-bottom... the height edges s4->s1, s3->s2 point
  // along +x.
  EXPECT_GT((out[0] - out[3]).x(), 100.0);
  EXPECT_GT((out[1] - out[2]).x(), 100.0);
  EXPECT_LT(SignedArea(out), 0.0);
  // Without gravity the image rule gives a different start.
  const Corners plain = CanonicalOrder(in);
  EXPECT_GT((plain[0] - plain[3]).y(), 100.0);
}

TEST(GravityImageDirection, UndefinedAlongTheViewingRay) {
  const Mat3 K = DefaultK(640, 480, 60.0);
  EXPECT_FALSE(GravityImageDirection(Vec2(319.5, 239.5), K, Vec3(0, 0, 1)).has_value());
  const auto d = GravityImageDirection(Vec2(319.5, 239.5), K, Vec3(0, 1, 0));
  ASSERT_TRUE(d.has_value());
  EXPECT_NEAR(d->y(), 1.0, 1e-12);
}

}  // namespace
}  // namespace fsp::frontend

namespace fsp::frontend {
namespace {

// A quad sharing a side with the outer one is inside; one reaching 3 px past the outer side is
// inside with a 5 px margin, not with 2 px; the outer is not inside the smaller one.
TEST(RectGeometry, ContainsWithMarginToleratesSharedSides) {
  const Corners outer = {Vec2(0, 100), Vec2(100, 100), Vec2(100, 0), Vec2(0, 0)};
  const Corners shared = {Vec2(0, 100), Vec2(50, 100), Vec2(50, 50), Vec2(0, 50)};
  const Corners past = {Vec2(10, 103), Vec2(50, 103), Vec2(50, 50), Vec2(10, 50)};
  EXPECT_TRUE(ContainsWithMargin(outer, shared, 2.0));
  EXPECT_TRUE(ContainsWithMargin(outer, past, 5.0));
  EXPECT_FALSE(ContainsWithMargin(outer, past, 2.0));
  EXPECT_FALSE(ContainsWithMargin(shared, outer, 2.0));
}

// ShapeDifference: a translated copy (a drifting map's prediction) has the same shape whatever its
// corner order; a quad with one side moved by 12 px (an outline closed by an inner edge) differs by
// 6 px, half the move, at each corner.
TEST(RectGeometry, ShapeDifferenceIgnoresTranslationNotAMovedSide) {
  const Corners q = {Vec2(10, 110), Vec2(90, 108), Vec2(92, 10), Vec2(8, 12)};
  Corners moved = q, rotated;
  for (Vec2& c : moved) c += Vec2(7.0, -3.0);
  for (int i = 0; i < 4; ++i) rotated[i] = moved[(i + 1) % 4];
  EXPECT_NEAR(ShapeDifference(q, moved), 0.0, 1e-12);
  EXPECT_NEAR(ShapeDifference(q, rotated), 0.0, 1e-12);
  Corners side = q;
  side[0].x() += 12.0;
  side[3].x() += 12.0;
  EXPECT_NEAR(ShapeDifference(q, side), 6.0, 1e-12);
  EXPECT_NEAR(ShapeDifference(side, q), 6.0, 1e-12);
}

}  // namespace
}  // namespace fsp::frontend
