// The scene file of `fsp render` (documented with assets/scenes/default_room.yaml): camera, mount,
// IMU noise, room, rectangles, trajectory, noise, duration; parsed and validated here, then turned
// into renderer quads.
//
// Optional keys (all optional):
//   imu:        gyroscope_bias: [3], accelerometer_bias: [3]   initial biases (rad/s, m/s^2),
//   default 0 objects[i]: tag_id (required for texture tag), texture
//   (wall|floor|ceiling|wood|glass|poster|cabinet|
//               tag|plain; default from the class), seed (texture variation, default the id)
//   room:       wall_texture (wall, default; paint: a painted wall with few point features)
//   trajectory: smoothing_s, knot_s   (pose-file form: TrajectoryOptions::pose_smoothing_s,
//   pose_knot_s) render:     {supersampling, motion_blur_samples, exposure_s, ambient}
//   (RenderOptions; exposure_s is
//               the shutter time for motion blur, centred on the frame time)
// Every map rejects keys it does not know, naming the key, its line and the keys allowed.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fsp/common/calibration.h"
#include "fsp/common/camera.h"
#include "fsp/common/geometry.h"
#include "fsp/common/types.h"
#include "fsp/sim/renderer.h"
#include "fsp/sim/trajectory.h"

namespace fsp::sim {

// One rectangle of the scene. Corners s1..s4 in W (docs/conventions.md: s1 = (0,0,0), s2 =
// (w,0,0), s3 = (w,h,0), s4 = (0,h,0) in O; x along the width, y along the height, z = x cross y
// out of the visible face).
struct SceneObject {
  int id = -1;             // object id (>= 0, unique in the scene)
  std::string class_name;  // as written in the scene: door, window, cabinet, poster, painting, tag
  ObjectClass object_class = ObjectClass::kUnknown;
  std::array<Vec3, 4> corners_W;  // s1..s4 [m]
  TextureKind texture = TextureKind::kPlain;
  int tag_id = -1;            // tag36h11 code for texture tag; -1 otherwise
  uint32_t texture_seed = 0;  // varies the procedural texture
  int line = 0;               // line in the scene file (for messages)

  double width() const { return (corners_W[1] - corners_W[0]).norm(); }
  double height() const { return (corners_W[3] - corners_W[0]).norm(); }
  // Object pose: origin at s1, x along s2 - s1, y along s4 - s1.
  Rigid3 T_W_O() const;
};

struct Room {
  Vec3 min_W = Vec3::Zero();  // [m] floor corner
  Vec3 max_W = Vec3::Zero();  // [m] ceiling corner
  // The four walls' texture (room.wall_texture: wall, the default, or paint: low texture).
  TextureKind walls = TextureKind::kWall;
};

struct Scene {
  std::string path;  // scene file (messages; pose files are relative to it)
  PinholeRadtan camera;
  double camera_rate_hz = 20.0;    // [Hz]
  Rigid3 T_B_C;                    // camera -> body; default: DefaultCameraMount()
  ImuNoise imu;                    // densities and rate (Kalibr names)
  Vec3 gyro_bias0 = Vec3::Zero();  // initial IMU biases
  Vec3 acc_bias0 = Vec3::Zero();
  std::optional<Room> room;
  std::vector<SceneObject> objects;
  Trajectory trajectory;        // from the waypoints or the pose file (validated)
  std::string trajectory_file;  // the pose file it came from (resolved path); empty for waypoints
  double pixel_sigma = 0.0;     // image noise standard deviation [grey levels of 0..255]
  uint32_t seed = 1;            // seeds every random draw of the sequence
  double duration_s = 0.0;      // [s]
  RenderOptions render;
  double exposure_s = 0.0;  // shutter time for motion blur [s] (0: none)

  // Calibration of the rendered sequence (camera, T_B_C, IMU noise, rate).
  Calibration MakeCalibration() const;
};

// A forward-looking camera on a drone: camera z (optical axis) along body x, camera x along -body
// y, camera y along -body z (so the image is upright when the body is level).
Rigid3 DefaultCameraMount();

// Reads and validates a scene file. Throws InputError "FILE:LINE: what" for: YAML syntax, an
// unknown key, a missing field, a wrong type or a non-finite number, a bad class or texture, a tag
// without tag_id, duplicate object ids, corners that are not a rectangle (zero area, non-planar,
// not right-angled; corners within 1e-3 of a rectangle are snapped to an exact one), a room with
// min >= max, waypoints that do not start at t = 0, a trajectory that ends before duration_s, and a
// camera or IMU that fails its Check.
Scene LoadScene(const std::string& path);
// The same from text (tests); NAME is used in messages and BASE_DIR resolves a relative pose file.
Scene ParseScene(const std::string& yaml_text, const std::string& name,
                 const std::string& base_dir);

// Renderer quads: room floor, ceiling and 4 walls (id -1, normal axis_u x axis_v into the room,
// axis_v up on walls so their textures stand upright) and one quad per object (id = object id,
// corners exactly the scene's: offset_m = 0, since the renderer lets an object win a depth tie with
// its wall).
std::vector<TexturedQuad> SceneQuads(const Scene& scene);

}  // namespace fsp::sim
