// Plain data types shared by the front end, the back end, the simulator and the apps.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/common/geometry.h"

namespace fsp {

// One IMU reading in the body frame B: angular velocity [rad/s] and specific force [m/s^2].
struct ImuSample {
  int64_t t_ns = 0;
  Vec3 gyro = Vec3::Zero();
  Vec3 acc = Vec3::Zero();
};

// One camera image. `image` is 8-bit grey (CV_8UC1); `source` names where it came from (a file
// path, or "video.mp4#frame=12") for error messages.
struct Frame {
  int64_t t_ns = 0;
  int index = 0;
  std::string source;
  cv::Mat image;
};

// A ground-truth or estimated body state (EuRoC ground-truth columns).
struct StateSample {
  int64_t t_ns = 0;
  Rigid3 T_W_B;
  Vec3 v_W = Vec3::Zero();
  Vec3 gyro_bias = Vec3::Zero();
  Vec3 acc_bias = Vec3::Zero();
};

// A timestamped pose (TUM trajectory row).
struct StampedPose {
  int64_t t_ns = 0;
  Rigid3 T_W_B;
};

// Four image corners of one rectangle in s1..s4 order (bottom-left, bottom-right, top-right,
// top-left for an upright object seen from the front).
using Corners = std::array<Vec2, 4>;
// Which of the four corners (s1..s4) were seen: in the image and not hidden. An object partly out
// of view is observed through the corners it shows.
using CornerMask = std::array<bool, 4>;
inline constexpr CornerMask kAllCorners = {true, true, true, true};
int CountSeen(const CornerMask& seen);

// Object classes the front end can name. kUnknown is a rectangle without a class guess.
enum class ObjectClass { kUnknown, kDoor, kWindow, kCabinet, kPoster, kTag };
const char* ToString(ObjectClass c);
// Parses "door", "window", "cabinet", "poster" (also "painting"), "tag", "unknown"; false
// otherwise.
bool ParseObjectClass(const std::string& name, ObjectClass* c);

// What the front end hands to the back end for one object in one frame.
struct ObjectObservation {
  int64_t t_ns = 0;
  int object_id = -1;
  ObjectClass object_class = ObjectClass::kUnknown;
  Corners corners;     // UNDISTORTED pixels, s1..s4 order
  double score = 1.0;  // detector/tracker confidence in [0, 1]
  // The corners' noise the source expects, per coordinate [px]; 0: the estimator's own
  // (EstimatorOptions::factor.sigma_px). The front end tells corners fitted to the edges from
  // corners carried by the keypoints alone (FrontEndOptions::edge_sigma_px, keypoint_sigma_px).
  double sigma_px = 0.0;
  // The corners seen; the others' entries in `corners` carry no information. The back end uses a
  // partial observation only for an object its window already tracks (backend/README.md, "Objects
  // partly in view").
  CornerMask seen = kAllCorners;
  bool Complete() const { return seen == kAllCorners; }
};

// What the front end hands on for one tracked point feature in one frame (frontend/README.md,
// "Point features"); kept apart from the object observations. A point is one scene point for as
// long as its id lives: ids are never reused, and a point lost once is never resumed.
struct PointObservation {
  int64_t t_ns = 0;
  int64_t point_id = -1;
  Vec2 uv_undistorted = Vec2::Zero();  // UNDISTORTED pixels (the back end's, as Corners)
  int age = 0;  // frames the point was tracked through before this one (0: detected in this frame)
  // Its pixel noise relative to a well-textured point's tracked at full resolution: the tracker's
  // working level's scale (2 for 1280x720 tracked at 640x360), times more for a point found on
  // faint texture (the flow's error grows as the texture's gradient falls).
  double sigma_scale = 1.0;
};

// What the back end and the IMU expect of the next frame, handed to the front end (the front end
// and the back end never include each other; this plain type is how predictions flow back).
struct FramePrediction {
  // Rotation of the camera since the previous frame, R_Cprev_Ccur (from the gyroscope); absent when
  // unknown. Lets the tracker predict each object's corners through the infinite homography
  // K R_Ccur_Cprev K^-1.
  std::optional<Mat3> R_Cprev_Ccur;
  // Gravity direction in the current camera frame (any length); absent before initialisation.
  // Orders the corners of new rectangles (s1 bottom-left).
  std::optional<Vec3> gravity_C;
  // Whether `objects` and `objects_behind` come from an initialised estimate (else both are empty
  // because nothing is known yet).
  bool map_known = false;
  // Predicted corners (undistorted px, s1..s4) of map objects in front of the camera, by object id.
  std::vector<std::pair<int, Corners>> objects;
  // Map objects with a corner behind the camera (more than ~80 deg off the optical axis: no drift
  // of the estimate brings them into view): whatever a detection looks like, it is not one of them.
  std::vector<int> objects_behind;
};

}  // namespace fsp
