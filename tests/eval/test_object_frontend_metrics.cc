// Object and front-end metrics on tiny hand-written files with hand-computed answers.
#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "fsp/common/error.h"
#include "fsp/eval/frontend_metrics.h"
#include "fsp/eval/object_metrics.h"
#include "test_util.h"

namespace fsp::eval {
namespace {

std::string WriteText(const std::filesystem::path& dir, const std::string& name,
                      const std::string& text) {
  const std::string path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

// Ground truth: a door 1 m x 2 m and a window 1 m x 1 m on the wall y = 0, and a poster the map
// lacks.
const char* kObjectsGt = R"({"objects": [
  {"id": 1, "class": "door", "corners_W": [[0,0,0],[1,0,0],[1,0,2],[0,0,2]], "width": 1.0, "height": 2.0},
  {"id": 2, "class": "window", "corners_W": [[2,0,1],[3,0,1],[3,0,2],[2,0,2]], "width": 1.0, "height": 1.0},
  {"id": 3, "class": "poster", "corners_W": [[4,0,1],[5,0,1],[5,0,2],[4,0,2]], "width": 1.0, "height": 1.0}
]})";

// The map in the ground truth's own frame: the door shifted by (0.03, 0.04, 0) (every corner 0.05 m
// off), 1.1 m wide (0.1 off) and 1.9 m high (0.1 off); the window exact but its third corner 0.6 m
// too high and 1.3 m high (0.3 off); and an object (id 7) the ground truth does not have.
struct MapObject {
  int id;
  std::array<Vec3, 4> corners;
  double width, height;
};
std::vector<MapObject> HandMap() {
  const Vec3 d(0.03, 0.04, 0.0);
  return {
      {1, {Vec3(0, 0, 0) + d, Vec3(1, 0, 0) + d, Vec3(1, 0, 2) + d, Vec3(0, 0, 2) + d}, 1.1, 1.9},
      {2, {Vec3(2, 0, 1), Vec3(3, 0, 1), Vec3(3, 0, 2.6), Vec3(2, 0, 2)}, 1.0, 1.3},
      {7, {Vec3(9, 0, 0), Vec3(10, 0, 0), Vec3(10, 0, 1), Vec3(9, 0, 1)}, 1.0, 1.0}};
}

// map.json of HandMap() expressed in another world: c_est = G⁻¹ c = Rᵀ (c − t) / s, sizes / s.
std::string MapJson(const Alignment& G) {
  std::ostringstream os;
  os.precision(17);
  os << "{\"objects\": [";
  bool first = true;
  for (const MapObject& o : HandMap()) {
    os << (first ? "" : ",") << "{\"id\": " << o.id << ", \"class\": \"door\", \"corners_W\": [";
    first = false;
    for (size_t j = 0; j < 4; ++j) {
      const Vec3 c = G.R.transpose() * (o.corners[j] - G.t) / G.scale;
      os << (j ? "," : "") << "[" << c.x() << "," << c.y() << "," << c.z() << "]";
    }
    os << "], \"width\": " << o.width / G.scale << ", \"height\": " << o.height / G.scale
       << ", \"width_sigma\": 0.01, \"observations\": 12}";
  }
  os << "]}";
  return os.str();
}

