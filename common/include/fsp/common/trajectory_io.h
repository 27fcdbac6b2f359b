// Trajectory files: TUM (evo's format) and EuRoC ground-truth csv.
#pragma once

#include <string>
#include <vector>

#include "fsp/common/types.h"

namespace fsp {

// EuRoC ground truth csv: t_ns, p xyz, q wxyz, v xyz, gyro bias xyz, acc bias xyz (extra columns ignored;
// the first 8 are required).
std::vector<StateSample> ReadEurocGroundTruth(const std::string& path);
void WriteEurocGroundTruth(const std::vector<StateSample>& states, const std::string& path);

// TUM trajectory: "t_s tx ty tz qx qy qz qw", '#' comments, space or comma separated.
std::vector<StampedPose> ReadTum(const std::string& path);
void WriteTum(const std::vector<StampedPose>& poses, const std::string& path);

}  // namespace fsp
