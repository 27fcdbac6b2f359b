// Scene files: both object forms, defaults, room quads, and a clear error for each kind of bad
// input.
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "fsp/common/error.h"
#include "fsp/sim/renderer.h"
#include "fsp/sim/scene.h"
#include "test_util.h"

namespace fsp::sim {
namespace {

const char* kScene =
    R"(camera: {width: 160, height: 120, fx: 115.0, fy: 115.0, cx: 80.0, cy: 60.0, rate_hz: 20}
imu: {rate_hz: 200, gyroscope_noise_density: 1.7e-4, accelerometer_noise_density: 2.0e-3,
      gyroscope_random_walk: 1.9e-5, accelerometer_random_walk: 3.0e-3}
room: {min: [0, 0, 0], max: [4, 3, 2.5]}
objects:
  - {id: 1, class: door, corners: [[1, 0, 0], [1.9, 0, 0], [1.9, 0, 2], [1, 0, 2]]}
  - {id: 2, class: window, position: [1, 0, 0], rpy_deg: [90, 0, 0], width: 0.9, height: 2}
  - {id: 3, class: tag, tag_id: 5, position: [3, 0, 1], rpy_deg: [90, 0, 0], width: 0.3, height: 0.3}
trajectory:
  waypoints: [[0, 2, 1.5, 1.2, -90], [1, 2, 1.5, 1.2, -90], [2.5, 2.3, 1.2, 1.2, -80]]
noise: {pixel_sigma: 1.0, seed: 3}
duration_s: 2
)";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  return pos == std::string::npos ? text : text.replace(pos, from.size(), to);
}

// The InputError message of parsing TEXT ("" when it parses).
std::string ErrorOf(const std::string& text) {
  try {
    ParseScene(text, "scene.yaml", ".");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Scene, ParsesBothObjectFormsAlike) {
  const Scene scene = ParseScene(kScene, "scene.yaml", ".");
  ASSERT_EQ(scene.objects.size(), 3u);
  EXPECT_EQ(scene.camera.width, 160);
  EXPECT_DOUBLE_EQ(scene.camera_rate_hz, 20.0);
  EXPECT_EQ(scene.seed, 3u);
  EXPECT_DOUBLE_EQ(scene.pixel_sigma, 1.0);
  // A door on the y = 0 wall facing -y is rpy [90, 0, 0]: the same corners as written out.
  for (int j = 0; j < 4; ++j) {
    EXPECT_LT((scene.objects[0].corners_W[j] - scene.objects[1].corners_W[j]).norm(), 1e-12) << j;
  }
  const Rigid3 T_W_O = scene.objects[1].T_W_O();
  EXPECT_LT((T_W_O.R().col(2) - Vec3(0, -1, 0)).norm(), 1e-12);  // visible face normal
  EXPECT_NEAR(scene.objects[1].width(), 0.9, 1e-12);
  EXPECT_NEAR(scene.objects[1].height(), 2.0, 1e-12);
  EXPECT_EQ(scene.objects[0].texture, TextureKind::kWood);
  EXPECT_EQ(scene.objects[1].texture, TextureKind::kGlass);
  EXPECT_EQ(scene.objects[2].texture, TextureKind::kTag);
  EXPECT_EQ(scene.objects[2].tag_id, 5);
  EXPECT_EQ(scene.objects[2].object_class, ObjectClass::kTag);
  EXPECT_DOUBLE_EQ(scene.trajectory.t_end(), 2.5);
  // Default mount: the camera looks along body x, image x along -body y.
  EXPECT_LT((scene.T_B_C.R() * Vec3::UnitZ() - Vec3::UnitX()).norm(), 1e-12);
  EXPECT_LT((scene.T_B_C.R() * Vec3::UnitX() + Vec3::UnitY()).norm(), 1e-12);
}

TEST(Scene, RoomQuadsFaceInwardAndObjectsKeepTheirCorners) {
  const Scene scene = ParseScene(kScene, "scene.yaml", ".");
  const std::vector<TexturedQuad> quads = SceneQuads(scene);
  ASSERT_EQ(quads.size(), 6u + 3u);
  const Vec3 centre(2, 1.5, 1.25);
  for (int i = 0; i < 6; ++i) {
    const TexturedQuad& q = quads[i];
    EXPECT_EQ(q.id, -1);
    const Vec3 n = q.axis_u_W.cross(q.axis_v_W);
    EXPECT_GT(n.dot(centre - q.origin_W), 0.0) << "room quad " << i << " faces outward";
    if (q.texture == TextureKind::kWall) {
      EXPECT_GT(q.axis_v_W.z(), 0.0);  // upright wall texture
    }
  }
  const TexturedQuad& door = quads[6];
  EXPECT_EQ(door.id, 1);
  EXPECT_EQ(door.origin_W, scene.objects[0].corners_W[0]);
  EXPECT_LT((door.origin_W + door.axis_u_W + door.axis_v_W - scene.objects[0].corners_W[2]).norm(),
            1e-12);
  EXPECT_EQ(door.offset_m, 0.0);
  EXPECT_EQ(quads[8].tag_id, 5);
}

// Painted walls (room.wall_texture: paint): the four walls take it, floor and ceiling keep theirs;
// the paint is the plaster at a fifth of its contrast. A texture that does not exist is an error.
TEST(Scene, PaintedWalls) {
  const Scene scene =
      ParseScene(Replace(kScene, "max: [4, 3, 2.5]}", "max: [4, 3, 2.5], wall_texture: paint}"),
                 "scene.yaml", ".");
  const std::vector<TexturedQuad> quads = SceneQuads(scene);
  EXPECT_EQ(quads[0].texture, TextureKind::kFloor);
  EXPECT_EQ(quads[1].texture, TextureKind::kCeiling);
  for (int i = 2; i < 6; ++i) EXPECT_EQ(quads[i].texture, TextureKind::kPaint) << i;
  TexturedQuad wall = quads[2];
  const auto spread = [](const cv::Mat& tex) {
    cv::Scalar mean, sd;
    cv::meanStdDev(tex, mean, sd);
    return sd[0];
  };
  const double paint = spread(MakeTexture(wall, 400, 250));
  wall.texture = TextureKind::kWall;
  const double plaster = spread(MakeTexture(wall, 400, 250));
  EXPECT_GT(paint, 0.0);
  EXPECT_LT(paint, 0.3 * plaster) << paint << " " << plaster;
  const std::string err =
      ErrorOf(Replace(kScene, "max: [4, 3, 2.5]}", "max: [4, 3, 2.5], wall_texture: chalk}"));
  EXPECT_NE(err.find("scene.yaml:4: room.wall_texture: 'chalk' is not a texture"),
            std::string::npos)
      << err;
}

TEST(Scene, UnknownKeySaysWhichAndWhere) {
  const std::string err = ErrorOf(Replace(kScene, "rate_hz: 20}", "rate_hz: 20, fps: 3}"));
  EXPECT_NE(err.find("scene.yaml:1:"), std::string::npos) << err;
  EXPECT_NE(err.find("unknown key 'fps' in camera"), std::string::npos) << err;
  const std::string top = ErrorOf(std::string(kScene) + "lights: 3\n");
  EXPECT_NE(top.find("scene.yaml:13: unknown key 'lights' in the scene"), std::string::npos) << top;
  const std::string obj = ErrorOf(Replace(kScene, "class: door,", "class: door, colour: red,"));
  EXPECT_NE(obj.find("scene.yaml:6: unknown key 'colour' in objects[0]"), std::string::npos) << obj;
}

TEST(Scene, MissingFieldIsNamed) {
  EXPECT_NE(ErrorOf(Replace(kScene, "fx: 115.0, ", ""))
                .find("scene.yaml:1: missing field 'fx' in camera"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kScene, "duration_s: 2\n", ""))
                .find("scene.yaml: missing field 'duration_s'"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kScene, "width: 0.9, ", ""))
                .find("missing field 'width' in objects[1] (id 2)"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kScene, "tag_id: 5, ", ""))
                .find("missing field 'tag_id' in objects[2] (id 3)"),
            std::string::npos);
}

