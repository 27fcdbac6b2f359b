#include "fsp/sim/scene.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "fsp/common/error.h"
#include "fsp/common/trajectory_io.h"

namespace fsp::sim {

namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
constexpr int kTag36h11Codes = 587;  // tag36h11 has codes 0..586

// Line-numbered access to the scene's YAML tree: every problem becomes InputError "FILE:LINE:
// what".
class Reader {
 public:
  explicit Reader(std::string name) : name_(std::move(name)) {}

  int Line(const YAML::Node& node) const {
    const YAML::Mark mark = node.Mark();
    return mark.line >= 0 ? mark.line + 1 : 0;
  }
  [[noreturn]] void Fail(const YAML::Node& node, const std::string& what) const {
    throw InputError(name_, Line(node), what);
  }
  [[noreturn]] void Fail(int line, const std::string& what) const {
    throw InputError(name_, line, what);
  }

  // MAP must be a map whose keys are all in ALLOWED; WHERE names it in messages ("camera").
  void CheckMap(const YAML::Node& map, const std::string& where,
                const std::set<std::string>& allowed) const {
    if (!map.IsMap()) Fail(map, where + " must be a map of keys");
    for (auto it = map.begin(); it != map.end(); ++it) {
      const std::string key = it->first.Scalar();
      if (allowed.count(key) == 0) {
        std::string list;
        for (const std::string& k : allowed) list += (list.empty() ? "" : ", ") + k;
        Fail(it->first, "unknown key '" + key + "' in " + where + " (allowed: " + list + ")");
      }
    }
  }
  YAML::Node Require(const YAML::Node& map, const std::string& key,
                     const std::string& where) const {
    const YAML::Node node = map[key];
    if (!node) Fail(map, "missing field '" + key + "' in " + where);
    return node;
  }
  double Double(const YAML::Node& node, const std::string& what) const {
    if (!node.IsScalar()) Fail(node, what + " must be a number");
    double value = 0.0;
    try {
      value = node.as<double>();
    } catch (const YAML::Exception&) {
      Fail(node, what + " must be a number, not '" + node.Scalar() + "'");
    }
    if (!std::isfinite(value)) Fail(node, what + " must be finite");
    return value;
  }
  int Int(const YAML::Node& node, const std::string& what) const {
    if (!node.IsScalar()) Fail(node, what + " must be an integer");
    try {
      return node.as<int>();
    } catch (const YAML::Exception&) {
      Fail(node, what + " must be an integer, not '" + node.Scalar() + "'");
    }
  }
  std::string String(const YAML::Node& node, const std::string& what) const {
    if (!node.IsScalar()) Fail(node, what + " must be a string");
    return node.Scalar();
  }
  std::vector<double> Doubles(const YAML::Node& node, const std::string& what, size_t n) const {
    if (!node.IsSequence() || node.size() != n) {
      Fail(node, what + " must be a list of " + std::to_string(n) + " numbers");
    }
    std::vector<double> out;
    for (size_t i = 0; i < n; ++i)
      out.push_back(Double(node[i], what + "[" + std::to_string(i) + "]"));
    return out;
  }
  Vec3 Vector3(const YAML::Node& node, const std::string& what) const {
    const std::vector<double> v = Doubles(node, what, 3);
    return Vec3(v[0], v[1], v[2]);
  }

  const std::string& name() const { return name_; }