void ExpectHandComputedObjectErrors(const ObjectMetrics& m) {
  EXPECT_EQ(m.gt, 3u);
  EXPECT_EQ(m.estimated, 3u);
  EXPECT_EQ(m.matched, 2u);
  // Corner errors: 0.05 x 4 (door), 0, 0, 0.6, 0 (window): mean 0.8 / 8 = 0.1, median (0.05 + 0.05)
  // / 2.
  EXPECT_EQ(m.corner_err.count, 8u);
  EXPECT_NEAR(m.corner_err.mean, 0.1, 1e-9);
  EXPECT_NEAR(m.corner_err.median, 0.05, 1e-9);
  // Width errors 0.1 and 0; height errors 0.1 and 0.3.
  EXPECT_NEAR(m.width_err.mean, 0.05, 1e-9);
  EXPECT_NEAR(m.width_err.max, 0.1, 1e-9);
  EXPECT_NEAR(m.height_err.mean, 0.2, 1e-9);
  EXPECT_NEAR(m.height_err.max, 0.3, 1e-9);
  ASSERT_EQ(m.per_object.size(), 2u);
  EXPECT_EQ(m.per_object[0].id, 1);
  EXPECT_NEAR(m.per_object[0].corner_err_mean_m, 0.05, 1e-9);
  for (double e : m.per_object[0].corner_err_m) EXPECT_NEAR(e, 0.05, 1e-9);
  EXPECT_NEAR(m.per_object[1].corner_err_m[0] + m.per_object[1].corner_err_m[1] +
                  m.per_object[1].corner_err_m[3],
              0.0, 1e-9);
  EXPECT_NEAR(m.per_object[1].corner_err_m[2], 0.6, 1e-9);  // the moved corner c3
  EXPECT_NEAR(m.per_object[0].normal_err_deg, 0.0, 1e-6);
  // The window's normal: (c2 − c1) × (c4 − c1) is unchanged by moving c3.
  EXPECT_NEAR(m.per_object[1].normal_err_deg, 0.0, 1e-6);
  // Every map object is called a door: right for the door, wrong for the window.
  EXPECT_EQ(m.classes_right, 1u);
  EXPECT_TRUE(m.per_object[0].class_right);
  EXPECT_FALSE(m.per_object[1].class_right);
  EXPECT_EQ(m.per_object[1].gt_class, "window");
  EXPECT_EQ(m.per_object[1].est_class, "door");
}

TEST(ObjectMetrics, HandComputedErrorsInTheSameFrame) {
  const auto dir = test::ScratchDir();
  const auto gt = ReadObjectsJson(WriteText(dir, "objects_gt.json", kObjectsGt));
  const auto est = ReadObjectsJson(WriteText(dir, "map.json", MapJson(Alignment{})));
  ExpectHandComputedObjectErrors(EvaluateObjects(gt, est, Alignment{}));
}

// Classes are compared as the front end names them: a painting is a poster; a class nobody knows
// counts as unknown.
TEST(ObjectMetrics, ClassesAreComparedAsTheFrontEndNamesThem) {
  const auto dir = test::ScratchDir();
  auto object = [](int id, const std::string& c, double x) {
    std::ostringstream os;
    os << "{\"id\": " << id << ", \"class\": \"" << c << "\", \"corners_W\": [[" << x << ",0,1],["
       << x + 1 << ",0,1],[" << x + 1 << ",0,2],[" << x << ",0,2]], \"width\": 1, \"height\": 1}";
    return os.str();
  };
  const auto gt =
      ReadObjectsJson(WriteText(dir, "gt.json",
                                "{\"objects\": [" + object(1, "painting", 0) + "," +
                                    object(2, "cabinet", 2) + "," + object(3, "shelf", 4) + "]}"));
  const auto est =
      ReadObjectsJson(WriteText(dir, "map.json",
                                "{\"objects\": [" + object(7, "poster", 0) + "," +
                                    object(8, "window", 2) + "," + object(9, "unknown", 4) + "]}"));
  const ObjectMetrics m = EvaluateObjects(gt, est, Alignment{});
  ASSERT_EQ(m.matched, 3u);
  EXPECT_EQ(m.classes_right, 2u);
  EXPECT_TRUE(m.per_object[0].class_right);
  EXPECT_FALSE(m.per_object[1].class_right);
  EXPECT_TRUE(m.per_object[2].class_right);
}

TEST(ObjectMetrics, RigidAlignmentLeavesSizesAloneAndSim3ScalesThem) {
  const auto dir = test::ScratchDir();
  const auto gt = ReadObjectsJson(WriteText(dir, "objects_gt.json", kObjectsGt));
  Alignment G;
  G.R = RotFromRpy(0.2, -0.4, 1.3);
  G.t = Vec3(5.0, -1.0, 0.5);
  // SE3: the map lives in a rotated, shifted world; the same errors come out after alignment.
  ExpectHandComputedObjectErrors(
      EvaluateObjects(gt, ReadObjectsJson(WriteText(dir, "se3.json", MapJson(G))), G));
  // Sim3 with s = 2.5: the map is 2.5 times too small, sizes too; scaled back they agree.
  G.mode = AlignMode::kSim3;
  G.scale = 2.5;
  ExpectHandComputedObjectErrors(
      EvaluateObjects(gt, ReadObjectsJson(WriteText(dir, "sim3.json", MapJson(G))), G));
  // Without the scale the sizes stay 2.5 times too small: the window's width 0.4 m instead of 1 m.
  // (The objects are then metres off too, so only a wide gate pairs them; every map width is 0.4 or
  // 0.44 m against 1 m, so the largest error is 0.6 m however they pair.)
  Alignment no_scale = G;
  no_scale.scale = 1.0;
  ObjectOptions wide;
  wide.match_gate_m = 100.0;
  const auto wrong = EvaluateObjects(gt, ReadObjectsJson(WriteText(dir, "sim3b.json", MapJson(G))),
                                     no_scale, wide);
  EXPECT_NEAR(wrong.width_err.max, 0.6, 1e-9);
}

