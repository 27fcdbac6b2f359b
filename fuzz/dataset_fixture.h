// Pieces shared by the targets that open a recording through OpenSource (fuzz_euroc,
// fuzz_image_folder): a small valid image for every listed name, and the checks of what a Source
// promises (dataset.h).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "fsp/common/dataset.h"
#include "fuzz_util.h"

namespace fsp::fuzz {

constexpr int kImageWidth = 32, kImageHeight = 24;  // the test fixtures' size (seed calibrations)

// A binary PGM of kImageWidth x kImageHeight (decodes quickly, prints nothing).
inline std::string TestPgm() {
  std::string pgm =
      "P5\n" + std::to_string(kImageWidth) + " " + std::to_string(kImageHeight) + "\n255\n";
  for (int i = 0; i < kImageWidth * kImageHeight; ++i) pgm.push_back(static_cast<char>(i % 251));
  return pgm;
}

// NAME can be created as a file inside a folder: letters, digits, '.', '_', '-', at most one
// leading "data/" folder, not "." or "..", not too long.
inline bool SafeName(std::string_view name) {
  if (name.rfind("data/", 0) == 0) name.remove_prefix(5);
  if (name.empty() || name.size() > 100 || name == "." || name == "..") return false;
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

// Writes the test image as DIR/NAME for every safe name that can be created (at most MAX).
inline void WriteImages(const std::filesystem::path& dir, const std::vector<std::string>& names,
                        size_t max) {
  static const std::string pgm = TestPgm();
  size_t written = 0;
  for (const std::string& n : names) {
    if (written == max) break;
    // Names that clash ("data" and "data/x.png") leave out the one that cannot be created.
    if (!SafeName(n) || !TryWriteFile(dir / n, pgm)) continue;
    ++written;
  }
}

// The lines of TEXT, without their '\r' and the line break.
inline std::vector<std::string> Lines(std::string_view text) {
  std::vector<std::string> out;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    std::string line(text.substr(pos, eol - pos));
    if (!line.empty() && line.back() == '\r') line.pop_back();
    out.push_back(line);
    pos = eol + 1;
  }
  return out;
}

// Opens OPTIONS; a source that opens must keep dataset.h's promises: strictly increasing frame
// times, IMU samples in strictly increasing time and finite, measurements in time order (IMU
// samples at or before a frame's time first), the first frame decodes at the calibration's size.
inline void OpenAndCheck(const SourceOptions& options) {
  std::unique_ptr<Source> source;
  if (RejectsOrReturns("OpenSource", [&] { source = OpenSource(options); })) return;
  const std::vector<int64_t>& ft = source->frame_times();
  const std::vector<ImuSample>& imu = source->imu();
  FUZZ_CHECK(!ft.empty() && !imu.empty());
  for (size_t i = 1; i < ft.size(); ++i) FUZZ_CHECK(ft[i] > ft[i - 1]);
  for (size_t i = 0; i < imu.size(); ++i) {
    FUZZ_CHECK(imu[i].gyro.allFinite() && imu[i].acc.allFinite());
    if (i > 0) FUZZ_CHECK(imu[i].t_ns > imu[i - 1].t_ns);
  }
  std::string why;
  FUZZ_CHECK(source->calibration().Check(&why));
  // The merge dataset.h describes: IMU samples with t_ns <= a frame's t_ns come before that frame.
  size_t frames = 0, samples = 0;
  while (const std::optional<Measurement> m = source->Next()) {
    if (std::holds_alternative<Frame>(*m)) {
      FUZZ_CHECK(frames < ft.size() && (samples == imu.size() || imu[samples].t_ns > ft[frames]));
      FUZZ_CHECK(std::get<Frame>(*m).index == static_cast<int>(frames));
      FUZZ_CHECK(std::get<Frame>(*m).t_ns == ft[frames]);
      ++frames;
    } else {
      FUZZ_CHECK(samples < imu.size() && (frames == ft.size() || imu[samples].t_ns <= ft[frames]));
      ++samples;
    }
  }
  FUZZ_CHECK(frames == ft.size() && samples == imu.size());
  const SourceSummary s = Summarize(*source);
  FUZZ_CHECK(s.frames == static_cast<int>(ft.size()) &&
             s.imu_samples == static_cast<int>(imu.size()));
  FUZZ_CHECK(s.largest_imu_gap_ns >= 0 && s.frames_outside_imu >= 0);
}

}  // namespace fsp::fuzz
