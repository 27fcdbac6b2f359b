#include "fsp/common/observations_io.h"

#include <cstdio>
#include <fstream>
#include <iomanip>
#include <limits>

#include "fsp/common/atomic_file.h"
#include "fsp/common/csv.h"
#include "fsp/common/error.h"

namespace fsp {

std::vector<CornerRow> ReadCornerRows(const std::string& path) {
  TableReader reader(path, "observations csv");
  std::vector<CornerRow> rows;
  std::vector<std::string> f;
  while (reader.NextRow(&f)) {
    if (!f.empty() && f[0] == "t_ns") continue;  // header without '#'
    reader.ExpectColumns(f, 10, 12);
    CornerRow row;
    row.line = reader.line();
    row.t_ns = reader.Int64(f, 0, "t_ns");
    const int64_t id = reader.Int64(f, 1, "object_id");
    if (id < std::numeric_limits<int>::min() || id > std::numeric_limits<int>::max())
      reader.Fail("column 2 (object_id) is out of range: '" + f[1] + "'");
    row.object_id = static_cast<int>(id);
    static const char* kNames[8] = {"u1", "v1", "u2", "v2", "u3", "v3", "u4", "v4"};
    for (int j = 0; j < 4; ++j) {
      row.corners[j] = Vec2(reader.Double(f, 2 + 2 * j, kNames[2 * j]),
                            reader.Double(f, 3 + 2 * j, kNames[2 * j + 1]));
    }
    if (f.size() >= 11) {
      const int64_t flag = reader.Int64(f, 10, "fully_visible");
      if (flag != 0 && flag != 1) reader.Fail("column 11 (fully_visible) must be 0 or 1");
      // Without visible_corners, which corners a row not fully visible shows is not known: none.
      const int64_t bits = f.size() == 12 ? reader.Int64(f, 11, "visible_corners") : 15 * flag;
      if (bits < 0 || bits > 15) reader.Fail("column 12 (visible_corners) must be 0..15");
      if ((flag == 1) != (bits == 15))
        reader.Fail("column 12 (visible_corners) contradicts column 11 (fully_visible)");
      for (int j = 0; j < 4; ++j) row.visible[j] = ((bits >> j) & 1) != 0;
    }
    if (!rows.empty() && row.t_ns < rows.back().t_ns) {
      reader.Fail("timestamp " + std::to_string(row.t_ns) + " goes backwards (previous row has " +
                  std::to_string(rows.back().t_ns) + ")");
    }
    rows.push_back(row);
  }
  return rows;
}

void WriteCornerRows(const std::vector<CornerRow>& rows, const std::string& path, bool with_flag) {
  WriteFileAtomically(path, "observations csv", [&](std::ostream& out) {
    out << "# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4"
        << (with_flag ? ",fully_visible,visible_corners" : "") << "\n";
    // "%.4f" of a double is at most 309 integer digits, the sign, the point and 4 decimals.
    char buf[2 * 320];
    for (const CornerRow& r : rows) {
      out << r.t_ns << ',' << r.object_id;
      for (const Vec2& c : r.corners) {
        const int n = std::snprintf(buf, sizeof(buf), ",%.4f,%.4f", c.x(), c.y());
        FSP_CHECK(n > 0 && static_cast<size_t>(n) < sizeof(buf));
        out << buf;
      }
      if (with_flag) {
        int bits = 0;
        for (int j = 0; j < 4; ++j) bits |= r.visible[j] ? 1 << j : 0;
        out << ',' << (r.FullyVisible() ? 1 : 0) << ',' << bits;
      }
      out << '\n';
    }
  });
}

}  // namespace fsp