TEST(Scene, BadRectanglesAreRejected) {
  const std::string zero =
      ErrorOf(Replace(kScene, "[1.9, 0, 0], [1.9, 0, 2]", "[1, 0, 0], [1, 0, 2]"));
  EXPECT_NE(zero.find("scene.yaml:6: objects[0] (id 1): zero-area rectangle"), std::string::npos)
      << zero;
  const std::string zero_rpy = ErrorOf(Replace(kScene, "width: 0.9", "width: 0"));
  EXPECT_NE(zero_rpy.find("objects[1] (id 2): zero-area rectangle"), std::string::npos) << zero_rpy;
  const std::string skew =
      ErrorOf(Replace(kScene, "[1.9, 0, 2], [1, 0, 2]", "[2.2, 0, 2], [1.3, 0, 2]"));
  EXPECT_NE(skew.find("not a rectangle: the angle at s1"), std::string::npos) << skew;
  const std::string bent =
      ErrorOf(Replace(kScene, "[1.9, 0, 2], [1, 0, 2]", "[1.9, 0.2, 2], [1, 0, 2]"));
  EXPECT_NE(bent.find("corners are not planar"), std::string::npos) << bent;
  const std::string order = ErrorOf(Replace(kScene, "[1.9, 0, 0], [1.9, 0, 2], [1, 0, 2]",
                                            "[1.9, 0, 0], [1, 0, 2], [1.9, 0, 2]"));
  EXPECT_NE(order.find("not a rectangle"), std::string::npos) << order;  // s3 and s4 swapped
}

TEST(Scene, TrajectoryShorterThanDurationIsRejected) {
  const std::string err = ErrorOf(Replace(kScene, "duration_s: 2", "duration_s: 3"));
  EXPECT_NE(err.find("scene.yaml:10: trajectory ends at t = 2.5 s, before duration_s = 3 s"),
            std::string::npos)
      << err;
  const std::string late = ErrorOf(Replace(kScene, "[[0, 2, 1.5", "[[0.5, 2, 1.5"));
  EXPECT_NE(late.find("must start at t = 0"), std::string::npos) << late;
}

