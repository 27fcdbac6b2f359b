#include "fsp/eval/trajectory_metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fsp/common/csv.h"
#include "fsp/common/error.h"
#include "fsp/common/trajectory_io.h"

namespace fsp::eval {

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

// True when PATH looks like a EuRoC ground-truth csv rather than a TUM file (see the header).
bool LooksLikeEuroc(const std::string& path) {
  {
    std::ifstream in(path);
    std::string first_line;
    std::getline(in, first_line);
    if (first_line.find("q_RS_w") != std::string::npos) return true;  // EuRoC's own header line
  }
  TableReader reader(path, "trajectory file");
  std::vector<std::string> f;
  if (!reader.NextRow(&f) || f.empty()) return false;
  if (f.size() == 11 || f.size() == 14 || f.size() == 17) return true;
  const std::string& first = f[0];
  if (f.size() != 8 || first.empty() || first.find_first_not_of("0123456789") != std::string::npos)
    return false;
  return std::filesystem::path(path).extension() == ".csv" ||
         std::strtod(first.c_str(), nullptr) > 1e12;
}

std::string Seconds(double s) {
  std::ostringstream os;
  os.precision(6);
  os << std::fixed << s;
  return os.str();
}

}  // namespace

Trajectory ReadTrajectory(const std::string& path) {
  Trajectory traj;
  traj.source = path;
  if (LooksLikeEuroc(path)) {
    for (const StateSample& s : ReadEurocGroundTruth(path, TimeOrder::kNonDecreasing)) {
      traj.t_ns.push_back(s.t_ns);
      // evo: np.divide(float(t_ns), 1e9).
      traj.t_s.push_back(static_cast<double>(s.t_ns) / 1e9);
      traj.T_W_B.push_back(s.T_W_B);
    }
  } else {
    for (const StampedPose& p : ReadTum(path, &traj.t_s, TimeOrder::kNonDecreasing)) {
      traj.t_ns.push_back(p.t_ns);
      traj.T_W_B.push_back(p.T_W_B);
    }
  }
  return traj;
}

bool AssociationOptions::Check(std::string* why) const {
  if (!(max_diff_s >= 0.0) || !std::isfinite(max_diff_s)) {
    *why = "max_diff_s must be finite and >= 0";
    return false;
  }
  if (!std::isfinite(offset_s)) {
    *why = "offset_s must be finite";
    return false;
  }
  return true;
}

bool TrajectoryOptions::Check(std::string* why) const {
  if (!association.Check(why)) return false;
  if (min_pairs < 3) {
    *why = "min_pairs must be >= 3 (alignment needs 3 pairs)";
    return false;
  }
  return true;
}

Association Associate(const Trajectory& ref, const Trajectory& est,
                      const AssociationOptions& options) {
  std::string why;
  FSP_CHECK(options.Check(&why));
  FSP_CHECK(ref.t_s.size() == ref.size() && est.t_s.size() == est.size());
  // evo sync.associate_trajectories: the estimate searches the reference unless it has more poses.
  const bool est_longer = est.size() > ref.size();
  const Trajectory& shorter = est_longer ? ref : est;
  const Trajectory& longer = est_longer ? est : ref;
  const double offset = est_longer ? options.offset_s : -options.offset_s;
  std::vector<double> long_s = longer.t_s;
  for (double& t : long_s) t += offset;  // evo: stamps_2 += offset_2

  Association assoc;
  for (size_t i = 0; i < shorter.size(); ++i) {
    const double t = shorter.t_s[i];
    // argmin_k |long_s[k] − t| (first index on ties). long_s increases, so fl(|long_s[k] − t|) is
    // non-increasing before the insertion point and non-decreasing after it: the minimum is at one
    // of its two neighbours, and equal values to its left are scanned to pick the first index as
    // numpy does.
    const auto it = std::lower_bound(long_s.begin(), long_s.end(), t);
    size_t best = static_cast<size_t>(it - long_s.begin());
    if (best == long_s.size()) best = long_s.size() - 1;
    double best_diff = std::abs(long_s[best] - t);
    if (best > 0 && std::abs(long_s[best - 1] - t) <= best_diff) {
      --best;
      best_diff = std::abs(long_s[best] - t);
    }
    while (best > 0 && std::abs(long_s[best - 1] - t) == best_diff) --best;
    if (best_diff <= options.max_diff_s) {
      (est_longer ? assoc.ref : assoc.est).push_back(i);
      (est_longer ? assoc.est : assoc.ref).push_back(best);
    }
  }
  return assoc;
}