 private:
  std::string name_;
};

// Optional number: MAP[key] if present, else FALLBACK.
double OptionalDouble(const Reader& r, const YAML::Node& map, const std::string& key,
                      const std::string& where, double fallback) {
  const YAML::Node node = map[key];
  return node ? r.Double(node, where + "." + key) : fallback;
}

bool ParseTexture(const std::string& name, TextureKind* kind) {
  static const std::pair<const char*, TextureKind> kNames[] = {
      {"wall", TextureKind::kWall},       {"floor", TextureKind::kFloor},
      {"ceiling", TextureKind::kCeiling}, {"wood", TextureKind::kWood},
      {"glass", TextureKind::kGlass},     {"poster", TextureKind::kPoster},
      {"cabinet", TextureKind::kCabinet}, {"tag", TextureKind::kTag},
      {"plain", TextureKind::kPlain},     {"paint", TextureKind::kPaint}};
  for (const auto& [n, k] : kNames) {
    if (name == n) {
      *kind = k;
      return true;
    }
  }
  return false;
}

TextureKind DefaultTexture(ObjectClass c) {
  switch (c) {
    case ObjectClass::kDoor:
      return TextureKind::kWood;
    case ObjectClass::kWindow:
      return TextureKind::kGlass;
    case ObjectClass::kCabinet:
      return TextureKind::kCabinet;
    case ObjectClass::kPoster:
      return TextureKind::kPoster;
    case ObjectClass::kTag:
      return TextureKind::kTag;
    case ObjectClass::kUnknown:
      break;
  }
  return TextureKind::kPlain;
}

std::string Fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Validates four corners as a rectangle and snaps them to an exact one (keeping s1, s2 and the
// height):
//   e1 = s2 - s1 (width), e3 = s4 - s1 (height); requires |e1|, |e3| > 1 mm, |cos(e1, e3)| < 1e-3,
//   and s3 within 1e-3 (relative to the size) of s1 + e1 + e3, out of the plane (non-planar) and in
//   it.
std::array<Vec3, 4> CheckRectangle(const Reader& r, const YAML::Node& node,
                                   const std::string& where, const std::array<Vec3, 4>& s) {
  const Vec3 e1 = s[1] - s[0], e3 = s[3] - s[0];
  const double w = e1.norm(), h = e3.norm();
  if (!std::isfinite(w) || !std::isfinite(h) || !std::isfinite(e1.cross(e3).norm())) {
    r.Fail(node, where + ": corners too far apart (sides beyond the range of doubles)");
  }
  if (w < 1e-3 || h < 1e-3 || e1.cross(e3).norm() < 1e-6) {
    r.Fail(node, where + ": zero-area rectangle (width " + Fmt(w) + " m, height " + Fmt(h) + " m)");
  }
  const double cos_angle = e1.dot(e3) / (w * h);
  if (std::abs(cos_angle) > 1e-3) {
    r.Fail(node, where + ": corners are not a rectangle: the angle at s1 is " +
                     Fmt(std::acos(std::clamp(cos_angle, -1.0, 1.0)) / kDegToRad) + " deg, not 90");
  }
  const double tol = 1e-3 * std::max(w, h);
  const Vec3 n = e1.cross(e3).normalized();
  const Vec3 off = s[2] - (s[0] + e1 + e3);
  if (std::abs(off.dot(n)) > tol) {
    r.Fail(node, where + ": corners are not planar: s3 is " + Fmt(std::abs(off.dot(n))) +
                     " m off the plane of s1, s2, s4");
  }
  if (off.norm() > tol) {
    r.Fail(node, where + ": corners are not a rectangle: s3 is " + Fmt(off.norm()) +
                     " m from s2 + s4 - s1 (order must be s1..s4 around the rectangle)");
  }
  const Vec3 x = e1 / w;
  const Vec3 y = (e3 - x * x.dot(e3)).normalized();
  return {s[0], s[0] + w * x, s[0] + w * x + h * y, s[0] + h * y};
}

SceneObject ParseObject(const Reader& r, const YAML::Node& node, size_t index) {
  const std::string where = "objects[" + std::to_string(index) + "]";
  r.CheckMap(node, where,
             {"id", "class", "corners", "position", "rpy_deg", "width", "height", "texture",
              "tag_id", "seed"});
  SceneObject obj;
  obj.line = r.Line(node);
  obj.id = r.Int(r.Require(node, "id", where), where + ".id");
  if (obj.id < 0) r.Fail(node["id"], where + ".id must be >= 0");
  const std::string label = where + " (id " + std::to_string(obj.id) + ")";

  const YAML::Node cls = r.Require(node, "class", label);
  obj.class_name = r.String(cls, label + ".class");
  static const std::set<std::string> kClasses = {"door",   "window",   "cabinet",
                                                 "poster", "painting", "tag"};
  if (kClasses.count(obj.class_name) == 0 || !ParseObjectClass(obj.class_name, &obj.object_class)) {
    r.Fail(cls, label + ": unknown class '" + obj.class_name +
                    "' (allowed: door, window, cabinet, poster, painting, tag)");
  }

  if (node["corners"]) {
    for (const char* key : {"position", "rpy_deg", "width", "height"}) {
      if (node[key])
        r.Fail(node[key],
               label + ": give either corners or position/rpy_deg/width/height, not both");
    }
    const YAML::Node corners = node["corners"];
    if (!corners.IsSequence() || corners.size() != 4)
      r.Fail(corners, label + ".corners must be 4 points [x, y, z]");
    std::array<Vec3, 4> s;
    for (size_t j = 0; j < 4; ++j)
      s[j] = r.Vector3(corners[j], label + ".corners[" + std::to_string(j) + "]");
    obj.corners_W = CheckRectangle(r, corners, label, s);
  } else {
    if (!node["position"]) {
      r.Fail(node,
             "missing field 'corners' or 'position' (with rpy_deg, width, height) in " + label);
    }
    const Vec3 s1 = r.Vector3(node["position"], label + ".position");
    const Vec3 rpy = r.Vector3(r.Require(node, "rpy_deg", label), label + ".rpy_deg") * kDegToRad;
    const double w = r.Double(r.Require(node, "width", label), label + ".width");
    const double h = r.Double(r.Require(node, "height", label), label + ".height");
    if (w < 1e-3 || h < 1e-3) {
      r.Fail(node,
             label + ": zero-area rectangle (width " + Fmt(w) + " m, height " + Fmt(h) + " m)");
    }
    // R_W_O = Rz(yaw) Ry(pitch) Rx(roll); s_j = s1 + R_W_O * (0|w, 0|h, 0).
    const Mat3 R_W_O = RotFromRpy(rpy[0], rpy[1], rpy[2]);
    const Vec3 x = R_W_O.col(0), y = R_W_O.col(1);
    obj.corners_W = {s1, s1 + w * x, s1 + w * x + h * y, s1 + h * y};
    // Far from the origin a small rectangle's corners round to fewer distinct points (or overflow).
    const double tol = 1e-6;
    for (const Vec3& c : obj.corners_W) {
      if (!c.allFinite()) r.Fail(node, label + ": a corner is not finite (position too large)");
    }
    if (std::abs(obj.width() - w) > tol * w || std::abs(obj.height() - h) > tol * h) {
      r.Fail(node, label + ": position " + Fmt(s1.stableNorm()) +
                       " m from the origin is too far for a " + Fmt(w) + " x " + Fmt(h) +
                       " m rectangle (its corners do not round to one)");
    }
  }

  obj.texture = DefaultTexture(obj.object_class);
  if (const YAML::Node tex = node["texture"]) {
    const std::string name = r.String(tex, label + ".texture");
    if (!ParseTexture(name, &obj.texture)) {
      r.Fail(tex,
             label + ": unknown texture '" + name +
                 "' (allowed: wall, floor, ceiling, wood, glass, poster, cabinet, tag, plain)");
    }
  }
  if (const YAML::Node tag = node["tag_id"]) {
    if (obj.texture != TextureKind::kTag)
      r.Fail(tag, label + ": tag_id is only for the tag texture/class");
    obj.tag_id = r.Int(tag, label + ".tag_id");
    if (obj.tag_id < 0 || obj.tag_id >= kTag36h11Codes) {
      r.Fail(tag,
             label + ".tag_id must be in 0.." + std::to_string(kTag36h11Codes - 1) + " (tag36h11)");
    }
  } else if (obj.texture == TextureKind::kTag) {
    r.Fail(node, "missing field 'tag_id' in " + label + " (a tag needs its tag36h11 code)");
  }
  obj.texture_seed = static_cast<uint32_t>(obj.id);
  if (const YAML::Node seed = node["seed"]) {
    const int s = r.Int(seed, label + ".seed");
    if (s < 0) r.Fail(seed, label + ".seed must be >= 0");
    obj.texture_seed = static_cast<uint32_t>(s);
  }
  return obj;
}

}  // namespace

Rigid3 SceneObject::T_W_O() const {
  const Vec3 x = (corners_W[1] - corners_W[0]).normalized();
  const Vec3 y = (corners_W[3] - corners_W[0]).normalized();
  Mat3 R;
  R << x, y, x.cross(y);
  return Rigid3(R, corners_W[0]);
}

Rigid3 DefaultCameraMount() {
  // Columns: camera axes in B. x_C = -y_B, y_C = -z_B, z_C = x_B.
  Mat3 R_B_C;
  R_B_C << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return Rigid3(R_B_C, Vec3::Zero());
}

Calibration Scene::MakeCalibration() const {
  Calibration calib;
  calib.camera = camera;
  calib.T_B_C = T_B_C;
  calib.imu = imu;
  calib.camera_rate_hz = camera_rate_hz;
  calib.source = path;
  return calib;
}

Scene ParseScene(const std::string& yaml_text, const std::string& name,
                 const std::string& base_dir) {
  const Reader r(name);
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw InputError(name, e.mark.line >= 0 ? e.mark.line + 1 : 0, "YAML syntax: " + e.msg);
  }
  if (!root.IsMap())
    throw InputError(name, 0, "a scene file must be a YAML map (camera, objects, trajectory, ...)");
  r.CheckMap(
      root, "the scene",
      {"camera", "T_B_C", "imu", "room", "objects", "trajectory", "noise", "duration_s", "render"});
  auto require_top = [&](const std::string& key) {
    const YAML::Node node = root[key];
    if (!node) throw InputError(name, 0, "missing field '" + key + "'");
    return node;
  };

