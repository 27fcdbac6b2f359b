#include "fsp/eval/frontend_metrics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
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
  if (!(success_px > 0.0) || !std::isfinite(success_px)) {
    *why = "success_px must be finite and > 0";
    return false;
  }
  if (return_gap_frames < 1) {
    *why = "return_gap_frames must be >= 1";
    return false;
  }
  return true;
}

namespace {

// Mean corner distance after shifting the estimate's corner order by R: 1/4 Σ_j ‖e_{(j+r) mod 4} −
// g_j‖.
double ShiftedDistance(const Corners& e, const Corners& g, int r) {
  double sum = 0.0;
  for (int j = 0; j < 4; ++j)
    sum += (e[static_cast<size_t>((j + r) % 4)] - g[static_cast<size_t>(j)]).norm();
  return 0.25 * sum;
}

struct Candidate {
  double distance;
  size_t gt;   // index into the ground-truth rows
  size_t est;  // index into the estimated rows
  int shift;
};

// One matched pair of rows in frame FRAME (an index into Frames::times).
struct Match {
  size_t gt;
  size_t est;
  int shift;
  size_t frame;
};

// The sequence's frames in time order with the rows of each.
struct Frames {
  std::vector<int64_t> times;
  std::vector<std::vector<size_t>> gt_rows, est_rows;
};

// Index of the time in the sorted TIMES nearest to T within TOLERANCE, or -1.
long NearestTime(const std::vector<int64_t>& times, int64_t t, int64_t tolerance) {
  auto it = std::lower_bound(times.begin(), times.end(), t);
  if (it == times.end() || (it != times.begin() && t - *std::prev(it) < *it - t)) {
    if (it == times.begin()) return -1;
    it = std::prev(it);
  }
  return std::llabs(*it - t) <= tolerance ? static_cast<long>(it - times.begin()) : -1;
}

// Each row's time snapped to the nearest of the sorted TIMES within TOLERANCE (its own time when
// none is that close); the times used are added to FRAMES.
std::vector<int64_t> SnapTimes(const std::vector<CornerRow>& rows,
                               const std::vector<int64_t>& times, int64_t tolerance,
                               std::set<int64_t>* frames) {
  std::vector<int64_t> snapped(rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    const long k = NearestTime(times, rows[i].t_ns, tolerance);
    snapped[i] = k >= 0 ? times[static_cast<size_t>(k)] : rows[i].t_ns;
    frames->insert(snapped[i]);
  }
  return snapped;
}

// Frames: FRAME_TIMES, then the ground truth's times (snapped to FRAME_TIMES when within the
// tolerance, so a sequence whose frame list is stamped slightly differently does not get doubled
// frames), then the estimate's (snapped to both).
Frames BuildFrames(const std::vector<CornerRow>& gt, const std::vector<CornerRow>& est,
                   const std::vector<int64_t>& frame_times, int64_t tolerance) {
  std::set<int64_t> base(frame_times.begin(), frame_times.end());
  const std::vector<int64_t> gt_times =
      SnapTimes(gt, std::vector<int64_t>(base.begin(), base.end()), tolerance, &base);
  const std::vector<int64_t> est_times =
      SnapTimes(est, std::vector<int64_t>(base.begin(), base.end()), tolerance, &base);
  Frames f;
  f.times.assign(base.begin(), base.end());
  f.gt_rows.resize(f.times.size());
  f.est_rows.resize(f.times.size());
  auto index = [&](int64_t t) {
    return static_cast<size_t>(std::lower_bound(f.times.begin(), f.times.end(), t) -
                               f.times.begin());
  };
  for (size_t i = 0; i < gt.size(); ++i) f.gt_rows[index(gt_times[i])].push_back(i);
  for (size_t i = 0; i < est.size(); ++i) f.est_rows[index(est_times[i])].push_back(i);
  return f;
}

// Greedy one-to-one assignment of one frame's rows by increasing shift-tolerant distance within the
// gate (ties by row order: deterministic).
std::vector<Match> MatchFrame(const std::vector<CornerRow>& gt, const std::vector<CornerRow>& est,
                              const std::vector<size_t>& gt_rows,
                              const std::vector<size_t>& est_rows, size_t frame, double gate_px) {
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
      if (c.distance <= gate_px) candidates.push_back(c);
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.distance, a.gt, a.est) < std::tie(b.distance, b.gt, b.est);
  });
  std::vector<Match> matches;
  std::set<size_t> used_gt, used_est;
  for (const Candidate& c : candidates) {
    if (used_gt.count(c.gt) || used_est.count(c.est)) continue;
    used_gt.insert(c.gt);
    used_est.insert(c.est);
    matches.push_back({c.gt, c.est, c.shift, frame});
  }
  return matches;
}

