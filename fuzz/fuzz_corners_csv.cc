// Corner observations csv (observations_gt.csv, observations.csv, `fsp run --frontend corners
// --corners FILE`): ReadCornerRows. What it returns must keep observations_io.h's promises
// (non-decreasing time, finite corners) and survive a WriteCornerRows / ReadCornerRows round trip
// (corners are written with 4 decimals: equal to 5e-5 px).
#include <cmath>

#include "fsp/common/observations_io.h"
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace fsp;
  const auto& dir = fuzz::Scratch().Fresh();
  const std::string path = (dir / "corners.csv").string();
  fuzz::WriteFile(path, fuzz::AsText(data, size));
  std::vector<CornerRow> rows;
  if (fuzz::RejectsOrReturns("ReadCornerRows", [&] { rows = ReadCornerRows(path); })) return 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    for (const Vec2& c : rows[i].corners) FUZZ_CHECK(c.allFinite());
    if (i > 0) FUZZ_CHECK(rows[i].t_ns >= rows[i - 1].t_ns);
  }
  const std::string written = (dir / "written.csv").string();
  WriteCornerRows(rows, written, true);
  std::vector<CornerRow> back;
  FUZZ_CHECK(
      !fuzz::RejectsOrReturns("ReadCornerRows(written)", [&] { back = ReadCornerRows(written); }));
  FUZZ_CHECK(back.size() == rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    FUZZ_CHECK(back[i].t_ns == rows[i].t_ns && back[i].object_id == rows[i].object_id &&
               back[i].visible == rows[i].visible);
    for (size_t j = 0; j < 4; ++j) {
      const Vec2 d = back[i].corners[j] - rows[i].corners[j];
      const double scale = 1.0 + rows[i].corners[j].cwiseAbs().maxCoeff();
      FUZZ_CHECK(std::abs(d.x()) <= 5e-5 + 1e-15 * scale &&
                 std::abs(d.y()) <= 5e-5 + 1e-15 * scale);
    }
  }
  return 0;
}