  Scene scene;
  scene.path = name;

  // camera
  {
    const YAML::Node cam = require_top("camera");
    r.CheckMap(cam, "camera", {"width", "height", "fx", "fy", "cx", "cy", "rate_hz", "distortion"});
    scene.camera.width = r.Int(r.Require(cam, "width", "camera"), "camera.width");
    scene.camera.height = r.Int(r.Require(cam, "height", "camera"), "camera.height");
    scene.camera.fx = r.Double(r.Require(cam, "fx", "camera"), "camera.fx");
    scene.camera.fy = r.Double(r.Require(cam, "fy", "camera"), "camera.fy");
    scene.camera.cx = r.Double(r.Require(cam, "cx", "camera"), "camera.cx");
    scene.camera.cy = r.Double(r.Require(cam, "cy", "camera"), "camera.cy");
    scene.camera_rate_hz = OptionalDouble(r, cam, "rate_hz", "camera", 20.0);
    if (const YAML::Node d = cam["distortion"]) {
      const std::vector<double> k = r.Doubles(d, "camera.distortion", 4);
      scene.camera.distortion = {k[0], k[1], k[2], k[3]};
    }
    std::string why;
    if (!scene.camera.Check(&why)) r.Fail(cam, "camera: " + why);
    if (!(scene.camera_rate_hz > 0.0)) r.Fail(cam, "camera.rate_hz must be > 0");
  }

