// Shared pieces of the fuzz targets (fuzz/README.md): a per-process scratch folder, writing the
// fuzz input into files, splitting one input into several files, and the rule that decides what
// counts as a finding.
//
// Expected outcomes of a reader on any input: it returns a valid result, or it throws
// fsp::InputError (the project's bad-input error). Anything else is a finding: a crash, a hang, an
// ASan/UBSan report, another exception type (reported here with its message, then abort()), or a
// result that breaks what the reader's header promises (checked by each target with FUZZ_CHECK).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <typeinfo>
#include <vector>

#include "fsp/common/error.h"

namespace fsp::fuzz {

// A finding that is not a crash by itself: a promise of the reader's header broken.
#define FUZZ_CHECK(cond)                                                                 \
  do {                                                                                   \
    if (!(cond)) {                                                                       \
      std::fprintf(stderr, "%s:%d: fuzz check failed: %s\n", __FILE__, __LINE__, #cond); \
      std::abort();                                                                      \
    }                                                                                    \
  } while (false)

// A folder of its own for this process (under $TMPDIR, else /tmp), emptied for each input and
// removed when the process exits normally (a crashing process leaves it behind: scripts/fuzz.sh
// points TMPDIR into the build tree and clears it).
class ScratchDir {
 public:
  ScratchDir() {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/fsp_fuzz.XXXXXX";
    std::vector<char> buf(pattern.begin(), pattern.end());
    buf.push_back('\0');
    if (!mkdtemp(buf.data())) {
      std::perror("fsp fuzz: mkdtemp");
      std::abort();
    }
    root_ = buf.data();
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(root_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  // The folder, emptied (call once per input, before writing the input's files).
  const std::filesystem::path& Fresh() const {
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(root_, ec))
      std::filesystem::remove_all(e.path(), ec);
    return root_;
  }
  const std::filesystem::path& path() const { return root_; }

 private:
  std::filesystem::path root_;
};

// The process's scratch folder (created on first use).
inline const ScratchDir& Scratch() {
  static const ScratchDir dir;
  return dir;
}

// Writes BYTES as PATH (creating its folder); false when that is impossible (a file of the same
// name as the folder, ...).
inline bool TryWriteFile(const std::filesystem::path& path, std::string_view bytes) {
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return static_cast<bool>(out);
}

// TryWriteFile for the files a target always writes: failing is a broken machine, not a finding.
inline void WriteFile(const std::filesystem::path& path, std::string_view bytes) {
  if (!TryWriteFile(path, bytes)) {
    std::fprintf(stderr, "fsp fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
}

// Splits DATA into the parts between lines that are exactly MARKER (the marker lines themselves
// dropped), so that one input can hold several files: "a\n<MARKER>\nb" -> {"a\n", "b"}. Missing
// parts are empty.
inline std::vector<std::string> SplitParts(std::string_view data, std::string_view marker,
                                           size_t parts) {
  std::vector<std::string> out(1);
  size_t pos = 0;
  while (pos <= data.size()) {
    const size_t eol = data.find('\n', pos);
    const size_t end = eol == std::string_view::npos ? data.size() : eol + 1;
    std::string_view line = data.substr(pos, end - pos);
    std::string_view bare = line;
    if (!bare.empty() && bare.back() == '\n') bare.remove_suffix(1);
    if (bare == marker && out.size() < parts) {
      out.emplace_back();
    } else {
      out.back().append(line);
    }
    if (eol == std::string_view::npos) break;
    pos = end;
  }
  out.resize(parts);
  return out;
}

// Runs FN; fsp::InputError is an expected outcome (true: FN threw it). Any other exception is a
// finding: its type and message are printed and the process aborts (libFuzzer saves the input).
template <typename Fn>
bool RejectsOrReturns(const char* what, Fn&& fn) {
  try {
    fn();
    return false;
  } catch (const InputError&) {
    return true;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fsp fuzz: %s threw %s (not fsp::InputError): %s\n", what,
                 typeid(e).name(), e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "fsp fuzz: %s threw a non-std exception\n", what);
    std::abort();
  }
}

inline std::string_view AsText(const uint8_t* data, size_t size) {
  return std::string_view(reinterpret_cast<const char*>(data), size);
}

}  // namespace fsp::fuzz
