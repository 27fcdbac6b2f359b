// A DSO / TUM-VI / DM-VIO layout (`fsp run DIR`, `fsp info DIR` with DIR/cam0/times.txt):
// OpenSource on DIR with the files a user's recording brings, then every Next() and Summarize. One
// input holds five files, separated by lines "--- next file ---": cam0/times.txt, cam0/camera.txt,
// imu.txt, camchain.yaml and a YAML file beside it (written as d435.yaml, DM-VIO's settings file
// with the IMU noise, which the reader looks for when the camchain has none; left out when that
// part is empty). Every id that times.txt lists (its first column, split as the reader splits it)
// is created as cam0/images/<id>.png, a valid 32x24 image, so the reader gets past its existence
// checks.
#include "dataset_fixture.h"
#include "fsp/common/csv.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace fsp;
  const auto& dir = fuzz::Scratch().Fresh();
  const std::vector<std::string> parts =
      fuzz::SplitParts(fuzz::AsText(data, size), "--- next file ---", 5);
  const auto cam0 = dir / "cam0";
  fuzz::WriteFile(cam0 / "times.txt", parts[0]);
  fuzz::WriteFile(cam0 / "camera.txt", parts[1]);
  fuzz::WriteFile(dir / "imu.txt", parts[2]);
  fuzz::WriteFile(dir / "camchain.yaml", parts[3]);
  if (!parts[4].empty()) fuzz::WriteFile(dir / "d435.yaml", parts[4]);
  // The ids as the reader reads them: TableReader's rows (',' and/or whitespace, '#' comments).
  std::vector<std::string> names;
  TableReader rows((cam0 / "times.txt").string(), "DSO times.txt", parts[0], 0);
  std::vector<std::string> fields;
  while (rows.NextRow(&fields))
    if (!fields.empty()) names.push_back(fields[0] + ".png");
  fuzz::WriteImages(cam0 / "images", names, 32);
  SourceOptions options;
  options.input = dir.string();
  options.decode_images = false;
  fuzz::OpenAndCheck(options);
  return 0;
}
