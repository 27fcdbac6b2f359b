// Per-frame corner observations as csv (docs/outputs.md):
//   observations_gt.csv: t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4,fully_visible,visible_corners
//                        (rendered ground truth; visible_corners: bit j-1 set when corner j is in
//                        the image and not hidden, 0..15; files without it are read too)
//   observations.csv:    t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4 (what a run's front end saw)
// Corners are undistorted pixels in s1..s4 order.
#pragma once

#include <string>
#include <vector>

#include "fsp/common/types.h"

namespace fsp {

struct CornerRow {
  int64_t t_ns = 0;
  int object_id = -1;
  Corners corners;
  // The corners in the image and not hidden (all when the file has no flag column; a row with
  // fully_visible 0 but no visible_corners column: none, which ones is not known).
  CornerMask visible = kAllCorners;
  bool FullyVisible() const { return visible == kAllCorners; }
  int line = 0;  // line of the file it was read from (0: not read from a file)
};

// Reads either layout (10, 11 or 12 columns; a header line starting with '#' or "t_ns" is skipped).
// Rows must be in non-decreasing time order. Throws InputError naming file and line.
std::vector<CornerRow> ReadCornerRows(const std::string& path);
// Writes the layout with the fully_visible and visible_corners columns when `with_flag`.
void WriteCornerRows(const std::vector<CornerRow>& rows, const std::string& path, bool with_flag);

}  // namespace fsp
