// The rectangle detector's options check and its pipeline: Detect runs the stages (one file each,
// see rect_internal.h) in order and times them.
#include "fsp/frontend/rect_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <sstream>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "fsp/common/error.h"
#include "fsp/frontend/edge_refine.h"
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
  if (bridge_gap_frac < 0.0 || uncalibrated_bridge_gap_frac < 0.0 || bridge_min_frac < 0.0 ||
      bridge_min_piece_frac < 0.0)
    os << "bridge_gap_frac must be >= 0; ";
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
  if (!(frame_band_max_frac >= 0.0 && frame_band_max_frac <= 0.5))
    os << "frame_band_max_frac must be in [0, 0.5]; ";
  if (!(max_side_continuation >= 0.0 && max_side_continuation <= 1.0))
    os << "max_side_continuation must be in [0, 1]; ";
  if (!(continuation_start_px >= 0.0)) os << "continuation_start_px must be >= 0; ";
  positive(continuation_frac, "continuation_frac");
  if (!(continuation_step_px >= 0.0)) os << "continuation_step_px must be >= 0; ";
  if (!(union_gap_frac >= 0.0 && union_gap_frac < 1.0)) os << "union_gap_frac must be in [0, 1); ";
  if (!(any_corner_min_side_frac >= 0.0)) os << "any_corner_min_side_frac must be >= 0; ";
  if (!(max_abs_cos > 0.0 && max_abs_cos <= 1.0)) os << "max_abs_cos must be in (0, 1]; ";
  if (!(rectangle_corner_px >= 0.0)) os << "rectangle_corner_px must be >= 0; ";
  if (!(max_aspect >= 1.0)) os << "max_aspect must be >= 1; ";
  if (!(door_leaf_min_area_frac >= 0.0 && door_leaf_min_area_frac <= 1.0))
    os << "door_leaf_min_area_frac must be in [0, 1]; ";
  if (!(door_rule_max_overlap >= 0.0)) os << "door_rule_max_overlap must be >= 0; ";
  if (!(door_max_tilt_deg > 0.0 && door_max_tilt_deg < 90.0))
    os << "door_max_tilt_deg must be in (0, 90); ";
  if (!(door_jamb_gap_frac >= 0.0)) os << "door_jamb_gap_frac must be >= 0; ";
  if (!(door_bottom_max_deg >= 0.0 && door_bottom_max_deg < 90.0))
    os << "door_bottom_max_deg must be in [0, 90); ";
  if (!(door_min_height_frac >= 0.0)) os << "door_min_height_frac must be >= 0; ";
  if (!(door_min_aspect >= 0.0 && door_max_aspect >= door_min_aspect))
    os << "door_min_aspect must be >= 0 and <= door_max_aspect; ";
  if (detect_long_side < 0) os << "detect_long_side must be >= 0; ";
  if (!(min_side_px >= 0.0) || !(min_level_side_px >= 0.0))
    os << "min_side_px and min_level_side_px must be >= 0; ";
  if (texture_level < 0) os << "texture_level must be >= 0; ";
  if (!(texture_search_px >= 0.0)) os << "texture_search_px must be >= 0; ";
  if (!(focal_prior_min > 0.0 && focal_prior_max >= focal_prior_min))
    os << "focal_prior_min must be positive and <= focal_prior_max; ";
  if (reach_failures_allowed < 0 || uncalibrated_reach_failures_allowed < 0 ||
      reach_failures_any_corner < 0 || uncalibrated_reach_failures_any_corner < 0 ||
      texture_reach_failures_any_corner < 0 || door_reach_failures_allowed < 0 ||
      uncalibrated_door_reach_failures_allowed < 0)
    os << "reach_failures_allowed must be >= 0; ";
  if (!(uncalibrated_container_outside_frac >= 0.0))
    os << "uncalibrated_container_outside_frac must be >= 0; ";
  if (focal_prior_steps < 0) os << "focal_prior_steps must be >= 0; ";
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

