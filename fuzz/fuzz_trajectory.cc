// Trajectory files: TUM ("t_s tx ty tz qx qy qz qw": `fsp eval --est`, a scene's pose file) and the
// EuRoC ground-truth csv (`fsp eval --gt`): ReadTum and ReadEurocGroundTruth in both time orders,
// and fsp::eval::ReadTrajectory, which tells the two apart by content. What they return must keep
// trajectory_io.h's promises: time order, unit quaternions, finite values, and a TUM time in exact
// nanoseconds that agrees with the double strtod reads (the same text).
#include <cmath>

#include "fsp/common/trajectory_io.h"
#include "fsp/eval/trajectory_metrics.h"
#include "fuzz_util.h"

namespace {

void CheckPose(const fsp::Rigid3& T) {
  FUZZ_CHECK(T.translation().allFinite());
  FUZZ_CHECK(std::abs(T.rotation().norm() - 1.0) < 1e-9);
}

void CheckTum(const std::string& path, fsp::TimeOrder order) {
  std::vector<fsp::StampedPose> poses;
  std::vector<double> t_s;
  if (fsp::fuzz::RejectsOrReturns("ReadTum", [&] { poses = fsp::ReadTum(path, &t_s, order); }))
    return;
  FUZZ_CHECK(!poses.empty() && t_s.size() == poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    CheckPose(poses[i].T_W_B);
    FUZZ_CHECK(std::isfinite(t_s[i]));
    // Exact nanoseconds vs strtod's double: apart by strtod's rounding and the 0.5 ns rounding.
    const long double ns = static_cast<long double>(poses[i].t_ns);
    const long double from_double = static_cast<long double>(t_s[i]) * 1e9L;
    FUZZ_CHECK(std::fabs(ns - from_double) <= 1.0L + std::fabs(from_double) * 1e-15L);
    if (i > 0) {
      FUZZ_CHECK(order == fsp::TimeOrder::kStrictlyIncreasing ? poses[i].t_ns > poses[i - 1].t_ns
                                                              : poses[i].t_ns >= poses[i - 1].t_ns);
    }
  }
}

void CheckEuroc(const std::string& path, fsp::TimeOrder order) {
  std::vector<fsp::StateSample> states;
  if (fsp::fuzz::RejectsOrReturns("ReadEurocGroundTruth",
                                  [&] { states = fsp::ReadEurocGroundTruth(path, order); }))
    return;
  FUZZ_CHECK(!states.empty());
  for (size_t i = 0; i < states.size(); ++i) {
    CheckPose(states[i].T_W_B);
    FUZZ_CHECK(states[i].v_W.allFinite() && states[i].gyro_bias.allFinite() &&
               states[i].acc_bias.allFinite());
    if (i > 0) {
      FUZZ_CHECK(order == fsp::TimeOrder::kStrictlyIncreasing
                     ? states[i].t_ns > states[i - 1].t_ns
                     : states[i].t_ns >= states[i - 1].t_ns);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace fsp;
  const auto& dir = fuzz::Scratch().Fresh();
  const std::string path = (dir / "trajectory.txt").string();
  fuzz::WriteFile(path, fuzz::AsText(data, size));
  for (const TimeOrder order : {TimeOrder::kStrictlyIncreasing, TimeOrder::kNonDecreasing}) {
    CheckTum(path, order);
    CheckEuroc(path, order);
  }
  eval::Trajectory traj;
  if (!fuzz::RejectsOrReturns("eval::ReadTrajectory", [&] { traj = eval::ReadTrajectory(path); })) {
    FUZZ_CHECK(traj.size() > 0 && traj.t_ns.size() == traj.size() &&
               traj.t_s.size() == traj.size());
    for (const Rigid3& T : traj.T_W_B) CheckPose(T);
  }
  return 0;
}
