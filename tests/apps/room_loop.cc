#include "room_loop.h"

#include <string>

#include "fsp/sim/scene.h"
#include "fsp/sim/sequence_writer.h"
#include "test_util.h"

namespace fsp::test {
namespace {

namespace fs = std::filesystem;

// The objects and the flight; test::SmallRoomRig() adds the camera, the IMU and the room.
const char* kScene = R"(
objects:
  - {id: 1, class: door, corners: [[1.9, 0, 0], [1.0, 0, 0], [1.0, 0, 2.1], [1.9, 0, 2.1]]}
  - {id: 2, class: window, position: [4.6, 0, 1.0], rpy_deg: [90, 0, 180], width: 1.4, height: 1.2}
  - {id: 3, class: window, position: [7.2, 0, 1.0], rpy_deg: [90, 0, 180], width: 1.4, height: 1.2}
  - {id: 4, class: poster, position: [9.2, 0, 1.1], rpy_deg: [90, 0, 180], width: 0.8, height: 1.0}
  - {id: 10, class: window, position: [0, 1.5, 1.0], rpy_deg: [90, 0, 90], width: 1.5, height: 1.2}
  - {id: 11, class: poster, position: [0, 3.9, 1.2], rpy_deg: [90, 0, 90], width: 0.7, height: 1.0}
  - {id: 12, class: door, position: [0, 6.4, 0], rpy_deg: [90, 0, 90], width: 0.9, height: 2.1}
  - {id: 5, class: cabinet, corners: [[0.8, 8, 0], [2.0, 8, 0], [2.0, 8, 1.8], [0.8, 8, 1.8]]}
  - {id: 6, class: painting, position: [2.8, 8, 1.3], rpy_deg: [90, 0, 0], width: 1.2, height: 0.8}
  - {id: 7, class: window, position: [4.5, 8, 1.0], rpy_deg: [90, 0, 0], width: 1.4, height: 1.2}
  - {id: 8, class: poster, position: [6.8, 8, 1.2], rpy_deg: [90, 0, 0], width: 0.8, height: 1.0}
  - {id: 20, class: door, position: [10, 1.2, 0], rpy_deg: [90, 0, -90], width: 0.9, height: 2.1}
  - {id: 21, class: window, position: [10, 3.6, 1.0], rpy_deg: [90, 0, -90], width: 1.5, height: 1.2}
  - {id: 22, class: poster, position: [10, 6.0, 1.2], rpy_deg: [90, 0, -90], width: 0.8, height: 1.0}
trajectory:
  waypoints:
    - [0, 5.0, 4.0, 1.3, -90]
    - [2, 5.0, 4.0, 1.3, -90]
    - [4, 5.2, 3.4, 1.4, -120]
    - [6, 4.6, 3.0, 1.3, -150]
    - [8, 4.0, 3.4, 1.5, 180]
    - [10, 4.0, 4.2, 1.3, 150]
    - [12, 4.4, 4.8, 1.4, 120]
    - [14, 5.0, 5.0, 1.3, 90]
    - [16, 5.6, 4.8, 1.5, 60]
    - [18, 6.0, 4.2, 1.3, 20]
    - [20, 6.0, 3.6, 1.4, 0]
    - [22, 5.6, 3.2, 1.3, -40]
    - [24, 5.0, 3.0, 1.4, -80]
    - [26, 4.6, 3.2, 1.3, -110]
    - [28, 4.4, 3.6, 1.4, -140]
noise: {pixel_sigma: 1.0, seed: 4}
duration_s: 26
)";

}  // namespace

std::string SmallRoomRig() {
  return R"(
camera: {width: 320, height: 240, fx: 229.0, fy: 229.0, cx: 159.5, cy: 119.5, rate_hz: 20}
T_B_C: [0, 0, 1, 0.05,  -1, 0, 0, 0.0,  0, -1, 0, 0.0,  0, 0, 0, 1]
imu: {rate_hz: 200, gyroscope_noise_density: 1.7e-4, accelerometer_noise_density: 2.0e-3,
      gyroscope_random_walk: 1.9e-5, accelerometer_random_walk: 3.0e-3,
      gyroscope_bias: [0.002, -0.001, 0.0015], accelerometer_bias: [0.03, -0.02, 0.04]}
room: {min: [0, 0, 0], max: [10, 8, 3]})";
}

sim::Scene RoomLoopScene() {
  return sim::ParseScene(test::SmallRoomRig() + kScene, "room_loop.yaml", ".");
}

void WriteSequenceForGtCorners(const sim::Scene& scene, const fs::path& dir) {
  fs::remove_all(dir);
  sim::SequenceOptions options;
  options.images = false;  // frames listed with a placeholder image: gt-corners opens it
  options.video = false;
  options.top_view = false;
  options.progress = false;
  sim::WriteSequence(scene, dir.string(), options);
}

const fs::path& RoomLoopSequence() {
  static const ProcessFolder dir("room_loop_sequence", [](const fs::path& d) {
    WriteSequenceForGtCorners(RoomLoopScene(), d);
  });
  return dir.path();
}

}  // namespace fsp::test