  // T_B_C
  scene.T_B_C = DefaultCameraMount();
  if (const YAML::Node t = root["T_B_C"]) {
    const std::vector<double> v = r.Doubles(t, "T_B_C (row-major 4x4)", 16);
    Mat4 M;
    for (int i = 0; i < 16; ++i) M(i / 4, i % 4) = v[i];
    if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
      r.Fail(t, "T_B_C: last row must be 0 0 0 1");
    try {
      scene.T_B_C = Rigid3::FromMatrix(M);
    } catch (const std::exception& e) {
      r.Fail(t, std::string("T_B_C is not a rigid transform: ") + e.what());
    }
  }

  // imu
  if (const YAML::Node imu = root["imu"]) {
    r.CheckMap(imu, "imu",
               {"rate_hz", "gyroscope_noise_density", "accelerometer_noise_density",
                "gyroscope_random_walk", "accelerometer_random_walk", "gyroscope_bias",
                "accelerometer_bias"});
    ImuNoise& n = scene.imu;
    n.rate_hz = OptionalDouble(r, imu, "rate_hz", "imu", n.rate_hz);
    n.gyroscope_noise_density =
        OptionalDouble(r, imu, "gyroscope_noise_density", "imu", n.gyroscope_noise_density);
    n.accelerometer_noise_density =
        OptionalDouble(r, imu, "accelerometer_noise_density", "imu", n.accelerometer_noise_density);
    n.gyroscope_random_walk =
        OptionalDouble(r, imu, "gyroscope_random_walk", "imu", n.gyroscope_random_walk);
    n.accelerometer_random_walk =
        OptionalDouble(r, imu, "accelerometer_random_walk", "imu", n.accelerometer_random_walk);
    if (const YAML::Node b = imu["gyroscope_bias"])
      scene.gyro_bias0 = r.Vector3(b, "imu.gyroscope_bias");
    if (const YAML::Node b = imu["accelerometer_bias"])
      scene.acc_bias0 = r.Vector3(b, "imu.accelerometer_bias");
    std::string why;
    if (!n.Check(&why)) r.Fail(imu, "imu: " + why);
  }

