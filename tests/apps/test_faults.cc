// Faults real drivers produce, end to end through `fsp run --frontend gt-corners` (window mode): a
// 3 s hole in the IMU stream, 2 s of dropped frames, 10 s with no object in view, and a divergence
// forced by a bias bound no estimate can meet. Each run must end normally with a pose for every
// frame, a map, and the fault counted in run.json ("faults"). The sequence (the end-to-end room, a
// 26 s loop around its centre looking at each of its four walls in turn) is rendered once per test
// process without images (ground truth, IMU, corners: about a second); the faults are cut out of
// copies of its files.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fsp/common/trajectory_io.h"
#include "fsp/eval/evaluate.h"
#include "fsp/sim/scene.h"
#include "fsp/sim/sequence_writer.h"
#include "room_loop.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;

const fs::path& Sequence() {
  return test::RoomLoopSequence();
}

// Copies the sequence into DIR, keeping only the rows of FILE (relative path) for which KEEP(t_ns)
// holds (comment lines are kept).
void CopyWithout(const fs::path& dir, const std::string& file,
                 const std::function<bool(int64_t)>& keep) {
  fs::remove_all(dir);
  fs::copy(Sequence(), dir, fs::copy_options::recursive);
  std::ifstream in(Sequence() / file);
  std::ofstream out(dir / file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || keep(std::stoll(line.substr(0, line.find(',')))))
      out << line << "\n";
  }
}

// Copies the sequence into DIR with every data row of FILE passed through EDIT as its
// comma-separated fields (comment lines are kept as they are).
void CopyEditing(const fs::path& dir, const std::string& file,
                 const std::function<void(std::vector<std::string>*)>& edit) {
  CopyWithout(dir, file, [](int64_t) { return false; });
  std::ifstream in(Sequence() / file);
  std::ofstream out(dir / file);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') {
      std::vector<std::string> f;
      std::stringstream ss(line);
      for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
      edit(&f);
      line = f[0];
      for (size_t k = 1; k < f.size(); ++k) line += "," + f[k];
    }
    out << line << "\n";
  }
}

bool Outside(int64_t t_ns, double from_s, double to_s) {
  return t_ns < static_cast<int64_t>(from_s * 1e9) || t_ns >= static_cast<int64_t>(to_s * 1e9);
}

struct FaultRun {
  test::CommandResult command;
  nlohmann::json run, faults, map;
  size_t poses = 0;
  bool finite = true;
  double ate = -1.0;
};

FaultRun RunFaulty(const fs::path& sequence, const fs::path& out, const std::string& extra = "") {
  FaultRun r;
  r.command = test::RunFsp("run " + sequence.string() + " --frontend gt-corners --seed 1 --out " +
                           out.string() + " " + extra);
  EXPECT_EQ(r.command.exit_code, 0) << r.command.err;
  if (r.command.exit_code != 0) return r;
  std::ifstream(out / "run.json") >> r.run;
  std::ifstream(out / "map.json") >> r.map;
  r.faults = r.run["faults"];
  const std::vector<StampedPose> poses = ReadTum((out / "trajectory.tum").string());
  r.poses = poses.size();
  for (const StampedPose& p : poses) r.finite = r.finite && p.T_W_B.Matrix().allFinite();
  const eval::Metrics m =
      eval::Evaluate(eval::ResolvePaths(sequence.string(), out.string()), eval::EvalOptions());
  if (m.trajectory) r.ate = m.trajectory->ate.rmse;
  std::printf("[%s] ATE %.3f m, %zu poses, %zu objects in the map, starts rejected %d, faults %s\n",
              out.filename().c_str(), r.ate, r.poses, r.map["objects"].size(),
              r.run["estimator"]["starts_rejected"].get<int>(), r.faults.dump().c_str());
  return r;
}

