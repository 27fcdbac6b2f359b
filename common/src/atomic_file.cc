#include "fsp/common/atomic_file.h"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "fsp/common/error.h"

namespace fsp {

namespace fs = std::filesystem;

std::string PartPath(const std::string& path) {
  const fs::path p(path);
  return (p.parent_path() / ("." + p.stem().string() + ".part" + p.extension().string())).string();
}

void CommitPart(const std::string& part, const std::string& path) {
  std::error_code ec;
  fs::rename(part, path, ec);
  if (ec) {
    fs::remove(part, ec);
    throw InputError(path, 0, "cannot replace the file: " + ec.message());
  }
}

void WriteFileAtomically(const std::string& path, const std::string& what,
                         const std::function<void(std::ostream&)>& write) {
  const std::string part = PartPath(path);
  {
    std::ofstream out(part);
    if (!out) throw InputError(path, 0, "cannot write " + what);
    try {
      write(out);
    } catch (...) {
      out.close();
      std::error_code ec;
      fs::remove(part, ec);
      throw;
    }
    out.flush();
    if (!out) {
      out.close();
      std::error_code ec;
      fs::remove(part, ec);
      throw InputError(path, 0, "error while writing " + what);
    }
  }
  CommitPart(part, path);
}

}  // namespace fsp