// Corner errors of a match in the files' own order: ‖e_j − g_j‖ [px].
std::array<double, 4> CornerErrors(const CornerRow& e, const CornerRow& g) {
  std::array<double, 4> err{};
  for (size_t j = 0; j < 4; ++j) err[j] = (e.corners[j] - g.corners[j]).norm();
  return err;
}

// Estimated id -> the ground-truth id it is matched to most often (ties: the smaller ground-truth
// id).
std::map<int, int> MostFrequentGtId(const std::vector<CornerRow>& gt,
                                    const std::vector<CornerRow>& est,
                                    const std::vector<Match>& matches) {
  std::map<int, std::map<int, int>> counts;  // est id -> gt id -> matches
  for (const Match& mt : matches) ++counts[est[mt.est].object_id][gt[mt.gt].object_id];
  std::map<int, int> id_map;
  for (const auto& [est_id, per_gt] : counts) {
    int best = per_gt.begin()->first, best_count = 0;
    for (const auto& [gt_id, n] : per_gt) {
      if (n > best_count) std::tie(best, best_count) = std::make_pair(gt_id, n);
    }
    id_map[est_id] = best;
  }
  return id_map;
}

// One ground-truth object over the sequence: frames with a fully visible row, and its matches
// (frame, estimated row) in time order.
struct GtTrack {
  std::vector<size_t> fully_visible_frames;
  std::vector<const Match*> matches;
};

std::map<int, GtTrack> GtTracks(const std::vector<CornerRow>& gt, const Frames& frames,
                                const std::vector<Match>& matches) {
  std::map<int, GtTrack> tracks;
  for (size_t k = 0; k < frames.times.size(); ++k) {
    for (size_t gi : frames.gt_rows[k]) {
      GtTrack& t = tracks[gt[gi].object_id];
      if (gt[gi].FullyVisible() &&
          (t.fully_visible_frames.empty() || t.fully_visible_frames.back() != k)) {
        t.fully_visible_frames.push_back(k);
      }
    }
  }
  for (const Match& mt : matches)
    tracks[gt[mt.gt].object_id].matches.push_back(&mt);  // matches are in frame order
  return tracks;
}

int CountIdSwitches(const std::vector<CornerRow>& est, const GtTrack& track) {
  int switches = 0;
  for (size_t k = 1; k < track.matches.size(); ++k) {
    switches +=
        est[track.matches[k]->est].object_id != est[track.matches[k - 1]->est].object_id ? 1 : 0;
  }
  return switches;
}

double WorstCornerError(const std::vector<CornerRow>& gt, const std::vector<CornerRow>& est,
                        const Match& mt) {
  const std::array<double, 4> err = CornerErrors(est[mt.est], gt[mt.gt]);
  return *std::max_element(err.begin(), err.end());
}

// One object's tracking (see ObjectTracking). Success over its fully visible rows from its first
// match on: matched with every corner within SUCCESS_PX.
ObjectTracking TrackObject(const std::vector<CornerRow>& gt, const std::vector<CornerRow>& est,
                           int gt_id, const GtTrack& track, double success_px) {
  ObjectTracking o;
  o.gt_id = gt_id;
  o.matched = track.matches.size();
  std::vector<double> worst;
  std::set<int> ids;
  std::map<size_t, const Match*> by_frame;
  for (const Match* mt : track.matches) {
    worst.push_back(WorstCornerError(gt, est, *mt));
    ids.insert(est[mt->est].object_id);
    by_frame[mt->frame] = mt;
  }
  o.est_ids.assign(ids.begin(), ids.end());
  o.worst_corner_median_px = Median(worst);
  o.worst_corner_p90_px = Percentile(worst, 0.9);
  const size_t first = track.matches.front()->frame;
  for (size_t k : track.fully_visible_frames) {
    if (k < first) continue;
    ++o.success_total;
    const auto it = by_frame.find(k);
    if (it != by_frame.end() && WorstCornerError(gt, est, *it->second) <= success_px)
      ++o.success_frames;
  }
  return o;
}

