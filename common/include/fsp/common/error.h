// Bad input is reported by throwing InputError at the boundary where it is read; apps/ turns it
// into one line on stderr and a non-zero exit. Programmer errors are FSP_CHECK (abort with a
// message).
#pragma once

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace fsp {

// "FILE:LINE: what" (or "FILE: what" when line is 0). Names the file so a user can fix it.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
  InputError(const std::string& file, int line, const std::string& what)
      : std::runtime_error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " +
                           what) {}
};

}  // namespace fsp

// Invariant that only a bug can break; aborts with the location.
#define FSP_CHECK(cond)                                                             \
  do {                                                                              \
    if (!(cond)) {                                                                  \
      std::fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
      std::abort();                                                                 \
    }                                                                               \
  } while (false)
