#include "fsp/common/trajectory_io.h"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>

#include "fsp/common/atomic_file.h"
#include "fsp/common/csv.h"
#include "fsp/common/error.h"

namespace fsp {

namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.12g", v);
  return buf;
}

// Exact "<seconds>.<9 digits>" text of an int64 nanosecond time (also for negative times).
std::string SecondsText(int64_t t_ns) {
  const bool negative = t_ns < 0;
  // Work on the magnitude as unsigned so INT64_MIN does not overflow.
  const uint64_t mag =
      negative ? static_cast<uint64_t>(-(t_ns + 1)) + 1u : static_cast<uint64_t>(t_ns);
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%s%" PRIu64 ".%09" PRIu64, negative ? "-" : "",
                mag / 1000000000u, mag % 1000000000u);
  return buf;
}

// Quaternion from four file values; throws (through the reader) when its norm is far from 1.
Quat CheckedQuat(const TableReader& reader, double w, double x, double y, double z) {
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
    reader.Fail("quaternion norm " + Num(norm) +
                " is far from 1 (wrong column order or a corrupt row?)");
  }
  return Quat(w, x, y, z).normalized();
}

bool OutOfOrder(int64_t t_ns, int64_t previous_ns, TimeOrder order) {
  return order == TimeOrder::kStrictlyIncreasing ? t_ns <= previous_ns : t_ns < previous_ns;
}

std::ofstream OpenForWriting(const std::string& path, const char* what) {
  std::ofstream out(path);
  if (!out) throw InputError(path, 0, std::string("cannot write ") + what);
  return out;
}

}  // namespace

bool ParseSecondsToNs(const std::string& text, int64_t* t_ns) {
  size_t i = 0;
  bool negative = false;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) negative = text[i++] == '-';
  std::string digits;   // all mantissa digits, the decimal point removed
  int int_digits = -1;  // digits before the decimal point (-1: no point seen yet)
  for (; i < text.size(); ++i) {
    const char c = text[i];
    if (c >= '0' && c <= '9') {
      digits.push_back(c);
    } else if (c == '.' && int_digits < 0) {
      int_digits = static_cast<int>(digits.size());
    } else {
      break;
    }
  }
  if (digits.empty()) return false;
  if (int_digits < 0) int_digits = static_cast<int>(digits.size());
  long exponent = 0;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    bool exp_negative = false;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) exp_negative = text[i++] == '-';
    if (i >= text.size()) return false;
    for (; i < text.size(); ++i) {
      if (text[i] < '0' || text[i] > '9') return false;
      exponent = exponent * 10 + (text[i] - '0');
      if (exponent > 1000) return false;
    }
    if (exp_negative) exponent = -exponent;
  }
  if (i != text.size()) return false;
  // value = 0.d1d2... * 10^int_digits * 10^exponent; in nanoseconds the decimal point moves 9
  // further right.
  const long point = int_digits + exponent + 9;  // digits[0, point) form the integer nanoseconds
  uint64_t ns = 0;
  const uint64_t limit = static_cast<uint64_t>(std::numeric_limits<int64_t>::max());
  for (long k = 0; k < point; ++k) {
    const int d = k < static_cast<long>(digits.size()) ? digits[static_cast<size_t>(k)] - '0' : 0;
    if (ns > (limit - static_cast<uint64_t>(d)) / 10u) return false;
    ns = ns * 10u + static_cast<uint64_t>(d);
  }
  // Round half away from zero on the first dropped digit.
  if (point >= 0 && point < static_cast<long>(digits.size()) &&
      digits[static_cast<size_t>(point)] >= '5') {
    if (ns == limit) return false;
    ++ns;
  }
  *t_ns = negative ? -static_cast<int64_t>(ns) : static_cast<int64_t>(ns);
  return true;
}

std::vector<StampedPose> ReadTum(const std::string& path, std::vector<double>* t_s,
                                 TimeOrder order) {
  TableReader reader(path, "TUM trajectory");
  std::vector<StampedPose> poses;
  if (t_s) t_s->clear();
  std::vector<std::string> f;
  while (reader.NextRow(&f)) {
    reader.ExpectColumns(f, 8, 8);
    const double seconds = reader.Double(f, 0, "t_s");
    StampedPose pose;
    if (!ParseSecondsToNs(f[0], &pose.t_ns)) {
      reader.Fail("column 1 (t_s) is not a time in seconds that fits in int64 nanoseconds: '" +
                  f[0] + "'");
    }
    if (!poses.empty() && OutOfOrder(pose.t_ns, poses.back().t_ns, order)) {
      reader.Fail(
          "timestamp " + f[0] +
          (order == TimeOrder::kStrictlyIncreasing ? " does not increase" : " goes backwards") +
          " (previous row has " + SecondsText(poses.back().t_ns) + " s)");
    }
    const Vec3 p(reader.Double(f, 1, "tx"), reader.Double(f, 2, "ty"), reader.Double(f, 3, "tz"));
    const double qx = reader.Double(f, 4, "qx"), qy = reader.Double(f, 5, "qy");
    const double qz = reader.Double(f, 6, "qz"), qw = reader.Double(f, 7, "qw");
    pose.T_W_B = Rigid3(CheckedQuat(reader, qw, qx, qy, qz), p);
    poses.push_back(pose);
    if (t_s) t_s->push_back(seconds);
  }
  if (poses.empty()) throw InputError(path, 0, "TUM trajectory has no poses");
  return poses;
}

