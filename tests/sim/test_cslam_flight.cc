// The seed paper's experiment: the C-SLAM authors' logs as a scene (fsp convert-cslam).
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "../test_util.h"
#include "fsp/common/error.h"
#include "fsp/sim/cslam_flight.h"
#include "fsp/sim/scene.h"

namespace fsp::sim {
namespace {

TEST(CslamFlight, AuthorsLogsBecomeARenderableScene) {
  FSP_REQUIRE_TEST_DATA(logs, "cslam_paper_flight");
  const CslamFlight flight = ReadCslamFlight(logs);
  ASSERT_EQ(flight.objects.size(), 22u);
  EXPECT_EQ(flight.poses.size(), 13536u);
  Vec3 mean = Vec3::Zero();
  for (const StampedPose& p : flight.poses) mean += p.T_W_B.translation();
  mean /= static_cast<double>(flight.poses.size());
  int doors = 0, windows = 0, cabinets = 0;
  for (const SceneObject& o : flight.objects) {
    const auto& s = o.corners_W;
    // s1..s4: bottom-left, bottom-right, top-right, top-left, the face towards the flight.
    EXPECT_LE(s[0].z(), s[3].z() - 0.2) << "object " << o.id;
    EXPECT_NEAR(s[0].z(), s[1].z(), 1e-9) << "object " << o.id;
    const Vec3 n = (s[1] - s[0]).cross(s[3] - s[0]);
    EXPECT_GT(n.dot(mean - s[0]), 0.0) << "object " << o.id;
    doors += o.object_class == ObjectClass::kDoor;
    windows += o.object_class == ObjectClass::kWindow;
    cabinets += o.object_class == ObjectClass::kCabinet;
  }
  EXPECT_EQ(doors, 9);
  EXPECT_EQ(windows, 9);
  EXPECT_EQ(cabinets, 4);
  // The first object: a 0.8 x 2.2 m door on the wall x = 8.6, seen from -x.
  EXPECT_NEAR(flight.objects[0].width(), 0.8, 1e-9);
  EXPECT_NEAR(flight.objects[0].height(), 2.2, 1e-9);
  EXPECT_NEAR(flight.objects[0].corners_W[0].y(), 0.4, 1e-9);

  const auto dir = test::ScratchDir();
  const Scene scene = LoadScene(WriteCslamScene(flight, dir.string()));
  EXPECT_EQ(scene.objects.size(), 22u);
  EXPECT_NEAR(scene.camera.fy, 529.505432128906, 1e-6);
  EXPECT_NEAR(scene.duration_s, 135.35, 1e-9);
  EXPECT_NEAR(scene.trajectory.Pose(60.0).translation().z(), 1.0, 0.5);  // flying
}

TEST(CslamFlight, BadLogsAreRefusedWithTheirLine) {
  const auto dir = test::ScratchDir();
  {
    std::ofstream poses(dir / "PoseSE3(W)_GT.log");
    poses << "%time,seq,stamp,x,y,z,qx,qy,qz,qw\n"
             "0,1,1000,0,0,0.08,0,0,0,1\n0,2,2000,0,0,0.08,0,0,0,1\n";
    std::ofstream rects(dir / "LandmarksGT.log");
    rects << "8.6,0.4,2.2,,8.6,-0.4,2.2,8.6,-0.4,0,8.6,0.4,0\n"
             "8.6,0.4,2.2,,8.6,-0.4,2.2,8.6,-0.4,0,8.6,0.9,0\n";  // a trapezoid
  }
  try {
    ReadCslamFlight(dir.string());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("LandmarksGT.log:2: "), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadCslamFlight((dir / "missing").string()), InputError);
}

}  // namespace
}  // namespace fsp::sim
