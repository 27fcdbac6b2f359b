// IMU csv reader/writer and the shared timestamp check.
#include <charconv>
#include <fstream>
#include <sstream>

#include "dataset_internal.h"
#include "fsp/common/csv.h"
#include "fsp/common/dataset.h"
#include "fsp/common/error.h"

namespace fsp {

namespace internal {

void CheckIncreasing(const TableReader& reader, int64_t t, int64_t prev, int prev_line) {
  if (t == prev) {
    reader.Fail("duplicate timestamp " + std::to_string(t) + " (also on line " +
                std::to_string(prev_line) + ")");
  }
  if (t < prev) {
    reader.Fail("timestamp " + std::to_string(t) + " goes backwards (line " +
                std::to_string(prev_line) + " has " + std::to_string(prev) + ")");
  }
}

void ReadImuRows(TableReader& reader, std::vector<ImuSample>* out, int* prev_line) {
  std::vector<std::string> f;
  static const char* const kNames[] = {"wx", "wy", "wz", "ax", "ay", "az"};
  while (reader.NextRow(&f)) {
    reader.ExpectColumns(f, 7, 7);
    ImuSample s;
    s.t_ns = reader.Int64(f, 0, "t_ns");
    for (int i = 0; i < 3; ++i) s.gyro[i] = reader.Double(f, static_cast<size_t>(1 + i), kNames[i]);
    for (int i = 0; i < 3; ++i)
      s.acc[i] = reader.Double(f, static_cast<size_t>(4 + i), kNames[3 + i]);
    if (!out->empty()) CheckIncreasing(reader, s.t_ns, out->back().t_ns, *prev_line);
    *prev_line = reader.line();
    out->push_back(s);
  }
}

}  // namespace internal

std::vector<ImuSample> ReadImuCsv(const std::string& path) {
  TableReader reader(path, "IMU csv");
  std::vector<ImuSample> out;
  int prev_line = 0;
  internal::ReadImuRows(reader, &out, &prev_line);
  if (out.empty())
    throw InputError(path, 0, "no IMU samples (expected rows t_ns,wx,wy,wz,ax,ay,az)");
  return out;
}

void WriteImuCsv(const std::vector<ImuSample>& imu, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw InputError(path, 0, "cannot write IMU csv");
  out << "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
         "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
  char buf[64];
  std::string line;
  for (const ImuSample& s : imu) {
    line = std::to_string(s.t_ns);
    const double v[6] = {s.gyro.x(), s.gyro.y(), s.gyro.z(), s.acc.x(), s.acc.y(), s.acc.z()};
    for (double x : v) {
      // Shortest decimal that reads back to exactly x.
      const auto res = std::to_chars(buf, buf + sizeof(buf), x);
      line.push_back(',');
      line.append(buf, res.ptr);
    }
    line.push_back('\n');
    out << line;
  }
  if (!out) throw InputError(path, 0, "error while writing IMU csv");
}

}  // namespace fsp
