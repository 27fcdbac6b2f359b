// A folder of images named by their timestamps, or listed in the folder's data.csv (`fsp run
// FOLDER --calib FILE --imu FILE`): OpenSource on the folder. One input holds the file names (one
// per line; each plain name, optionally under "data/", is created as a valid 32x24 image) and,
// after a line "--- data.csv ---", the folder's data.csv (not written when that part is empty). The
// calibration (32x24) and the IMU csv (samples at 0 and 4e18 ns) are fixed, outside the folder.
#include "dataset_fixture.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace fsp;
  const auto& dir = fuzz::Scratch().Fresh();
  const std::vector<std::string> parts =
      fuzz::SplitParts(fuzz::AsText(data, size), "--- data.csv ---", 2);
  const auto folder = dir / "images";
  std::filesystem::create_directories(folder);
  fuzz::WriteImages(folder, fuzz::Lines(parts[0]), 32);
  if (!parts[1].empty()) fuzz::WriteFile(folder / "data.csv", parts[1]);
  fuzz::WriteFile(dir / "calib.yaml",
                  "camera: {width: 32, height: 24, fx: 30, fy: 30, cx: 16, cy: 12}\n"
                  "T_B_C: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n");
  fuzz::WriteFile(dir / "imu.csv", "0,0,0,0,0,0,9.81\n4000000000000000000,0,0,0,0,0,9.81\n");
  SourceOptions options;
  options.input = folder.string();
  options.calib = (dir / "calib.yaml").string();
  options.imu = (dir / "imu.csv").string();
  options.decode_images = false;
  fuzz::OpenAndCheck(options);
  return 0;
}