namespace {

// A camera model for an image scaled by 1/s (s = full px per level px): pixel centres
// map as u_level = (u + 0.5) / s - 0.5; the distortion acts on normalised coordinates and stays.
PinholeRadtan ScaledCamera(const PinholeRadtan& c, int cols, int rows, double s) {
  PinholeRadtan l = c;
  l.width = cols;
  l.height = rows;
  l.fx = c.fx / s;
  l.fy = c.fy / s;
  l.cx = (c.cx + 0.5) / s - 0.5;
  l.cy = (c.cy + 0.5) / s - 0.5;
  return l;
}

// Texture hypotheses (RectDetectorOptions::texture_level): quads found on the area-averaged
// gradient magnitude, corners in full-resolution undistorted px, no segments (sides of either
// polarity).
std::vector<rect_internal::Quad> TextureHypotheses(const RectDetectorOptions& o,
                                                   const rect_internal::EdgeImages& edges,
                                                   const PinholeRadtan& camera) {
  namespace ri = rect_internal;
  const int k = o.texture_level;
  const int cols = edges.dx.cols / k, rows = edges.dx.rows / k;
  std::vector<ri::Quad> out;
  if (cols < 16 || rows < 16) return out;
  // (|dx| + |dy|) / 4 (Sobel's response to a step of C grey levels: 4C) averaged over k x k blocks
  // in one pass: column sums over k rows, then sums of k columns.
  cv::Mat level(rows, cols, CV_8UC1);
  std::vector<int> column(static_cast<size_t>(cols) * k);
  const double to_level = 0.25 / (k * k);
  for (int y = 0; y < rows; ++y) {
    std::fill(column.begin(), column.end(), 0);
    for (int r = 0; r < k; ++r) {
      const int16_t* gx = edges.dx.ptr<int16_t>(y * k + r);
      const int16_t* gy = edges.dy.ptr<int16_t>(y * k + r);
      for (int x = 0; x < cols * k; ++x) column[x] += std::abs(gx[x]) + std::abs(gy[x]);
    }
    uint8_t* level_row = level.ptr<uint8_t>(y);
    for (int x = 0; x < cols; ++x) {
      int sum = 0;
      for (int c = 0; c < k; ++c) sum += column[x * k + c];
      level_row[x] = cv::saturate_cast<uint8_t>(sum * to_level);
    }
  }
  const PinholeRadtan lc = ScaledCamera(camera, cols, rows, k);
  const PinholeRadtan* cam = lc.HasDistortion() ? &lc : nullptr;
  const double diag = std::hypot(cols, rows);
  ri::EdgeImages le = ri::DetectEdges(level, o);
  const int min_seg = ri::MinSegmentPx(o, diag);
  const int min_piece = std::max(6, min_seg / 3);
  // Straight sides only: no bridged sides, no curved ones (a block's outline is neither). The
  // map's pieces are a few level px long between pixel centres on its grid, so a piece's direction
  // is quantised by up to atan(1 / length): a side tilted by 5 deg is traced as a level stretch
  // and a one-pixel step (the in-flight board's top side, frame 8: pieces at 0 and 4.9 deg, one
  // level px apart, never merged within 3 deg). Merged within that quantisation (9.5 deg for the
  // shortest pieces, 6 px); merge_line_px still bounds how far off the line a piece may lie.
  RectDetectorOptions so = o;
  so.bridge_gap_frac = 0.0;
  so.curved_step_deg = 0.0;
  so.merge_angle_deg = std::max(o.merge_angle_deg, std::atan(1.0 / min_piece) * 180.0 / M_PI);
  const std::vector<ri::Seg> segs = ri::BuildSegments(
      ri::TracePieces(le.edges, min_piece, o.segment_fit_px), le.smooth, cam, so, diag, min_seg);
  const double min_side = o.min_side_frac * diag;
  for (const ri::Quad& lq : ri::FindQuads(ri::FindJunctions(segs, o), min_side, o.max_hypotheses)) {
    ri::Quad q;
    q.texture = true;
    for (int i = 0; i < 4; ++i) {
      const Vec2 p = cam ? cam->DistortPixel(lq.c[i]) : lq.c[i];
      q.c[i] = camera.UndistortPixel((p + Vec2(0.5, 0.5)) * k - Vec2(0.5, 0.5));
    }
    out.push_back(q);
  }
  return out;
}

// The pipeline on one image (the detection level); `smooth_out` (optional) receives the smoothed
// image the refinement read.
RectDetector::Result DetectLevel(const RectDetectorOptions& options, const cv::Mat& gray,
                                 const PinholeRadtan* camera, const Vec3* gravity_C,
                                 const std::vector<Corners>* ignore, cv::Mat* smooth_out,
                                 double level_scale = 1.0) {
  namespace ri = rect_internal;
  RectDetectorOptions uncalibrated = options;
  if (!camera) {
    uncalibrated.container_outside_frac = options.uncalibrated_container_outside_frac;
    uncalibrated.reach_failures_allowed = options.uncalibrated_reach_failures_allowed;
    uncalibrated.reach_failures_any_corner = options.uncalibrated_reach_failures_any_corner;
    uncalibrated.bridge_gap_frac = options.uncalibrated_bridge_gap_frac;
    uncalibrated.reach_either_polarity = options.uncalibrated_reach_either_polarity;
    uncalibrated.door_reach_failures_allowed = options.uncalibrated_door_reach_failures_allowed;
    uncalibrated.prefer_door_leaf = options.uncalibrated_prefer_door_leaf;
  }
  const RectDetectorOptions& o = camera ? options : uncalibrated;
  RectDetector::Result res;
  Stopwatch sw;
  const double diag = std::hypot(gray.cols, gray.rows);
  const std::vector<Mat3> Ks = ri::CandidateIntrinsics(o, gray.cols, gray.rows, camera);
  const PinholeRadtan* cam = camera && camera->HasDistortion() ? camera : nullptr;

  // 1. edges: smoothing, Sobel, Canny with data-driven thresholds.
  ri::EdgeImages edges = ri::DetectEdges(gray, o);
  if (ignore && !ignore->empty()) {
    cv::Mat mask = cv::Mat::zeros(edges.edges.size(), CV_8UC1);
    for (const Corners& q : *ignore) {
      std::vector<cv::Point> poly;
      for (const Vec2& c : q)
        poly.emplace_back(static_cast<int>(std::lround(c.x())),
                          static_cast<int>(std::lround(c.y())));
      cv::fillConvexPoly(mask, poly, 255);
    }
    edges.edges.setTo(0, mask);
  }
  res.canny_low = edges.canny_low;
  res.canny_high = edges.canny_high;
  res.times.Add("edges", sw.Lap());

  // Size limits (see min_side_px): with a calibration the shortest side and segment are capped in
  // the full-resolution image's pixels (`level_scale` of them per level px).
  double min_side = o.min_side_frac * diag;
  int min_seg = ri::MinSegmentPx(o, diag);
  if (camera && o.min_side_px > 0.0) {
    const double side_px = o.min_side_px / level_scale;
    min_side = std::min(min_side, side_px);
    min_seg = std::min(
        min_seg,
        std::max(4, static_cast<int>(std::lround(side_px * o.min_segment_frac / o.min_side_frac))));
  }

  // 2. segments: edge chains split into straight pieces, each fitted by least squares. Pieces down
  // to a third of the minimum length are kept for merging: a chain that runs into another edge
  // takes a stretch of it, leaving short pieces of a long side that merging joins again.
  const int min_piece = std::max(6, min_seg / 3);
  std::vector<ri::Seg> segs =
      ri::BuildSegments(ri::TracePieces(edges.edges, min_piece, o.segment_fit_px), edges.smooth,
                        cam, o, diag, min_seg);
  res.segments = static_cast<int>(segs.size());
  if (o.debug)
    for (const ri::Seg& sg : segs) res.segment_ends.emplace_back(sg.a, sg.b);
  res.times.Add("segments", sw.Lap());

  // 3. grouping: junctions at segment ends, then 4-cycles a → b → c → d → a. Quads down to
  // `margin_probe_frac` x min_side are found only to recognise the margins of objects too small to
  // report (see the bright margin rule in the suppression stage); they are never reported.
  const double probe_side =
      o.prefer_inner_of_bright_margin ? o.margin_probe_frac * min_side : min_side;
  const ri::SegmentJunctions junctions = ri::FindJunctions(segs, o);
  std::vector<ri::Quad> quads = ri::FindQuads(junctions, probe_side, o.max_hypotheses);
  if (o.door_hypotheses && o.door_reach_failures_allowed > o.reach_failures_allowed) {
    // Jambs broken by handles, hinges, hardware or low contrast: the near-vertical straight
    // segments merged again with a gap of up to `door_jamb_gap_frac` of the diagonal; the new
    // merged lines are appended to the segments (the others keep their indices) and door
    // hypotheses are built from all of them.
    const double cos_vertical = std::cos(o.door_max_tilt_deg * M_PI / 180.0);
    std::vector<ri::Seg> vertical;
    for (const ri::Seg& sg : segs)
      if (sg.path.empty() && std::abs(sg.dir.y()) >= cos_vertical) vertical.push_back(sg);
    const size_t n_before = segs.size();
    for (const ri::Seg& j : ri::MergeCollinear(vertical, o.merge_angle_deg, o.merge_line_px,
                                               o.door_jamb_gap_frac * diag)) {
      if (j.len < o.door_min_height_frac * gray.rows) continue;
      bool known = false;
      for (const ri::Seg& v : vertical)
        known = known || ((v.a - j.a).squaredNorm() < 1e-6 && (v.b - j.b).squaredNorm() < 1e-6);
      if (!known) segs.push_back(j);
    }
    const std::vector<ri::Quad> doors = ri::FindDoorQuads(
        segs, segs.size() > n_before ? ri::FindJunctions(segs, o, &junctions) : junctions, quads, o,
        gray.cols, gray.rows, min_side);
    quads.insert(quads.end(), doors.begin(), doors.end());
  }
  if (camera && o.texture_level > 0) {
    // Not inside what is ignored (the texture map reads the gradients, not the masked edges): a
    // tracked poster's frame gave quads whose coarse refinement put its track on the frame's
    // inner edge (the rendered room's 24-33 px poster: 48 of 134 frames more than 2 px off).
    for (const ri::Quad& q : TextureHypotheses(o, edges, *camera)) {
      const Vec2 centre = 0.25 * (q.c[0] + q.c[1] + q.c[2] + q.c[3]);
      bool ignored = false;
      if (ignore)
        for (const Corners& c : *ignore) ignored = ignored || InsideConvex(c, centre);
      if (!ignored) quads.push_back(q);
    }
  }
  res.hypotheses = static_cast<int>(quads.size());
  if (o.debug)
    for (const ri::Quad& q : quads) res.hypothesis_quads.push_back(q.c);
  res.times.Add("group", sw.Lap());

  // 4. refinement (with a cheap rectangle pre-test at twice the tolerance on the hypothesis
  // corners). Sobel magnitude ≈ 8 x (grey levels per px).
  const ri::EdgeProbe probe(edges.smooth, cam, o);
  std::vector<ri::Quad> refined = ri::RefineHypotheses(quads, segs, probe, Ks, res.canny_low / 8.0);
  res.refined = static_cast<int>(refined.size());
  res.times.Add("refine", sw.Lap());

  // 5. verification on the refined corners, canonical order.
  std::vector<ri::Quad> good, cut_off;
  ri::VerifyQuads(refined, probe, Ks, gravity_C, probe_side, &good, &cut_off);
  if (o.debug)
    for (const ri::Quad& q : good) res.verified_quads.emplace_back(q.c, q.score);
  res.times.Add("verify", sw.Lap());

  // 6. suppression (duplicates, nesting, bright margins, containment; the L-corner tests on the
  // survivors), then the detections with their class guess.
  res.detections = ri::MakeDetections(ri::Suppress(good, cut_off, probe, min_side), probe);
  res.times.Add("nms", sw.Lap());
  if (smooth_out) *smooth_out = edges.smooth;
  return res;
}

// Polarity of each side of a quad (corners in the level's distorted px; side i joins c[i-1] and
// c[i]) on the level's smoothed image, as RefineCornersOnEdges reports it: +1 when the image is
// brighter towards the side's left normal. 0 when the side's profile is flat or leaves the image.
std::array<int, 4> SidePolarity(const cv::Mat& smooth, const Corners& c) {
  std::array<int, 4> sign = {0, 0, 0, 0};
  for (int i = 0; i < 4; ++i) {
    const Vec2& a = c[(i + 3) % 4];
    const Vec2& b = c[i];
    const Vec2 u = (b - a).normalized();
    const Vec2 n(-u.y(), u.x());
    double sum = 0.0;
    for (int k = 1; k < 8; ++k) {
      const Vec2 p = a + (b - a) * (k / 8.0);
      double vp, vm;
      if (rect_internal::Bilinear(smooth, p.x() + 2.0 * n.x(), p.y() + 2.0 * n.y(), &vp) &&
          rect_internal::Bilinear(smooth, p.x() - 2.0 * n.x(), p.y() - 2.0 * n.y(), &vm))
        sum += vp - vm;
    }
    sign[i] = sum > 0.0 ? 1 : (sum < 0.0 ? -1 : 0);
  }
  return sign;
}

}  // namespace

