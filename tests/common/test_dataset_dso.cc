// The DSO / TUM-VI / DM-VIO layout (cam0/{times.txt, camera.txt, images/}, imu.txt, camchain.yaml)
// on tiny folders written here, camera.txt's forms, and its bad input (one line naming the file).
#include <algorithm>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dataset_fixtures.h"
#include "fsp/common/dataset.h"
#include "test_util.h"

namespace fsp {
namespace {

namespace fs = std::filesystem;
using test::ErrorOf;

std::unique_ptr<Source> Open(const fs::path& dir) {
  SourceOptions opts;
  opts.input = dir.string();
  return OpenSource(opts);
}

std::string OpenError(const fs::path& dir) {
  return ErrorOf([&] { Open(dir); });
}

PinholeRadtan CameraFrom(const std::string& text) {
  const fs::path p = test::ScratchRoot() / "dso_camera" / "camera.txt";
  test::WriteText(p, text);
  return ReadDsoCamera(p.string());
}

std::string CameraError(const std::string& text) {
  const fs::path p = test::ScratchRoot() / "dso_camera" / "camera.txt";
  test::WriteText(p, text);
  return ErrorOf([&] { ReadDsoCamera(p.string()); });
}

// Replaces line LINE (1-based) of P with TEXT.
void ReplaceLine(const fs::path& p, int line, const std::string& text) {
  const std::string all = test::ReadText(p);
  std::string out;
  size_t start = 0;
  for (int i = 1; start < all.size(); ++i) {
    const size_t end = all.find('\n', start);
    out += (i == line ? text : all.substr(start, end - start)) + "\n";
    start = end + 1;
  }
  test::WriteText(p, out);
}

// A time offset given with the source (the run config's camera.time_offset_s) replaces the
// calibration's: the frames move by it, the IMU does not.
TEST(DsoLayout, TimeOffsetOverrideMovesTheFrames) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = test::MakeDso(dir);
  SourceOptions o;
  o.input = dir.string();
  o.time_offset_ns = -45'000'000;
  const auto src = OpenSource(o);
  EXPECT_EQ(src->calibration().time_offset_ns, -45'000'000);
  ASSERT_EQ(src->frame_times().size(), t.size());
  for (size_t i = 0; i < t.size(); ++i) EXPECT_EQ(src->frame_times()[i], t[i] - 45'000'000);
  EXPECT_EQ(src->imu().front().t_ns, t.front() - 20'000'000);
}

// Frames, IMU, K, T_B_C and the IMU noise of a DM-VIO-style folder.
TEST(DsoLayout, ReadsFramesImuCameraAndCamchain) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = test::MakeDso(dir);
  auto src = Open(dir);
  EXPECT_EQ(src->kind(), InputKind::kDso);
  EXPECT_STREQ(ToString(src->kind()), "dso");
  // The ids are the times in nanoseconds (times.txt's seconds are rounded to the microsecond).
  EXPECT_EQ(src->frame_times(), t);
  ASSERT_EQ(src->imu().size(), 39u);  // 200 Hz over 150 ms + 2 x 20 ms
  EXPECT_EQ(src->imu().front().t_ns, t.front() - 20'000'000);
  EXPECT_DOUBLE_EQ(src->imu().front().gyro.y(), -0.02);
  EXPECT_DOUBLE_EQ(src->imu().front().acc.z(), 9.81);