  // room
  if (const YAML::Node room = root["room"]) {
    r.CheckMap(room, "room", {"min", "max", "wall_texture"});
    Room rm;
    rm.min_W = r.Vector3(r.Require(room, "min", "room"), "room.min");
    rm.max_W = r.Vector3(r.Require(room, "max", "room"), "room.max");
    if (!((rm.max_W - rm.min_W).array() > 0.0).all())
      r.Fail(room, "room: max must exceed min on every axis");
    if (const YAML::Node t = room["wall_texture"]) {
      const std::string texture = t.IsScalar() ? t.as<std::string>() : "";
      if (!ParseTexture(texture, &rm.walls))
        r.Fail(t, "room.wall_texture: '" + texture + "' is not a texture (wall, paint, ...)");
    }
    scene.room = rm;
  }

  // objects
  {
    const YAML::Node objects = require_top("objects");
    if (!objects.IsSequence()) r.Fail(objects, "objects must be a list");
    std::set<int> ids;
    for (size_t i = 0; i < objects.size(); ++i) {
      SceneObject obj = ParseObject(r, objects[i], i);
      if (!ids.insert(obj.id).second)
        r.Fail(objects[i], "duplicate object id " + std::to_string(obj.id));
      scene.objects.push_back(std::move(obj));
    }
  }

  // noise, render, duration
  if (const YAML::Node noise = root["noise"]) {
    r.CheckMap(noise, "noise", {"pixel_sigma", "seed"});
    scene.pixel_sigma = OptionalDouble(r, noise, "pixel_sigma", "noise", 0.0);
    if (scene.pixel_sigma < 0.0) r.Fail(noise["pixel_sigma"], "noise.pixel_sigma must be >= 0");
    if (const YAML::Node seed = noise["seed"]) {
      const int s = r.Int(seed, "noise.seed");
      if (s < 0) r.Fail(seed, "noise.seed must be >= 0");
      scene.seed = static_cast<uint32_t>(s);
    }
  }
  if (const YAML::Node render = root["render"]) {
    r.CheckMap(render, "render", {"supersampling", "motion_blur_samples", "exposure_s", "ambient"});
    if (render["supersampling"])
      scene.render.supersampling = r.Int(render["supersampling"], "render.supersampling");
    if (render["motion_blur_samples"]) {
      scene.render.motion_blur_samples =
          r.Int(render["motion_blur_samples"], "render.motion_blur_samples");
    }
    scene.render.ambient = OptionalDouble(r, render, "ambient", "render", scene.render.ambient);
    scene.exposure_s = OptionalDouble(r, render, "exposure_s", "render", 0.0);
    if (scene.exposure_s < 0.0) r.Fail(render["exposure_s"], "render.exposure_s must be >= 0");
    std::string why;
    if (!scene.render.Check(&why)) r.Fail(render, "render: " + why);
  }
  const YAML::Node duration = require_top("duration_s");
  scene.duration_s = r.Double(duration, "duration_s");
  if (!(scene.duration_s > 0.0)) r.Fail(duration, "duration_s must be > 0");

