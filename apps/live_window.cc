#include "live_window.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include <opencv2/highgui.hpp>

namespace fsp::apps {

namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kName = "fsp run";

// Whether OpenCV can open a window, tried in a child process first: a GUI backend that cannot
// reach the display may abort the whole process (Qt does) instead of throwing. Called before any
// thread is started (fork copies only the calling thread).
bool WindowOpensInChild() {
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) return false;
  if (pid == 0) {
    const int devnull = open("/dev/null", O_WRONLY);
    if (devnull >= 0) {
      dup2(devnull, STDOUT_FILENO);
      dup2(devnull, STDERR_FILENO);
    }
    try {
      cv::namedWindow("fsp probe", cv::WINDOW_AUTOSIZE);
      cv::destroyAllWindows();
    } catch (...) {
      _exit(1);
    }
    _exit(0);
  }
  int status = 0;
  const Clock::time_point give_up = Clock::now() + std::chrono::seconds(5);
  for (;;) {
    const pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0) return false;
    if (Clock::now() > give_up) {  // a display that does not answer
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace

bool LiveWindow::Open(std::string* why) {
  const char* display = std::getenv("DISPLAY");
  if (!display || !*display) {
    *why = "--show: no display ($DISPLAY is not set): running without the window";
    return false;
  }
  if (!WindowOpensInChild()) {
    *why = std::string("--show: OpenCV cannot open a window on display ") + display +
           " (no GUI backend, or the display does not answer): running without it";
    return false;
  }
  try {
    cv::namedWindow(kName, cv::WINDOW_AUTOSIZE);
  } catch (const cv::Exception& e) {
    *why = "--show: OpenCV cannot open a window (" + e.err.substr(0, e.err.find('\n')) +
           "): running without it";
    return false;
  }
  open_ = true;
  return true;
}

void LiveWindow::Show(const cv::Mat& image) {
  if (!open_ || image.empty()) return;
  cv::imshow(kName, image);
  cv::waitKey(1);
}

LiveWindow::~LiveWindow() {
  if (open_) cv::destroyWindow(kName);
}

}  // namespace fsp::apps
