#include "fsp/common/csv.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "fsp/common/error.h"

namespace fsp {

TableReader::TableReader(const std::string& path, std::string what)
    : path_(path), what_(std::move(what)) {
  if (!std::filesystem::exists(path)) throw InputError(path, 0, what_ + " not found");
  if (std::filesystem::is_directory(path))
    throw InputError(path, 0, "is a directory, expected a " + what_);
  in_ = std::make_unique<std::ifstream>(path);
  if (!*in_) throw InputError(path, 0, "cannot open " + what_);
}

TableReader::TableReader(const std::string& path, std::string what, const std::string& text,
                         int first_line)
    : path_(path),
      what_(std::move(what)),
      in_(std::make_unique<std::istringstream>(text)),
      line_(first_line) {}

bool TableReader::NextRow(std::vector<std::string>* fields) {
  std::string text;
  while (std::getline(*in_, text)) {
    ++line_;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    size_t start = text.find_first_not_of(" \t");
    if (start == std::string::npos || text[start] == '#') continue;
    fields->clear();
    std::string cur;
    bool pending = false;  // a ',' was seen: the next field exists even if empty
    for (size_t i = start; i < text.size(); ++i) {
      const char c = text[i];
      if (c == ',') {
        fields->push_back(cur);
        cur.clear();
        pending = true;
      } else if (c == ' ' || c == '\t') {
        if (!cur.empty()) {
          // whitespace separator unless a comma follows (", " style)
          size_t next = text.find_first_not_of(" \t", i);
          if (next != std::string::npos && text[next] != ',') {
            fields->push_back(cur);
            cur.clear();
            pending = false;
          }
        }
      } else {
        cur.push_back(c);
        pending = false;
      }
    }
    if (!cur.empty() || pending) fields->push_back(cur);
    ++rows_;
    return true;
  }
  return false;
}

void TableReader::Fail(const std::string& what) const {
  throw InputError(path_, line_, what);
}

void TableReader::ExpectColumns(const std::vector<std::string>& fields, size_t min,
                                size_t max) const {
  if (fields.size() < min || fields.size() > max) {
    Fail("expected " +
         (min == max ? std::to_string(min) : std::to_string(min) + " to " + std::to_string(max)) +
         " columns in " + what_ + ", found " + std::to_string(fields.size()));
  }
}

double TableReader::Double(const std::vector<std::string>& fields, size_t index, const char* name,
                           bool allow_nonfinite) const {
  if (index >= fields.size())
    Fail(std::string("missing column ") + std::to_string(index + 1) + " (" + name + ")");
  const std::string& s = fields[index];
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size()) {
    Fail("column " + std::to_string(index + 1) + " (" + name + ") is not a number: '" + s + "'");
  }
  if (!allow_nonfinite && !std::isfinite(v)) {
    Fail("column " + std::to_string(index + 1) + " (" + name + ") is not finite: '" + s + "'");
  }
  return v;
}

int64_t TableReader::Int64(const std::vector<std::string>& fields, size_t index,
                           const char* name) const {
  if (index >= fields.size())
    Fail(std::string("missing column ") + std::to_string(index + 1) + " (" + name + ")");
  const std::string& s = fields[index];
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE) {
    Fail("column " + std::to_string(index + 1) + " (" + name + ") is not an integer: '" + s + "'");
  }
  return static_cast<int64_t>(v);
}

}  // namespace fsp
