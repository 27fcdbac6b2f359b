#include "fsp/frontend/image_io.h"

#include <filesystem>
#include <system_error>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fsp/common/error.h"

namespace fsp::frontend {

cv::Mat ReadGray8(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path, 0, "image file does not exist");
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, 0, "is a directory, not an image");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path, 0, "cannot read image file (" + ec.message() + ")");
  if (size == 0) throw InputError(path, 0, "image file is empty (0 bytes)");
  // IMREAD_UNCHANGED keeps the bit depth so a 16-bit image can be refused instead of scaled.
  cv::Mat img;
  try {
    img = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw InputError(path, 0, "image does not decode");
  }
  if (img.empty()) throw InputError(path, 0, "image does not decode (not a PNG/JPEG/... or corrupt)");
  if (img.depth() != CV_8U)
    throw InputError(path, 0, std::string("image is not 8-bit per channel (depth ") +
                                  (img.depth() == CV_16U ? "16-bit" : "not 8-bit") +
                                  "); convert it to 8-bit first");
  if (img.rows < 8 || img.cols < 8)
    throw InputError(path, 0, "image is too small (" + std::to_string(img.cols) + "x" + std::to_string(img.rows) + ")");
  cv::Mat gray;
  switch (img.channels()) {
    case 1: gray = img; break;
    case 3: cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY); break;
    case 4: cv::cvtColor(img, gray, cv::COLOR_BGRA2GRAY); break;
    default: throw InputError(path, 0, "image has " + std::to_string(img.channels()) + " channels");
  }
  return gray;
}

}  // namespace fsp::frontend
