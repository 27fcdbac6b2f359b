#include "fsp/sim/cslam_flight.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "fsp/common/csv.h"
#include "fsp/common/error.h"
#include "fsp/common/trajectory_io.h"

namespace fsp::sim {
namespace {

constexpr char kLandmarks[] = "LandmarksGT.log";
constexpr char kPoses[] = "PoseSE3(W)_GT.log";

// The project's corner order for a rectangle whose front faces TOWARDS: y along the world's up
// direction projected onto the plane, x = y × n (so z = x × y = n points at the viewer), s1 the
// corner lowest along both.
std::array<Vec3, 4> OrderCorners(const std::array<Vec3, 4>& p, const Vec3& towards) {
  const Vec3 centre = 0.25 * (p[0] + p[1] + p[2] + p[3]);
  Vec3 n = (p[1] - p[0]).cross(p[3] - p[0]).normalized();
  if (n.dot(towards - centre) < 0.0) n = -n;
  Vec3 up = Vec3::UnitZ() - Vec3::UnitZ().dot(n) * n;
  // A horizontal rectangle has no up: take the world's y instead (none in the authors' logs).
  if (up.norm() < 1e-6) up = Vec3::UnitY() - Vec3::UnitY().dot(n) * n;
  up.normalize();
  const Vec3 x = up.cross(n);
  auto best = [&](double sx, double sy) {
    int k = 0;
    for (int j = 1; j < 4; ++j) {
      const Vec3 dj = p[j] - centre, dk = p[k] - centre;
      if (sx * dj.dot(x) + sy * dj.dot(up) > sx * dk.dot(x) + sy * dk.dot(up)) k = j;
    }
    return p[k];
  };
  return {best(-1, -1), best(1, -1), best(1, 1), best(-1, 1)};
}

ObjectClass ClassOf(const std::array<Vec3, 4>& s) {
  const double width = (s[1] - s[0]).norm(), height = (s[3] - s[0]).norm();
  const double lowest = std::min({s[0].z(), s[1].z(), s[2].z(), s[3].z()});
  if (lowest > 0.3) return ObjectClass::kWindow;
  return height >= 1.8 && width <= 1.2 ? ObjectClass::kDoor : ObjectClass::kCabinet;
}

std::vector<StampedPose> ReadPoses(const std::string& path) {
  TableReader in(path, "C-SLAM pose log");
  std::vector<std::string> f;
  std::vector<StampedPose> poses;
  while (in.NextRow(&f)) {
    if (!f.empty() && !f[0].empty() && f[0][0] == '%') continue;  // the ROS dump's header
    in.ExpectColumns(f, 10, 1000);
    StampedPose p;
    p.t_ns = in.Int64(f, 2, "field.header.stamp");
    const Vec3 t(in.Double(f, 3, "x"), in.Double(f, 4, "y"), in.Double(f, 5, "z"));
    const Quat q(in.Double(f, 9, "qw"), in.Double(f, 6, "qx"), in.Double(f, 7, "qy"),
                 in.Double(f, 8, "qz"));
    if (std::abs(q.norm() - 1.0) > 1e-3) in.Fail("the quaternion is not of unit length");
    if (!poses.empty() && p.t_ns <= poses.back().t_ns) in.Fail("time does not increase");
    p.T_W_B = Rigid3(q, t);
    poses.push_back(p);
  }
  if (poses.size() < 2) throw InputError(path, 0, "fewer than 2 poses");
  return poses;
}

}  // namespace

PinholeRadtan CslamCamera() {
  PinholeRadtan c;
  c.width = 640;
  c.height = 360;
  c.fx = 460.890258789062;
  c.fy = 529.505432128906;
  c.cx = 343.462058902507;
  c.cy = 201.160554159542;
  return c;
}

CslamFlight ReadCslamFlight(const std::string& folder) {
  const std::string landmarks = (std::filesystem::path(folder) / kLandmarks).string();
  CslamFlight flight;
  flight.poses = ReadPoses((std::filesystem::path(folder) / kPoses).string());
  Vec3 mean = Vec3::Zero();
  for (const StampedPose& p : flight.poses) mean += p.T_W_B.translation();
  mean /= static_cast<double>(flight.poses.size());

  TableReader in(landmarks, "C-SLAM landmark log");
  std::vector<std::string> f;
  while (in.NextRow(&f)) {
    std::vector<double> v;
    for (size_t i = 0; i < f.size(); ++i) {
      if (!f[i].empty()) v.push_back(in.Double(f, i, "corner coordinate"));
    }
    if (v.size() != 12) in.Fail("expected 4 corners of 3 numbers, got " + std::to_string(v.size()));
    std::array<Vec3, 4> p;
    for (int j = 0; j < 4; ++j) p[j] = Vec3(v[3 * j], v[3 * j + 1], v[3 * j + 2]);
    for (int j = 0; j < 4; ++j) {
      const Vec3 a = p[(j + 1) % 4] - p[j], b = p[(j + 3) % 4] - p[j];
      if (a.norm() < 0.01 || b.norm() < 0.01) in.Fail("a side shorter than 1 cm");
      if (std::abs(a.normalized().dot(b.normalized())) > 1e-3)
        in.Fail("the corners are not a rectangle (sides not at right angles)");
    }
    SceneObject o;
    o.id = static_cast<int>(flight.objects.size()) + 1;
    o.corners_W = OrderCorners(p, mean);
    o.object_class = ClassOf(o.corners_W);
    o.class_name = ToString(o.object_class);
    o.line = in.line();
    flight.objects.push_back(o);
  }
  if (flight.objects.empty()) throw InputError(landmarks, 0, "no rectangle");
  return flight;
}

std::string WriteCslamScene(const CslamFlight& flight, const std::string& out_dir) {
  std::filesystem::create_directories(out_dir);
  const std::filesystem::path dir(out_dir);
  WriteTum(flight.poses, (dir / "paper_flight_poses.tum").string());

  Vec3 lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
  for (const SceneObject& o : flight.objects) {
    for (const Vec3& c : o.corners_W) {
      lo = lo.cwiseMin(c);
      hi = hi.cwiseMax(c);
    }
  }
  for (const StampedPose& p : flight.poses) {
    lo = lo.cwiseMin(p.T_W_B.translation());
    hi = hi.cwiseMax(p.T_W_B.translation());
  }
  lo.z() = std::min(lo.z(), 0.0);
  hi.z() = std::max(hi.z() + 0.5, 3.0);

  const PinholeRadtan cam = CslamCamera();
  const double duration_s =
      1e-9 * static_cast<double>(flight.poses.back().t_ns - flight.poses.front().t_ns);
  const std::string path = (dir / "paper_flight.yaml").string();
  std::ofstream out(path);
  if (!out) throw InputError(path, 0, "cannot write the scene file");
  char buf[512];
  out << "# The seed paper's experiment (C-SLAM's ground-truth logs, converted by fsp "
         "convert-cslam):\n"
         "# the authors' 22 rectangles and their hexacopter flight (20 s resting on the floor "
         "first),\n"
         "# the authors' camera K (640 x 360, non-square pixels) at 10 Hz looking forward, IMU at\n"
         "# 100 Hz with the default room's noise.\n";
  std::snprintf(buf, sizeof(buf),
                "camera: {width: %d, height: %d, fx: %.12g, fy: %.12g, cx: %.12g, cy: %.12g, "
                "rate_hz: %g}\n",
                cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy, kCslamCameraRateHz);
  out << buf;
  out << "imu: {rate_hz: 100, gyroscope_noise_density: 1.7e-4, accelerometer_noise_density: "
         "2.0e-3,\n"
         "      gyroscope_random_walk: 1.9e-5, accelerometer_random_walk: 3.0e-3,\n"
         "      gyroscope_bias: [0.002, -0.001, 0.0015], accelerometer_bias: [0.03, -0.02, "
         "0.04]}\n";
  std::snprintf(buf, sizeof(buf), "room: {min: [%.6f, %.6f, %.6f], max: [%.6f, %.6f, %.6f]}\n",
                lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z());
  out << buf << "objects:\n";
  for (const SceneObject& o : flight.objects) {
    out << "  - {id: " << o.id << ", class: " << o.class_name << ", corners: [";
    for (int j = 0; j < 4; ++j) {
      std::snprintf(buf, sizeof(buf), "%s[%.9f, %.9f, %.9f]", j ? ", " : "", o.corners_W[j].x(),
                    o.corners_W[j].y(), o.corners_W[j].z());
      out << buf;
    }
    out << "]}\n";
  }
  std::snprintf(buf, sizeof(buf), "%.2f", std::floor(duration_s * 100.0) / 100.0);
  out << "trajectory: {file: paper_flight_poses.tum}\n"
         "noise: {pixel_sigma: 1.0, seed: 1}\n"
         "duration_s: "
      << buf << "\n";
  if (!out) throw InputError(path, 0, "cannot write the scene file");
  return path;
}

}  // namespace fsp::sim
