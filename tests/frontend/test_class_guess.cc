// The rectangle detector's class guess (rect_verify.cc, GuessClass) on synthetic framed panels and
// doors with exactly known corners (synthetic.h).
#include <gtest/gtest.h>

#include <vector>

#include "fsp/frontend/rect_detector.h"
#include "fsp/frontend/rect_geometry.h"
#include "synthetic.h"

namespace fsp::frontend {
namespace {

// A w x h m rectangle centred at `centre` (camera frame), turned 0.3 rad about the vertical and 0.1
// about the horizontal, seen by a 640 x 480 camera of focal length 500 px.
test::SyntheticRect Panel(double w, double h, const Vec3& centre, int grey) {
  return {test::ProjectRect(w, h, centre, 0.3, 0.1, 0.0, 500.0, 319.5, 239.5), grey};
}

// The class of the detection at outline C (within 0.5 px, any corner order).
ObjectClass ClassAt(const std::vector<Detection>& dets, const Corners& c) {
  for (const Detection& d : dets)
    if (CornerDistanceBestShift(c, d.corners_px) < 0.5) return d.object_class;
  ADD_FAILURE() << "no detection at the outline";
  return ObjectClass::kUnknown;
}

// Windows and cabinet fronts are both a dark frame round a plain panel: a window's pane (daylight)
// is more than twice as bright as its frame on every side, a cabinet's body is not, even when it is
// brighter than the wall.
TEST(RectDetector, ClassGuessTellsAWindowFromACabinetFront) {
  const Vec3 win_c(-0.75, -0.2, 2.0), dark_c(0.0, 0.1, 2.0), light_c(0.7, 0.1, 2.0);
  // 4 cm frames; the window 0.5 x 0.4 m, the cabinets 0.5 x 0.6 m (not door-shaped).
  const std::vector<test::SyntheticRect> quads = {
      Panel(0.50, 0.40, win_c, 40),
      Panel(0.42, 0.32, win_c, 225),  // window: pane 5.6x its frame
      Panel(0.50, 0.60, dark_c, 60),
      Panel(0.42, 0.52, dark_c, 135),  // cabinet as bright as the wall
      Panel(0.50, 0.60, light_c, 110),
      Panel(0.42, 0.52, light_c, 190)};  // brighter than the wall
  const cv::Mat img = test::RenderQuads(640, 480, quads, 0.8, 2.0, 11, 120);
  const auto dets = RectDetector().Detect(img).detections;
  EXPECT_EQ(ClassAt(dets, quads[0].corners), ObjectClass::kWindow);
  EXPECT_EQ(ClassAt(dets, quads[2].corners), ObjectClass::kCabinet);
  EXPECT_EQ(ClassAt(dets, quads[4].corners), ObjectClass::kCabinet);
}

// A door is taller than 1.8 times its width (a standard door, 2.0-2.1 m high and at most 1.1 m
// wide, is 1.9-3.4); a tall cabinet front of 1.75 (the hall flight's cabinet 20 is 1.0 x 1.7 m)
// is a frame round a plain panel, not a door. With a bound of 1.7 its detections voted door and
// cabinet about evenly (11 / 12 on the hall flight), and the map called it a door.
TEST(RectDetector, ClassGuessTellsATallCabinetFromADoor) {
  const Vec3 door_c(-0.75, 0.0, 3.2), cabinet_c(0.75, 0.1, 3.2);
  const std::vector<test::SyntheticRect> quads = {
      Panel(0.90, 2.10, door_c, 70),       // a plain door leaf
      Panel(1.00, 1.75, cabinet_c, 60),    // the cabinet's frame...
      Panel(0.84, 1.59, cabinet_c, 135)};  // ...round its plain body (8 cm frame)
  const cv::Mat img = test::RenderQuads(640, 480, quads, 0.8, 2.0, 12, 120);
  const PinholeRadtan cam = test::PinholeCamera(640, 480, 500.0, 319.5, 239.5);
  const auto dets = RectDetector().Detect(img, &cam).detections;
  EXPECT_EQ(ClassAt(dets, quads[0].corners), ObjectClass::kDoor);
  EXPECT_EQ(ClassAt(dets, quads[1].corners), ObjectClass::kCabinet);
}

}  // namespace
}  // namespace fsp::frontend