TEST(Scene, OtherBadValues) {
  EXPECT_NE(ErrorOf(Replace(kScene, "class: door", "class: sofa")).find("unknown class 'sofa'"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kScene, "tag_id: 5", "tag_id: 600")).find("tag_id must be in 0..586"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kScene, "{id: 2,", "{id: 1,")).find("duplicate object id 1"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kScene, "fx: 115.0", "fx: abc"))
                .find("camera.fx must be a number, not 'abc'"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kScene, "max: [4, 3, 2.5]", "max: [4, 3, 0]"))
                .find("room: max must exceed min"),
            std::string::npos);
  EXPECT_NE(ErrorOf("camera: [1, 2\n").find("scene.yaml:"), std::string::npos);
  try {
    LoadScene("/nonexistent/scene.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/scene.yaml: cannot open"),
              std::string::npos);
  }
}

TEST(Scene, PoseFileRelativeToTheScene) {
  const auto dir = test::ScratchDir();
  {
    std::ofstream tum(dir / "flight.tum");
    tum << "# t x y z qx qy qz qw\n";
    for (int i = 0; i <= 300; ++i) {
      const double t = 100.0 + i * 0.01;
      tum << t << " " << 1.0 + 0.1 * i * 0.01 << " 1 1.2 0 0 0 1\n";
    }
  }
  const std::string text = Replace(
      kScene,
      "waypoints: [[0, 2, 1.5, 1.2, -90], [1, 2, 1.5, 1.2, -90], [2.5, 2.3, 1.2, 1.2, -80]]",
      "file: flight.tum");
  {
    std::ofstream out(dir / "scene.yaml");
    out << text;
  }
  const Scene scene = LoadScene((dir / "scene.yaml").string());
  EXPECT_EQ(scene.trajectory_file, (dir / "flight.tum").string());
  EXPECT_DOUBLE_EQ(scene.trajectory.t_begin(), 0.0);
  // The B-spline of a pose file hovers 3 knots (0.3 s) at each end: file time t is t + 0.3 s.
  EXPECT_NEAR(scene.trajectory.t_end(), 3.6, 1e-9);
  EXPECT_NEAR(scene.trajectory.Pose(1.8).translation().x(), 1.15, 0.01);
  std::filesystem::remove(dir / "flight.tum");
  try {
    LoadScene((dir / "scene.yaml").string());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("flight.tum"), std::string::npos) << e.what();
  }
}

// Findings of fuzz_scene (fuzz/README.md), each with its minimal input.

// A small object far from the origin: its corners rounded to one point (width 0) and the scene
// loaded; corners beyond the range of doubles passed the rectangle checks (NaN comparisons).
TEST(SceneFuzzFindings, ObjectsBeyondDoublePrecision) {
  EXPECT_NE(ErrorOf(Replace(kScene, "position: [1, 0, 0], rpy_deg: [90, 0, 0], width: 0.9",
                            "position: [1e300, 0, 0], rpy_deg: [90, 0, 0], width: 0.9"))
                .find("scene.yaml:7: objects[1] (id 2): position 1e+300 m from the origin is too "
                      "far for a 0.9 x 2 m rectangle"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kScene, "position: [1, 0, 0], rpy_deg: [90, 0, 0], width: 0.9",
                            "position: [1.7e308, 0, 0], rpy_deg: [0, 0, 0], width: 1e308"))
                .find("objects[1] (id 2): a corner is not finite"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kScene, "[[1, 0, 0], [1.9, 0, 0], [1.9, 0, 2], [1, 0, 2]]",
                            "[[-1e308, 0, 0], [1e308, 0, 0], [1e308, 0, 2], [-1e308, 0, 2]]"))
                .find("objects[0] (id 1): corners too far apart"),
            std::string::npos);
}

// A pose file resampled at knot_s 1e-300 converted 3e300 knots to int (undefined behaviour), and
// pose times 292 years apart overflowed their int64 difference.
TEST(SceneFuzzFindings, PoseFileKnotsAndSpan) {
  const auto dir = test::ScratchDir();
  auto load = [&](const std::string& knot_s, const std::string& tum) {
    std::ofstream(dir / "poses.tum") << tum;
    std::ofstream(dir / "scene.yaml") << Replace(
        kScene,
        "waypoints: [[0, 2, 1.5, 1.2, -90], [1, 2, 1.5, 1.2, -90], [2.5, 2.3, 1.2, 1.2, -80]]",
        "{file: poses.tum, knot_s: " + knot_s + "}");
    try {
      LoadScene((dir / "scene.yaml").string());
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string poses = "0 1 1 1 0 0 0 1\n3 2 1 1 0 0 0 1\n";
  EXPECT_NE(load("1e-300", poses).find("the poses span 3 s: more than 100000 knots"),
            std::string::npos);
  EXPECT_NE(load("0.1", "-9000000000 1 1 1 0 0 0 1\n9000000000 1 1 1 0 0 0 1\n")
                .find("pose 1 is more than 292 years after the first"),
            std::string::npos);
  EXPECT_EQ(load("0.1", poses), "");
}

}  // namespace
}  // namespace fsp::sim