// Returns after absences of ≥ GAP frames (see the header) and how many kept the estimated id.
void CountReturns(const std::vector<CornerRow>& est, const GtTrack& track, int gap,
                  FrontendMetrics* m) {
  const std::vector<size_t>& fv = track.fully_visible_frames;
  for (size_t i = 0; i + 1 < fv.size(); ++i) {
    if (fv[i + 1] - fv[i] - 1 < static_cast<size_t>(gap)) continue;
    // The return's stretch of visibility ends where the next absence begins.
    size_t end = i + 1;
    while (end + 1 < fv.size() && fv[end + 1] - fv[end] - 1 < static_cast<size_t>(gap)) ++end;
    const Match* before = nullptr;
    const Match* after = nullptr;
    for (const Match* mt : track.matches) {
      if (mt->frame <= fv[i]) before = mt;
      if (!after && mt->frame >= fv[i + 1] && mt->frame <= fv[end]) after = mt;
    }
    if (!before || !after) continue;
    ++m->returns;
    m->reidentified += est[before->est].object_id == est[after->est].object_id ? 1 : 0;
  }
}

// Estimated rows whose mapped ground-truth object has no row in their frame.
size_t CountOutOfView(const std::vector<CornerRow>& gt, const std::vector<CornerRow>& est,
                      const Frames& frames, const std::map<int, int>& id_map) {
  size_t out = 0;
  for (size_t k = 0; k < frames.times.size(); ++k) {
    std::set<int> present;
    for (size_t gi : frames.gt_rows[k]) present.insert(gt[gi].object_id);
    for (size_t ei : frames.est_rows[k]) {
      const auto it = id_map.find(est[ei].object_id);
      if (it != id_map.end() && !present.count(it->second)) ++out;
    }
  }
  return out;
}

std::optional<double> Ratio(size_t num, size_t den, double scale = 1.0) {
  if (den == 0) return std::nullopt;
  return scale * static_cast<double>(num) / static_cast<double>(den);
}

}  // namespace

FrontendMetrics EvaluateFrontend(const std::vector<CornerRow>& gt,
                                 const std::vector<CornerRow>& est, const FrontendOptions& options,
                                 const std::vector<int64_t>& frame_times) {
  std::string why;
  if (!options.Check(&why)) throw InputError("front-end options: " + why);
  FrontendMetrics m;
  m.success_px = options.success_px;
  m.gt_rows = gt.size();
  m.est_rows = est.size();
  for (const CornerRow& g : gt) m.gt_fully_visible += g.FullyVisible() ? 1 : 0;

  const Frames frames = BuildFrames(gt, est, frame_times, options.time_tolerance_ns);
  m.frames = frames.times.size();
  std::vector<Match> matches;
  for (size_t k = 0; k < frames.times.size(); ++k) {
    for (const Match& mt :
         MatchFrame(gt, est, frames.gt_rows[k], frames.est_rows[k], k, options.match_gate_px)) {
      matches.push_back(mt);
    }
  }

  std::vector<double> corner_errors, outward;
  for (const Match& mt : matches) {
    ++m.matched;
    if (gt[mt.gt].FullyVisible()) ++m.matched_fully_visible;
    if (mt.shift != 0) ++m.corner_order_errors;
    for (double e : CornerErrors(est[mt.est], gt[mt.gt])) corner_errors.push_back(e);
    const CornerRow& g = gt[mt.gt];
    const Vec2 centre = 0.25 * (g.corners[0] + g.corners[1] + g.corners[2] + g.corners[3]);
    for (size_t j = 0; j < 4; ++j) {
      const Vec2 ray = g.corners[j] - centre;
      if (ray.norm() > 0.0)
        outward.push_back((est[mt.est].corners[j] - g.corners[j]).dot(ray.normalized()));
    }
  }
  // recall = matched fully visible / fully visible; precision = matched / estimated rows.
  m.recall = Ratio(m.matched_fully_visible, m.gt_fully_visible);
  m.precision = Ratio(m.matched, m.est_rows);
  m.corner_err_px = ComputeStats(std::move(corner_errors));
  m.corner_outward_px = ComputeStats(std::move(outward));
  m.unmatched_est_rows = m.est_rows - m.matched;

  m.id_map = MostFrequentGtId(gt, est, matches);
  m.boxes_out_of_view = CountOutOfView(gt, est, frames, m.id_map);
  for (const auto& [gt_id, track] : GtTracks(gt, frames, matches)) {
    m.id_switches += CountIdSwitches(est, track);
    CountReturns(est, track, options.return_gap_frames, &m);
    if (track.matches.empty()) continue;
    m.per_object.push_back(TrackObject(gt, est, gt_id, track, options.success_px));
    m.success_frames += m.per_object.back().success_frames;
    m.success_total += m.per_object.back().success_total;
  }
  m.id_switches_per_1000 = Ratio(static_cast<size_t>(m.id_switches), m.matched, 1000.0);
  m.success_rate = Ratio(m.success_frames, m.success_total);
  m.reid_rate = Ratio(m.reidentified, m.returns);
  return m;
}

}  // namespace fsp::eval
