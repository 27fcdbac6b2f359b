// Pieces of the input sources (private to fsp_common): where frames come from and how they decode.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/common/csv.h"
#include "fsp/common/types.h"

namespace fsp::internal {

// Decodes frame `index` of a recording to CV_8UC1; throws InputError naming the image or video
// frame.
class FrameDecoder {
 public:
  virtual ~FrameDecoder() = default;
  virtual std::string Name(int index) const = 0;  // image path, or "VIDEO#frame=K"
  virtual cv::Mat Decode(int index) = 0;
};

// Frame timestamps as recorded (camera clock, before the calibration's time offset) plus a decoder.
struct FrameList {
  std::vector<int64_t> t_ns;
  std::unique_ptr<FrameDecoder> decoder;
};

// Frames listed in a EuRoC-style data.csv ("t_ns,filename"); names are relative to IMAGE_DIR. Every
// listed file must exist; timestamps must strictly increase.
FrameList ListImagesFromCsv(const std::string& csv_path, const std::string& image_dir);
// Frames of a folder whose image files are named <t_ns>.<png|jpg|jpeg|pgm|bmp>.
FrameList ListImagesByName(const std::string& folder);
// Frames listed in a DSO / TUM-VI / DM-VIO times.txt: rows "id t_s [exposure_ms]" (whitespace
// separated), the image IMAGE_DIR/<id>.<png|jpg|jpeg|pgm|bmp>. The time is t_s read exactly to the
// nanosecond, or the id itself when it is a nanosecond timestamp within 1 ms of t_s (DM-VIO and
// TUM-VI name images by their nanosecond time and print t_s rounded to the microsecond). The
// exposure, when present, must be a number and is not used. Every image must exist; times must
// strictly increase.
FrameList ListImagesFromDsoTimes(const std::string& times_path, const std::string& image_dir);
// Frames of a video: times from its clock, or from FRAME_TIMES when not empty (count must match).
FrameList ScanVideo(const std::string& video, const std::string& frame_times);

// Runs FN with file descriptor 2 redirected to a temporary file and returns what third-party
// decoders (libpng, libjpeg, FFmpeg) printed meanwhile: the library stays silent and can quote the
// text in its error message. Captures are serialised by a mutex; output of other threads during FN
// is captured too.
std::string CaptureStderr(const std::function<void()>& fn);
// First line of TEXT, trimmed, prefixed by ": " (empty when TEXT is blank).
std::string FirstLineDetail(const std::string& text);

// Reads one image file as 8-bit grey; throws InputError "PATH: ..." when missing or not decodable.
cv::Mat ReadGreyImage(const std::string& path);

// Throws "FILE:LINE: duplicate timestamp" / "goes backwards" unless T > PREV (the row at
// PREV_LINE).
void CheckIncreasing(const TableReader& reader, int64_t t, int64_t prev, int prev_line);

// The rows of an IMU csv ("t_ns,wx,wy,wz,ax,ay,az") appended to OUT, each checked as ReadImuCsv
// does; the time must increase past OUT's last sample (read from line *PREV_LINE, updated).
void ReadImuRows(TableReader& reader, std::vector<ImuSample>* out, int* prev_line);

}  // namespace fsp::internal