void WriteTum(const std::vector<StampedPose>& poses, const std::string& path) {
  WriteFileAtomically(path, "TUM trajectory", [&](std::ostream& out) {
    out << "# t_s tx ty tz qx qy qz qw\n";
    for (const StampedPose& pose : poses) {
      const Vec3& p = pose.T_W_B.translation();
      const Quat& q = pose.T_W_B.rotation();
      out << SecondsText(pose.t_ns) << ' ' << Num(p.x()) << ' ' << Num(p.y()) << ' ' << Num(p.z())
          << ' ' << Num(q.x()) << ' ' << Num(q.y()) << ' ' << Num(q.z()) << ' ' << Num(q.w())
          << '\n';
    }
  });
}

std::vector<StateSample> ReadEurocGroundTruth(const std::string& path, TimeOrder order) {
  TableReader reader(path, "EuRoC ground-truth csv");
  std::vector<StateSample> states;
  std::vector<std::string> f;
  while (reader.NextRow(&f)) {
    if (f.size() != 8 && f.size() != 11 && f.size() != 14 && f.size() != 17) {
      reader.Fail(
          "expected 8, 11, 14 or 17 columns in EuRoC ground-truth csv (t_ns, p xyz, q wxyz[, v xyz"
          "[, gyro bias xyz[, acc bias xyz]]]), found " +
          std::to_string(f.size()));
    }
    StateSample s;
    s.t_ns = reader.Int64(f, 0, "t_ns");
    if (!states.empty() && OutOfOrder(s.t_ns, states.back().t_ns, order)) {
      reader.Fail(
          "timestamp " + f[0] +
          (order == TimeOrder::kStrictlyIncreasing ? " does not increase" : " goes backwards") +
          " (previous row has " + std::to_string(states.back().t_ns) + ")");
    }
    const Vec3 p(reader.Double(f, 1, "px"), reader.Double(f, 2, "py"), reader.Double(f, 3, "pz"));
    // EuRoC stores the quaternion w first; Eigen's constructor takes (w, x, y, z) too.
    const double qw = reader.Double(f, 4, "qw"), qx = reader.Double(f, 5, "qx");
    const double qy = reader.Double(f, 6, "qy"), qz = reader.Double(f, 7, "qz");
    s.T_W_B = Rigid3(CheckedQuat(reader, qw, qx, qy, qz), p);
    if (f.size() >= 11)
      s.v_W =
          Vec3(reader.Double(f, 8, "vx"), reader.Double(f, 9, "vy"), reader.Double(f, 10, "vz"));
    if (f.size() >= 14) {
      s.gyro_bias = Vec3(reader.Double(f, 11, "bgx"), reader.Double(f, 12, "bgy"),
                         reader.Double(f, 13, "bgz"));
    }
    if (f.size() >= 17) {
      s.acc_bias = Vec3(reader.Double(f, 14, "bax"), reader.Double(f, 15, "bay"),
                        reader.Double(f, 16, "baz"));
    }
    states.push_back(s);
  }
  if (states.empty()) throw InputError(path, 0, "EuRoC ground-truth csv has no rows");
  return states;
}

void WriteEurocGroundTruth(const std::vector<StateSample>& states, const std::string& path) {
  std::ofstream out = OpenForWriting(path, "EuRoC ground-truth csv");
  out << "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
         "q_RS_z [], "
         "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
         "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
         "b_a_RS_S_z [m s^-2]\n";
  for (const StateSample& s : states) {
    const Vec3& p = s.T_W_B.translation();
    const Quat& q = s.T_W_B.rotation();
    out << s.t_ns;
    for (double v : {p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z(), s.v_W.x(), s.v_W.y(),
                     s.v_W.z(), s.gyro_bias.x(), s.gyro_bias.y(), s.gyro_bias.z(), s.acc_bias.x(),
                     s.acc_bias.y(), s.acc_bias.z()}) {
      out << ',' << Num(v);
    }
    out << '\n';
  }
  if (!out) throw InputError(path, 0, "error while writing EuRoC ground-truth csv");
}

}  // namespace fsp
