// `fsp run --show`: the annotated frame (AnnotatedVideo's drawing) in a window while the run goes
// on, where a display exists. An observer of the pipeline's results in apps/, like the video.
#pragma once

#include <string>

#include <opencv2/core/mat.hpp>

namespace fsp::apps {

class LiveWindow {
 public:
  LiveWindow() = default;
  ~LiveWindow();
  LiveWindow(const LiveWindow&) = delete;
  LiveWindow& operator=(const LiveWindow&) = delete;

  // Opens the window; false with WHY (one line for a warning) when $DISPLAY is not set or OpenCV
  // cannot open a window there. OpenCV's Qt backend aborts the process on a display it cannot
  // reach instead of throwing, so a child process tries first: call this before starting threads
  // (fork copies only the calling thread).
  bool Open(std::string* why);
  // Shows IMAGE (BGR) and lets the window draw itself; nothing when the window is not open.
  void Show(const cv::Mat& image);

 private:
  bool open_ = false;
};

}  // namespace fsp::apps
