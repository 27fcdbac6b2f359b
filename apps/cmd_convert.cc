// fsp convert-cslam LOG_DIR --out DIR: the seed paper's experiment (the C-SLAM authors'
// ground-truth logs) as a scene file and a pose file that `fsp render` takes.
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "fsp/sim/cslam_flight.h"

namespace fsp::apps {

void AddConvertCommand(CLI::App& root) {
  struct Args {
    std::string logs, out;
  };
  auto args = std::make_shared<Args>();
  auto* sub = root.add_subcommand(
      "convert-cslam",
      "Turn the seed paper's ground-truth logs (LandmarksGT.log, PoseSE3(W)_GT.log of the C-SLAM\n"
      "repository) into DIR/paper_flight.yaml + DIR/paper_flight_poses.tum for `fsp render`");
  sub->add_option("LOG_DIR", args->logs, "folder holding the two logs")->required();
  sub->add_option("--out", args->out, "output folder (created)")->required();
  sub->callback([args] {
    const sim::CslamFlight flight = sim::ReadCslamFlight(args->logs);
    const std::string scene = sim::WriteCslamScene(flight, args->out);
    int count[6] = {};
    for (const sim::SceneObject& o : flight.objects) ++count[static_cast<int>(o.object_class)];
    std::printf("%s: %zu rectangles (%d doors, %d windows, %d cabinets), %zu poses over %.2f s\n",
                scene.c_str(), flight.objects.size(), count[static_cast<int>(ObjectClass::kDoor)],
                count[static_cast<int>(ObjectClass::kWindow)],
                count[static_cast<int>(ObjectClass::kCabinet)], flight.poses.size(),
                1e-9 * static_cast<double>(flight.poses.back().t_ns - flight.poses.front().t_ns));
  });
}

}  // namespace fsp::apps
