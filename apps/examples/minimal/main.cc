// FSP-SLAM as a library: a EuRoC-layout recording (a rendered sequence is one) fed frame by frame
// and IMU sample by IMU sample through fsp::pipeline::System, then the map of rectangles.
//   minimal DATASET
#include <cstdio>
#include <exception>
#include <memory>
#include <optional>
#include <variant>

#include "fsp/common/dataset.h"
#include "fsp/pipeline/system.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s DATASET (EuRoC layout: DIR/mav0/...)\n", argv[0]);
    return 2;
  }
  try {
    fsp::SourceOptions input;
    input.input = argv[1];
    const std::unique_ptr<fsp::Source> source = fsp::OpenSource(input);
    fsp::pipeline::SystemOptions options;  // rectangles + AprilTags, sliding window, FSP landmarks
    options.estimator.imu.noise = source->calibration().imu;
    fsp::pipeline::System slam(source->calibration(), options);
    while (const std::optional<fsp::Measurement> m = source->Next()) {
      if (const auto* imu = std::get_if<fsp::ImuSample>(&*m)) {
        slam.AddImu(*imu);
      } else {
        slam.AddFrame(std::get<fsp::Frame>(*m));
      }
    }
    slam.Finish();
    if (!slam.summary().init_failure.empty())
      std::printf("not initialised: %s\n", slam.summary().init_failure.c_str());
    std::printf("%zu poses, %zu objects\n", slam.Trajectory().size(), slam.Map().size());
    for (const fsp::backend::MapObject& o : slam.Map()) {
      const fsp::Vec3 c = o.T_W_O.translation();
      std::printf("object %d %s: %.3f x %.3f m at (%.2f, %.2f, %.2f)\n", o.id,
                  fsp::ToString(o.object_class), o.width, o.height, c.x(), c.y(), c.z());
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "minimal: error: %s\n", e.what());
    return 2;
  }
}
