// fsp info INPUT [--calib FILE] [--imu FILE] [--json]: what a recording holds.
#include "commands.h"

namespace fsp::apps {

void AddInfoCommand(CLI::App& root) {
  auto* sub = root.add_subcommand("info", "Describe a recording: frames, IMU samples, time span, calibration");
  sub->callback([] {});
}

}  // namespace fsp::apps
