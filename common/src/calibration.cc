#include "fsp/common/calibration.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <system_error>

#include "fsp/common/error.h"
#include "yaml_util.h"

namespace fsp {

namespace {

using internal::YamlFile;

bool PositiveFinite(double v) {
  return std::isfinite(v) && v > 0.0;
}

// Shortest decimal text that reads back to exactly V.
std::string Num(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

// 2^63 as a double: doubles in (-2^63, 2^63) convert to int64 exactly (they are integers there
// once rounded).
constexpr double kInt64Limit = 9223372036854775808.0;

// An integer number of nanoseconds: written as an integer (exact over all of int64), or in a
// floating-point form that is an integer within int64 ("1.5e9").
int64_t ParseNanoseconds(const YamlFile& f, const YAML::Node& node) {
  const std::string name = "time_offset_ns";
  if (node.IsScalar()) {
    const std::string& s = node.Scalar();
    int64_t v = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec == std::errc() && end == s.data() + s.size()) return v;
    if (ec == std::errc::result_out_of_range)
      f.Fail(node, "'" + name + "' is out of range (int64 nanoseconds): '" + s + "'");
  }
  const double v = f.Double(node, name);
  if (v != std::floor(v)) f.Fail(node, "'" + name + "' is not an integer");
  if (!(std::abs(v) < kInt64Limit))
    f.Fail(node, "'" + name + "' is out of range (int64 nanoseconds): '" + node.Scalar() + "'");
  return static_cast<int64_t>(v);
}

// The four Kalibr densities plus the rate ("rate_hz" in EuRoC/FSP files, "update_rate" in
// Kalibr's).
ImuNoise ParseImuNoise(const YamlFile& f, const YAML::Node& map) {
  ImuNoise n;
  n.gyroscope_noise_density =
      f.Double(f.Require(map, "gyroscope_noise_density"), "gyroscope_noise_density");
  n.accelerometer_noise_density =
      f.Double(f.Require(map, "accelerometer_noise_density"), "accelerometer_noise_density");
  n.gyroscope_random_walk =
      f.Double(f.Require(map, "gyroscope_random_walk"), "gyroscope_random_walk");
  n.accelerometer_random_walk =
      f.Double(f.Require(map, "accelerometer_random_walk"), "accelerometer_random_walk");
  if (map["rate_hz"])
    n.rate_hz = f.Double(map["rate_hz"], "rate_hz");
  else if (map["update_rate"])
    n.rate_hz = f.Double(map["update_rate"], "update_rate");
  std::string why;
  if (!n.Check(&why)) f.Fail(map, "IMU noise: " + why);
  return n;
}

// Rejects every model but pinhole + radial-tangential (or no distortion).
void CheckCameraModel(const YamlFile& f, const YAML::Node& cam, const char* model_key,
                      const char* dist_key) {
  const YAML::Node model = cam[model_key];
  const YAML::Node dist = cam[dist_key];
  const std::string m = model ? f.String(model, model_key) : "pinhole";
  const std::string d = dist ? f.String(dist, dist_key) : "radtan";
  const bool radtan = d == "radtan" || d == "radial-tangential" || d == "plumb_bob" || d == "none";
  if (m != "pinhole" || !radtan) {
    f.Fail(model ? model : cam,
           "unsupported camera model '" + m + "' with '" + d +
               "' distortion: fsp supports pinhole cameras with radial-tangential "
               "(radtan) distortion only");
  }
}

// Intrinsics [fu, fv, cu, cv] and resolution [w, h] (EuRoC and Kalibr share these keys).
void ParseIntrinsics(const YamlFile& f, const YAML::Node& cam, PinholeRadtan* camera) {
  const std::vector<double> k = f.Doubles(f.Require(cam, "intrinsics"), "intrinsics", 4);
  camera->fx = k[0];
  camera->fy = k[1];
  camera->cx = k[2];
  camera->cy = k[3];
  const YAML::Node res = f.Require(cam, "resolution");
  if (!res.IsSequence() || res.size() != 2) f.Fail(res, "'resolution' must be [width, height]");
  camera->width = f.Int(res[0], "resolution[0]");
  camera->height = f.Int(res[1], "resolution[1]");
}

void ParseDistortion(const YamlFile& f, const YAML::Node& node, const std::string& name,
                     PinholeRadtan* camera) {
  if (!node) return;  // no distortion
  if (node.IsSequence() && node.size() == 0) return;
  const std::vector<double> d = f.Doubles(node, name, 4);
  for (size_t i = 0; i < 4; ++i) camera->distortion[i] = d[i];
}

// EuRoC cam0/sensor.yaml.
void ParseEuroc(const YamlFile& f, bool check_model, Calibration* c) {
  const YAML::Node& root = f.root();
  c->T_B_C = f.Transform(f.Require(root, "T_BS"), "T_BS");
  if (!check_model) return;
  CheckCameraModel(f, root, "camera_model", "distortion_model");
  ParseIntrinsics(f, root, &c->camera);
  ParseDistortion(f, root["distortion_coefficients"], "distortion_coefficients", &c->camera);
  if (root["rate_hz"]) c->camera_rate_hz = f.Double(root["rate_hz"], "rate_hz");
}

// cam0's T_B_C from T_imu_cam, or T_cam_imu inverted.
Rigid3 ParseKalibrTBC(const YamlFile& f, const YAML::Node& cam) {
  if (cam["T_imu_cam"]) return f.Transform(cam["T_imu_cam"], "T_imu_cam");  // camera -> IMU already
  if (cam["T_cam_imu"]) {
    const Rigid3 T_B_C = f.Transform(cam["T_cam_imu"], "T_cam_imu").Inverse();  // T_C_B -> T_B_C
    if (!T_B_C.translation().allFinite())
      f.Fail(cam["T_cam_imu"], "'T_cam_imu' has a translation too large to invert");
    return T_B_C;
  }
  f.Fail(cam, "cam0 has neither T_imu_cam nor T_cam_imu");
}

// timeshift_cam_imu, and the IMU noise where a camchain may hold it: an imu0 block (Kalibr's
// imu-cam chain), or the four density keys inside cam0 or at the top (DM-VIO's camchains).
void ParseKalibrTimeshiftAndNoise(const YamlFile& f, const YAML::Node& cam, Calibration* c) {
  if (cam["timeshift_cam_imu"]) {
    const double ns = f.Double(cam["timeshift_cam_imu"], "timeshift_cam_imu") * 1e9;
    if (!(std::abs(ns) < kInt64Limit))
      f.Fail(cam["timeshift_cam_imu"], "'timeshift_cam_imu' is out of range (|t| < 9.2e9 s)");
    c->time_offset_ns = std::llround(ns);
  }
  const YAML::Node& root = f.root();
  YAML::Node noise;
  if (root["imu0"])
    noise = root["imu0"];
  else if (cam["gyroscope_noise_density"])
    noise = cam;
  else if (root["gyroscope_noise_density"])
    noise = root;
  if (noise.IsDefined() && !noise.IsNull()) {
    c->imu = ParseImuNoise(f, noise);
    c->imu_source = f.path();
  }
}

// Kalibr camchain: cam0 {T_imu_cam | T_cam_imu, camera_model, intrinsics, distortion_model,
// distortion_coeffs, resolution, timeshift_cam_imu}, IMU noise as ParseKalibrTimeshiftAndNoise.
void ParseKalibr(const YamlFile& f, bool check_model, Calibration* c) {
  const YAML::Node cam = f.Require(f.root(), "cam0");
  if (!cam.IsMap()) f.Fail(cam, "'cam0' is not a map");
  c->T_B_C = ParseKalibrTBC(f, cam);
  if (!check_model) return;
  CheckCameraModel(f, cam, "camera_model", "distortion_model");
  ParseIntrinsics(f, cam, &c->camera);
  ParseDistortion(f, cam["distortion_coeffs"], "distortion_coeffs", &c->camera);
  ParseKalibrTimeshiftAndNoise(f, cam, c);
}

// FSP's calib.yaml (format in calibration.h).
void ParseFsp(const YamlFile& f, bool check_model, Calibration* c) {
  const YAML::Node& root = f.root();
  c->T_B_C = f.Transform(f.Require(root, "T_B_C"), "T_B_C");
  if (!check_model) return;
  const YAML::Node cam = root["camera"];
  if (!cam.IsMap()) f.Fail(cam, "'camera' is not a map");
  c->camera.width = f.Int(f.Require(cam, "width"), "width");
  c->camera.height = f.Int(f.Require(cam, "height"), "height");
  c->camera.fx = f.Double(f.Require(cam, "fx"), "fx");
  c->camera.fy = f.Double(f.Require(cam, "fy"), "fy");
  c->camera.cx = f.Double(f.Require(cam, "cx"), "cx");
  c->camera.cy = f.Double(f.Require(cam, "cy"), "cy");
  ParseDistortion(f, cam["distortion"], "distortion", &c->camera);
  if (cam["rate_hz"]) c->camera_rate_hz = f.Double(cam["rate_hz"], "rate_hz");
  if (root["time_offset_ns"]) c->time_offset_ns = ParseNanoseconds(f, root["time_offset_ns"]);
  if (root["imu"]) {
    c->imu = ParseImuNoise(f, root["imu"]);
    c->imu_source = f.path();
  }
}

Calibration Parse(const std::string& path, bool check_model) {
  const YamlFile f(path, "calibration file");
  const YAML::Node& root = f.root();
  Calibration c;
  c.source = path;
  if (root["camera"]) {
    ParseFsp(f, check_model, &c);
  } else if (root["cam0"]) {
    ParseKalibr(f, check_model, &c);
  } else if (root["intrinsics"] || root["T_BS"]) {
    ParseEuroc(f, check_model, &c);
  } else {
    const bool imu_only = root["imu0"] || root["gyroscope_noise_density"] || root["imu"];
    f.Fail(
        root,
        std::string(imu_only ? "holds only an IMU calibration; " : "") +
            "not a camera calibration: expected an EuRoC sensor.yaml (T_BS, intrinsics), a Kalibr "
            "camchain (cam0:) or an fsp calib.yaml (camera:, T_B_C:)");
  }
  if (check_model) {
    std::string why;
    if (!c.Check(&why)) throw InputError(path, 0, why);
  }
  return c;
}

}  // namespace

bool ImuNoise::Check(std::string* why) const {
  std::string w;
  if (!PositiveFinite(gyroscope_noise_density))
    w = "gyroscope_noise_density must be positive";
  else if (!PositiveFinite(accelerometer_noise_density))
    w = "accelerometer_noise_density must be positive";
  else if (!PositiveFinite(gyroscope_random_walk))
    w = "gyroscope_random_walk must be positive";
  else if (!PositiveFinite(accelerometer_random_walk))
    w = "accelerometer_random_walk must be positive";
  else if (!PositiveFinite(rate_hz))
    w = "IMU rate_hz must be positive";
  if (why) *why = w;
  return w.empty();
}

bool Calibration::Check(std::string* why) const {
  std::string w;
  if (!camera.Check(&w)) {
    w = "camera: " + w;
  } else if (!T_B_C.Matrix().allFinite()) {
    w = "T_B_C is not finite";
  } else if (!PositiveFinite(camera_rate_hz)) {
    w = "camera rate_hz must be positive";
  } else if (!imu.Check(&w)) {
    w = "imu: " + w;
  }
  if (why) *why = w;
  return w.empty();
}

Calibration ReadCalibration(const std::string& path) {
  return Parse(path, true);
}

Rigid3 ReadCameraExtrinsics(const std::string& path) {
  return Parse(path, false).T_B_C;
}

Calibration ReadKalibrCameraImu(const std::string& path) {
  const YamlFile f(path, "camera-IMU calibration (camchain)");
  const YAML::Node cam = f.Require(f.root(), "cam0");
  if (!cam.IsMap()) f.Fail(cam, "'cam0' is not a map");
  Calibration c;
  c.source = path;
  c.T_B_C = ParseKalibrTBC(f, cam);
  ParseKalibrTimeshiftAndNoise(f, cam, &c);
  return c;
}

ImuNoise ReadImuNoise(const std::string& path) {
  const YamlFile f(path, "IMU calibration file");
  const YAML::Node& root = f.root();
  if (root["imu"]) return ParseImuNoise(f, root["imu"]);
  if (root["imu0"]) return ParseImuNoise(f, root["imu0"]);
  if (root["gyroscope_noise_density"]) return ParseImuNoise(f, root);
  f.Fail(root,
         "no IMU noise: expected an EuRoC imu0/sensor.yaml (gyroscope_noise_density, ...), a "
         "Kalibr imu "
         "chain (imu0:) or an fsp calib.yaml (imu:)");
}

void WriteCalibration(const Calibration& calib, const std::string& path) {
  const PinholeRadtan& cam = calib.camera;
  const ImuNoise& imu = calib.imu;
  std::ostringstream os;
  os << "# fsp calibration (format: common/include/fsp/common/calibration.h)\n"
     << "camera:\n"
     << "  width: " << cam.width << "\n"
     << "  height: " << cam.height << "\n"
     << "  fx: " << Num(cam.fx) << "\n"
     << "  fy: " << Num(cam.fy) << "\n"
     << "  cx: " << Num(cam.cx) << "\n"
     << "  cy: " << Num(cam.cy) << "\n"
     << "  distortion: [" << Num(cam.distortion[0]) << ", " << Num(cam.distortion[1]) << ", "
     << Num(cam.distortion[2]) << ", " << Num(cam.distortion[3]) << "]  # k1, k2, p1, p2\n"
     << "  rate_hz: " << Num(calib.camera_rate_hz) << "\n"
     << "# camera -> body (IMU), row-major 4x4: p_B = T_B_C * p_C\n"
     << "T_B_C: [";
  const Mat4 M = calib.T_B_C.Matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) os << Num(M(r, c)) << (c < 3 ? ", " : r < 3 ? "," : "");
    if (r < 3) os << "\n        ";
  }
  os << "]\n"
     << "time_offset_ns: " << calib.time_offset_ns << "  # t_imu = t_cam + time_offset_ns\n"
     << "imu:\n"
     << "  rate_hz: " << Num(imu.rate_hz) << "\n"
     << "  gyroscope_noise_density: " << Num(imu.gyroscope_noise_density)
     << "      # [rad/s/sqrt(Hz)]\n"
     << "  accelerometer_noise_density: " << Num(imu.accelerometer_noise_density)
     << "  # [m/s^2/sqrt(Hz)]\n"
     << "  gyroscope_random_walk: " << Num(imu.gyroscope_random_walk)
     << "        # [rad/s^2/sqrt(Hz)]\n"
     << "  accelerometer_random_walk: " << Num(imu.accelerometer_random_walk)
     << "    # [m/s^3/sqrt(Hz)]\n";
  std::ofstream out(path);
  if (!out) throw InputError(path, 0, "cannot write calibration file");
  out << os.str();
  if (!out) throw InputError(path, 0, "error while writing calibration file");
}

}  // namespace fsp
