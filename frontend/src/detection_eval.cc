#include "fsp/frontend/detection_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "fsp/common/csv.h"
#include "fsp/common/error.h"
#include "fsp/frontend/image_io.h"
#include "fsp/frontend/rect_geometry.h"

namespace fsp::frontend {

double MatchStats::Recall() const {
  return gt_eligible ? double(gt_eligible_found) / gt_eligible : 1.0;
}
double MatchStats::Precision() const {
  return detections ? double(true_positives) / detections : 1.0;
}

double MatchStats::ErrorQuantile(double q) const {
  if (corner_err_px.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::vector<double> e = corner_err_px;
  const size_t k =
      std::min(e.size() - 1, static_cast<size_t>(std::floor(q * (e.size() - 1) + 0.5)));
  std::nth_element(e.begin(), e.begin() + k, e.end());
  return e[k];
}

void MatchStats::Merge(const MatchStats& o) {
  frames += o.frames;
  gt_eligible += o.gt_eligible;
  gt_eligible_found += o.gt_eligible_found;
  detections += o.detections;
  true_positives += o.true_positives;
  order_mismatches += o.order_mismatches;
  corner_err_px.insert(corner_err_px.end(), o.corner_err_px.begin(), o.corner_err_px.end());
}

MatchStats MatchFrame(const std::vector<Detection>& dets, const std::vector<GtObservation>& gt,
                      const MatchOptions& o) {
  MatchStats s;
  s.frames = 1;
  s.detections = static_cast<int>(dets.size());
  auto tolerance = [&](const GtObservation& g) {
    return std::max(o.match_px, o.match_frac * ShortestSide(g.corners));
  };
  for (const Detection& d : dets) {
    bool tp = false;
    for (const GtObservation& g : gt)
      tp = tp || CornerDistanceBestShift(d.corners_undistorted, g.corners) <= tolerance(g);
    s.true_positives += tp;
  }
  for (const GtObservation& g : gt) {
    if (!g.FullyVisible() || ShortestSide(g.corners) < o.min_shortest_side_px) continue;
    ++s.gt_eligible;
    double best = std::numeric_limits<double>::infinity();
    int best_shift = 0;
    const Detection* best_det = nullptr;
    for (const Detection& d : dets) {
      int shift = 0;
      const double e = CornerDistanceBestShift(g.corners, d.corners_undistorted, &shift);
      if (e < best) {
        best = e;
        best_shift = shift;
        best_det = &d;
      }
    }
    if (!best_det || best > tolerance(g)) continue;
    ++s.gt_eligible_found;
    if (best_shift != 0) ++s.order_mismatches;
    for (int i = 0; i < 4; ++i)
      s.corner_err_px.push_back(
          (g.corners[i] - best_det->corners_undistorted[(i + best_shift) % 4]).norm());
  }
  return s;
}

MatchStats EvaluateSequence(const std::string& dir, const DetectFn& detect,
                            const MatchOptions& options, int every) {
  FSP_CHECK(every >= 1);
  const std::vector<GtObservation> gt = ReadCornerRows(dir + "/observations_gt.csv");
  std::map<int64_t, std::vector<GtObservation>> by_time;
  for (const auto& g : gt) by_time[g.t_ns].push_back(g);
  TableReader r(dir + "/mav0/cam0/data.csv", "camera csv");
  std::vector<std::string> f;
  MatchStats total;
  int index = 0;
  while (r.NextRow(&f)) {
    r.ExpectColumns(f, 2, 2);
    const int64_t t_ns = r.Int64(f, 0, "t_ns");
    if (index++ % every != 0) continue;
    const cv::Mat gray = ReadGray8(dir + "/mav0/cam0/data/" + f[1]);
    const auto it = by_time.find(t_ns);
    total.Merge(MatchFrame(
        detect(gray), it == by_time.end() ? std::vector<GtObservation>() : it->second, options));
  }
  return total;
}

}  // namespace fsp::frontend
