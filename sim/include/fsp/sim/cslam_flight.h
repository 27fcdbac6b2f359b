// The seed paper's own experiment (C-SLAM, AIRLab-POLIMI: the authors' simulated hexacopter flight
// past 22 rectangles) turned into a scene the renderer takes: the authors' two ground-truth logs
// become a scene file with the paper's camera and a TUM pose file for its trajectory.
//
//   LandmarksGT.log     one rectangle per line: 4 corners x,y,z [m] in W (z up), comma separated;
//                       the authors' files have a stray empty field after the first corner.
//   PoseSE3(W)_GT.log   a ROS text dump (header line starting with '%'): column 3 the stamp [ns],
//                       columns 4-10 position x y z and quaternion x y z w of the body in W.
//
// Each rectangle's corners are put in the project's order s1..s4 (bottom-left, bottom-right,
// top-right, top-left seen from the front; y up), its front being the side that faces the flight
// (the mean body position). The class follows from the geometry, as the logs carry none: raised
// off the floor (lowest corner above 0.3 m) a window; standing on it, at least 1.8 m tall and at
// most 1.2 m wide a door; any other on the floor a cabinet. That gives 9 doors, 9 windows and 4
// cabinets where the paper counts 12, 8 and 2; the class only sets an object's first depth guess.
#pragma once

#include <string>
#include <vector>

#include "fsp/common/types.h"
#include "fsp/sim/scene.h"

namespace fsp::sim {

struct CslamFlight {
  std::vector<SceneObject> objects;  // ids 1..22 in the log's line order; corners s1..s4
  std::vector<StampedPose> poses;    // body poses, times as in the log
};

// The authors' camera (c_slam.launch, parameter K; 10 Hz in the paper): 640 x 360, no distortion,
// forward-looking (camera z along body x, DefaultCameraMount without its offset).
PinholeRadtan CslamCamera();
constexpr double kCslamCameraRateHz = 10.0;

// Reads FOLDER/LandmarksGT.log and FOLDER/PoseSE3(W)_GT.log. Throws InputError("FILE:LINE: what")
// on a missing file, a malformed row (not 12 numbers, non-finite values), corners that are not a
// rectangle (sides not at right angles within 1e-3 rad, or shorter than 1 cm), times that do not
// increase, or fewer than 2 poses.
CslamFlight ReadCslamFlight(const std::string& folder);

// Writes OUT_DIR/paper_flight.yaml (the scene: camera, mount, IMU noise of the default room at
// 100 Hz, a room around the objects, the 22 rectangles, the pose file, 1 px corner noise, the
// flight's duration) and OUT_DIR/paper_flight_poses.tum; returns the scene file's path.
std::string WriteCslamScene(const CslamFlight& flight, const std::string& out_dir);

}  // namespace fsp::sim