  const Calibration& c = src->calibration();
  EXPECT_EQ(c.camera.width, test::kW);
  EXPECT_EQ(c.camera.height, test::kH);
  EXPECT_DOUBLE_EQ(c.camera.fx, 30.0);
  EXPECT_DOUBLE_EQ(c.camera.fy, 31.0);
  EXPECT_DOUBLE_EQ(c.camera.cx, 15.5);
  EXPECT_DOUBLE_EQ(c.camera.cy, 11.5);
  EXPECT_FALSE(c.camera.HasDistortion());
  EXPECT_NEAR(c.camera_rate_hz, 20.0, 1e-9);  // the median frame interval
  // T_cam_imu is T_C_B: T_B_C is its inverse.
  Mat4 T_C_B;
  T_C_B << 0, -1, 0, 0.01, 1, 0, 0, 0.02, 0, 0, 1, 0.03, 0, 0, 0, 1;
  EXPECT_LT((c.T_B_C.Matrix() - Mat4(T_C_B.inverse())).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(c.time_offset_ns, 0);
  EXPECT_DOUBLE_EQ(c.imu.gyroscope_noise_density, 3.7425273003024506e-05);
  EXPECT_DOUBLE_EQ(c.imu.accelerometer_noise_density, 0.1829589017330412);
  EXPECT_DOUBLE_EQ(c.imu.gyroscope_random_walk, 2.5996760318842082e-06);
  EXPECT_DOUBLE_EQ(c.imu.accelerometer_random_walk, 0.024480362284765463);
  EXPECT_EQ(c.imu_source, (dir / "camchain.yaml").string());
  EXPECT_NE(c.source.find("camera.txt"), std::string::npos) << c.source;

  const Frame f2 = src->ReadFrame(2);
  EXPECT_EQ(f2.source, (dir / "cam0" / "images" / (std::to_string(t[2]) + ".png")).string());
  EXPECT_EQ(cv::norm(f2.image, test::TestImage(2), cv::NORM_INF), 0.0);
  int frames = 0, samples = 0;
  while (auto m = src->Next()) (std::holds_alternative<Frame>(*m) ? frames : samples)++;
  EXPECT_EQ(frames, 4);
  EXPECT_EQ(samples, 39);

  // fsp info reads it with no --calib and no --imu.
  const auto r = test::RunFsp("info '" + dir.string() + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("kind").get<std::string>(), "dso");
  EXPECT_EQ(j.at("frames").get<int>(), 4);
  EXPECT_EQ(j.at("t_first_ns").get<int64_t>(), t.front());
  EXPECT_DOUBLE_EQ(j.at("camera").at("fy").get<double>(), 31.0);
  EXPECT_EQ(j.at("frames_decoded").get<int>(), 4);
}

// TUM monoVO / DSO style: ids that are not times, t_s in seconds (read exactly to the ns, beyond
// a double's 238 ns at this magnitude), an exposure column, jpg images; the IMU noise from a DM-VIO
// settings file beside a camchain without it; the camchain's time shift applied to the frames.
TEST(DsoLayout, SecondsColumnExposureAndNoiseFileBeside) {
  const fs::path dir = test::ScratchDir();
  fs::create_directories(dir / "cam0" / "images");
  const int64_t t0 = 1'650'458'716'848'712'921LL;
  std::string times;
  for (int k = 0; k < 3; ++k) {
    char id[16], t_s[32];
    std::snprintf(id, sizeof(id), "%05d", k);
    const long long t = t0 + 50'000'001LL * k;
    std::snprintf(t_s, sizeof(t_s), "%lld.%09lld", t / 1'000'000'000LL, t % 1'000'000'000LL);
    cv::imwrite((dir / "cam0" / "images" / (std::string(id) + ".jpg")).string(),
                test::TestImage(k));
    times += std::string(id) + " " + t_s + " " + std::to_string(8 + k) + ".5\n";
  }
  test::WriteText(dir / "cam0" / "times.txt", times);
  test::WriteText(dir / "cam0" / "camera.txt", "Pinhole 30 30 16 12 0\n32 24\nnone\n32 24\n");
  std::string imu;
  for (int i = 0; i < 100; ++i)
    imu += std::to_string(t0 - 100'000'000LL + 5'000'000LL * i) + " 0 0 0 0 0 9.81\n";
  test::WriteText(dir / "imu.txt", imu);
  test::WriteText(dir / "camchain.yaml",
                  test::DsoCamchain(false) + "  timeshift_cam_imu: 0.000002\n");
  test::WriteText(dir / "a_notes.yaml", "comment: not an IMU file\n");
  test::WriteText(dir / "d435.yaml",
                  "accelerometer_noise_density: 0.003\naccelerometer_random_walk: 0.0004\n"
                  "gyroscope_noise_density: 0.0005\ngyroscope_random_walk: 0.00002\n"
                  "integration_sigma: 0.2\n");
  auto src = Open(dir);
  EXPECT_EQ(src->frame_times(),
            (std::vector<int64_t>{t0 + 2000, t0 + 50'000'001 + 2000, t0 + 100'000'002 + 2000}));
  EXPECT_EQ(src->calibration().time_offset_ns, 2000);
  EXPECT_EQ(src->ReadFrame(1).source, (dir / "cam0" / "images" / "00001.jpg").string());
  EXPECT_EQ(src->calibration().imu_source, (dir / "d435.yaml").string());
  EXPECT_DOUBLE_EQ(src->calibration().imu.gyroscope_noise_density, 5e-4);
  EXPECT_DOUBLE_EQ(src->calibration().imu.accelerometer_noise_density, 3e-3);

  // Without any noise file: the defaults.
  fs::remove(dir / "d435.yaml");
  EXPECT_EQ(Open(dir)->calibration().imu_source, "");
}

// camera.txt: named and bare lines, absolute and relative numbers.
TEST(DsoLayout, CameraTxtForms) {
  // Bare pinhole (DM-VIO's walk), named pinhole (the fifth number ignored, as DSO does).
  PinholeRadtan c = CameraFrom(
      "906.259765625 906.550964355469 642.896362304688 353.142242431641 0\n1280 720\ncrop\n512 "
      "512\n");
  EXPECT_EQ(c.width, 1280);
  EXPECT_EQ(c.height, 720);
  EXPECT_DOUBLE_EQ(c.fx, 906.259765625);
  EXPECT_DOUBLE_EQ(c.cy, 353.142242431641);
  EXPECT_FALSE(c.HasDistortion());
  EXPECT_DOUBLE_EQ(CameraFrom("Pinhole 400 401 320 240 0.5\n640 480\n").fy, 401.0);
  // Relative: fractions of the size, origin at the corner of the top-left pixel (DSO's -0.5).
  c = CameraFrom("Pinhole 0.5 0.75 0.5 0.5 0\n640 480\ncrop\n640 480\n");
  EXPECT_DOUBLE_EQ(c.fx, 320.0);
  EXPECT_DOUBLE_EQ(c.fy, 360.0);
  EXPECT_DOUBLE_EQ(c.cx, 319.5);
  EXPECT_DOUBLE_EQ(c.cy, 239.5);
  // RadTan, named and bare (OpenCV's k1 k2 p1 p2 order); relative intrinsics, coefficients as is.
  for (const std::string& line : {std::string("RadTan 0.6 0.8 0.5 0.5 -0.28 0.07 0.0002 -0.0001"),
                                  std::string("0.6 0.8 0.5 0.5 -0.28 0.07 0.0002 -0.0001")}) {
    c = CameraFrom(line + "\n752 480\n");
    EXPECT_DOUBLE_EQ(c.fx, 0.6 * 752) << line;
    EXPECT_DOUBLE_EQ(c.cx, 0.5 * 752 - 0.5) << line;
    EXPECT_EQ(c.distortion, (std::array<double, 4>{-0.28, 0.07, 0.0002, -0.0001})) << line;
  }
  // FOV with omega 0 is a pinhole.
  EXPECT_DOUBLE_EQ(CameraFrom("FOV 400 400 320 240 0\n640 480\n").fx, 400.0);
}

TEST(DsoLayout, CameraTxtRejected) {
  const auto expect = [](const std::string& text, const std::string& must) {
    const std::string msg = CameraError(text);
    EXPECT_NE(msg.find(must), std::string::npos) << "'" << must << "' not in: " << msg;
    EXPECT_NE(msg.find("camera.txt:"), std::string::npos) << msg;
  };
  expect("EquiDistant 0.37 0.37 0.5 0.5 0.003 0.0007 -0.005 0.001\n512 512\n",
         "camera.txt:1: unsupported camera model 'EquiDistant' (fisheye)");
  expect("KannalaBrandt 190 190 254 256 0.003 0.0007 -0.005 0.001\n512 512\n",
         ":1: unsupported camera model 'KannalaBrandt' (fisheye)");
  expect("FOV 0.5 0.7 0.5 0.5 0.93\n640 480\n", ":1: unsupported camera model 'FOV'");
  expect("0.5 0.7 0.5 0.5 0.93\n640 480\n", ":1: unsupported camera model 'FOV' (ATAN");
  expect("Fisheye 1 2 3 4 5\n640 480\n", ":1: unknown camera model 'Fisheye'");
  expect("RadTan 400 400 320 240 0.1\n640 480\n", ":1: 'RadTan' needs 8 numbers");
  expect("400 400 320 240\n640 480\n", ":1: expected 5 numbers");
  expect("400 400 x 240 0\n640 480\n", ":1: column 3 (cx) is not a number: 'x'");
  expect("400 400 320 240 0\n", "missing the image size line");
  expect("400 400 320 240 0\n640\n", ":2: expected 2 columns");
  expect("400 400 320 240 0\n640 -480\n", ":2: image size 640x-480 is not plausible");
  expect("400 400 900 240 0\n640 480\n", ":1: camera: principal point");
  expect("\n", "camera.txt: camera.txt is empty");
}

// Bad input: one InputError naming the file and line, and one line from `fsp info`.
TEST(DsoLayout, BadInput) {
  const fs::path dir = test::ScratchDir();
  const auto fresh = [&] {
    fs::remove_all(dir / "seq");
    return test::MakeDso(dir / "seq");
  };
  const fs::path seq = dir / "seq";
  const auto expect = [&](const std::string& must) {
    const std::string msg = OpenError(seq);
    EXPECT_NE(msg.find(must), std::string::npos) << "'" << must << "' not in: " << msg;
    const test::CommandResult r = test::RunFsp("info '" + seq.string() + "' --quick");
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err, "fsp: error: " + msg + "\n");
  };

