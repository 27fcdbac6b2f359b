// Frames of a video file, timed by the video clock or by a frame-times file.
#include <cmath>
#include <filesystem>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "dataset_internal.h"
#include "fsp/common/error.h"

namespace fsp::internal {

namespace {

cv::VideoCapture OpenVideo(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path, 0, "video not found");
  if (std::filesystem::file_size(path, ec) == 0) throw InputError(path, 0, "video file is empty");
  cv::VideoCapture cap;
  std::string cv_error;
  const std::string printed = CaptureStderr([&] {
    try {
      cap.open(path, cv::CAP_FFMPEG);
    } catch (const cv::Exception& e) {
      cv_error = e.err;
    }
  });
  if (!cap.isOpened()) {
    const std::string detail = !printed.empty() ? FirstLineDetail(printed)
                               : !cv_error.empty()
                                   ? FirstLineDetail(cv_error)
                                   : std::string(" (not a video file or unsupported codec)");
    throw InputError(path, 0, "cannot open as a video" + detail);
  }
  return cap;
}

class VideoDecoder : public FrameDecoder {
 public:
  VideoDecoder(std::string path, int count) : path_(std::move(path)), count_(count) {}
  std::string Name(int index) const override { return path_ + "#frame=" + std::to_string(index); }

  cv::Mat Decode(int index) override {
    if (index < 0 || index >= count_) throw InputError(Name(index), 0, "frame index out of range");
    if (!cap_.isOpened() || index < next_) {  // (re)start from the beginning: seeking is not exact
      cap_ = OpenVideo(path_);
      next_ = 0;
    }
    cv::Mat frame;
    int failed = -1;
    const std::string printed = CaptureStderr([&] {
      for (; next_ < index; ++next_) {
        if (!cap_.grab()) {
          failed = next_;
          return;
        }
      }
      if (!cap_.read(frame) || frame.empty()) failed = index;
      ++next_;
    });
    if (failed >= 0) {
      cap_.release();  // restart on the next call
      throw InputError(Name(failed), 0, "video frame does not decode" + FirstLineDetail(printed));
    }
    cv::Mat grey;
    if (frame.channels() == 3)
      cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
    else if (frame.channels() == 4)
      cv::cvtColor(frame, grey, cv::COLOR_BGRA2GRAY);
    else
      grey = frame;
    if (grey.type() != CV_8UC1) grey.convertTo(grey, CV_8U);
    return grey;
  }

 private:
  std::string path_;
  int count_ = 0;
  cv::VideoCapture cap_;
  int next_ = 0;  // index of the frame the next read returns
};

std::vector<int64_t> ReadFrameTimes(const std::string& path) {
  TableReader reader(path, "frame times file");
  std::vector<int64_t> t;
  std::vector<std::string> f;
  int prev_line = 0;
  while (reader.NextRow(&f)) {
    const int64_t v = reader.Int64(f, 0, "t_ns");
    if (!t.empty()) CheckIncreasing(reader, v, t.back(), prev_line);
    prev_line = reader.line();
    t.push_back(v);
  }
  if (t.empty()) throw InputError(path, 0, "no frame times (expected one t_ns per line)");
  return t;
}

}  // namespace

FrameList ScanVideo(const std::string& video, const std::string& frame_times) {
  cv::VideoCapture cap = OpenVideo(video);
  const double fps = cap.get(cv::CAP_PROP_FPS);
  // One pass over the packets (grab decodes but skips the colour conversion) for the count and
  // clock.
  std::vector<double> msec;
  const std::string printed = CaptureStderr([&] {
    while (cap.grab()) msec.push_back(cap.get(cv::CAP_PROP_POS_MSEC));
  });
  if (msec.empty())
    throw InputError(video, 0, "video has no frames that decode" + FirstLineDetail(printed));
  const int n = static_cast<int>(msec.size());

  FrameList list;
  if (!frame_times.empty()) {
    list.t_ns = ReadFrameTimes(frame_times);
    if (static_cast<int>(list.t_ns.size()) != n) {
      throw InputError(frame_times, 0,
                       std::to_string(list.t_ns.size()) + " frame times but " + video + " has " +
                           std::to_string(n) + " frames");
    }
  } else {
    const bool fps_ok = fps > 0.0 && std::isfinite(fps);
    bool clock_ok = true;         // strictly increasing
    bool constant_rate = fps_ok;  // t_k = k / fps to the clock's resolution
    for (int i = 0; i < n; ++i) {
      const double ms = msec[static_cast<size_t>(i)];
      // Video clocks have at best microsecond resolution: round there so 50 ms is exactly
      // 50'000'000 ns.
      const int64_t t = std::isfinite(ms) ? std::llround(ms * 1e3) * 1000 : 0;
      if (!std::isfinite(ms) || (i > 0 && t <= list.t_ns.back())) clock_ok = false;
      if (constant_rate && std::abs(static_cast<double>(t) - i * 1e9 / fps) > 2000.0)
        constant_rate = false;
      list.t_ns.push_back(t);
    }
    if (!clock_ok && !fps_ok) {
      throw InputError(
          video, 0, "video has neither a usable clock nor a frame rate: pass --frame-times FILE");
    }
    if (!clock_ok || constant_rate) {
      // t_k = round(k * 1e9 / fps): exact nanoseconds for a constant-rate video (the renderer's own
      // frame times at any rate, e.g. 33'333'333 ns at 30 Hz), and the fallback for a broken clock.
      for (int i = 0; i < n; ++i) list.t_ns[static_cast<size_t>(i)] = std::llround(i * 1e9 / fps);
    }
  }
  list.decoder = std::make_unique<VideoDecoder>(video, n);
  return list;
}

}  // namespace fsp::internal
