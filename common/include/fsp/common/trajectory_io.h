// Trajectory files: TUM (evo's format) and EuRoC ground-truth csv.
//
// Readers validate every row and throw InputError("FILE:LINE: what") on: a wrong column count, a
// value that is not a finite number, a timestamp that does not strictly increase (or, with
// TimeOrder::kNonDecreasing, that goes backwards), a quaternion whose norm is far from 1
// (|‖q‖ − 1| > kQuaternionNormTolerance; nearer ones are normalised).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fsp/common/types.h"

namespace fsp {

// Largest accepted |‖q‖ − 1| of a quaternion read from a file. Files printed with 4 decimals (the
// TUM benchmark's ground truth) are ~1e-4 off; anything beyond 1e-2 is a wrong column order or a
// corrupt row.
constexpr double kQuaternionNormTolerance = 1e-2;

// What the readers require of the time column. Third-party files do repeat a stamp now and then
// (the TUM benchmark's fr2_desk ground truth once, an EuRoC VIO estimate in evo's test data four
// times, each with a different pose); evaluation accepts that as evo does, everything else insists
// on strictly increasing time.
enum class TimeOrder { kStrictlyIncreasing, kNonDecreasing };

// EuRoC ground truth csv: t_ns, p xyz, q wxyz (w first, converted to Eigen's order here), then
// optional v xyz, gyro bias xyz, acc bias xyz: 8, 11, 14 or 17 columns. Missing optional columns
// read as zero.
std::vector<StateSample> ReadEurocGroundTruth(const std::string& path,
                                              TimeOrder order = TimeOrder::kStrictlyIncreasing);
// Writes all 17 columns with a EuRoC header line.
void WriteEurocGroundTruth(const std::vector<StateSample>& states, const std::string& path);

// TUM trajectory: "t_s tx ty tz qx qy qz qw", '#' comments, space or comma separated. The time
// column is converted to integer nanoseconds exactly from its decimal text (no double rounding;
// "1.4037e+09" style is accepted). When `t_s` is given it receives the time column as strtod reads
// it (double seconds): what evo compares when it associates two trajectories, so fsp eval can
// reproduce evo bit for bit.
std::vector<StampedPose> ReadTum(const std::string& path, std::vector<double>* t_s = nullptr,
                                 TimeOrder order = TimeOrder::kStrictlyIncreasing);
// Time with 9 decimals (exact nanoseconds), positions and quaternions with 12 significant digits.
void WriteTum(const std::vector<StampedPose>& poses, const std::string& path);

// Parses a decimal number of seconds ("1311868164.363181", "1.403715278862139940e+09", "-0.5") into
// integer nanoseconds exactly, rounding half away from zero below 1 ns. False when TEXT is not a
// plain decimal number or does not fit in int64 nanoseconds.
bool ParseSecondsToNs(const std::string& text, int64_t* t_ns);

}  // namespace fsp
