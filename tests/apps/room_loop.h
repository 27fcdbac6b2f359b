// The room-loop sequence of the end-to-end tests that need a loop: the end-to-end room with an
// object on each of its four walls, a 26 s flight around its centre that looks at each wall in
// turn and comes back to the first (its objects return: a loop). Rendered once per test process
// without images (ground truth, IMU, corners: about a second).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>

#include "fsp/sim/scene.h"

namespace fsp::test {

// The camera (320 x 240, 20 Hz, forward-looking), its mount, the IMU (200 Hz) and the 10 x 8 x 3 m
// room that the small end-to-end scenes share, as scene YAML: a scene is this plus its objects,
// trajectory, noise and duration.
std::string SmallRoomRig();

// The rendered sequence's folder (one per process: CTest runs tests as parallel processes).
const std::filesystem::path& RoomLoopSequence();
// The room loop's scene, to render it with other seeds.
sim::Scene RoomLoopScene();

// Renders SCENE into DIR without images (ground truth, IMU, corners), with a cam0 frame list so
// that `fsp run --frontend gt-corners` reads it (the reader decodes the first image only: one blank
// image and empty files).
void WriteSequenceForGtCorners(const sim::Scene& scene, const std::filesystem::path& dir);
constexpr size_t kRoomLoopFrames = 520;  // 26 s at 20 Hz

}  // namespace fsp::test