RectDetector::Result RectDetector::Detect(const cv::Mat& gray, const PinholeRadtan* camera,
                                          const Vec3* gravity_C,
                                          const std::vector<Corners>* ignore) const {
  FSP_CHECK(gray.type() == CV_8UC1 && !gray.empty());
  if (camera) FSP_CHECK(camera->width == gray.cols && camera->height == gray.rows);
  const Options& o = options_;
  const int long_side = std::max(gray.cols, gray.rows);
  // The reduction factor: the largest integer that keeps the longer side at least
  // detect_long_side, and with a calibration the smallest rectangle (min_side_px) at least
  // min_level_side_px level px.
  int k = o.detect_long_side > 0 ? long_side / o.detect_long_side : 1;
  if (camera && o.min_side_px > 0.0 && o.min_level_side_px > 0.0)
    k = std::min(k, static_cast<int>(o.min_side_px / o.min_level_side_px));
  if (k < 2) return DetectLevel(o, gray, camera, gravity_C, ignore, nullptr);

  // Detection level: area-averaged to `detect_long_side`, the options unchanged (their pixel
  // values are level pixels: edge blur, search widths, slacks).
  Stopwatch sw;
  // An integer factor (OpenCV's fast path for area averaging: ~5 ms on 12 megapixels against ~50 ms
  // for a fractional one): the level's longer side is in [detect_long_side, 2 x detect_long_side)
  // unless min_side_px asks for a finer level.
  cv::Mat level;
  // The last cols % k columns and rows % k rows are left out so that the factor is exact.
  cv::resize(gray(cv::Rect(0, 0, gray.cols / k * k, gray.rows / k * k)), level,
             cv::Size(gray.cols / k, gray.rows / k), 0.0, 0.0, cv::INTER_AREA);
  const double s = k;
  std::optional<PinholeRadtan> level_cam;
  if (camera) level_cam = ScaledCamera(*camera, level.cols, level.rows, s);
  const double t_pyramid = sw.Lap();
  cv::Mat level_smooth;
  std::vector<Corners> level_ignore;  // the ignored quads in level pixels
  if (ignore)
    for (Corners q : *ignore) {
      for (Vec2& c : q) c = (c + Vec2(0.5, 0.5)) / s - Vec2(0.5, 0.5);
      level_ignore.push_back(q);
    }
  Result res = DetectLevel(o, level, level_cam ? &*level_cam : nullptr, gravity_C,
                           ignore ? &level_ignore : nullptr, &level_smooth, s);
  sw.Lap();

  // Full-resolution refinement of each detection's corners: the smoothed image only along the
  // sides (a 12-megapixel blur would cost more than the whole detection), the side polarities of
  // the level, a search wide enough for the level's corner error scaled up.
  const PinholeRadtan* cam = camera && camera->HasDistortion() ? camera : nullptr;
  RectDetectorOptions fo = o;
  // The frame-outline rule ran on the level (its corners are already on the outline); here it
  // would read the band far from the sides, where `smooth` holds no data.
  fo.frame_band_max_frac = 0.0;
  fo.search_px = std::max(o.search_px, 1.5 * s);
  fo.search_step_px = std::min(fo.search_px, o.search_step_px);
  cv::Mat smooth;
  const int pad = static_cast<int>(std::ceil(fo.search_px)) + 4;
  for (Detection& d : res.detections) {
    Corners full_px, full_und;
    for (int i = 0; i < 4; ++i) {
      full_px[i] =
          Vec2((d.corners_px[i].x() + 0.5) * s - 0.5, (d.corners_px[i].y() + 0.5) * s - 0.5);
      full_und[i] = camera ? camera->UndistortPixel(full_px[i]) : full_px[i];
    }
    for (int i = 0; i < 4; ++i) {
      const Vec2& a = full_px[(i + 3) % 4];
      const Vec2& b = full_px[i];
      SmoothForEdgeRefine(
          gray,
          cv::Rect(cv::Point(static_cast<int>(std::floor(std::min(a.x(), b.x()))) - pad,
                             static_cast<int>(std::floor(std::min(a.y(), b.y()))) - pad),
                   cv::Point(static_cast<int>(std::ceil(std::max(a.x(), b.x()))) + pad + 1,
                             static_cast<int>(std::ceil(std::max(a.y(), b.y()))) + pad + 1)),
          &smooth);
    }
    const EdgeRefinement ref = RefineCornersOnEdges(smooth, cam, full_und, res.canny_low / 8.0 / s,
                                                    fo, SidePolarity(level_smooth, d.corners_px));
    if (ref.ok) {
      full_und = ref.corners_undistorted;
      d.side_sign = ref.side_sign;
    }
    d.corners_undistorted = full_und;
    for (int i = 0; i < 4; ++i)
      d.corners_px[i] = cam ? cam->DistortPixel(full_und[i]) : full_und[i];
  }
  StageTimes times;
  times.Add("pyramid", t_pyramid);
  for (const auto& [name, ms] : res.times.ms) times.Add(name, ms);
  times.Add("full_res", sw.Lap());
  res.times = times;
  return res;
}

}  // namespace fsp::frontend