// What every faulty run must give: a normal end, one finite pose per frame given, a map.
void ExpectCompleteRun(const FaultRun& r, size_t frames) {
  EXPECT_EQ(r.run["frames_processed"].get<size_t>(), frames);
  EXPECT_EQ(r.poses, frames);
  EXPECT_TRUE(r.finite);
  EXPECT_GE(r.map["objects"].size(), 5u);
  EXPECT_GT(r.ate, 0.0);
}

constexpr size_t kFrames = test::kRoomLoopFrames;

// Without faults: the reference for the ATE of the faulty runs, and no fault is reported.
TEST(Faults, NoFaultNoCounter) {
  const FaultRun r = RunFaulty(Sequence(), test::ScratchDir() / "clean");
  ExpectCompleteRun(r, kFrames);
  for (const char* k : {"imu_gaps", "frame_gaps", "blind_stretches", "divergences", "resets"})
    EXPECT_EQ(r.faults[k].get<int>(), 0) << k;
  EXPECT_TRUE(r.faults["warnings"].empty());
  EXPECT_EQ(r.run["estimator"]["starts_rejected"].get<int>(), 0) << "1 px noise is no fault";
  EXPECT_LT(r.ate, 0.045);  // measured 2.7 cm (11.9 cm before the global step)
}

// A sequence rendered without images (one grey placeholder per frame) run from pixels: the run
// completes, and one warning says why nothing is mapped instead of an empty map without a word.
TEST(Faults, NoPixelsFromPixelsIsWarned) {
  const test::CommandResult r =
      test::RunFsp("run " + test::RoomLoopSequence().string() + " --frontend rect --out " +
                   (test::ScratchDir() / "run").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("the first image is one uniform grey level"), std::string::npos) << r.err;
}

// 3 s without IMU samples (as a driver that stalls): the constant-velocity motion prior bridges
// it; before, the preintegration across the hole aborted the run (an LLT check).
TEST(Faults, ImuGapOfThreeSeconds) {
  const fs::path dir = test::ScratchDir();
  CopyWithout(dir / "seq", "mav0/imu0/data.csv", [](int64_t t) { return Outside(t, 9.0, 12.0); });
  const FaultRun r = RunFaulty(dir / "seq", dir / "imu_gap");
  ExpectCompleteRun(r, kFrames);
  EXPECT_EQ(r.faults["imu_gaps"].get<int>(), 1);
  EXPECT_NEAR(r.faults["imu_gap_max_s"].get<double>(), 3.0, 0.02);
  EXPECT_GT(r.faults["imu_gap_links"].get<int>(), 0);
  EXPECT_NE(r.command.err.find("warning: t=9."), std::string::npos) << r.command.err;
  EXPECT_EQ(r.faults["divergences"].get<int>(), 0);
  // Measured 3.3 cm (2.8 without the gap; 14.9 cm before the global step); before, the run
  // aborted.
  EXPECT_LT(r.ate, 0.05);  // measured 3.3 cm (14.9 cm before the global step)
}

// 2 s of dropped frames (the IMU continues): the IMU preintegration bridges them.
TEST(Faults, TwoSecondsOfDroppedFrames) {
  const fs::path dir = test::ScratchDir();
  const auto keep = [](int64_t t) { return Outside(t, 9.0, 11.0); };
  CopyWithout(dir / "seq", "mav0/cam0/data.csv", keep);
  const FaultRun r = RunFaulty(dir / "seq", dir / "frame_gap");
  ExpectCompleteRun(r, kFrames - 40);
  EXPECT_EQ(r.faults["frame_gaps"].get<int>(), 1);
  EXPECT_NEAR(r.faults["frame_gap_max_s"].get<double>(), 2.05, 0.01);
  EXPECT_NE(r.command.err.find("frame gap"), std::string::npos) << r.command.err;
  EXPECT_EQ(r.faults["blind_stretches"].get<int>(), 0);  // objects were in view around the gap
  EXPECT_LT(r.ate, 0.045);  // measured 3.0 cm (13.0 cm before the global step)
}

