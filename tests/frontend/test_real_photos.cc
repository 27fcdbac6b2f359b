// Rectangle detector on real photos of the shared test data: pins what it finds, and checks corners
// against corners measured by hand.
//
// How the corners were measured by hand (distorted pixels of the image file, OpenCV convention):
// each corner was located on 8x-16x zoomed crops; then, for each of the two sides meeting there,
// two intensity profiles were taken across the side (a row across a near-vertical side, a column
// across a near-horizontal one) 10-30 px away from the corner, each placed by eye to cross only
// that edge (not the tag squares or print next to it). The edge position on a profile is where the
// raw grey value crosses the midpoint between the two plateaus (linear interpolation between
// pixels; no smoothing, no line fitting of our own). The two points per side give a line; the
// corner is the intersection of the two lines. Independent of the detector except for knowing
// roughly where the corners are.
#include <gtest/gtest.h>

#include "fsp/common/calibration.h"
#include "fsp/frontend/image_io.h"
#include "fsp/frontend/rect_detector.h"
#include "fsp/frontend/rect_geometry.h"
#include "test_util.h"

namespace fsp::frontend {
namespace {

void ExpectCornersNear(const Corners& got, const Corners& hand, double tol_px) {
  for (int i = 0; i < 4; ++i)
    EXPECT_LT((got[i] - hand[i]).norm(), tol_px)
        << "s" << i + 1 << ": got " << got[i].transpose() << ", measured " << hand[i].transpose();
}

// EuRoC V1_01 in-flight frame left_img_2 with its calibration: the Kalibr AprilGrid board leaning
// on the mattress box. (The step ladder behind it, two rails and the lowest rung closed by the
// image's top, was found as a second rectangle before the T-junction test: its rails run on past
// the rung, so the rung's ends are not corners, and it is no longer reported.)
TEST(RealPhotos, EurocCalibrationBoard) {
  FSP_REQUIRE_TEST_DATA(dir, "euroc_v101_micro/inflight_frames_kimera_lcd");
  const Calibration calib = ReadCalibration(dir + "/sensorLeft.yaml");
  const auto res = RectDetector().Detect(ReadGray8(dir + "/left_img_2.png"), &calib.camera);
  ASSERT_EQ(res.detections.size(), 1u);
  // Hand-measured board corners s1..s4 (bottom-left, bottom-right, top-right, top-left).
  const Corners board = {Vec2(349.75, 436.39), Vec2(485.66, 365.67), Vec2(491.51, 209.63),
                         Vec2(334.16, 243.48)};
  const Detection& best = res.detections[0];  // best score first
  ExpectCornersNear(best.corners_px, board, 1.0);
  // (Its class guess is "window": white and much brighter than the mattress; see the README.)
  // The undistorted corners are the same points through the lens model.
  for (int i = 0; i < 4; ++i)
    EXPECT_LT(
        (calib.camera.UndistortPixel(best.corners_px[i]) - best.corners_undistorted[i]).norm(),
        1e-6);
}

// The same board from the paired view left_img_3 (no hand measurement; pins the count and
// position).
TEST(RealPhotos, EurocCalibrationBoardSecondView) {
  FSP_REQUIRE_TEST_DATA(dir, "euroc_v101_micro/inflight_frames_kimera_lcd");
  const Calibration calib = ReadCalibration(dir + "/sensorLeft.yaml");
  const auto res = RectDetector().Detect(ReadGray8(dir + "/left_img_3.png"), &calib.camera);
  ASSERT_EQ(res.detections.size(), 1u);
  const Corners pinned = {Vec2(346.16, 435.63), Vec2(512.85, 393.76), Vec2(534.53, 227.84),
                          Vec2(346.48, 238.26)};
  ExpectCornersNear(res.detections[0].corners_px, pinned, 1.0);
}

// sudoku.png: the printed grid on curled paper. The outer square is NOT found yet: its top side
// bends by ~8 deg towards the top-right corner (three straight pieces at 0, -3.4 and -7.6 deg), so
// no single straight side closes the quad. (A quad closed by a line of the strip below the grid
// was found before the corner reach test; its corners are not where its sides' edges end.)
TEST(RealPhotos, SudokuOuterSquareNotFoundYet) {
  FSP_REQUIRE_TEST_DATA(path, "opencv_samples/sudoku.png");
  const auto res = RectDetector().Detect(ReadGray8(path));
  EXPECT_EQ(res.detections.size(), 0u);
}

// building.jpg: a facade whose windows and panels line up in rows and columns. Their sides are
// collinear across floors and bays, so the edge pieces merge into long lines that cross each other
// instead of ending at corners, and the grouping (which takes L-junctions, not crossings, on
// purpose: otherwise every cell combination of a grid is a rectangle) finds no quadrilateral.
// Pinned at zero so a change in this behaviour is noticed; see the front end's notes.
TEST(RealPhotos, BuildingFacadeGridFindsNothing) {
  FSP_REQUIRE_TEST_DATA(path, "opencv_samples/building.jpg");
  const auto res = RectDetector().Detect(ReadGray8(path));
  EXPECT_EQ(res.detections.size(), 0u);
  EXPECT_GT(res.segments, 200);  // the edges are there: it is the grouping that refuses grids
}

}  // namespace
}  // namespace fsp::frontend
