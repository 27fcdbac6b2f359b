// The scene file of `fsp render` (sim/include/fsp/sim/scene.h): LoadScene. One input holds the
// scene and, after a line "--- poses.tum ---", a TUM pose file written beside it as poses.tum (a
// scene's `trajectory: {file: poses.tum}` reads it). A scene that loads must keep scene.h's
// promises: a camera and IMU that pass their Checks, rectangles with unique ids, a trajectory that
// covers duration_s.
#include <set>

#include "fsp/sim/scene.h"
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace fsp;
  const auto& dir = fuzz::Scratch().Fresh();
  const std::vector<std::string> parts =
      fuzz::SplitParts(fuzz::AsText(data, size), "--- poses.tum ---", 2);
  const std::string path = (dir / "scene.yaml").string();
  fuzz::WriteFile(path, parts[0]);
  fuzz::WriteFile(dir / "poses.tum", parts[1]);
  sim::Scene scene;
  if (fuzz::RejectsOrReturns("LoadScene", [&] { scene = sim::LoadScene(path); })) return 0;
  std::string why;
  FUZZ_CHECK(scene.camera.Check(&why));
  FUZZ_CHECK(scene.imu.Check(&why));
  FUZZ_CHECK(scene.duration_s > 0.0 && scene.trajectory.t_end() >= scene.duration_s);
  std::set<int> ids;
  for (const sim::SceneObject& o : scene.objects) {
    FUZZ_CHECK(ids.insert(o.id).second);
    for (const Vec3& c : o.corners_W) FUZZ_CHECK(c.allFinite());
    FUZZ_CHECK(o.width() > 0.0 && o.height() > 0.0);
  }
  FUZZ_CHECK(scene.MakeCalibration().Check(&why));
  return 0;
}
