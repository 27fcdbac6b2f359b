// Keeps third-party decoders' messages off the terminal (see dataset_internal.h).
#include <unistd.h>

#include <cstdio>
#include <exception>
#include <mutex>

#include "dataset_internal.h"

namespace fsp::internal {

std::string CaptureStderr(const std::function<void()>& fn) {
  static std::mutex mutex;
  const std::lock_guard<std::mutex> lock(mutex);
  std::fflush(stderr);
  FILE* tmp = std::tmpfile();
  const int saved = tmp ? dup(STDERR_FILENO) : -1;
  if (!tmp || saved < 0 || dup2(fileno(tmp), STDERR_FILENO) < 0) {  // cannot capture: run as is
    if (saved >= 0) close(saved);
    if (tmp) std::fclose(tmp);
    fn();
    return "";
  }
  std::exception_ptr error;
  try {
    fn();
  } catch (...) {
    error = std::current_exception();
  }
  std::fflush(stderr);
  dup2(saved, STDERR_FILENO);
  close(saved);
  std::string text;
  std::rewind(tmp);
  char buf[4096];
  size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof(buf), tmp)) > 0 && text.size() < 65536) text.append(buf, n);
  std::fclose(tmp);
  if (error) std::rethrow_exception(error);
  return text;
}

std::string FirstLineDetail(const std::string& text) {
  const size_t start = text.find_first_not_of(" \t\r\n");
  if (start == std::string::npos) return "";
  size_t end = text.find_first_of("\r\n", start);
  if (end == std::string::npos) end = text.size();
  return ": " + text.substr(start, end - start);
}

}  // namespace fsp::internal