  std::vector<int64_t> t = fresh();
  fs::remove(seq / "cam0" / "times.txt");
  expect((seq / "cam0" / "times.txt").string() + ": DSO frame list not found");

  t = fresh();  // frame 2 stamped before frame 1
  ReplaceLine(seq / "cam0" / "times.txt", 3,
              std::to_string(t[0] + 1000) + " " + test::MicrosecondSeconds(t[0] + 1000));
  fs::rename(seq / "cam0" / "images" / (std::to_string(t[2]) + ".png"),
             seq / "cam0" / "images" / (std::to_string(t[0] + 1000) + ".png"));
  expect((seq / "cam0" / "times.txt").string() + ":3: timestamp " + std::to_string(t[0] + 1000) +
         " goes backwards (line 2 has " + std::to_string(t[1]) + ")");

  fresh();
  test::WriteText(seq / "cam0" / "camera.txt",
                  "EquiDistant 0.37 0.37 0.5 0.5 0.003 0.0007 -0.005 0.001\n32 24\ncrop\n32 24\n");
  expect((seq / "cam0" / "camera.txt").string() +
         ":1: unsupported camera model 'EquiDistant' (fisheye): fsp supports pinhole cameras");

  t = fresh();  // a calibration that does not fit the images
  test::WriteText(seq / "cam0" / "camera.txt", "30 30 16 12 0\n64 48\n");
  expect(std::to_string(t[0]) + ".png: image size 32x24 differs from the calibration's 64x48");

