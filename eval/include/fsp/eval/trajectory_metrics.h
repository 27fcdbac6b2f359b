// Trajectory accuracy: association by timestamp (evo's rule), alignment, ATE and RPE.
//
// Definitions (the same as evo 1.x `evo_ape` / `evo_rpe`, so numbers agree with evo):
//  - Association: the trajectory with fewer poses is the "short" one (the estimate when both have
//  the same
//    count). For each pose i of the short trajectory, j = argmin_k |t_long,k + offset − t_short,i|
//    (first index on a tie), kept when that |dt| ≤ max_diff. A long pose may be used more than
//    once. Times are compared in double seconds as evo parses them, so boundary cases (|dt| = 0.01
//    s) fall the same way. `offset` is evo's --t_offset: added to the estimate's times (subtracted
//    from the reference's when the estimate is the short trajectory, exactly as evo does).
//  - ATE (evo's APE, translation part): e_i = ‖s R p_est,i + t − p_ref,i‖ after aligning the
//  associated
//    positions (alignment.h); rmse/mean/median/std/min/max over the pairs.
//  - RPE with Δ = 1 frame (evo_rpe --delta 1 --delta_unit f, consecutive associated pairs i, i+1):
//      E_i = (Q_i⁻¹ Q_{i+1})⁻¹ (P_i⁻¹ P_{i+1}),  Q reference poses, P aligned estimated poses,
//    translation error ‖trans(E_i)‖ [m] and rotation error angle(rot(E_i)) [deg]. SE3 and posyaw
//    alignment do not change it; Sim3 scales the estimate's relative translations by s (evo_rpe
//    --correct_scale).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fsp/common/geometry.h"
#include "fsp/eval/alignment.h"
#include "fsp/eval/stats.h"

namespace fsp::eval {

// Poses to evaluate, with two clocks: t_ns exact, t_s the seconds evo would compare.
struct Trajectory {
  std::string source;  // file it was read from (for messages)
  std::vector<int64_t> t_ns;
  std::vector<double> t_s;  // TUM: strtod of the time text; EuRoC csv: double(t_ns) / 1e9 (as evo)
  std::vector<Rigid3> T_W_B;
  size_t size() const { return T_W_B.size(); }
};

// Reads a TUM file or a EuRoC ground-truth csv. EuRoC when the first line is EuRoC's header
// (q_RS_w), or the first data row has 11, 14 or 17 columns, or it has 8 columns whose first is an
// integer and the file ends in .csv or that integer exceeds 1e12 (nanoseconds since 1970); TUM
// otherwise. Repeated timestamps are accepted (evo keeps both poses; the first wins when the other
// trajectory searches it), times that go backwards are not. Throws InputError on any problem (see
// fsp/common/trajectory_io.h).
Trajectory ReadTrajectory(const std::string& path);

struct AssociationOptions {
  double max_diff_s =
      0.01;  // largest |dt| of a pair [s]; evo's default. Larger pairs poses further apart.
  double offset_s = 0.0;  // added to the estimate's times [s] (evo's --t_offset)
  bool Check(std::string* why) const;
};

// Index pairs (reference, estimate), in the order of the short trajectory.
struct Association {
  std::vector<size_t> ref;
  std::vector<size_t> est;
  size_t size() const { return ref.size(); }
};
Association Associate(const Trajectory& ref, const Trajectory& est,
                      const AssociationOptions& options);

struct TrajectoryOptions {
  AssociationOptions association;
  AlignMode align = AlignMode::kSe3;  // see alignment.h
  size_t min_pairs = 3;               // fewer associated pairs is an error (alignment needs 3)
  bool Check(std::string* why) const;
};

struct TrajectoryMetrics {
  size_t ref_poses = 0;
  size_t est_poses = 0;
  size_t pairs = 0;
  // The most pairs the two could give: the fewer of their poses inside the other's time span
  // (the offset applied, max_diff_s either side). Far fewer pairs: stamps of different clocks.
  size_t possible_pairs = 0;
  Alignment alignment;       // p_ref = s R p_est + t
  double scale_error = 0.0;  // |s − 1| (Sim3 only; 0 otherwise)
  ErrorStats ate;            // [m]
  ErrorStats rpe_trans;      // [m] per consecutive pair (pairs − 1 values)
  ErrorStats rpe_rot;        // [deg]
  // The series the statistics above summarise, for plots (`fsp bench`): per associated pair k, in
  // the short trajectory's order, the reference time, the reference position, the aligned estimated
  // position and its ATE error; per consecutive pair k, k+1 the RPE errors (pairs − 1 values, step
  // k ends at t_s[k + 1]).
  struct Series {
    std::vector<double> t_s;  // reference time [s]
    std::vector<Vec3> p_ref, p_est_aligned;
    std::vector<double> ate;                 // [m]
    std::vector<double> rpe_trans, rpe_rot;  // [m], [deg]
  } series;
};

// Associates, aligns and measures. Throws InputError naming both sources when the trajectories do
// not overlap in time, give fewer than `min_pairs` pairs, or cannot be aligned (degenerate motion).
TrajectoryMetrics EvaluateTrajectory(const Trajectory& ref, const Trajectory& est,
                                     const TrajectoryOptions& options);

}  // namespace fsp::eval
