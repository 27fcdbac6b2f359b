// The rectangle detector's options check and its pipeline: Detect runs the stages (one file each,
// see rect_internal.h) in order and times them.
#include "fsp/frontend/rect_detector.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "fsp/common/error.h"
#include "fsp/frontend/rect_geometry.h"
#include "rect_internal.h"

namespace fsp::frontend {

bool RectDetectorOptions::Check(std::string* why) const {
  std::ostringstream os;
  auto positive = [&](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) os << name << " must be positive (got " << v << "); ";
  };
  positive(canny_noise_multiple, "canny_noise_multiple");
  positive(min_edge_contrast, "min_edge_contrast");
  if (!(canny_low_ratio > 0.0 && canny_low_ratio <= 1.0))
    os << "canny_low_ratio must be in (0, 1]; ";
  positive(min_segment_frac, "min_segment_frac");
  positive(segment_fit_px, "segment_fit_px");
  positive(merge_angle_deg, "merge_angle_deg");
  positive(merge_line_px, "merge_line_px");
  if (merge_gap_frac < 0.0) os << "merge_gap_frac must be >= 0; ";
  positive(min_side_frac, "min_side_frac");
  if (!(min_corner_angle_deg > 0.0 && min_corner_angle_deg < 90.0))
    os << "min_corner_angle_deg must be in (0, 90); ";
  if (junction_gap_frac < 0.0 || junction_overshoot_frac < 0.0 || junction_slack_px < 0.0)
    os << "junction tolerances must be >= 0; ";
  if (max_hypotheses < 1) os << "max_hypotheses must be >= 1; ";
  positive(search_px, "search_px");
  if (!(search_step_px > 0.0 && search_step_px <= search_px))
    os << "search_step_px must be in (0, search_px]; ";
  if (samples_per_side < 4) os << "samples_per_side must be >= 4; ";
  if (!(corner_margin_frac >= 0.0 && corner_margin_frac < 0.4))
    os << "corner_margin_frac must be in [0, 0.4); ";
  positive(ransac_inlier_px, "ransac_inlier_px");
  if (ransac_iterations < 1) os << "ransac_iterations must be >= 1; ";
  if (!(min_side_support >= 0.0 && min_side_support <= 1.0))
    os << "min_side_support must be in [0, 1]; ";
  if (!(max_side_continuation >= 0.0 && max_side_continuation <= 1.0))
    os << "max_side_continuation must be in [0, 1]; ";
  if (!(continuation_start_px >= 0.0)) os << "continuation_start_px must be >= 0; ";
  positive(continuation_frac, "continuation_frac");
  if (!(continuation_step_px >= 0.0)) os << "continuation_step_px must be >= 0; ";
  if (!(max_abs_cos > 0.0 && max_abs_cos <= 1.0)) os << "max_abs_cos must be in (0, 1]; ";
  if (!(max_aspect >= 1.0)) os << "max_aspect must be >= 1; ";
  if (!(assumed_hfov_deg > 1.0 && assumed_hfov_deg < 179.0))
    os << "assumed_hfov_deg must be in (1, 179); ";
  positive(margin_min_contrast, "margin_min_contrast");
  if (!(margin_max_texture >= 0.0)) os << "margin_max_texture must be >= 0; ";
  positive(margin_min_width_px, "margin_min_width_px");
  if (!(max_corner_outside_px >= 0.0)) os << "max_corner_outside_px must be >= 0; ";
  if (!(margin_probe_frac > 0.0 && margin_probe_frac <= 1.0))
    os << "margin_probe_frac must be in (0, 1]; ";
  if (duplicate_corner_frac < 0.0 || nest_corner_frac < 0.0)
    os << "suppression fractions must be >= 0; ";
  if (max_detections < 0) os << "max_detections must be >= 0; ";
  if (why) *why = os.str();
  return os.str().empty();
}

RectDetector::RectDetector(Options options) : options_(std::move(options)) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
}

RectDetector::Result RectDetector::Detect(const cv::Mat& gray, const PinholeRadtan* camera,
                                          const Vec3* gravity_C) const {
  namespace ri = rect_internal;
  FSP_CHECK(gray.type() == CV_8UC1 && !gray.empty());
  if (camera) FSP_CHECK(camera->width == gray.cols && camera->height == gray.rows);
  const Options& o = options_;
  Result res;
  Stopwatch sw;
  const double diag = std::hypot(gray.cols, gray.rows);
  const Mat3 K = camera ? camera->K() : DefaultK(gray.cols, gray.rows, o.assumed_hfov_deg);
  const PinholeRadtan* cam = camera && camera->HasDistortion() ? camera : nullptr;

  // 1. edges: smoothing, Sobel, Canny with data-driven thresholds.
  ri::EdgeImages edges = ri::DetectEdges(gray, o);
  res.canny_low = edges.canny_low;
  res.canny_high = edges.canny_high;
  res.times.Add("edges", sw.Lap());

  // 2. segments: edge chains split into straight pieces, each fitted by least squares. Pieces down
  // to a third of the minimum length are kept for merging: a chain that runs into another edge
  // takes a stretch of it, leaving short pieces of a long side that merging joins again.
  const int min_seg = ri::MinSegmentPx(o, diag);
  const int min_piece = std::max(6, min_seg / 3);
  const std::vector<ri::Seg> segs =
      ri::BuildSegments(ri::TracePieces(edges.edges, min_piece, o.segment_fit_px), edges.smooth,
                        cam, o, diag, min_seg);
  res.segments = static_cast<int>(segs.size());
  if (o.debug)
    for (const ri::Seg& sg : segs) res.segment_ends.emplace_back(sg.a, sg.b);
  res.times.Add("segments", sw.Lap());

  // 3. grouping: junctions at segment ends, then 4-cycles a → b → c → d → a. Quads down to
  // `margin_probe_frac` x min_side are found only to recognise the margins of objects too small to
  // report (see the bright margin rule in the suppression stage); they are never reported.
  const double min_side = o.min_side_frac * diag;
  const double probe_side =
      o.prefer_inner_of_bright_margin ? o.margin_probe_frac * min_side : min_side;
  std::vector<ri::Quad> quads =
      ri::FindQuads(ri::FindJunctions(segs, o), probe_side, o.max_hypotheses);
  res.hypotheses = static_cast<int>(quads.size());
  if (o.debug)
    for (const ri::Quad& q : quads) res.hypothesis_quads.push_back(q.c);
  res.times.Add("group", sw.Lap());

  // 4. refinement (with a cheap rectangle pre-test at twice the tolerance on the hypothesis
  // corners). Sobel magnitude ≈ 8 x (grey levels per px).
  const ri::EdgeProbe probe(edges.smooth, cam, o);
  std::vector<ri::Quad> refined = ri::RefineHypotheses(quads, segs, probe, K, res.canny_low / 8.0);
  res.refined = static_cast<int>(refined.size());
  res.times.Add("refine", sw.Lap());

  // 5. verification on the refined corners, canonical order.
  std::vector<ri::Quad> good, cut_off;
  ri::VerifyQuads(refined, probe, K, gravity_C, probe_side, &good, &cut_off);
  if (o.debug)
    for (const ri::Quad& q : good) res.verified_quads.emplace_back(q.c, q.score);
  res.times.Add("verify", sw.Lap());

  // 6. suppression (duplicates, nesting, bright margins, containment; the L-corner tests on the
  // survivors), then the detections with their class guess.
  res.detections = ri::MakeDetections(ri::Suppress(good, cut_off, probe, min_side), probe);
  res.times.Add("nms", sw.Lap());
  return res;
}

}  // namespace fsp::frontend
