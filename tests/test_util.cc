#include "test_util.h"

#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

namespace fsp::test {

std::string Slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

ProcessFolder::ProcessFolder(const std::string& name,
                             const std::function<void(const std::filesystem::path&)>& fill)
    : path_(ScratchRoot() / (name + "_" + std::to_string(::getpid()))) {
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
  fill(path_);
}

ProcessFolder::~ProcessFolder() {
  std::error_code ec;  // nothing to report at exit
  std::filesystem::remove_all(path_, ec);
}

CommandResult RunFsp(const std::string& args) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const auto dir =
      ScratchRoot() / "_capture" / (std::string(info->test_suite_name()) + "." + info->name());
  std::filesystem::create_directories(dir);
  const auto out = dir / "out.txt", err = dir / "err.txt";
  const std::string cmd =
      std::string(FSP_BINARY) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(cmd.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = Slurp(out);
  r.err = Slurp(err);
  return r;
}

}  // namespace fsp::test
