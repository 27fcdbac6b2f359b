// Calibration files in their three forms (EuRoC cam0/sensor.yaml, Kalibr camchain, FSP calib.yaml)
// and the IMU noise files (EuRoC imu0/sensor.yaml, Kalibr imu chain): ReadCalibration,
// ReadImuNoise and ReadCameraExtrinsics on the same file. A calibration that is read must pass its
// Check and survive a WriteCalibration / ReadCalibration round trip (calibration.h: lossless).
#include <cmath>

#include "fsp/common/calibration.h"
#include "fuzz_util.h"

namespace {

bool SameNoise(const fsp::ImuNoise& a, const fsp::ImuNoise& b) {
  return a.gyroscope_noise_density == b.gyroscope_noise_density &&
         a.accelerometer_noise_density == b.accelerometer_noise_density &&
         a.gyroscope_random_walk == b.gyroscope_random_walk &&
         a.accelerometer_random_walk == b.accelerometer_random_walk && a.rate_hz == b.rate_hz;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace fsp;
  using fuzz::RejectsOrReturns;
  const auto& dir = fuzz::Scratch().Fresh();
  const std::string path = (dir / "sensor.yaml").string();
  fuzz::WriteFile(path, fuzz::AsText(data, size));

  Calibration c;
  if (!RejectsOrReturns("ReadCalibration", [&] { c = ReadCalibration(path); })) {
    std::string why;
    FUZZ_CHECK(c.Check(&why));
    const std::string written = (dir / "calib.yaml").string();
    WriteCalibration(c, written);
    Calibration back;
    FUZZ_CHECK(
        !RejectsOrReturns("ReadCalibration(written)", [&] { back = ReadCalibration(written); }));
    const PinholeRadtan &a = c.camera, &b = back.camera;
    FUZZ_CHECK(a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
               a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion);
    FUZZ_CHECK(c.camera_rate_hz == back.camera_rate_hz);
    FUZZ_CHECK(c.time_offset_ns == back.time_offset_ns);
    FUZZ_CHECK(SameNoise(c.imu, back.imu));
    // The rotation goes through a matrix and back: equal to rounding.
    FUZZ_CHECK((c.T_B_C.Matrix() - back.T_B_C.Matrix()).cwiseAbs().maxCoeff() <=
               1e-12 * (1.0 + c.T_B_C.translation().cwiseAbs().maxCoeff()));
  }
  ImuNoise noise;
  if (!RejectsOrReturns("ReadImuNoise", [&] { noise = ReadImuNoise(path); })) {
    std::string why;
    FUZZ_CHECK(noise.Check(&why));
  }
  Rigid3 T;
  if (!RejectsOrReturns("ReadCameraExtrinsics", [&] { T = ReadCameraExtrinsics(path); }))
    FUZZ_CHECK(T.Matrix().allFinite());
  return 0;
}
