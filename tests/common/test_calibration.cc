// Calibration readers: EuRoC sensor.yaml, Kalibr camchain (T_imu_cam and T_cam_imu), FSP
// calib.yaml.
#include <fstream>

#include <gtest/gtest.h>

#include "fsp/common/calibration.h"
#include "fsp/common/error.h"
#include "test_util.h"

namespace fsp {
namespace {

// EuRoC V1_01 cam0/sensor.yaml T_BS, copied from the file's text.
Mat4 EurocTBS() {
  Mat4 M;
  M << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,  //
      0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,       //
      -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,   //
      0.0, 0.0, 0.0, 1.0;
  return M;
}

void WriteText(const std::filesystem::path& p, const std::string& text) {
  std::ofstream out(p);
  out << text;
}

// The message of the InputError FN throws (fails the test when it throws nothing).
template <typename Fn>
std::string ErrorOf(Fn fn) {
  try {
    fn();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError thrown";
  return "";
}

TEST(Calibration, EurocSensorYaml) {
  FSP_REQUIRE_TEST_DATA(path, "euroc_v101_micro/mav0/cam0/sensor.yaml");
  const Calibration c = ReadCalibration(path);
  EXPECT_EQ(c.camera.width, 752);
  EXPECT_EQ(c.camera.height, 480);
  EXPECT_DOUBLE_EQ(c.camera.fx, 458.654);
  EXPECT_DOUBLE_EQ(c.camera.fy, 457.296);
  EXPECT_DOUBLE_EQ(c.camera.cx, 367.215);
  EXPECT_DOUBLE_EQ(c.camera.cy, 248.375);
  EXPECT_DOUBLE_EQ(c.camera.distortion[0], -0.28340811);
  EXPECT_DOUBLE_EQ(c.camera.distortion[3], 1.76187114e-05);
  EXPECT_DOUBLE_EQ(c.camera_rate_hz, 20.0);
  EXPECT_LT((c.T_B_C.Matrix() - EurocTBS()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_TRUE(c.imu_source.empty());  // a camera sensor.yaml has no IMU noise
}

TEST(Calibration, EurocImuSensorYaml) {
  FSP_REQUIRE_TEST_DATA(path, "euroc_v101_micro/mav0/imu0/sensor.yaml");
  const ImuNoise n = ReadImuNoise(path);
  EXPECT_DOUBLE_EQ(n.gyroscope_noise_density, 1.6968e-04);
  EXPECT_DOUBLE_EQ(n.gyroscope_random_walk, 1.9393e-05);
  EXPECT_DOUBLE_EQ(n.accelerometer_noise_density, 2.0e-3);
  EXPECT_DOUBLE_EQ(n.accelerometer_random_walk, 3.0e-3);
  EXPECT_DOUBLE_EQ(n.rate_hz, 200.0);
}

// A sensor.yaml without the %YAML:1.0 line (as real EuRoC files are) reads the same.
TEST(Calibration, EurocWithoutYamlDirective) {
  FSP_REQUIRE_TEST_DATA(path, "euroc_v101_micro/mav0/cam0/sensor.yaml");
  std::ifstream in(path);
  std::string first, rest, line;
  std::getline(in, first);
  ASSERT_EQ(first.rfind("%YAML", 0), 0u);
  while (std::getline(in, line)) rest += line + "\n";
  const auto dir = test::ScratchDir();
  WriteText(dir / "sensor.yaml", rest);
  const Calibration a = ReadCalibration(path);
  const Calibration b = ReadCalibration((dir / "sensor.yaml").string());
  EXPECT_EQ(a.camera.fx, b.camera.fx);
  EXPECT_LT((a.T_B_C.Matrix() - b.T_B_C.Matrix()).norm(), 1e-15);
}

TEST(Calibration, KalibrTimuCamEqualsEurocTBS) {
  FSP_REQUIRE_TEST_DATA(kalibr, "vio_calibration/euroc_kalibr_openvins/kalibr_imucam_chain.yaml");
  FSP_REQUIRE_TEST_DATA(euroc, "euroc_v101_micro/mav0/cam0/sensor.yaml");
  const Calibration k = ReadCalibration(kalibr);
  const Calibration e = ReadCalibration(euroc);
  EXPECT_LT((k.T_B_C.Matrix() - e.T_B_C.Matrix()).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_EQ(k.camera.width, 752);
  EXPECT_DOUBLE_EQ(k.camera.fx, 458.654);
  for (int i = 0; i < 4; ++i) EXPECT_DOUBLE_EQ(k.camera.distortion[i], e.camera.distortion[i]);
}

TEST(Calibration, KalibrImuChain) {
  FSP_REQUIRE_TEST_DATA(path, "vio_calibration/tumvi_kalibr_openvins/kalibr_imu_chain.yaml");
  const ImuNoise n = ReadImuNoise(path);
  EXPECT_DOUBLE_EQ(n.accelerometer_noise_density, 0.0028);
  EXPECT_DOUBLE_EQ(n.accelerometer_random_walk, 0.00086);
  EXPECT_DOUBLE_EQ(n.gyroscope_noise_density, 0.00016);
  EXPECT_DOUBLE_EQ(n.gyroscope_random_walk, 2.2e-05);
  EXPECT_DOUBLE_EQ(n.rate_hz, 200.0);
  // An IMU-only file is not a camera calibration.
  EXPECT_NE(ErrorOf([&] { ReadCalibration(path); }).find("only an IMU calibration"),
            std::string::npos);
}

// TUM-VI stores T_cam_imu (IMU -> camera): its inverse is T_B_C. Its equidistant model is rejected.
TEST(Calibration, KalibrTcamImuIsInvertedAndFisheyeRejected) {
  FSP_REQUIRE_TEST_DATA(path, "vio_calibration/tumvi_kalibr_openvins/kalibr_imucam_chain.yaml");
  Mat4 T_cam_imu;
  T_cam_imu << -0.9995250378696743, 0.029615343885863205, -0.008522328211654736,
      0.04727988224914392,                                                                      //
      0.0075019185074052044, -0.03439736061393144, -0.9993800792498829, -0.047443232143367084,  //
      -0.02989013031643309, -0.998969345370175, 0.03415885127385616, -0.0681999605066297,       //
      0.0, 0.0, 0.0, 1.0;
  const Rigid3 T_B_C = ReadCameraExtrinsics(path);
  const Mat3 R = T_B_C.R();
  EXPECT_LT((R * R.transpose() - Mat3::Identity()).norm(), 1e-12);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_LT((T_B_C.Matrix() * T_cam_imu - Mat4::Identity()).cwiseAbs().maxCoeff(), 1e-6);
  // Not the matrix itself: reading the key name matters (this rotation is almost its own inverse,
  // so the translations tell them apart: 3.3 cm).
  EXPECT_GT((T_B_C.translation() - T_cam_imu.topRightCorner<3, 1>()).norm(), 0.02);

  const std::string msg = ErrorOf([&] { ReadCalibration(path); });
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("unsupported camera model"), std::string::npos) << msg;
  EXPECT_NE(msg.find("equidistant"), std::string::npos) << msg;
}

TEST(Calibration, WriteReadRoundTrip) {
  Calibration c;
  c.camera.width = 640;
  c.camera.height = 480;
  c.camera.fx = 458.123456789012;
  c.camera.fy = 457.1;
  c.camera.cx = 320.25;
  c.camera.cy = 239.75;
  c.camera.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  c.camera_rate_hz = 30.0;
  c.T_B_C = Rigid3(ExpSO3(Vec3(0.1, -0.2, 1.3)), Vec3(0.01, -0.065, 0.0098));
  c.time_offset_ns = -1234567;
  c.imu.rate_hz = 400.0;
  c.imu.gyroscope_noise_density = 1.1e-4;
  c.imu.accelerometer_noise_density = 2.2e-3;
  c.imu.gyroscope_random_walk = 3.3e-5;
  c.imu.accelerometer_random_walk = 4.4e-3;
  const auto path = (test::ScratchDir() / "calib.yaml").string();
  WriteCalibration(c, path);
  const Calibration r = ReadCalibration(path);
  EXPECT_EQ(r.camera.width, c.camera.width);
  EXPECT_EQ(r.camera.height, c.camera.height);
  EXPECT_EQ(r.camera.fx, c.camera.fx);  // exact: shortest round-trip decimal
  EXPECT_EQ(r.camera.fy, c.camera.fy);
  EXPECT_EQ(r.camera.cx, c.camera.cx);
  EXPECT_EQ(r.camera.cy, c.camera.cy);
  EXPECT_EQ(r.camera.distortion, c.camera.distortion);
  EXPECT_EQ(r.camera_rate_hz, c.camera_rate_hz);
  EXPECT_EQ(r.time_offset_ns, c.time_offset_ns);
  EXPECT_EQ(r.imu.rate_hz, c.imu.rate_hz);
  EXPECT_EQ(r.imu.gyroscope_noise_density, c.imu.gyroscope_noise_density);
  EXPECT_EQ(r.imu.accelerometer_noise_density, c.imu.accelerometer_noise_density);
  EXPECT_EQ(r.imu.gyroscope_random_walk, c.imu.gyroscope_random_walk);
  EXPECT_EQ(r.imu.accelerometer_random_walk, c.imu.accelerometer_random_walk);
  EXPECT_EQ(r.imu_source, path);
  // The rotation goes through a 4x4 matrix and back: equal to rounding.
  EXPECT_LT((r.T_B_C.Matrix() - c.T_B_C.Matrix()).cwiseAbs().maxCoeff(), 1e-15);
  // The IMU noise of our file is also readable on its own.
  EXPECT_EQ(ReadImuNoise(path).gyroscope_random_walk, c.imu.gyroscope_random_walk);
}

TEST(Calibration, BadFilesNameFileAndLine) {
  const auto dir = test::ScratchDir();
  const auto p = [&](const char* name) { return (dir / name).string(); };

  // Missing file.
  std::string msg = ErrorOf([&] { ReadCalibration(p("nope.yaml")); });
  EXPECT_NE(msg.find(p("nope.yaml")), std::string::npos) << msg;
  EXPECT_NE(msg.find("not found"), std::string::npos) << msg;

  // Empty file.
  WriteText(dir / "empty.yaml", "");
  msg = ErrorOf([&] { ReadCalibration(p("empty.yaml")); });
  EXPECT_NE(msg.find("empty"), std::string::npos) << msg;

  // Broken YAML syntax: line reported.
  WriteText(dir / "syntax.yaml", "camera:\n  width: 640\n  height: [480\n");
  msg = ErrorOf([&] { ReadCalibration(p("syntax.yaml")); });
  EXPECT_NE(msg.find(p("syntax.yaml") + ":"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not valid YAML"), std::string::npos) << msg;

  // A non-numeric intrinsic, on line 4.
  WriteText(dir / "nan.yaml",
            "camera:\n  width: 640\n  height: 480\n  fx: abc\n  fy: 1\n  cx: 1\n  cy: 1\nT_B_C: "
            "[1,0,0,0, "
            "0,1,0,0, 0,0,1,0, 0,0,0,1]\n");
  msg = ErrorOf([&] { ReadCalibration(p("nan.yaml")); });
  EXPECT_NE(msg.find(p("nan.yaml") + ":4: 'fx' is not a number"), std::string::npos) << msg;

  // A transform that is not rigid.
  WriteText(dir / "scaled.yaml",
            "camera: {width: 640, height: 480, fx: 400, fy: 400, cx: 320, cy: 240}\nT_B_C: "
            "[2,0,0,0, 0,1,0,0, "
            "0,0,1,0, 0,0,0,1]\n");
  msg = ErrorOf([&] { ReadCalibration(p("scaled.yaml")); });
  EXPECT_NE(msg.find(p("scaled.yaml") + ":2:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not a rigid transform"), std::string::npos) << msg;

  // Principal point outside the image (Check).
  WriteText(dir / "pp.yaml",
            "camera: {width: 640, height: 480, fx: 400, fy: 400, cx: 900, cy: 240}\nT_B_C: "
            "[1,0,0,0, 0,1,0,0, "
            "0,0,1,0, 0,0,0,1]\n");
  msg = ErrorOf([&] { ReadCalibration(p("pp.yaml")); });
  EXPECT_NE(msg.find("principal point"), std::string::npos) << msg;

  // Something else entirely.
  WriteText(dir / "other.yaml", "foo: 1\n");
  msg = ErrorOf([&] { ReadCalibration(p("other.yaml")); });
  EXPECT_NE(msg.find("not a camera calibration"), std::string::npos) << msg;
}

}  // namespace
}  // namespace fsp
