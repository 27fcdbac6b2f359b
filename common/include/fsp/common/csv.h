// Line-numbered reading of text tables (csv, TUM, whitespace separated), so every malformed row is
// reported as "FILE:LINE: what" (InputError).
#pragma once

#include <cstdint>
#include <fstream>
#include <istream>
#include <memory>
#include <string>
#include <vector>

namespace fsp {

class TableReader {
 public:
  // Opens PATH; throws InputError when it does not exist or cannot be read. `what` names the kind
  // of file in messages ("IMU csv", "TUM trajectory").
  explicit TableReader(const std::string& path, std::string what = "file");
  // Reads TEXT instead of the file: lines of PATH that follow line FIRST_LINE (for a file read
  // piece by piece as it grows); messages name PATH and the line in the file.
  TableReader(const std::string& path, std::string what, const std::string& text, int first_line);

  // Next data row split on ',' and/or whitespace; skips blank lines and lines starting with '#'.
  // Returns false at the end of the file.
  bool NextRow(std::vector<std::string>* fields);

  int line() const { return line_; }
  const std::string& path() const { return path_; }
  int rows_read() const { return rows_; }

  // Field parsers that throw InputError naming the file, line and column ("column 3 (wx)").
  double Double(const std::vector<std::string>& fields, size_t index, const char* name,
                bool allow_nonfinite = false) const;
  int64_t Int64(const std::vector<std::string>& fields, size_t index, const char* name) const;
  // Throws unless the row has at least `min` and at most `max` fields.
  void ExpectColumns(const std::vector<std::string>& fields, size_t min, size_t max) const;
  [[noreturn]] void Fail(const std::string& what) const;

 private:
  std::string path_;
  std::string what_;
  std::unique_ptr<std::istream> in_;
  int line_ = 0;
  int rows_ = 0;
};

}  // namespace fsp
