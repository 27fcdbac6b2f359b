#include "fsp/common/types.h"

#include <algorithm>

namespace fsp {

int CountSeen(const CornerMask& seen) {
  return static_cast<int>(std::count(seen.begin(), seen.end(), true));
}

const char* ToString(ObjectClass c) {
  switch (c) {
    case ObjectClass::kDoor:
      return "door";
    case ObjectClass::kWindow:
      return "window";
    case ObjectClass::kCabinet:
      return "cabinet";
    case ObjectClass::kPoster:
      return "poster";
    case ObjectClass::kTag:
      return "tag";
    case ObjectClass::kUnknown:
      break;
  }
  return "unknown";
}

bool ParseObjectClass(const std::string& name, ObjectClass* c) {
  if (name == "door")
    *c = ObjectClass::kDoor;
  else if (name == "window")
    *c = ObjectClass::kWindow;
  else if (name == "cabinet")
    *c = ObjectClass::kCabinet;
  else if (name == "poster" || name == "painting")
    *c = ObjectClass::kPoster;
  else if (name == "tag" || name == "apriltag")
    *c = ObjectClass::kTag;
  else if (name == "unknown")
    *c = ObjectClass::kUnknown;
  else
    return false;
  return true;
}

}  // namespace fsp