// 10 s with no object in view (every observation removed): IMU dead reckoning, reported.
TEST(Faults, TenSecondsWithNothingInView) {
  const fs::path dir = test::ScratchDir();
  CopyWithout(dir / "seq", "observations_gt.csv", [](int64_t t) { return Outside(t, 8.0, 18.0); });
  const FaultRun r = RunFaulty(dir / "seq", dir / "blind");
  ExpectCompleteRun(r, kFrames);
  EXPECT_EQ(r.faults["blind_stretches"].get<int>(), 1);
  EXPECT_NEAR(r.faults["blind_max_s"].get<double>(), 10.05, 0.01);
  EXPECT_NE(r.command.err.find("no object in view"), std::string::npos) << r.command.err;
  // Measured 2.1 cm: the objects seen again after the 10 s of dead reckoning close their loops
  // in the global step (72.8 cm before it: the window alone cannot undo the drift).
  EXPECT_LT(r.ate, 0.035);
}

// Global solves that keep diverging restart the estimator: with max_jump_m 0.3 m, after 10 s of
// dead reckoning the global solves that close the returning objects' loops move old keyframes
// further and are rejected, again and again; after two in a row the estimator restarts.
TEST(Faults, GlobalSolvesThatKeepDivergingRestartTheEstimator) {
  const fs::path dir = test::ScratchDir(), cfg = dir / "jump.yaml";
  CopyWithout(dir / "seq", "observations_gt.csv", [](int64_t t) { return Outside(t, 8.0, 18.0); });
  std::ofstream(cfg) << "estimator:\n  faults:\n    max_jump_m: 0.3\n";
  const FaultRun r = RunFaulty(dir / "seq", dir / "jump", "--config " + cfg.string());
  ExpectCompleteRun(r, kFrames);
  // Measured: rejected at 18.5 and 19.0 s (a keyframe moved 0.31 m), restarted at 19.0 s, once.
  EXPECT_GE(r.faults["divergences"].get<int>(), 1);
  EXPECT_EQ(r.faults["resets"].get<int>(), r.faults["divergences"].get<int>());
  const size_t rejected = r.command.err.find("divergence in a global solve");
  ASSERT_NE(rejected, std::string::npos) << r.command.err;
  EXPECT_NE(r.command.err.find("divergence (two global solves in a row", rejected),
            std::string::npos)
      << r.command.err;
}

// Divergence detection and restart: an accelerometer-bias bound below what any solve gives makes
// every solve "diverge"; each is rejected and the estimator restarts, and the run still ends with a
// finite pose per frame.
TEST(Faults, DivergenceIsDetectedAndTheEstimatorRestarts) {
  const fs::path dir = test::ScratchDir(), cfg = dir / "tight.yaml";
  std::ofstream(cfg) << "estimator:\n  faults:\n    max_acc_bias: 1.0e-6\n";
  const FaultRun r = RunFaulty(Sequence(), dir / "diverge", "--config " + cfg.string());
  EXPECT_EQ(r.poses, kFrames);
  EXPECT_TRUE(r.finite);
  EXPECT_GT(r.faults["divergences"].get<int>(), 0);
  EXPECT_EQ(r.faults["resets"].get<int>(), r.faults["divergences"].get<int>());
  EXPECT_NE(r.command.err.find("divergence (accelerometer bias"), std::string::npos)
      << r.command.err;
}

