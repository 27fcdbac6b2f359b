// Shared helpers for the tests: where the real test data lives, scratch directories, running `fsp`.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>

#include <gtest/gtest.h>

namespace fsp::test {

// $FSP_TEST_DATA, else ../shared/data beside the checkout; empty when neither exists.
inline std::string TestDataDir() {
  if (const char* env = std::getenv("FSP_TEST_DATA"); env && *env) return env;
  return std::filesystem::exists(FSP_DEFAULT_TEST_DATA) ? FSP_DEFAULT_TEST_DATA : "";
}

// Path of SUB inside the test data; the calling test skips (with the reason) when it is absent.
#define FSP_REQUIRE_TEST_DATA(var, sub)                                    \
  const std::string var = ::fsp::test::TestDataDir() + "/" + (sub);        \
  if (::fsp::test::TestDataDir().empty() || !std::filesystem::exists(var)) \
  GTEST_SKIP() << "test data '" << (sub)                                   \
               << "' not found: set FSP_TEST_DATA to the shared data "     \
                  "directory (see docs/development.md)"

// The DM-VIO room walk (a handheld RealSense recording in the DSO layout; fetched, never copied
// here: see the shared data's README): $FSP_DMVIO_WALK, else /work/scratch/dmvio when it exists;
// empty when neither.
inline std::string DmvioWalkDir() {
  if (const char* env = std::getenv("FSP_DMVIO_WALK"); env && *env) return env;
  return std::filesystem::exists("/work/scratch/dmvio") ? "/work/scratch/dmvio" : "";
}

#define FSP_REQUIRE_DMVIO_WALK(var)                                                               \
  const std::string var = ::fsp::test::DmvioWalkDir();                                            \
  if (var.empty() || !std::filesystem::exists(std::filesystem::path(var) / "cam0" / "times.txt")) \
  GTEST_SKIP() << "DM-VIO room walk not found: fetch github:Zoltan3057/DM-VIO-dataset (commit "   \
                  "7f0fcff) into a scratch folder and set FSP_DMVIO_WALK to it"

// Where the tests write: test_scratch/ in this build tree.
inline std::filesystem::path ScratchRoot() {
  return FSP_TEST_SCRATCH;
}

// A fresh, empty scratch directory named after the running test.
inline std::filesystem::path ScratchDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path dir =
      ScratchRoot() / (std::string(info->test_suite_name()) + "." + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// A folder for what one test process renders once and reads in several tests:
// ScratchRoot()/NAME_<pid>, created empty and handed to FILL (CTest runs the tests of a file as
// parallel processes: a shared folder would be deleted by one while another reads it). Removed
// when the object is destroyed, so a function-local static one goes when the process exits: the
// suite leaves no renders behind.
class ProcessFolder {
 public:
  ProcessFolder(const std::string& name,
                const std::function<void(const std::filesystem::path&)>& fill);
  ~ProcessFolder();
  ProcessFolder(const ProcessFolder&) = delete;
  ProcessFolder& operator=(const ProcessFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

struct CommandResult {
  int exit_code = 0;
  std::string out;  // stdout
  std::string err;  // stderr
};

// Runs the built `fsp` binary with ARGS (a shell-quoted string), capturing stdout and stderr.
CommandResult RunFsp(const std::string& args);

// The bytes of a file (empty when it cannot be read).
std::string Slurp(const std::filesystem::path& p);

}  // namespace fsp::test