TEST(ObjectMetrics, MalformedFilesAreClearErrors) {
  const auto dir = test::ScratchDir();
  auto expect_error = [&](const std::string& text, const std::string& fragment) {
    try {
      ReadObjectsJson(WriteText(dir, "bad.json", text));
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    }
  };
  expect_error("{\"objects\": [", "not valid JSON");
  expect_error("[1, 2]", "expected {\"objects\"");
  expect_error(
      R"({"objects": [{"id": 1, "corners_W": [[0,0,0],[1,0,0],[1,0,1]], "width": 1, "height": 1}]})",
      "corners_W");
  expect_error(
      R"({"objects": [{"id": 4, "corners_W": [[0,0,0],[1,0,0],[1,0,1],[0,0,1]], "height": 1}]})",
      "(id 4): missing \"width\"");
  expect_error(
      R"({"objects": [{"id": 1, "corners_W": [[0,0,0],[1,0,0],[1,0,1],[0,0,1]], "width": 1, "height": 1},
                               {"id": 1, "corners_W": [[0,0,0],[1,0,0],[1,0,1],[0,0,1]], "width": 1, "height": 1}]})",
      "id repeated");
}

// Front end. Ground truth (undistorted px; a = object 1, b = object 2 a 10 px square, c = object 3
// partly visible):
//   t=100: a, b, c(not fully visible)   t=200: a + (1, 0), b   t=300: a, b
// Estimate:
//   t=100: id 10 = a + (0.5, 0); id 20 = b with its corners listed from s2 (wrong order); id 99 far
//   away t=200: id 10 = a + (1, 0) + (0, 1) (1.414 px off); b missed t=300: id 11 = a (an id switch
//   for object 1); id 20 = b t=400: id 5 (no ground-truth frame at that time)
const char* kObservationsGt =
    "# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4,fully_visible\n"
    "100,1,100,100,150,100,150,50,100,50,1\n"
    "100,2,300,300,310,300,310,290,300,290,1\n"
    "100,3,600,10,700,10,700,-50,600,-50,0\n"
    "200,1,101,100,151,100,151,50,101,50,1\n"
    "200,2,300,300,310,300,310,290,300,290,1\n"
    "300,1,100,100,150,100,150,50,100,50,1\n"
    "300,2,300,300,310,300,310,290,300,290,1\n";
const char* kObservations =
    "# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4\n"
    "100,10,100.5,100,150.5,100,150.5,50,100.5,50\n"
    "100,20,310,300,310,290,300,290,300,300\n"
    "100,99,500,400,550,400,550,350,500,350\n"
    "200,10,102,101,152,101,152,51,102,51\n"
    "300,11,100,100,150,100,150,50,100,50\n"
    "300,20,300,300,310,300,310,290,300,290\n"
    "400,5,100,100,150,100,150,50,100,50\n";