  // trajectory (last: its length is checked against the duration)
  {
    const YAML::Node traj = require_top("trajectory");
    r.CheckMap(traj, "trajectory", {"waypoints", "file", "smoothing_s", "knot_s"});
    TrajectoryOptions options;
    options.pose_smoothing_s =
        OptionalDouble(r, traj, "smoothing_s", "trajectory", options.pose_smoothing_s);
    options.pose_knot_s = OptionalDouble(r, traj, "knot_s", "trajectory", options.pose_knot_s);
    std::string why;
    if (!options.Check(&why)) r.Fail(traj, "trajectory: " + why);
    const YAML::Node wps = traj["waypoints"], file = traj["file"];
    if (static_cast<bool>(wps) == static_cast<bool>(file)) {
      r.Fail(traj, "trajectory needs exactly one of 'waypoints' or 'file'");
    }
    try {
      if (wps) {
        if (!wps.IsSequence())
          r.Fail(wps, "trajectory.waypoints must be a list of [t_s, x, y, z, yaw_deg]");
        std::vector<Waypoint> waypoints;
        for (size_t i = 0; i < wps.size(); ++i) {
          const std::vector<double> v = r.Doubles(
              wps[i], "trajectory.waypoints[" + std::to_string(i) + "] ([t_s, x, y, z, yaw_deg])",
              5);
          waypoints.push_back({v[0], Vec3(v[1], v[2], v[3]), v[4] * kDegToRad});
        }
        if (!waypoints.empty() && waypoints.front().t_s != 0.0) {
          r.Fail(wps[0], "trajectory.waypoints must start at t = 0 (the first frame)");
        }
        scene.trajectory = Trajectory::FromWaypoints(waypoints, options);
      } else {
        std::filesystem::path p = r.String(file, "trajectory.file");
        if (p.is_relative()) p = std::filesystem::path(base_dir) / p;
        scene.trajectory_file = p.lexically_normal().string();
        scene.trajectory = Trajectory::FromPoses(ReadTum(scene.trajectory_file), options);
      }
    } catch (const InputError& e) {
      const std::string what = e.what();
      // Errors from the pose file already name it; the trajectory's own ones get the scene's
      // location.
      if (what.rfind(name + ":", 0) == 0 ||
          (!scene.trajectory_file.empty() && what.rfind(scene.trajectory_file, 0) == 0)) {
        throw;
      }
      r.Fail(traj, "trajectory: " + what);
    }
    if (scene.trajectory.t_end() < scene.duration_s) {
      r.Fail(traj, "trajectory ends at t = " + Fmt(scene.trajectory.t_end()) +
                       " s, before duration_s = " + Fmt(scene.duration_s) + " s");
    }
  }
  return scene;
}

Scene LoadScene(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open scene file");
  std::stringstream text;
  text << in.rdbuf();
  const std::string dir = std::filesystem::path(path).parent_path().string();
  return ParseScene(text.str(), path, dir.empty() ? "." : dir);
}

std::vector<TexturedQuad> SceneQuads(const Scene& scene) {
  std::vector<TexturedQuad> quads;
  if (scene.room) {
    const Vec3 lo = scene.room->min_W, hi = scene.room->max_W, d = hi - lo;
    auto add = [&](const Vec3& origin, const Vec3& u, const Vec3& v, TextureKind tex,
                   uint32_t seed) {
      TexturedQuad q;
      q.id = -1;
      q.origin_W = origin;
      q.axis_u_W = u;
      q.axis_v_W = v;
      q.texture = tex;
      q.seed = seed;
      quads.push_back(q);
    };
    const Vec3 X(d.x(), 0, 0), Y(0, d.y(), 0), Z(0, 0, d.z());
    // Normals u x v point into the room; walls have v = +z.
    add(lo, X, Y, TextureKind::kFloor, 1);                              // floor, normal +z
    add(Vec3(lo.x(), lo.y(), hi.z()), Y, X, TextureKind::kCeiling, 2);  // ceiling, normal -z
    add(Vec3(hi.x(), lo.y(), lo.z()), -X, Z, scene.room->walls, 3);     // y = min wall, normal +y
    add(Vec3(lo.x(), hi.y(), lo.z()), X, Z, scene.room->walls, 4);      // y = max wall, normal -y
    add(lo, Y, Z, scene.room->walls, 5);                                // x = min wall, normal +x
    add(Vec3(hi.x(), hi.y(), lo.z()), -Y, Z, scene.room->walls, 6);     // x = max wall, normal -x
  }
  for (const SceneObject& obj : scene.objects) {
    TexturedQuad q;
    q.id = obj.id;
    q.origin_W = obj.corners_W[0];
    q.axis_u_W = obj.corners_W[1] - obj.corners_W[0];
    q.axis_v_W = obj.corners_W[3] - obj.corners_W[0];
    q.texture = obj.texture;
    q.tag_id = std::max(obj.tag_id, 0);
    q.seed = obj.texture_seed;
    q.offset_m = 0.0;
    quads.push_back(q);
  }
  return quads;
}

}  // namespace fsp::sim
