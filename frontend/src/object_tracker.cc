// Multi-object rectangle tracker (see object_tracker.h for the design, object_tracker_internal.h
// for the coordinates): options, the object model (Init), flow point seeding, edge refinement and
// the public ObjectTracker interface.
#include "fsp/frontend/object_tracker.h"

#include <algorithm>
#include <cmath>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "fsp/common/error.h"
#include "fsp/common/median.h"
#include "fsp/frontend/edge_refine.h"
#include "fsp/frontend/flow_pyramid.h"
#include "fsp/frontend/rect_geometry.h"
#include "object_tracker_internal.h"
#include "rect_internal.h"
#include "shi_tomasi.h"

namespace fsp::frontend {
namespace object_tracker_internal {

// Exact homography of four point pairs (DLT with h33 = 1, 8x8 solve in double).
bool HomographyFrom4(const Corners& from, const Corners& to, Mat3* H) {
  Eigen::Matrix<double, 8, 8> A;
  Eigen::Matrix<double, 8, 1> b;
  for (int i = 0; i < 4; ++i) {
    const double x = from[i].x(), y = from[i].y(), u = to[i].x(), v = to[i].y();
    A.row(2 * i) << x, y, 1, 0, 0, 0, -u * x, -u * y;
    A.row(2 * i + 1) << 0, 0, 0, x, y, 1, -v * x, -v * y;
    b(2 * i) = u;
    b(2 * i + 1) = v;
  }
  Eigen::FullPivLU<Eigen::Matrix<double, 8, 8>> lu(A);
  if (!lu.isInvertible()) return false;
  const Eigen::Matrix<double, 8, 1> h = lu.solve(b);
  *H << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1.0;
  return std::isfinite(H->sum());
}

}  // namespace object_tracker_internal

using object_tracker_internal::Apply;
using object_tracker_internal::HomographyFrom4;

bool ObjectTrackerOptions::Check(std::string* why) const {
  auto fail = [&](const char* w) {
    if (why) *why = w;
    return false;
  };
  if (patch_size < 8 || patch_size > 256) return fail("patch_size must be in [8, 256]");
  if (!(appearance_margin >= 0.0 && appearance_margin <= 0.5))
    return fail("appearance_margin must be in [0, 0.5]");
  if (!(min_side_px >= 4.0)) return fail("min_side_px must be >= 4");
  if (model_keypoints < 0) return fail("model_keypoints must be >= 0");
  if (max_points < 4) return fail("max_points must be >= 4");
  if (lk_window < 5 || lk_window % 2 == 0) return fail("lk_window must be odd and >= 5");
  if (lk_levels < 0 || lk_levels > 6) return fail("lk_levels must be in [0, 6]");
  if (lk_iterations < 1) return fail("lk_iterations must be >= 1");
  if (!(max_fb_error_px > 0.0)) return fail("max_fb_error_px must be > 0");
  if (!(recover_fraction >= 0.0 && recover_fraction <= 1.0))
    return fail("recover_fraction must be in [0, 1]");
  if (!(match_ratio > 0.0 && match_ratio <= 1.0)) return fail("match_ratio must be in (0, 1]");
  if (!(ransac_px > 0.0)) return fail("ransac_px must be > 0");
  if (min_inliers < 4) return fail("min_inliers must be >= 4");
  if (!(coarse_search_px >= refine.search_px)) return fail("coarse_search_px must be >= search_px");
  if (!(min_edge_gradient >= 0.0)) return fail("min_edge_gradient must be >= 0");
  if (!(max_refine_shift_px > 0.0)) return fail("max_refine_shift_px must be > 0");
  if (!(blur_sharpness_ratio >= 0.0 && blur_sharpness_ratio < 1.0))
    return fail("blur_sharpness_ratio must be in [0, 1)");
  if (!(blur_align_min_appearance >= 0.0 && blur_align_min_appearance <= 1.0))
    return fail("blur_align_min_appearance must be in [0, 1]");
  if (!(blur_align_max_shift_px > 0.0)) return fail("blur_align_max_shift_px must be > 0");
  if (!(fast_align_min_motion_px >= 0.0)) return fail("fast_align_min_motion_px must be >= 0");
  if (!(fast_align_max_shift_px > 0.0)) return fail("fast_align_max_shift_px must be > 0");
  if (!(fast_align_min_ncc >= 0.0 && fast_align_min_ncc <= 1.0))
    return fail("fast_align_min_ncc must be in [0, 1]");
  if (!(outline_px > 0.0)) return fail("outline_px must be > 0");
  if (max_unsupported_frames < 0) return fail("max_unsupported_frames must be >= 0");
  if (!(min_appearance >= -1.0 && min_appearance <= 1.0))
    return fail("min_appearance must be in [-1, 1]");
  if (!(min_visible > 0.0 && min_visible <= 1.0)) return fail("min_visible must be in (0, 1]");
  if (refresh_every < 1) return fail("refresh_every must be >= 1");
  return true;
}

void ObjectTracker::Impl::CheckFrame(const cv::Mat& gray) const {
  FSP_CHECK(!gray.empty() && gray.type() == CV_8UC1);
  if (gray.cols != camera.width || gray.rows != camera.height)
    throw InputError("ObjectTracker: frame of " + std::to_string(gray.cols) + "x" +
                     std::to_string(gray.rows) + " px, calibration of " +
                     std::to_string(camera.width) + "x" + std::to_string(camera.height));
}

std::vector<cv::Mat> ObjectTracker::Impl::Pyramid(const cv::Mat& gray) const {
  return BuildFlowPyramid(gray, o.lk_window, o.lk_levels).levels;
}

// Makes `gray` the previous frame (Start / Resume). Unchanged when it is the last tracked frame.
void ObjectTracker::Impl::SetPrevFrame(const cv::Mat& gray) {
  if (!prev_gray.empty() && prev_gray.size() == gray.size() &&
      (prev_gray.data == gray.data || cv::norm(prev_gray, gray, cv::NORM_INF) == 0.0))
    return;
  prev_gray = gray.clone();
  prev_pyr = Pyramid(prev_gray);
}

// Shi-Tomasi corners of `img` inside `mask` (ShiTomasiCorners), at most 2 max_points.
std::vector<cv::Point2f> ObjectTracker::Impl::Corners2D(const cv::Mat& img, const cv::Mat& mask,
                                                        double min_dist) const {
  return ShiTomasiCorners(img, mask, min_dist, o.min_corner_gradient, 2 * o.max_points);
}

// The quad's four corners as flow points at CORNERS_PX (distorted px), replacing the old corner
// points; a corner too close to the border for the LK window is left out.
void ObjectTracker::Impl::ResetCornerPoints(Object* ob, const Corners& corners_px,
                                            const cv::Mat& gray) const {
  std::vector<Vec2> keep_obj;
  std::vector<cv::Point2f> keep_img;
  for (size_t k = 0; k < ob->pt_obj.size(); ++k) {
    bool corner = false;
    for (const Vec2& c : ob->obj_corners) corner |= (ob->pt_obj[k] - c).norm() < 1e-9;
    if (corner) continue;
    keep_obj.push_back(ob->pt_obj[k]);
    keep_img.push_back(ob->pt_img[k]);
  }
  const double border = 0.5 * o.lk_window + 1.0;
  for (int i = 0; i < 4; ++i) {
    const Vec2& d = corners_px[i];
    if (d.x() < border || d.y() < border || d.x() > gray.cols - 1 - border ||
        d.y() > gray.rows - 1 - border)
      continue;
    keep_obj.push_back(ob->obj_corners[i]);
    keep_img.emplace_back(static_cast<float>(d.x()), static_cast<float>(d.y()));
  }
  ob->pt_obj.swap(keep_obj);
  ob->pt_img.swap(keep_img);
}

// Adds flow points: the quad's four corners (replacing older corner points) and Shi-Tomasi
// corners inside it away from the points already held, up to max_points.
void ObjectTracker::Impl::SeedPoints(Object* ob, const cv::Mat& gray) const {
  const Corners und = CornersOf(*ob, ob->H);
  Corners px;
  for (int i = 0; i < 4; ++i) px[i] = ToDistorted(und[i]);
  ResetCornerPoints(ob, px, gray);
  const int want = o.max_points - static_cast<int>(ob->pt_obj.size());
  if (want <= 0) return;
  const cv::Rect r = Box(und, 0.0);
  if (r.width < 8 || r.height < 8) return;
  const cv::Mat mask = QuadMask(und, r, 2);
  const double min_dist =
      std::clamp(std::sqrt(static_cast<double>(r.area()) / o.max_points) * 0.5, 3.0, 12.0);
  const std::vector<cv::Point2f> found = Corners2D(gray(r), mask, min_dist);
  const Mat3 Hinv = ob->H.inverse();
  const double min_d2 = min_dist * min_dist;
  for (const cv::Point2f& f : found) {
    if (static_cast<int>(ob->pt_obj.size()) >= o.max_points) break;
    const cv::Point2f p(f.x + r.x, f.y + r.y);
    bool near = false;
    for (const cv::Point2f& q : ob->pt_img) {
      const float dx = p.x - q.x, dy = p.y - q.y;
      if (dx * dx + dy * dy < min_d2) {
        near = true;
        break;
      }
    }
    if (near) continue;
    ob->pt_obj.push_back(Apply(Hinv, ToUndistorted(Vec2(p.x, p.y))));
    ob->pt_img.push_back(p);
  }
}

// Refines `c` on the edges (coarse pass first when `coarse`); fills `out` on success.
bool ObjectTracker::Impl::Refine(const Object& ob, const cv::Mat& gray, const Corners& c,
                                 bool coarse, EdgeRefinement* out,
                                 const std::array<int, 4>* side_sign) {
  const std::array<int, 4>& sign = side_sign ? *side_sign : ob.side_sign;
  const PinholeRadtan* cam = distorted ? &camera : nullptr;
  // The refinement reads the smoothed image only near the quad: smooth that region (a filter
  // on a sub-matrix reads the real neighbours outside it, so the values equal a whole-frame
  // EdgeRefineImage there).
  auto smooth_near = [&](const Corners& q, double search) {
    return SmoothForEdgeRefine(gray, Box(q, search + 8.0), &smooth);
  };
  Corners start = c;
  if (coarse) {
    RectDetectorOptions co = o.refine;
    co.search_px = o.coarse_search_px;
    if (!smooth_near(start, co.search_px)) return false;
    const EdgeRefinement e =
        RefineCornersOnEdges(smooth, cam, start, o.min_edge_gradient, co, sign);
    if (!e.ok) return false;
    start = e.corners_undistorted;
  }
  if (!smooth_near(start, o.refine.search_px)) return false;
  *out = RefineCornersOnEdges(smooth, cam, start, o.min_edge_gradient, o.refine, sign);
  return out->ok && IsConvex(out->corners_undistorted);
}

// Per side, the median over 9 places along its middle of the largest grey-level step over 1 px
// across it, of either polarity, within 10 px of it (on the smoothed image: a smear spreads the
// step over its length, a track a few px off its outline still finds the sharp edge). A side
// smeared by motion loses it on both polarities; a thin frame that thins further with the view (its
// outer edge fading into its inner one) keeps the step of the other.
std::array<double, 4> ObjectTracker::Impl::SideSharpness(const cv::Mat& gray, const Corners& c) {
  std::array<double, 4> out = {-1.0, -1.0, -1.0, -1.0};
  if (!SmoothForEdgeRefine(gray, Box(c, 18.0), &smooth)) return out;
  for (int i = 0; i < 4; ++i) {
    const Vec2 P = c[(i + 3) % 4], Q = c[i];
    const Vec2 u = (Q - P).normalized(), n(-u.y(), u.x());
    std::vector<double> steps;
    for (int k = 0; k < 9; ++k) {
      const Vec2 b = P + (0.2 + 0.6 * k / 8.0) * (Q - P);
      std::array<double, 41> v{};  // -10 .. +10 px, 0.5 px apart
      bool ok = true;
      for (int j = 0; j < 41 && ok; ++j) {
        const Vec2 d = ToDistorted(b + (0.5 * j - 10.0) * n);
        ok = rect_internal::Bilinear(smooth, d.x(), d.y(), &v[j]);
      }
      if (!ok) continue;
      double best = 0.0;
      for (int j = 1; j < 40; ++j) best = std::max(best, std::abs(v[j + 1] - v[j - 1]));
      steps.push_back(best);
    }
    out[i] = steps.size() >= 5 ? Median(steps) : -1.0;  // mostly out of the image: unknown
  }
  return out;
}

// The sides of quad C (undistorted px) that lie in the image but off the image's edges: at fewer
// than a third of 9 places along the side's middle does the grey level change across it by at least
// min_edge_gradient per px within outline_px (scaled by the image's longer side / 640) of it (on
// the smoothed image, either polarity: a thin frame offers both, and a smeared edge is a ramp
// without a peak). A side with fewer than 5 of its places in the image is not counted.
int ObjectTracker::Impl::UnsupportedSides(const cv::Mat& gray, const Corners& c) {
  const double tolerance = o.outline_px * std::max(1.0, std::max(gray.cols, gray.rows) / 640.0);
  if (!SmoothForEdgeRefine(gray, Box(c, tolerance + 9.0), &smooth)) return 0;
  const int m = static_cast<int>(std::ceil(2.0 * tolerance)) + 1;  // samples 0.5 px apart each side
  std::vector<double> v(2 * m + 1);
  int unsupported = 0;
  for (int i = 0; i < 4; ++i) {
    const Vec2 P = c[(i + 3) % 4], Q = c[i];
    const Vec2 u = (Q - P).normalized(), n(-u.y(), u.x());
    int searched = 0, found = 0;
    for (int k = 0; k < 9; ++k) {
      const Vec2 b = P + (0.15 + 0.7 * k / 8.0) * (Q - P);
      bool inside = true;
      for (int j = -m; j <= m && inside; ++j) {
        const Vec2 d = ToDistorted(b + 0.5 * j * n);
        inside = rect_internal::Bilinear(smooth, d.x(), d.y(), &v[j + m]);
      }
      if (!inside) continue;
      ++searched;
      double steepest = 0.0;  // grey levels per px, over 1 px centred within the tolerance
      for (int j = 1; j < 2 * m; ++j)
        if (std::abs(0.5 * (j - m)) <= tolerance)
          steepest = std::max(steepest, std::abs(v[j + 1] - v[j - 1]));
      found += steepest >= o.min_edge_gradient ? 1 : 0;
    }
    if (searched >= 5 && 3 * found < searched) ++unsupported;
  }
  return unsupported;
}

bool ObjectTracker::Impl::Init(Object* ob, const cv::Mat& gray, const Corners& corners,
                               bool build_model, const std::array<int, 4>& side_sign) {
  if (!IsConvex(corners) || ShortestSide(corners) < o.min_side_px) return false;
  for (const Vec2& c : corners) {
    const Vec2 d = ToDistorted(c);
    if (!(d.x() >= 0.0 && d.y() >= 0.0 && d.x() <= gray.cols - 1 && d.y() <= gray.rows - 1))
      return false;
  }
  if (build_model) {
    const double wq = 0.5 * ((corners[1] - corners[0]).norm() + (corners[2] - corners[3]).norm());
    const double hq = 0.5 * ((corners[3] - corners[0]).norm() + (corners[2] - corners[1]).norm());
    const double s = o.patch_size / std::max(wq, hq);
    ob->w = std::max(8, static_cast<int>(std::lround(wq * s)));
    ob->h = std::max(8, static_cast<int>(std::lround(hq * s)));
    ob->mx = static_cast<int>(std::lround(o.appearance_margin * ob->w));
    ob->my = static_cast<int>(std::lround(o.appearance_margin * ob->h));
    const double W = ob->w - 0.5, Hh = ob->h - 0.5;
    ob->obj_corners = {Vec2(-0.5, Hh), Vec2(W, Hh), Vec2(W, -0.5), Vec2(-0.5, -0.5)};
  }
  Mat3 H;
  if (!HomographyFrom4(ob->obj_corners, corners, &H)) return false;
  ob->H = H;
  ob->has_motion = false;
  ob->pt_obj.clear();
  ob->pt_img.clear();
  ob->frames_since_refresh = 0;
  ob->unsupported_frames = 0;
  if (build_model) {
    Warp(*ob, AppearanceLevels(gray), H, &ob->ref, &ob->ref_valid);
    cv::Scalar mean, sd;
    cv::meanStdDev(ob->ref(Interior(*ob)), mean, sd);
    ob->textured_interior = sd[0] >= 8.0;
    // Descriptors of the quad (grown by 2 px: corner features sit on the outline).
    ob->model_xy.clear();
    ob->model_desc = cv::Mat();
    const cv::Rect r = Box(corners, 34.0);
    if (o.model_keypoints > 0 && r.width > 0 && r.height > 0) {
      const cv::Mat mask = QuadMask(corners, r, -2);
      std::vector<cv::KeyPoint> kps;
      cv::Mat desc;
      orb->setMaxFeatures(o.model_keypoints);
      orb->detectAndCompute(gray(r), mask, kps, desc);
      const Mat3 Hinv = H.inverse();
      for (const cv::KeyPoint& k : kps)
        ob->model_xy.push_back(Apply(Hinv, ToUndistorted(Vec2(k.pt.x + r.x, k.pt.y + r.y))));
      ob->model_desc = desc;
    }
    // Edge polarity per side, so that each side stays on its own edge later.
    ob->side_sign = {0, 0, 0, 0};
    EdgeRefinement e;
    const bool hint = std::all_of(side_sign.begin(), side_sign.end(), [](int v) { return v != 0; });
    if (Refine(*ob, gray, corners, false, &e) ||
        (hint && Refine(*ob, gray, corners, false, &e, &side_sign)))
      ob->side_sign = e.side_sign;
    ob->start_sharpness = SideSharpness(gray, corners);
    if (o.blur_sharpness_ratio > 0.0) ob->sharpness = ob->start_sharpness;
  }
  SeedPoints(ob, gray);
  ob->seeded = static_cast<int>(ob->pt_obj.size());
  ob->active = true;
  return true;
}

ObjectTracker::ObjectTracker(const PinholeRadtan& camera, Options options)
    : options_(std::move(options)) {
  std::string why;
  if (!options_.Check(&why)) throw InputError("ObjectTracker options: " + why);
  if (!camera.Check(&why)) throw InputError("ObjectTracker camera: " + why);
  impl_ = std::make_unique<Impl>(camera, options_);
}

ObjectTracker::~ObjectTracker() = default;

bool ObjectTracker::Start(int id, const cv::Mat& gray, const Corners& corners_undistorted,
                          const std::array<int, 4>& side_sign) {
  impl_->CheckFrame(gray);
  Impl::Object ob;
  ob.id = id;
  if (!impl_->Init(&ob, gray, corners_undistorted, true, side_sign)) return false;
  impl_->SetPrevFrame(gray);
  impl_->objects[id] = std::move(ob);
  return true;
}

std::vector<TrackedObject> ObjectTracker::Track(const cv::Mat& gray,
                                                const std::map<int, Corners>& predicted) {
  impl_->CheckFrame(gray);
  return impl_->Track(gray, impl_->Pyramid(gray), predicted);
}

std::vector<TrackedObject> ObjectTracker::Track(const FlowPyramid& frame,
                                                const std::map<int, Corners>& predicted) {
  impl_->CheckFrame(frame.image);
  FSP_CHECK(frame.window >= options_.lk_window);
  return impl_->Track(frame.image, frame.Levels(options_.lk_levels), predicted);
}

bool ObjectTracker::Reacquire(int id, const cv::Mat& gray, const Corners& predicted,
                              Corners* corners, double* similarity, const Corners* motion,
                              bool* smeared) {
  impl_->CheckFrame(gray);
  if (smeared) *smeared = false;
  const auto it = impl_->objects.find(id);
  if (it == impl_->objects.end() || !IsConvex(predicted)) return false;
  for (const Vec2& c : predicted)
    if (!impl_->camera.InImage(impl_->ToDistorted(c))) return false;
  Mat3 H_pred, H;
  double visible = 0.0;
  if (motion && HomographyFrom4(it->second.obj_corners, predicted, &H_pred) &&
      impl_->AlignFastMotion(it->second, Impl::AppearanceLevels(gray), H_pred, *motion, corners, &H,
                             similarity, &visible)) {
    if (smeared) *smeared = true;
    return true;
  }
  EdgeRefinement e;
  if (!impl_->Refine(it->second, gray, predicted, true, &e)) return false;
  *corners = e.corners_undistorted;
  *similarity = Similarity(id, gray, *corners).value_or(-1.0);
  return true;
}

bool ObjectTracker::Resume(int id, const cv::Mat& gray, const Corners& corners_undistorted) {
  impl_->CheckFrame(gray);
  const auto it = impl_->objects.find(id);
  if (it == impl_->objects.end()) return false;
  Impl::Object ob = it->second;
  if (!impl_->Init(&ob, gray, corners_undistorted, false)) return false;
  impl_->SetPrevFrame(gray);
  it->second = std::move(ob);
  return true;
}

bool ObjectTracker::RelearnOutline(int id, const cv::Mat& gray, const Corners& corners_undistorted,
                                   double min_sharper) {
  impl_->CheckFrame(gray);
  const auto it = impl_->objects.find(id);
  if (it == impl_->objects.end()) return false;
  Impl::Object& ob = it->second;
  const std::array<double, 4> now = impl_->SideSharpness(gray, corners_undistorted);
  double sum_now = 0.0, sum_start = 0.0;  // over the sides measured in both views
  for (int i = 0; i < 4; ++i) {
    if (now[i] < 0.0 || ob.start_sharpness[i] < 0.0) continue;
    sum_now += now[i];
    sum_start += ob.start_sharpness[i];
  }
  if (!(sum_start > 0.0 && sum_now >= min_sharper * sum_start)) return false;
  EdgeRefinement e;
  const std::array<int, 4> any = {0, 0, 0, 0};
  if (!impl_->Refine(ob, gray, corners_undistorted, false, &e, &any)) return false;
  for (const int s : e.side_sign)
    if (s == 0) return false;
  ob.side_sign = e.side_sign;
  ob.start_sharpness = now;
  for (int i = 0; i < 4; ++i) ob.sharpness[i] = std::max(ob.sharpness[i], now[i]);
  return true;
}

void ObjectTracker::Drop(int id) {
  impl_->objects.erase(id);
}

std::vector<int> ObjectTracker::ActiveIds() const {
  std::vector<int> ids;
  for (const auto& [id, ob] : impl_->objects)
    if (ob.active) ids.push_back(id);
  return ids;
}

std::vector<int> ObjectTracker::DormantIds() const {
  std::vector<int> ids;
  for (const auto& [id, ob] : impl_->objects)
    if (!ob.active) ids.push_back(id);
  return ids;
}

}  // namespace fsp::frontend
