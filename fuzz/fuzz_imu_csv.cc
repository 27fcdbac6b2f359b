// IMU csv (EuRoC imu0/data.csv, FSP imu.csv, --imu FILE): ReadImuCsv. What it returns must keep
// dataset.h's promises (at least one sample, finite values, strictly increasing t_ns) and survive a
// WriteImuCsv / ReadImuCsv round trip unchanged (lossless).
#include "fsp/common/dataset.h"
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace fsp;
  const auto& dir = fuzz::Scratch().Fresh();
  const std::string path = (dir / "imu.csv").string();
  fuzz::WriteFile(path, fuzz::AsText(data, size));
  std::vector<ImuSample> imu;
  if (fuzz::RejectsOrReturns("ReadImuCsv", [&] { imu = ReadImuCsv(path); })) return 0;
  FUZZ_CHECK(!imu.empty());
  for (size_t i = 0; i < imu.size(); ++i) {
    FUZZ_CHECK(imu[i].gyro.allFinite() && imu[i].acc.allFinite());
    if (i > 0) FUZZ_CHECK(imu[i].t_ns > imu[i - 1].t_ns);
  }
  const std::string written = (dir / "written.csv").string();
  WriteImuCsv(imu, written);
  std::vector<ImuSample> back;
  FUZZ_CHECK(!fuzz::RejectsOrReturns("ReadImuCsv(written)", [&] { back = ReadImuCsv(written); }));
  FUZZ_CHECK(back.size() == imu.size());
  for (size_t i = 0; i < imu.size(); ++i) {
    FUZZ_CHECK(back[i].t_ns == imu[i].t_ns && back[i].gyro == imu[i].gyro &&
               back[i].acc == imu[i].acc);
  }
  return 0;
}
