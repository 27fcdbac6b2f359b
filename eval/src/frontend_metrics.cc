#include "fsp/eval/frontend_metrics.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "fsp/common/error.h"

namespace fsp::eval {

bool FrontendOptions::Check(std::string* why) const {
  if (!(match_gate_px > 0.0) || !std::isfinite(match_gate_px)) {
    *why = "match_gate_px must be finite and > 0";
    return false;
  }
  if (time_tolerance_ns < 0) {
    *why = "time_tolerance_ns must be >= 0";
    return false;
  }
  return true;
}

namespace {

// Mean corner distance after shifting the estimate's corner order by R: 1/4 Σ_j ‖e_{(j+r) mod 4} − g_j‖.
double ShiftedDistance(const Corners& e, const Corners& g, int r) {
  double sum = 0.0;
  for (int j = 0; j < 4; ++j) sum += (e[static_cast<size_t>((j + r) % 4)] - g[static_cast<size_t>(j)]).norm();
  return 0.25 * sum;
}

struct Candidate {
  double distance;
  size_t gt;   // index into the ground-truth rows
  size_t est;  // index into the estimated rows
  int shift;
};

}  // namespace

FrontendMetrics EvaluateFrontend(const std::vector<CornerRow>& gt, const std::vector<CornerRow>& est,
                                 const FrontendOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InputError("front-end options: " + why);
  FrontendMetrics m;
  m.gt_rows = gt.size();
  m.est_rows = est.size();
  for (const CornerRow& g : gt) m.gt_fully_visible += g.fully_visible ? 1 : 0;

  // Ground-truth frames: t_ns -> row indices.
  std::map<int64_t, std::vector<size_t>> gt_frames;
  for (size_t i = 0; i < gt.size(); ++i) gt_frames[gt[i].t_ns].push_back(i);
  // Estimated rows per ground-truth frame (nearest frame time within the tolerance).
  std::map<int64_t, std::vector<size_t>> est_frames;
  for (size_t i = 0; i < est.size(); ++i) {
    if (gt_frames.empty()) break;
    auto it = gt_frames.lower_bound(est[i].t_ns);
    auto best = it;
    if (it == gt_frames.end() || (it != gt_frames.begin() && est[i].t_ns - std::prev(it)->first < it->first - est[i].t_ns)) {
      best = std::prev(it);
    }
    if (std::llabs(best->first - est[i].t_ns) <= options.time_tolerance_ns) est_frames[best->first].push_back(i);
  }

  std::vector<double> corner_errors;
  // Per ground-truth object: (t_ns, matched estimate id) in time order.
  std::map<int, std::vector<std::pair<int64_t, int>>> tracks;
  for (const auto& [t_ns, est_rows] : est_frames) {
    const std::vector<size_t>& gt_rows = gt_frames.at(t_ns);
    std::vector<Candidate> candidates;
    for (size_t gi : gt_rows) {
      for (size_t ei : est_rows) {
        Candidate c{ShiftedDistance(est[ei].corners, gt[gi].corners, 0), gi, ei, 0};
        for (int r = 1; r < 4; ++r) {
          const double d = ShiftedDistance(est[ei].corners, gt[gi].corners, r);
          if (d < c.distance) {
            c.distance = d;
            c.shift = r;
          }
        }
        if (c.distance <= options.match_gate_px) candidates.push_back(c);
      }
    }
    // Greedy one-to-one assignment by increasing distance (ties by row order: deterministic).
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
      return std::tie(a.distance, a.gt, a.est) < std::tie(b.distance, b.gt, b.est);
    });
    std::vector<size_t> used_gt, used_est;
    for (const Candidate& c : candidates) {
      if (std::find(used_gt.begin(), used_gt.end(), c.gt) != used_gt.end() ||
          std::find(used_est.begin(), used_est.end(), c.est) != used_est.end()) {
        continue;
      }
      used_gt.push_back(c.gt);
      used_est.push_back(c.est);
      ++m.matched;
      if (gt[c.gt].fully_visible) ++m.matched_fully_visible;
      if (c.shift != 0) ++m.corner_order_errors;
      // Corner error in the files' own order: ‖e_j − g_j‖ [px].
      for (size_t j = 0; j < 4; ++j) corner_errors.push_back((est[c.est].corners[j] - gt[c.gt].corners[j]).norm());
      tracks[gt[c.gt].object_id].emplace_back(t_ns, est[c.est].object_id);
    }
  }

  // recall = matched fully visible / fully visible; precision = matched / estimated rows.
  if (m.gt_fully_visible > 0) {
    m.recall = static_cast<double>(m.matched_fully_visible) / static_cast<double>(m.gt_fully_visible);
  }
  if (m.est_rows > 0) m.precision = static_cast<double>(m.matched) / static_cast<double>(m.est_rows);
  m.corner_err_px = ComputeStats(std::move(corner_errors));
  // id switches: consecutive matches of one ground-truth object with different estimated ids.
  for (const auto& [gt_id, track] : tracks) {
    for (size_t k = 1; k < track.size(); ++k) m.id_switches += track[k].second != track[k - 1].second ? 1 : 0;
  }
  return m;
}

}  // namespace fsp::eval
