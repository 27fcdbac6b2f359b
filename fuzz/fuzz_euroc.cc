// A EuRoC-layout recording (`fsp run DIR`, `fsp info DIR`): OpenSource on DIR/mav0 with the files a
// user's recording brings. One input holds four files, separated by lines "--- next file ---":
// cam0/data.csv, imu0/data.csv, cam0/sensor.yaml and imu0/sensor.yaml (not written when that part
// is empty). Every image name that data.csv lists (second column, if it is a plain file name) is
// created in cam0/data/ as a valid 32x24 image, so the reader gets past its existence checks.
#include "dataset_fixture.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace fsp;
  const auto& dir = fuzz::Scratch().Fresh();
  const std::vector<std::string> parts =
      fuzz::SplitParts(fuzz::AsText(data, size), "--- next file ---", 4);
  const auto mav0 = dir / "mav0";
  fuzz::WriteFile(mav0 / "cam0" / "data.csv", parts[0]);
  fuzz::WriteFile(mav0 / "imu0" / "data.csv", parts[1]);
  fuzz::WriteFile(mav0 / "cam0" / "sensor.yaml", parts[2]);
  if (!parts[3].empty()) fuzz::WriteFile(mav0 / "imu0" / "sensor.yaml", parts[3]);
  std::vector<std::string> names;
  for (const std::string& line : fuzz::Lines(parts[0])) {
    const size_t comma = line.find(',');
    if (comma == std::string::npos) continue;
    std::string name = line.substr(comma + 1);
    while (!name.empty() && (name.back() == ' ' || name.back() == '\t')) name.pop_back();
    while (!name.empty() && (name.front() == ' ' || name.front() == '\t')) name.erase(0, 1);
    names.push_back(name);
  }
  fuzz::WriteImages(mav0 / "cam0" / "data", names, 32);
  SourceOptions options;
  options.input = dir.string();
  options.decode_images = false;
  fuzz::OpenAndCheck(options);
  return 0;
}