TEST(FrontendMetrics, HandComputedRecallPrecisionCornersAndIdSwitches) {
  const auto dir = test::ScratchDir();
  const auto gt = ReadCornerRows(WriteText(dir, "observations_gt.csv", kObservationsGt));
  const auto est = ReadCornerRows(WriteText(dir, "observations.csv", kObservations));
  const FrontendMetrics m = EvaluateFrontend(gt, est, FrontendOptions{});
  EXPECT_EQ(m.gt_rows, 7u);
  EXPECT_EQ(m.gt_fully_visible, 6u);
  EXPECT_EQ(m.est_rows, 7u);
  EXPECT_EQ(m.matched, 5u);
  EXPECT_EQ(m.matched_fully_visible, 5u);
  ASSERT_TRUE(m.recall && m.precision);
  EXPECT_DOUBLE_EQ(*m.recall, 5.0 / 6.0);
  EXPECT_DOUBLE_EQ(*m.precision, 5.0 / 7.0);
  // Corner errors: 0.5 x4, 10 x4 (wrong order: each corner sits on its neighbour), sqrt(2) x4, 0
  // x8. Sorted, the 10th and 11th of 20 are both 0.5.
  EXPECT_EQ(m.corner_err_px.count, 20u);
  EXPECT_NEAR(m.corner_err_px.median, 0.5, 1e-12);
  EXPECT_NEAR(m.corner_err_px.mean, (2.0 + 40.0 + 4.0 * std::sqrt(2.0)) / 20.0, 1e-12);
  EXPECT_EQ(m.corner_order_errors, 1u);
  EXPECT_EQ(m.id_switches, 1);
}

// The signed outward error: a 50 px square drawn 1 px too large on every side (each corner
// sqrt(2) px out along its diagonal), then the same square shifted 1 px right (outward +-1/sqrt(2)
// per corner: mean 0), then drawn 1 px too small.
TEST(FrontendMetrics, OutwardErrorIsSignedAlongTheRayFromTheCentre) {
  const auto dir = test::ScratchDir();
  const auto gt =
      ReadCornerRows(WriteText(dir, "observations_gt.csv",
                               "# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4,fully_visible\n"
                               "100,1,100,150,150,150,150,100,100,100,1\n"
                               "200,1,100,150,150,150,150,100,100,100,1\n"
                               "300,1,100,150,150,150,150,100,100,100,1\n"));
  const auto larger = ReadCornerRows(WriteText(dir, "larger.csv",
                                               "# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4\n"
                                               "100,7,99,151,151,151,151,99,99,99\n"));
  const FrontendMetrics l = EvaluateFrontend(gt, larger, FrontendOptions{});
  EXPECT_EQ(l.corner_outward_px.count, 4u);
  EXPECT_NEAR(l.corner_outward_px.median, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(l.corner_err_px.median, std::sqrt(2.0), 1e-12);
  const auto moved = ReadCornerRows(WriteText(dir, "moved.csv",
                                              "# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4\n"
                                              "200,7,101,150,151,150,151,100,101,100\n"
                                              "300,7,101,149,149,149,149,101,101,101\n"));
  const FrontendMetrics m = EvaluateFrontend(gt, moved, FrontendOptions{});
  EXPECT_EQ(m.corner_outward_px.count, 8u);
  // Shifted: -0.707, +0.707, +0.707, -0.707; smaller: -1.414 x4.
  EXPECT_NEAR(m.corner_outward_px.mean, -4.0 * std::sqrt(2.0) / 8.0, 1e-12);
  EXPECT_NEAR(m.corner_outward_px.min, -std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(m.corner_outward_px.max, std::sqrt(0.5), 1e-12);
}

TEST(FrontendMetrics, GateAndEmptyEstimate) {
  const auto dir = test::ScratchDir();
  const auto gt = ReadCornerRows(WriteText(dir, "observations_gt.csv", kObservationsGt));
  const auto est = ReadCornerRows(WriteText(dir, "observations.csv", kObservations));
  // A 1 px gate keeps the 0.5 px and exact matches and drops the 1.414 px one; the wrongly ordered
  // detection still matches (its best cyclic shift is exact).
  FrontendOptions tight;
  tight.match_gate_px = 1.0;
  const FrontendMetrics m = EvaluateFrontend(gt, est, tight);
  EXPECT_EQ(m.matched, 4u);
  EXPECT_DOUBLE_EQ(*m.recall, 4.0 / 6.0);
  const FrontendMetrics none = EvaluateFrontend(gt, {}, FrontendOptions{});
  EXPECT_EQ(none.matched, 0u);
  EXPECT_DOUBLE_EQ(*none.recall, 0.0);
  EXPECT_FALSE(none.precision.has_value());
  EXPECT_EQ(none.corner_err_px.count, 0u);
}

}  // namespace
}  // namespace fsp::eval