  t = fresh();
  fs::remove(seq / "cam0" / "images" / (std::to_string(t[1]) + ".png"));
  expect((seq / "cam0" / "times.txt").string() + ":2: no image '" + std::to_string(t[1]) +
         ".png' or");

  fresh();
  ReplaceLine(seq / "cam0" / "times.txt", 2, "1650458716898712921 x");
  expect((seq / "cam0" / "times.txt").string() + ":2: column 2 (t_s) is not a number: 'x'");

  fresh();
  ReplaceLine(seq / "imu.txt", 5, "1650458716808712921 0.01 -0.02 0.03 0.0 9.81");
  expect((seq / "imu.txt").string() + ":5: expected 7 columns in IMU csv, found 6");

  fresh();
  fs::remove(seq / "imu.txt");
  expect((seq / "imu.txt").string() + ": IMU samples not found");

  fresh();
  fs::remove(seq / "cam0" / "camera.txt");
  expect((seq / "cam0" / "camera.txt").string() + ": camera calibration not found");

  fresh();
  fs::remove(seq / "camchain.yaml");
  expect((seq / "camchain.yaml").string() + ": camera-IMU calibration not found");

  fresh();
  test::WriteText(seq / "camchain.yaml", "cam0:\n  camera_model: pinhole\n");
  expect((seq / "camchain.yaml").string() + ":2: cam0 has neither T_imu_cam nor T_cam_imu");
}

}  // namespace
}  // namespace fsp
