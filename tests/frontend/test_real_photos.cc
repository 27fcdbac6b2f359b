// Rectangle detector on real photos (shared test data): pins what it finds. Filled in below.
#include <gtest/gtest.h>

#include "fsp/frontend/image_io.h"
#include "fsp/frontend/rect_detector.h"
#include "test_util.h"

namespace fsp::frontend {
namespace {
}  // namespace
}  // namespace fsp::frontend