// A corrupted IMU burst (a driver glitch: 0.5 s with 60 m/s^2 added on the accelerometer's x):
// the window follows it until the speed or the objects in view give it away, then the solve is
// rejected and the estimator restarts once. Measured: detected at t = 10.5 s, 1 divergence, 1
// reset; with the 45-keyframe window by the speed (30 m/s, max_speed), with 30 keyframes by the 2
// objects in view 52 px from their prediction at a speed of 29.9 m/s; the trajectory stays
// continuous but keeps the error accumulated before the detection (ATE 3.4 m on this loop; 154 m
// when nothing caught it). The new session's global solves are accepted.
TEST(Faults, CorruptedImuBurstIsDetectedAndTheEstimatorRestarts) {
  const fs::path dir = test::ScratchDir();
  CopyEditing(dir / "seq", "mav0/imu0/data.csv", [](std::vector<std::string>* f) {
    const int64_t t = std::stoll((*f)[0]);
    if (t >= 10'000'000'000 && t < 10'500'000'000)
      (*f)[4] = std::to_string(std::stod((*f)[4]) + 60.0);  // a_x
  });
  const FaultRun r = RunFaulty(dir / "seq", dir / "burst");
  ExpectCompleteRun(r, kFrames);
  EXPECT_GE(r.faults["divergences"].get<int>(), 1);
  EXPECT_LE(r.faults["divergences"].get<int>(), 3);
  EXPECT_EQ(r.faults["resets"].get<int>(), r.faults["divergences"].get<int>());
  const size_t restart = r.command.err.find("t=10.50 s: divergence (");
  ASSERT_NE(restart, std::string::npos) << r.command.err;
  // The new session's global solves and its final solve leave the states before the restart out
  // (states that diverged would fail their checks).
  EXPECT_EQ(r.command.err.find("divergence in", restart), std::string::npos) << r.command.err;
  EXPECT_LT(r.ate, 5.0);
}

// A front end that closes an object entering the view with an inner edge (a window's pane) reports
// wrong corners for its first frames. Here the first two whole views of every object have s2 and
// s3 pulled a fifth of the way towards s1 and s4. The whole view start_agree_gap_s (0.1 s) after
// the first disagrees with it (starts_rejected), and the objects start from the good views; with
// start_agree_px 0 every object starts from its wrong first view. That the window then mends them
// is the estimator's strength, not the check's: with the still start's gyroscope bias kept as
// measured (backend/README.md, "Standing still") both runs end at ATE 1.36 cm, causal 3.64 cm,
// corners 5.4 cm (before, with the bias's σ 0.01 rad/s: 1.41 against 1.42 cm, causal 4.5 against
// 5.2 cm). The check must cost nothing.
TEST(Faults, WrongFirstViewsDoNotStartObjects) {
  const fs::path dir = test::ScratchDir();
  std::map<int, int> corrupted;  // whole views corrupted per object id
  CopyEditing(dir / "seq", "observations_gt.csv", [&](std::vector<std::string>* f) {
    if (f->size() < 11 || (*f)[10] != "1" || corrupted[std::stoi((*f)[1])]++ >= 2) return;
    // u_j, v_j are columns 2j, 2j + 1 (j = 1..4): s2 towards s1, s3 towards s4.
    for (const auto& [moved, towards] : {std::pair{2, 1}, std::pair{3, 4}})
      for (int xy = 0; xy < 2; ++xy) {
        const double a = std::stod((*f)[2 * moved + xy]), b = std::stod((*f)[2 * towards + xy]);
        (*f)[2 * moved + xy] = std::to_string(a + 0.2 * (b - a));
      }
  });
  const FaultRun r = RunFaulty(dir / "seq", dir / "wrong_first");
  ExpectCompleteRun(r, kFrames);
  const int objects = static_cast<int>(corrupted.size());
  EXPECT_GE(r.run["estimator"]["starts_rejected"].get<int>(), objects - 1);
  EXPECT_LE(r.run["estimator"]["starts_rejected"].get<int>(), objects + 1);
  EXPECT_LT(r.ate, 0.045);  // as the clean run's bound; measured 2.2 cm (clean 2.7 cm)

  const fs::path cfg = dir / "off.yaml";
  std::ofstream(cfg) << "estimator:\n  start_agree_px: 0\n";
  const FaultRun off = RunFaulty(dir / "seq", dir / "off", "--config " + cfg.string());
  EXPECT_EQ(off.run["estimator"]["starts_rejected"].get<int>(), 0);
  EXPECT_LT(r.ate, 1.01 * off.ate);  // measured 1.357 against 1.353 cm
}

}  // namespace
}  // namespace fsp::apps
