#include "fsp/frontend/image_io.h"

#include <filesystem>
#include <system_error>

#include <opencv2/imgcodecs.hpp>

#include "fsp/common/error.h"

namespace fsp::frontend {

cv::Mat ReadGray8(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path, 0, "image file does not exist");
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path, 0, "is a directory, not an image");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path, 0, "cannot read image file (" + ec.message() + ")");
  if (size == 0) throw InputError(path, 0, "image file is empty (0 bytes)");
  // Grey decoding (for JPEG: the luma channel itself, as libjpeg / apriltag's decoder give it) that
  // keeps the bit depth (ANYDEPTH) so a 16-bit image can be refused instead of scaled.
  cv::Mat img;
  try {
    img = cv::imread(path, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
  } catch (const cv::Exception&) {
    throw InputError(path, 0, "image does not decode");
  }
  if (img.empty())
    throw InputError(path, 0, "image does not decode (not a PNG/JPEG/... or corrupt)");
  if (img.depth() != CV_8U)
    throw InputError(path, 0,
                     std::string("image is not 8-bit per channel (depth ") +
                         (img.depth() == CV_16U ? "16-bit" : "not 8-bit") +
                         "); convert it to 8-bit first");
  if (img.rows < 8 || img.cols < 8)
    throw InputError(
        path, 0,
        "image is too small (" + std::to_string(img.cols) + "x" + std::to_string(img.rows) + ")");
  FSP_CHECK(img.channels() == 1);
  return img;
}

}  // namespace fsp::frontend
