#include "fsp/sim/sequence_writer.h"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <regex>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "fsp/common/dataset.h"
#include "fsp/common/error.h"
#include "fsp/common/progress.h"
#include "fsp/common/time.h"
#include "fsp/common/trajectory_io.h"
#include "fsp/sim/imu_synth.h"

namespace fsp::sim {

namespace fs = std::filesystem;

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

// Shortest decimal that reads back to exactly V (deterministic, lossless).
std::string Num(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

std::string List(const double* v, int n) {
  std::string s = "[";
  for (int i = 0; i < n; ++i) s += (i ? ", " : "") + Num(v[i]);
  return s + "]";
}

// EuRoC's OpenCV-style matrix block.
std::string EurocMatrix(const Mat4& M) {
  double d[16];
  for (int i = 0; i < 16; ++i) d[i] = M(i / 4, i % 4);
  return "  cols: 4\n  rows: 4\n  data: " + List(d, 16) + "\n";
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw InputError(path.string(), 0, "cannot write file");
}

void WriteCameraSensorYaml(const Scene& scene, const fs::path& path) {
  const PinholeRadtan& c = scene.camera;
  const double k[4] = {c.fx, c.fy, c.cx, c.cy};
  std::ostringstream os;
  os << "# General sensor definitions (EuRoC layout), written by fsp render from " << scene.path
     << "\n"
     << "sensor_type: camera\n"
     << "comment: rendered camera (pinhole, radial-tangential)\n"
     << "# Sensor extrinsics wrt. the body-frame (T_BS = T_B_C: camera -> body/IMU).\n"
     << "T_BS:\n"
     << EurocMatrix(scene.T_B_C.Matrix()) << "\n"
     << "# Camera specific definitions.\n"
     << "rate_hz: " << Num(scene.camera_rate_hz) << "\n"
     << "resolution: [" << c.width << ", " << c.height << "]\n"
     << "camera_model: pinhole\n"
     << "intrinsics: " << List(k, 4) << " # fu, fv, cu, cv\n"
     << "distortion_model: radial-tangential\n"
     << "distortion_coefficients: " << List(c.distortion.data(), 4) << "\n";
  WriteText(path, os.str());
}

void WriteImuSensorYaml(const Scene& scene, const fs::path& path) {
  const ImuNoise& n = scene.imu;
  std::ostringstream os;
  os << "# General sensor definitions (EuRoC layout), written by fsp render from " << scene.path
     << "\n"
     << "sensor_type: imu\n"
     << "comment: synthetic IMU (white noise + bias random walk, Kalibr densities)\n"
     << "# Sensor extrinsics wrt. the body-frame (the IMU is the body).\n"
     << "T_BS:\n"
     << EurocMatrix(Mat4::Identity()) << "\n"
     << "rate_hz: " << Num(n.rate_hz) << "\n"
     << "\n# inertial sensor noise model parameters (static)\n"
     << "gyroscope_noise_density: " << Num(n.gyroscope_noise_density)
     << "     # [ rad / s / sqrt(Hz) ]\n"
     << "gyroscope_random_walk: " << Num(n.gyroscope_random_walk)
     << "       # [ rad / s^2 / sqrt(Hz) ]\n"
     << "accelerometer_noise_density: " << Num(n.accelerometer_noise_density)
     << "  # [ m / s^2 / sqrt(Hz) ]\n"
     << "accelerometer_random_walk: " << Num(n.accelerometer_random_walk)
     << "    # [ m / s^3 / sqrt(Hz) ]\n";
  WriteText(path, os.str());
}

void WriteObjectsJson(const Scene& scene, const fs::path& path) {
  nlohmann::ordered_json objects = nlohmann::ordered_json::array();
  for (const SceneObject& o : scene.objects) {
    nlohmann::ordered_json j;
    j["id"] = o.id;
    j["class"] = o.class_name;
    nlohmann::ordered_json corners = nlohmann::ordered_json::array();
    for (const Vec3& c : o.corners_W) corners.push_back({c.x(), c.y(), c.z()});
    j["corners_W"] = corners;
    j["width"] = o.width();
    j["height"] = o.height();
    if (o.tag_id >= 0) j["tag_id"] = o.tag_id;
    const Mat4 T = o.T_W_O().Matrix();
    std::vector<double> t(16);
    for (int i = 0; i < 16; ++i) t[i] = T(i / 4, i % 4);
    j["T_W_O"] = t;
    objects.push_back(j);
  }
  nlohmann::ordered_json root;
  root["objects"] = objects;
  WriteText(path, root.dump(1) + "\n");
}

// SplitMix64 (Steele et al. 2014): a fast, well-mixed 64-bit generator, fully specified (unlike
// std::normal_distribution, whose algorithm varies between standard libraries).
uint64_t SplitMix64(uint64_t* state) {
  uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

cv::Scalar ClassColour(ObjectClass c) {  // BGR
  switch (c) {
    case ObjectClass::kDoor:
      return {30, 80, 150};
    case ObjectClass::kWindow:
      return {210, 140, 40};
    case ObjectClass::kCabinet:
      return {150, 60, 150};
    case ObjectClass::kPoster:
      return {50, 50, 220};
    case ObjectClass::kTag:
      return {20, 20, 20};
    case ObjectClass::kUnknown:
      break;
  }
  return {128, 128, 128};
}

}  // namespace

// n = (sum of four uniforms - 2) * sqrt(3): one SplitMix64 draw split into four 16-bit parts.
void AddPixelNoise(double sigma, uint32_t seed, int k, cv::Mat* image) {
  if (sigma <= 0.0) return;
  std::seed_seq seq{seed, 2u, static_cast<uint32_t>(k)};
  uint32_t words[2];
  seq.generate(words, words + 2);
  uint64_t state = (static_cast<uint64_t>(words[0]) << 32) | words[1];
  constexpr float kInv16 = 1.0f / 65536.0f;
  const float scale = static_cast<float>(sigma * std::sqrt(3.0));
  for (int r = 0; r < image->rows; ++r) {
    uint8_t* row = image->ptr<uint8_t>(r);
    for (int c = 0; c < image->cols; ++c) {
      const uint64_t z = SplitMix64(&state);
      const float sum = static_cast<float>((z & 0xffff) + ((z >> 16) & 0xffff) +
                                           ((z >> 32) & 0xffff) + (z >> 48));
      // Each 16-bit part is uniform on {0, ..., 65535}: (part + 0.5) / 65536 is centred on (0, 1).
      const float n = ((sum + 2.0f) * kInv16 - 2.0f) * scale;
      const float v = std::nearbyint(static_cast<float>(row[c]) + n);
      row[c] = static_cast<uint8_t>(std::clamp(v, 0.0f, 255.0f));
    }
  }
}

bool SequenceOptions::Check(std::string* why) const {
  if (threads < 1 || threads > 64) {
    if (why) *why = "threads must be in 1..64";
    return false;
  }
  return true;
}

std::vector<int64_t> FrameTimes(const Scene& scene) {
  std::vector<int64_t> times;
  const int64_t end_ns = SecondsToNs(scene.duration_s);
  for (int64_t k = 0;; ++k) {
    const int64_t t = SampleTimeNs(k, scene.camera_rate_hz);
    if (t >= end_ns) break;
    times.push_back(t);
  }
  return times;
}

std::vector<CornerRow> ProjectObjects(const Scene& scene, const Renderer* renderer,
                                      const Rigid3& T_W_C, int64_t t_ns) {
  const PinholeRadtan& cam = scene.camera;
  const Rigid3 T_C_W = T_W_C.Inverse();
  const Vec3 c_W = T_W_C.translation();
  std::vector<CornerRow> rows;
  for (const SceneObject& o : scene.objects) {
    // The visible face (normal z_O = x_O cross y_O) must point at the camera.
    const Vec3 n_W = (o.corners_W[1] - o.corners_W[0]).cross(o.corners_W[3] - o.corners_W[0]);
    if (n_W.dot(c_W - o.corners_W[0]) <= 0.0) continue;
    std::array<Vec3, 4> p_C;
    bool in_front = true;
    for (int j = 0; j < 4; ++j) {
      p_C[j] = T_C_W * o.corners_W[j];
      in_front = in_front && p_C[j].z() >= 0.01;
    }
    if (!in_front) continue;
    CornerRow row;
    row.t_ns = t_ns;
    row.object_id = o.id;
    Vec2 lo = Vec2::Constant(1e300), hi = Vec2::Constant(-1e300);
    for (int j = 0; j < 4; ++j) {
      row.corners[j] = cam.ProjectIdeal(p_C[j]);
      lo = lo.cwiseMin(row.corners[j]);
      hi = hi.cwiseMax(row.corners[j]);
    }
    // Bounding box against the image (pixel centres 0..w-1, so the image spans -0.5..w-0.5).
    if (hi.x() < -0.5 || hi.y() < -0.5 || lo.x() > cam.width - 0.5 || lo.y() > cam.height - 0.5)
      continue;
    for (int j = 0; j < 4; ++j) {
      row.visible[j] = cam.InImage(cam.Project(p_C[j])) &&
                       (renderer == nullptr || renderer->PointVisible(T_W_C, o.corners_W[j], o.id));
    }
    rows.push_back(row);
  }
  return rows;
}

cv::Mat DrawTopView(const Scene& scene, int width_px) {
  // World extent: the room, else the objects and the trajectory.
  Vec2 lo = Vec2::Constant(1e300), hi = Vec2::Constant(-1e300);
  auto grow = [&](const Vec3& p) {
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  };
  if (scene.room) {
    grow(scene.room->min_W);
    grow(scene.room->max_W);
  }
  for (const SceneObject& o : scene.objects) {
    for (const Vec3& c : o.corners_W) grow(c);
  }
  const double t_end = std::min(scene.duration_s, scene.trajectory.t_end());
  std::vector<double> times;
  for (double t = 0.0; t <= t_end + 1e-9; t += 0.05) times.push_back(std::min(t, t_end));
  std::vector<Rigid3> poses;
  for (double t : times) {
    poses.push_back(scene.trajectory.Pose(t));
    grow(poses.back().translation());
  }
  const Vec2 span = (hi - lo).cwiseMax(Vec2(1.0, 1.0));
  const int margin = 70, bar_w = 140, title_h = 60;
  const double scale = (width_px - 2 * margin - bar_w) / span.x();
  const int height_px = static_cast<int>(span.y() * scale) + 2 * margin + title_h;
  cv::Mat img(height_px, width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  auto px = [&](const Vec3& p) {
    return cv::Point(static_cast<int>(std::lround(margin + (p.x() - lo.x()) * scale)),
                     static_cast<int>(std::lround(height_px - margin - (p.y() - lo.y()) * scale)));
  };
  const int font = cv::FONT_HERSHEY_SIMPLEX;

  // 1 m grid with labels.
  auto label = [](double v) { return std::to_string(static_cast<long>(std::lround(v))); };
  for (double x = std::ceil(lo.x()); x <= hi.x() + 1e-9; x += 1.0) {
    cv::line(img, px(Vec3(x, lo.y(), 0)), px(Vec3(x, hi.y(), 0)), cv::Scalar(230, 230, 230), 1);
    cv::putText(img, label(x), px(Vec3(x, lo.y(), 0)) + cv::Point(-6, 22), font, 0.45,
                cv::Scalar(120, 120, 120), 1, cv::LINE_AA);
  }
  for (double y = std::ceil(lo.y()); y <= hi.y() + 1e-9; y += 1.0) {
    cv::line(img, px(Vec3(lo.x(), y, 0)), px(Vec3(hi.x(), y, 0)), cv::Scalar(230, 230, 230), 1);
    cv::putText(img, label(y), px(Vec3(lo.x(), y, 0)) + cv::Point(-30, 5), font, 0.45,
                cv::Scalar(120, 120, 120), 1, cv::LINE_AA);
  }
  cv::putText(img, "x [m]", px(Vec3(hi.x(), lo.y(), 0)) + cv::Point(-40, 45), font, 0.5,
              cv::Scalar(80, 80, 80), 1, cv::LINE_AA);
  cv::putText(img, "y [m]", px(Vec3(lo.x(), hi.y(), 0)) + cv::Point(-62, -12), font, 0.5,
              cv::Scalar(80, 80, 80), 1, cv::LINE_AA);
  if (scene.room) {
    cv::rectangle(img, px(scene.room->min_W), px(scene.room->max_W), cv::Scalar(0, 0, 0), 3);
  }

  // Trajectory coloured by time (turbo colour map), heading ticks every 2 s, start and end marks.
  cv::Mat ramp(1, 256, CV_8UC1), lut;
  for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(i);
  cv::applyColorMap(ramp, lut, cv::COLORMAP_TURBO);
  auto colour_at = [&](double t) {
    const int i =
        std::clamp(static_cast<int>(std::lround(255.0 * t / std::max(t_end, 1e-9))), 0, 255);
    const cv::Vec3b c = lut.at<cv::Vec3b>(0, i);
    return cv::Scalar(c[0], c[1], c[2]);
  };
  for (size_t i = 1; i < poses.size(); ++i) {
    cv::line(img, px(poses[i - 1].translation()), px(poses[i].translation()), colour_at(times[i]),
             3, cv::LINE_AA);
  }
  for (double t = 0.0; t <= t_end; t += 2.0) {
    const Rigid3 T_W_C = scene.trajectory.Pose(t) * scene.T_B_C;
    Vec3 fwd = T_W_C.R().col(2);
    fwd.z() = 0.0;
    if (fwd.norm() < 1e-6) continue;
    const Vec3 p = T_W_C.translation();
    cv::arrowedLine(img, px(p), px(p + 0.4 * fwd.normalized()), colour_at(t), 2, cv::LINE_AA, 0,
                    0.3);
  }
  const cv::Point start = px(poses.front().translation()), end = px(poses.back().translation());
  cv::circle(img, start, 9, cv::Scalar(0, 160, 0), cv::FILLED, cv::LINE_AA);
  cv::circle(img, start, 9, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  cv::putText(img, "start", start + cv::Point(12, -10), font, 0.55, cv::Scalar(0, 120, 0), 2,
              cv::LINE_AA);
  cv::rectangle(img, end - cv::Point(7, 7), end + cv::Point(7, 7), cv::Scalar(0, 0, 0), 2);
  cv::putText(img, "end", end + cv::Point(10, 18), font, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);

  // Objects: their footprint (a segment for a vertical rectangle), label "id class" pushed into the
  // room along the face normal, further out while it would overlap an earlier label.
  std::vector<cv::Rect> labels;
  for (const SceneObject& o : scene.objects) {
    std::vector<cv::Point> poly;
    for (const Vec3& c : o.corners_W) poly.push_back(px(c));
    const cv::Scalar colour = ClassColour(o.object_class);
    cv::polylines(img, poly, true, colour, 5, cv::LINE_AA);
    const Vec3 centre = 0.25 * (o.corners_W[0] + o.corners_W[1] + o.corners_W[2] + o.corners_W[3]);
    Vec3 n = o.T_W_O().R().col(2);
    n.z() = 0.0;
    n = n.norm() > 1e-6 ? n.normalized() : Vec3::Zero();
    const std::string text = std::to_string(o.id) + " " + o.class_name;
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, font, 0.42, 1, &baseline);
    // Box centre at gap + half the box's extent along the (image) normal, so the box clears the
    // wall.
    const Vec2 n_px(n.x(), -n.y());
    const double half_extent =
        0.5 * (std::abs(n_px.x()) * size.width + std::abs(n_px.y()) * size.height);
    cv::Rect box;
    for (int step = 0; step < 12; ++step) {
      const double d = 12.0 + half_extent + step * (size.height + 6);
      const cv::Point c = px(centre) + cv::Point(static_cast<int>(std::lround(n_px.x() * d)),
                                                 static_cast<int>(std::lround(n_px.y() * d)));
      box =
          cv::Rect(c.x - size.width / 2, c.y - size.height / 2, size.width, size.height + baseline);
      bool overlaps = false;
      for (const cv::Rect& r : labels) overlaps = overlaps || (r & box).area() > 0;
      if (!overlaps) break;
    }
    labels.push_back(box);
    cv::putText(img, text, cv::Point(box.x, box.y + size.height), font, 0.42, colour, 1,
                cv::LINE_AA);
  }

  // Title, class legend, time colour bar.
  const std::string name = fs::path(scene.path).filename().string();
  cv::putText(img,
              "top view: " + name + "  (" + Num(scene.duration_s) + " s, " +
                  std::to_string(scene.objects.size()) + " objects)",
              cv::Point(margin, 32), font, 0.7, cv::Scalar(0, 0, 0), 2, cv::LINE_AA);
  const int bar_x = width_px - bar_w + 20, bar_top = title_h + margin,
            bar_h = height_px - title_h - 2 * margin;
  for (int i = 0; i < bar_h; ++i) {
    const double t = t_end * (1.0 - static_cast<double>(i) / std::max(bar_h - 1, 1));
    cv::line(img, cv::Point(bar_x, bar_top + i), cv::Point(bar_x + 20, bar_top + i), colour_at(t),
             1);
  }
  cv::putText(img, "time [s]", cv::Point(bar_x - 10, bar_top - 12), font, 0.5, cv::Scalar(0, 0, 0),
              1, cv::LINE_AA);
  for (int k = 0; k <= 4; ++k) {
    const double t = t_end * k / 4.0;
    const int y = bar_top + static_cast<int>((bar_h - 1) * (1.0 - k / 4.0));
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.0f", t);
    cv::putText(img, buf, cv::Point(bar_x + 26, y + 5), font, 0.45, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
  }
  int legend_x = margin + 520;
  for (ObjectClass c : {ObjectClass::kDoor, ObjectClass::kWindow, ObjectClass::kCabinet,
                        ObjectClass::kPoster, ObjectClass::kTag}) {
    cv::line(img, cv::Point(legend_x, 48), cv::Point(legend_x + 22, 48), ClassColour(c), 5);
    cv::putText(img, ToString(c), cv::Point(legend_x + 28, 53), font, 0.45, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
    legend_x += 100;
  }
  return img;
}

SequenceSummary WriteSequence(const Scene& scene, const std::string& out_dir,
                              const SequenceOptions& options) {
  std::string why;
  FSP_CHECK(options.Check(&why));
  if (scene.trajectory.t_end() < scene.duration_s) {
    throw InputError(scene.path, 0,
                     "trajectory ends at t = " + Num(scene.trajectory.t_end()) +
                         " s, before the duration " + Num(scene.duration_s) + " s");
  }
  SequenceSummary summary;
  const fs::path out(out_dir), mav0 = out / "mav0", cam0 = mav0 / "cam0", data = cam0 / "data",
                               imu0 = mav0 / "imu0", gt0 = mav0 / "state_groundtruth_estimate0";
  std::error_code ec;
  for (const fs::path& d : {data, imu0, gt0}) {
    fs::create_directories(d, ec);
    if (ec) throw InputError(d.string(), 0, "cannot create directory: " + ec.message());
  }
  // Stale frames of an earlier render would confuse readers that list the folder.
  static const std::regex kFrameName("[0-9]+\\.png");
  for (const auto& entry : fs::directory_iterator(data)) {
    if (std::regex_match(entry.path().filename().string(), kFrameName))
      fs::remove(entry.path(), ec);
  }

  // IMU and ground truth at the IMU times.
  const int64_t end_ns = SecondsToNs(scene.duration_s);
  ImuSynthOptions imu_options;
  imu_options.noise = scene.imu;
  imu_options.gyro_bias0 = scene.gyro_bias0;
  imu_options.acc_bias0 = scene.acc_bias0;
  std::seed_seq imu_seq{scene.seed, 1u};
  std::mt19937 imu_rng(imu_seq);
  const ImuSequence imu = SynthesizeImu(scene.trajectory, end_ns, imu_options, &imu_rng);
  std::vector<StateSample> states;
  states.reserve(imu.samples.size());
  for (size_t k = 0; k < imu.samples.size(); ++k) {
    const TrajectoryState s = scene.trajectory.State(NsToSeconds(imu.samples[k].t_ns));
    StateSample st;
    st.t_ns = imu.samples[k].t_ns;
    st.T_W_B = s.T_W_B;
    st.v_W = s.v_W;
    st.gyro_bias = imu.gyro_bias[k];
    st.acc_bias = imu.acc_bias[k];
    states.push_back(st);
    summary.max_speed_mps = std::max(summary.max_speed_mps, s.v_W.norm());
    summary.max_acc_mps2 = std::max(summary.max_acc_mps2, s.a_W.norm());
    summary.max_rate_dps = std::max(summary.max_rate_dps, s.w_B.norm() * kRadToDeg);
  }
  summary.imu_samples = static_cast<int>(imu.samples.size());
  WriteImuCsv(imu.samples, (imu0 / "data.csv").string());
  WriteImuCsv(imu.samples, (out / "imu.csv").string());
  WriteImuSensorYaml(scene, imu0 / "sensor.yaml");
  WriteEurocGroundTruth(states, (gt0 / "data.csv").string());
  WriteCameraSensorYaml(scene, cam0 / "sensor.yaml");
  WriteCalibration(scene.MakeCalibration(), (out / "calib.yaml").string());
  WriteObjectsJson(scene, out / "objects_gt.json");
  summary.objects = static_cast<int>(scene.objects.size());

  // Ground-truth corner projections (occlusion through the renderer's ray casting).
  const Renderer renderer(scene.camera, SceneQuads(scene), scene.render);
  const std::vector<int64_t> frame_times = FrameTimes(scene);
  summary.frames = static_cast<int>(frame_times.size());
  auto camera_pose = [&](double t) { return scene.trajectory.Pose(t) * scene.T_B_C; };
  {
    std::vector<CornerRow> rows;
    for (int64_t t_ns : frame_times) {
      const std::vector<CornerRow> r =
          ProjectObjects(scene, &renderer, camera_pose(NsToSeconds(t_ns)), t_ns);
      rows.insert(rows.end(), r.begin(), r.end());
    }
    summary.observation_rows = static_cast<int>(rows.size());
    summary.fully_visible_rows = static_cast<int>(std::count_if(
        rows.begin(), rows.end(), [](const CornerRow& r) { return r.FullyVisible(); }));
    WriteCornerRows(rows, (out / "observations_gt.csv").string(), true);
  }

  if (options.top_view) {
    summary.top_view_path = (out / "top_view.png").string();
    if (!cv::imwrite(summary.top_view_path, DrawTopView(scene))) {
      throw InputError(summary.top_view_path, 0, "cannot write image");
    }
  }
  if (!options.images) {
    // No pixels: every frame listed with one grey placeholder, so that the sequence opens as a
    // recording for the front ends that read no pixels (gt-corners, corners).
    const std::string placeholder = "no_pixels.png";
    if (!cv::imwrite((data / placeholder).string(),
                     cv::Mat(scene.camera.height, scene.camera.width, CV_8UC1, cv::Scalar(128))))
      throw InputError((data / placeholder).string(), 0, "cannot write image");
    std::ostringstream csv;
    csv << "#timestamp [ns],filename\n";
    for (int64_t t : frame_times) csv << t << "," << placeholder << "\n";
    WriteText(cam0 / "data.csv", csv.str());
    return summary;
  }

  // Images: worker threads render frame k (pose at its time, or blurred over the exposure), add its
  // noise and write its PNG; this thread feeds the video in frame order. Workers stay at most
  // kAhead frames ahead of the video, which bounds memory.
  {
    std::ostringstream csv;
    csv << "#timestamp [ns],filename\n";
    for (int64_t t : frame_times) csv << t << "," << t << ".png\n";
    WriteText(cam0 / "data.csv", csv.str());
  }
  cv::VideoWriter video;
  const std::string video_path = (out / "video.mp4").string();
  if (options.video) {
    video.open(video_path, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), scene.camera_rate_hz,
               cv::Size(scene.camera.width, scene.camera.height), false);
    if (!video.isOpened())
      throw InputError(video_path, 0, "cannot open the video for writing (mp4v)");
  }
  const auto start = std::chrono::steady_clock::now();
  const int n = summary.frames;
  constexpr int kAhead = 16;
  std::mutex mutex;
  std::condition_variable cv_ready, cv_room;
  std::map<int, cv::Mat> ready;
  int next_video = 0;
  std::atomic<int> next_frame{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  const double half_exposure = 0.5 * scene.exposure_s;
  const bool blur = scene.exposure_s > 0.0 && scene.render.motion_blur_samples > 1;
  auto worker = [&]() {
    try {
      for (int k = next_frame++; k < n && !failed; k = next_frame++) {
        {
          std::unique_lock<std::mutex> lock(mutex);
          cv_room.wait(lock, [&] { return k < next_video + kAhead || failed; });
        }
        if (failed) break;
        const double t = NsToSeconds(frame_times[k]);
        cv::Mat image;
        if (blur) {
          const double t0 = std::max(0.0, t - half_exposure);
          const double t1 = std::min(scene.trajectory.t_end(), t + half_exposure);
          image = renderer.Render(camera_pose(t0), camera_pose(t1));
        } else {
          image = renderer.Render(camera_pose(t));
        }
        AddPixelNoise(scene.pixel_sigma, scene.seed, k, &image);
        const std::string png = (data / (std::to_string(frame_times[k]) + ".png")).string();
        if (!cv::imwrite(png, image)) throw InputError(png, 0, "cannot write image");
        {
          std::lock_guard<std::mutex> lock(mutex);
          ready[k] = image;
        }
        cv_ready.notify_all();
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex);
      if (!error) error = std::current_exception();
      failed = true;
      cv_ready.notify_all();
      cv_room.notify_all();
    }
  };
  std::vector<std::thread> threads;
  for (int i = 0; i < options.threads; ++i) threads.emplace_back(worker);
  {
    std::unique_ptr<Progress> progress;
    if (options.progress) progress = std::make_unique<Progress>("fsp render", n);
    for (int k = 0; k < n; ++k) {
      cv::Mat image;
      {
        std::unique_lock<std::mutex> lock(mutex);
        cv_ready.wait(lock, [&] { return ready.count(k) > 0 || failed; });
        if (failed) break;
        image = ready[k];
        ready.erase(k);
        next_video = k + 1;
      }
      cv_room.notify_all();
      if (options.video) video.write(image);
      if (progress) progress->Update(k + 1);
    }
  }
  for (std::thread& th : threads) th.join();
  if (error) std::rethrow_exception(error);
  video.release();
  summary.render_wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.render_fps = summary.render_wall_s > 0.0 ? n / summary.render_wall_s : 0.0;
  return summary;
}

}  // namespace fsp::sim