TrajectoryMetrics EvaluateTrajectory(const Trajectory& ref, const Trajectory& est,
                                     const TrajectoryOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InputError("trajectory options: " + why);
  const std::string names = "reference " + ref.source + " and estimate " + est.source;
  if (ref.size() == 0 || est.size() == 0) throw InputError(names + ": a trajectory is empty");
  const Association assoc = Associate(ref, est, options.association);
  if (assoc.size() < options.min_pairs) {
    const bool overlap = est.t_s.front() + options.association.offset_s <= ref.t_s.back() &&
                         ref.t_s.front() <= est.t_s.back() + options.association.offset_s;
    std::ostringstream msg;
    msg << names << ": only " << assoc.size() << " pose pairs within "
        << options.association.max_diff_s << " s (need " << options.min_pairs << ")";
    if (!overlap) {
      msg << "; they do not overlap in time (reference " << Seconds(ref.t_s.front()) << ".."
          << Seconds(ref.t_s.back()) << " s, estimate " << Seconds(est.t_s.front()) << ".."
          << Seconds(est.t_s.back()) << " s)";
    }
    throw InputError(msg.str());
  }

  TrajectoryMetrics m;
  m.ref_poses = ref.size();
  m.est_poses = est.size();
  m.pairs = assoc.size();
  const double off = options.association.offset_s, slack = options.association.max_diff_s;
  auto inside = [&](const std::vector<double>& t_s, double shift, double lo, double hi) {
    return static_cast<size_t>(std::count_if(t_s.begin(), t_s.end(), [&](double t) {
      return t + shift >= lo - slack && t + shift <= hi + slack;
    }));
  };
  m.possible_pairs = std::min(inside(ref.t_s, 0.0, est.t_s.front() + off, est.t_s.back() + off),
                              inside(est.t_s, off, ref.t_s.front(), ref.t_s.back()));
  std::vector<Vec3> p_ref(m.pairs), p_est(m.pairs);
  for (size_t k = 0; k < m.pairs; ++k) {
    p_ref[k] = ref.T_W_B[assoc.ref[k]].translation();
    p_est[k] = est.T_W_B[assoc.est[k]].translation();
  }
  const AlignResult aligned = AlignPoints(p_ref, p_est, options.align);
  if (!aligned.ok())
    throw InputError(names + ": cannot align (" + ToString(options.align) +
                     "): " + aligned.failure);
  m.alignment = aligned.alignment;
  if (options.align == AlignMode::kSim3) m.scale_error = std::abs(m.alignment.scale - 1.0);

  // ATE: e_k = ‖s R p_est,k + t − p_ref,k‖ [m].
  TrajectoryMetrics::Series& series = m.series;
  series.ate.resize(m.pairs);
  for (size_t k = 0; k < m.pairs; ++k) {
    series.t_s.push_back(ref.t_s[assoc.ref[k]]);
    series.p_est_aligned.push_back(m.alignment.Apply(p_est[k]));
    series.ate[k] = (series.p_est_aligned[k] - p_ref[k]).norm();
  }
  series.p_ref = std::move(p_ref);
  m.ate = ComputeStats(series.ate);

  // RPE, Δ = 1 associated pair: E_k = (Q_k⁻¹ Q_{k+1})⁻¹ (P_k⁻¹ P_{k+1}) with P the aligned estimate
  // (P = (R R_est, s R p_est + t), so only s matters); errors ‖trans(E_k)‖ [m] and
  // |angle(rot(E_k))| [deg].
  std::vector<double>& rpe_t = series.rpe_trans;
  std::vector<double>& rpe_r = series.rpe_rot;
  for (size_t k = 0; k + 1 < m.pairs; ++k) {
    const Rigid3 Q_rel = ref.T_W_B[assoc.ref[k]].Inverse() * ref.T_W_B[assoc.ref[k + 1]];
    const Rigid3 P_rel = m.alignment.Apply(est.T_W_B[assoc.est[k]]).Inverse() *
                         m.alignment.Apply(est.T_W_B[assoc.est[k + 1]]);
    const Rigid3 E = Q_rel.Inverse() * P_rel;
    rpe_t.push_back(E.translation().norm());
    rpe_r.push_back(LogQuat(E.rotation()).norm() * kRadToDeg);
  }
  m.rpe_trans = ComputeStats(rpe_t);
  m.rpe_rot = ComputeStats(rpe_r);
  return m;
}

}  // namespace fsp::eval
