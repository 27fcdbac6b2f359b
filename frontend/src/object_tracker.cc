// Multi-object rectangle tracker (see object_tracker.h for the design).
//
// Coordinates: the object plane is the reference patch's pixel grid without its margin ring: the
// object's outline runs from (-0.5, -0.5) (s4, top-left) to (W - 0.5, H - 0.5) (s2, bottom-right),
// patch pixel (i, j) samples object point (i - mx, j - my). Homographies map the object plane to
// UNDISTORTED pixels (a plane seen by a pinhole); flow points and the pyramid live in the distorted
// image as stored.
#include "fsp/frontend/object_tracker.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "fsp/common/error.h"
#include "fsp/frontend/edge_refine.h"
#include "fsp/frontend/rect_geometry.h"

namespace fsp::frontend {
namespace {

Vec2 Apply(const Mat3& H, const Vec2& p) {
  const Vec3 q = H * Vec3(p.x(), p.y(), 1.0);
  return Vec2(q.x() / q.z(), q.y() / q.z());
}

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

double MaxCornerDistance(const Corners& a, const Corners& b) {
  double d = 0.0;
  for (int i = 0; i < 4; ++i) d = std::max(d, (a[i] - b[i]).norm());
  return d;
}

// Bilinear sample of an 8-bit image; false outside [0, cols-1] x [0, rows-1].
bool Sample(const cv::Mat& img, double x, double y, float* v) {
  if (!(x >= 0.0 && y >= 0.0 && x <= img.cols - 1 && y <= img.rows - 1)) return false;
  const int x0 = std::max(0, std::min(static_cast<int>(x), img.cols - 2));
  const int y0 = std::max(0, std::min(static_cast<int>(y), img.rows - 2));
  const double fx = x - x0, fy = y - y0;
  const uint8_t* r0 = img.ptr<uint8_t>(y0);
  const uint8_t* r1 = img.ptr<uint8_t>(std::min(y0 + 1, img.rows - 1));
  const int x1 = std::min(x0 + 1, img.cols - 1);
  *v = static_cast<float>((1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x1]) +
                          fy * ((1 - fx) * r1[x0] + fx * r1[x1]));
  return true;
}

}  // namespace

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
  if (!(min_appearance >= -1.0 && min_appearance <= 1.0))
    return fail("min_appearance must be in [-1, 1]");
  if (!(min_visible > 0.0 && min_visible <= 1.0)) return fail("min_visible must be in (0, 1]");
  if (refresh_every < 1) return fail("refresh_every must be >= 1");
  return true;
}

struct ObjectTracker::Impl {
  struct Object {
    int id = -1;
    bool active = false;
    // Model: object-plane size (patch pixels without the margin) and margin.
    int w = 0, h = 0, mx = 0, my = 0;
    Corners obj_corners;                          // s1..s4 in the object plane
    std::vector<Vec2> model_xy;                   // descriptor keypoints in the object plane
    cv::Mat model_desc;                           // ORB descriptors (rows of model_xy)
    cv::Mat ref;                                  // reference patch, CV_32F, smoothed
    cv::Mat ref_valid;                            // CV_8U, 1 where the reference was in view
    std::array<int, 4> side_sign = {0, 0, 0, 0};  // edge polarity per side, 0 = unknown
    bool textured_interior = false;  // the reference's interior has structure (grey std >= 8)
    // State.
    Mat3 H = Mat3::Identity(), H_prev = Mat3::Identity();
    bool has_motion = false;          // H_prev valid (constant-velocity prediction)
    std::vector<Vec2> pt_obj;         // flow points in the object plane
    std::vector<cv::Point2f> pt_img;  // and in the last frame (distorted px)
    int frames_since_refresh = 0;
    int seeded = 0;  // flow points right after the last seeding
  };

  PinholeRadtan camera;
  const Options& o;
  bool distorted = false;
  std::map<int, Object> objects;
  std::vector<cv::Mat> prev_pyr;  // with derivatives (buildOpticalFlowPyramid)
  cv::Mat prev_gray;
  cv::Mat smooth;  // EdgeRefineImage, filled per object region
  cv::Ptr<cv::ORB> orb;

  Impl(const PinholeRadtan& cam, const Options& opt) : camera(cam), o(opt) {
    distorted = camera.HasDistortion();
    orb = cv::ORB::create(std::max(o.model_keypoints, 1), 1.3f, 4, 31, 0, 2, cv::ORB::HARRIS_SCORE,
                          31, 10);
  }

  Vec2 ToDistorted(const Vec2& u) const { return distorted ? camera.DistortPixel(u) : u; }
  Vec2 ToUndistorted(const Vec2& d) const { return distorted ? camera.UndistortPixel(d) : d; }

  void CheckFrame(const cv::Mat& gray) const {
    FSP_CHECK(!gray.empty() && gray.type() == CV_8UC1);
    if (gray.cols != camera.width || gray.rows != camera.height)
      throw InputError("ObjectTracker: frame of " + std::to_string(gray.cols) + "x" +
                       std::to_string(gray.rows) + " px, calibration of " +
                       std::to_string(camera.width) + "x" + std::to_string(camera.height));
  }

  std::vector<cv::Mat> Pyramid(const cv::Mat& gray) const {
    std::vector<cv::Mat> pyr;
    cv::buildOpticalFlowPyramid(gray, pyr, cv::Size(o.lk_window, o.lk_window), o.lk_levels, true);
    return pyr;
  }

  // Makes `gray` the previous frame (Start / Resume). Unchanged when it is the last tracked frame.
  void SetPrevFrame(const cv::Mat& gray) {
    if (!prev_gray.empty() && prev_gray.size() == gray.size() &&
        (prev_gray.data == gray.data || cv::norm(prev_gray, gray, cv::NORM_INF) == 0.0))
      return;
    prev_gray = gray.clone();
    prev_pyr = Pyramid(prev_gray);
  }

  // Image levels of a pyramid (every other entry when it holds derivatives).
  static std::vector<cv::Mat> Levels(const std::vector<cv::Mat>& pyr, bool with_derivatives) {
    std::vector<cv::Mat> lv;
    for (size_t i = 0; i < pyr.size(); i += with_derivatives ? 2 : 1) lv.push_back(pyr[i]);
    return lv;
  }

  // The frame warped into the patch through H (object plane -> undistorted px): CV_32F patch and
  // a validity mask; the pyramid level is chosen so that one patch pixel covers about one level
  // pixel (no aliasing when the object is large). Returns the fraction of patch pixels in view.
  double Warp(const Object& ob, const std::vector<cv::Mat>& levels, const Mat3& H, cv::Mat* patch,
              cv::Mat* valid) const {
    const int pw = ob.w + 2 * ob.mx, ph = ob.h + 2 * ob.my;
    patch->create(ph, pw, CV_32F);
    valid->create(ph, pw, CV_8U);
    Corners img;
    for (int i = 0; i < 4; ++i) img[i] = Apply(H, ob.obj_corners[i]);
    double perim = 0.0;
    for (int i = 0; i < 4; ++i) perim += (img[(i + 1) % 4] - img[i]).norm();
    const double scale = perim / (2.0 * (ob.w + ob.h));
    int level = scale > 1.0 ? static_cast<int>(std::floor(std::log2(scale))) : 0;
    level = std::clamp(level, 0, static_cast<int>(levels.size()) - 1);
    const double f = 1.0 / (1 << level);
    const cv::Mat& im = levels[level];
    int n_valid = 0;
    double sum = 0.0;
    for (int j = 0; j < ph; ++j) {
      float* pr = patch->ptr<float>(j);
      uint8_t* vr = valid->ptr<uint8_t>(j);
      for (int i = 0; i < pw; ++i) {
        const Vec2 u = Apply(H, Vec2(i - ob.mx, j - ob.my));
        const Vec2 d = ToDistorted(u);
        float v = 0.f;
        // Level coordinates: pixel centres scale about -0.5 (pyrDown halves the grid).
        const bool ok = std::isfinite(d.x()) && std::isfinite(d.y()) &&
                        Sample(im, (d.x() + 0.5) * f - 0.5, (d.y() + 0.5) * f - 0.5, &v);
        pr[i] = v;
        vr[i] = ok ? 1 : 0;
        if (ok) {
          ++n_valid;
          sum += v;
        }
      }
    }
    // Smooth (sigma 1 patch px) against noise and motion blur; pixels out of view take the mean
    // so that they do not create edges.
    const float mean = n_valid > 0 ? static_cast<float>(sum / n_valid) : 0.f;
    for (int j = 0; j < ph; ++j)
      for (int i = 0; i < pw; ++i)
        if (!valid->at<uint8_t>(j, i)) patch->at<float>(j, i) = mean;
    cv::GaussianBlur(*patch, *patch, cv::Size(5, 5), 1.0, 1.0, cv::BORDER_REPLICATE);
    return static_cast<double>(n_valid) / (pw * ph);
  }

  static double Ncc(const cv::Mat& a, const cv::Mat& va, const cv::Mat& b, const cv::Mat& vb) {
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    int n = 0;
    for (int j = 0; j < a.rows; ++j) {
      const float* pa = a.ptr<float>(j);
      const float* pb = b.ptr<float>(j);
      const uint8_t* ma = va.ptr<uint8_t>(j);
      const uint8_t* mb = vb.ptr<uint8_t>(j);
      for (int i = 0; i < a.cols; ++i) {
        if (!ma[i] || !mb[i]) continue;
        sa += pa[i];
        sb += pb[i];
        saa += pa[i] * pa[i];
        sbb += pb[i] * pb[i];
        sab += pa[i] * pb[i];
        ++n;
      }
    }
    if (n < 16) return -1.0;
    const double va2 = saa - sa * sa / n, vb2 = sbb - sb * sb / n;
    // A flat patch (variance below 1 grey level^2 per pixel) has no appearance to compare.
    if (va2 < n || vb2 < n) return 0.0;
    return (sab - sa * sb / n) / std::sqrt(va2 * vb2);
  }

  // NCC of the whole patch (object and margin ring); for an object with a textured interior
  // also of the interior alone, and the lower of the two: the ring and the outline are alike for
  // many objects (a light border on a wall), the interior tells them apart.
  double Appearance(const Object& ob, const std::vector<cv::Mat>& levels, const Mat3& H,
                    double* visible) const {
    cv::Mat patch, valid;
    *visible = Warp(ob, levels, H, &patch, &valid);
    double ncc = Ncc(ob.ref, ob.ref_valid, patch, valid);
    if (ob.textured_interior) {
      const cv::Rect in = Interior(ob);
      ncc = std::min(ncc, Ncc(ob.ref(in), ob.ref_valid(in), patch(in), valid(in)));
    }
    return ncc;
  }

  // The object part of the patch without its outer 15 % (away from the outline).
  static cv::Rect Interior(const Object& ob) {
    const int bx = std::max(1, static_cast<int>(0.15 * ob.w)),
              by = std::max(1, static_cast<int>(0.15 * ob.h));
    return cv::Rect(ob.mx + bx, ob.my + by, std::max(1, ob.w - 2 * bx), std::max(1, ob.h - 2 * by));
  }

  // Bounding box of a quad (distorted px) grown by `margin`, clipped to the image.
  cv::Rect Box(const Corners& und, double margin) const {
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (const Vec2& c : und) {
      const Vec2 d = ToDistorted(c);
      x0 = std::min(x0, d.x());
      y0 = std::min(y0, d.y());
      x1 = std::max(x1, d.x());
      y1 = std::max(y1, d.y());
    }
    const cv::Rect r(cv::Point(static_cast<int>(std::floor(x0 - margin)),
                               static_cast<int>(std::floor(y0 - margin))),
                     cv::Point(static_cast<int>(std::ceil(x1 + margin)) + 1,
                               static_cast<int>(std::ceil(y1 + margin)) + 1));
    return r & cv::Rect(0, 0, camera.width, camera.height);
  }

  // Mask of the quad (distorted) in box `r`, shrunk by `erode` px (negative: grown).
  cv::Mat QuadMask(const Corners& und, const cv::Rect& r, int erode) const {
    cv::Mat mask = cv::Mat::zeros(r.size(), CV_8U);
    std::vector<cv::Point> poly;
    for (const Vec2& c : und) {
      const Vec2 d = ToDistorted(c);
      poly.emplace_back(static_cast<int>(std::lround((d.x() - r.x) * 16)),
                        static_cast<int>(std::lround((d.y() - r.y) * 16)));
    }
    cv::fillConvexPoly(mask, poly, cv::Scalar(255), cv::LINE_8, 4);
    if (erode > 0) cv::erode(mask, mask, cv::Mat(), cv::Point(-1, -1), erode);
    if (erode < 0) cv::dilate(mask, mask, cv::Mat(), cv::Point(-1, -1), -erode);
    return mask;
  }

  Corners CornersOf(const Object& ob, const Mat3& H) const {
    Corners c;
    for (int i = 0; i < 4; ++i) c[i] = Apply(H, ob.obj_corners[i]);
    return c;
  }

  // Shi-Tomasi corners of `img` inside `mask`, strongest first, at least `min_dist` apart, whose
  // weaker structure-tensor eigenvalue exceeds both 1 % of the strongest and the absolute
  // min_corner_gradient (a plain surface's pixel noise is not a feature: LK on it wanders).
  std::vector<cv::Point2f> Corners2D(const cv::Mat& img, const cv::Mat& mask,
                                     double min_dist) const {
    constexpr int kBlock = 5;
    cv::Mat eig;
    cv::cornerMinEigenVal(img, eig, kBlock, 3, cv::BORDER_REPLICATE);
    // cornerMinEigenVal scales the 3x3 Sobel (8 x the gradient in grey levels / px) by
    // 1 / (4 kBlock 255) and sums over the block; its value is half the smaller eigenvalue.
    const double g = o.min_corner_gradient * 8.0 / (4.0 * kBlock * 255.0);
    double max_eig = 0.0;
    cv::minMaxLoc(eig, nullptr, &max_eig, nullptr, nullptr, mask);
    const float thr = static_cast<float>(std::max(0.01 * max_eig, 0.5 * kBlock * kBlock * g * g));
    cv::Mat dil;
    cv::dilate(eig, dil, cv::Mat());
    std::vector<std::pair<float, cv::Point>> cand;
    for (int y = 1; y < eig.rows - 1; ++y) {
      const float* e = eig.ptr<float>(y);
      const float* d = dil.ptr<float>(y);
      const uint8_t* m = mask.ptr<uint8_t>(y);
      for (int x = 1; x < eig.cols - 1; ++x)
        if (m[x] && e[x] >= thr && e[x] >= d[x]) cand.emplace_back(e[x], cv::Point(x, y));
    }
    std::sort(cand.begin(), cand.end(), [](const auto& a, const auto& b) {
      return a.first != b.first
                 ? a.first > b.first
                 : (a.second.y != b.second.y ? a.second.y < b.second.y : a.second.x < b.second.x);
    });
    std::vector<cv::Point2f> out;
    const double d2 = min_dist * min_dist;
    for (const auto& c : cand) {
      bool near = false;
      for (const cv::Point2f& q : out) {
        const double dx = q.x - c.second.x, dy = q.y - c.second.y;
        if (dx * dx + dy * dy < d2) {
          near = true;
          break;
        }
      }
      if (near) continue;
      out.emplace_back(static_cast<float>(c.second.x), static_cast<float>(c.second.y));
      if (static_cast<int>(out.size()) >= 2 * o.max_points) break;
    }
    return out;
  }

  // The quad's four corners as flow points at CORNERS_PX (distorted px), replacing the old corner
  // points; a corner too close to the border for the LK window is left out.
  void ResetCornerPoints(Object* ob, const Corners& corners_px, const cv::Mat& gray) const {
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
  void SeedPoints(Object* ob, const cv::Mat& gray) const {
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
  bool Refine(const Object& ob, const cv::Mat& gray, const Corners& c, bool coarse,
              EdgeRefinement* out) {
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
          RefineCornersOnEdges(smooth, cam, start, o.min_edge_gradient, co, ob.side_sign);
      if (!e.ok) return false;
      start = e.corners_undistorted;
    }
    if (!smooth_near(start, o.refine.search_px)) return false;
    *out = RefineCornersOnEdges(smooth, cam, start, o.min_edge_gradient, o.refine, ob.side_sign);
    return out->ok && IsConvex(out->corners_undistorted);
  }

  bool Init(Object* ob, const cv::Mat& gray, const Corners& corners, bool build_model) {
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
    if (build_model) {
      std::vector<cv::Mat> levels;
      cv::buildPyramid(gray, levels, 4);
      Warp(*ob, levels, H, &ob->ref, &ob->ref_valid);
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
      if (Refine(*ob, gray, corners, false, &e)) ob->side_sign = e.side_sign;
    }
    SeedPoints(ob, gray);
    ob->seeded = static_cast<int>(ob->pt_obj.size());
    ob->active = true;
    return true;
  }

  TrackedObject TrackOne(Object* ob, const cv::Mat& gray, const std::vector<cv::Mat>& levels,
                         const Mat3& H_pred, const std::vector<cv::Point2f>& p1,
                         const std::vector<uint8_t>& good, size_t offset) {
    TrackedObject t;
    t.id = ob->id;
    const size_t n = ob->pt_obj.size();
    std::vector<cv::Point2f> obj_pts, img_pts;  // correspondences: object plane, undistorted px
    std::vector<cv::Point2f> obj_dist;          // their distorted image positions
    int survived = 0;
    for (size_t k = 0; k < n; ++k) {
      if (!good[offset + k]) continue;
      ++survived;
      const Vec2 u = ToUndistorted(Vec2(p1[offset + k].x, p1[offset + k].y));
      obj_pts.emplace_back(static_cast<float>(ob->pt_obj[k].x()),
                           static_cast<float>(ob->pt_obj[k].y()));
      img_pts.emplace_back(static_cast<float>(u.x()), static_cast<float>(u.y()));
      obj_dist.push_back(p1[offset + k]);
    }
    const int n_flow = static_cast<int>(obj_pts.size());
    // Recovery: descriptors of the predicted region (dilated) matched against the model.
    if (ob->model_desc.rows >= o.min_inliers &&
        (survived < o.recover_fraction * static_cast<double>(n) || survived < o.min_inliers)) {
      t.recovered = true;
      // Search region: the predicted and the last quad, grown by the object's size.
      const Corners pc = CornersOf(*ob, H_pred);
      const double size = std::sqrt(std::abs(SignedArea(pc)));
      const cv::Rect r = Box(pc, size + 30.0) | Box(CornersOf(*ob, ob->H), size + 30.0);
      if (r.width > 40 && r.height > 40) {
        std::vector<cv::KeyPoint> kps;
        cv::Mat desc;
        orb->setMaxFeatures(std::max(2 * o.model_keypoints, 100));
        orb->detectAndCompute(gray(r), cv::noArray(), kps, desc);
        if (!kps.empty()) {
          cv::BFMatcher matcher(cv::NORM_HAMMING);
          std::vector<std::vector<cv::DMatch>> knn;
          matcher.knnMatch(desc, ob->model_desc, knn, 2);
          for (const auto& m : knn) {
            if (m.empty()) continue;
            if (m.size() == 2 && m[0].distance > o.match_ratio * m[1].distance) continue;
            const cv::Point2f p = kps[m[0].queryIdx].pt + cv::Point2f(r.x, r.y);
            const Vec2 u = ToUndistorted(Vec2(p.x, p.y));
            const Vec2& X = ob->model_xy[m[0].trainIdx];
            obj_pts.emplace_back(static_cast<float>(X.x()), static_cast<float>(X.y()));
            img_pts.emplace_back(static_cast<float>(u.x()), static_cast<float>(u.y()));
            obj_dist.push_back(p);
          }
        }
      }
    }
    // Consensus: RANSAC homography object plane -> undistorted image.
    Mat3 H = H_pred;
    bool strong = false;
    int inliers = 0;
    if (obj_pts.size() >= 4) {
      std::vector<uint8_t> mask;
      cv::Mat Hcv;
      // Cheap path first (most frames: flow points only, nearly all right): a least-squares fit
      // to all points; when >= 90 % of them lie within ransac_px it is refitted to those and
      // RANSAC is not needed (~5x cheaper). Otherwise, or after a recovery, RANSAC.
      if (!t.recovered && obj_pts.size() >= 8) {
        const double r2 = o.ransac_px * o.ransac_px;
        for (int pass = 0; pass < 2; ++pass) {
          std::vector<cv::Point2f> a, b;
          for (size_t k = 0; k < obj_pts.size(); ++k)
            if (pass == 0 || mask[k]) {
              a.push_back(obj_pts[k]);
              b.push_back(img_pts[k]);
            }
          Hcv = cv::findHomography(a, b, 0);
          if (Hcv.empty()) break;
          const cv::Matx33d Hm(Hcv);
          mask.assign(obj_pts.size(), 0);
          size_t n_in = 0;
          for (size_t k = 0; k < obj_pts.size(); ++k) {
            const cv::Vec3d q = Hm * cv::Vec3d(obj_pts[k].x, obj_pts[k].y, 1.0);
            const double dx = q[0] / q[2] - img_pts[k].x, dy = q[1] / q[2] - img_pts[k].y;
            mask[k] = dx * dx + dy * dy <= r2;
            n_in += mask[k];
          }
          if (n_in < 0.9 * obj_pts.size()) {
            Hcv = cv::Mat();
            break;
          }
        }
      }
      if (Hcv.empty())
        Hcv = cv::findHomography(obj_pts, img_pts, cv::RANSAC, o.ransac_px, mask, 500);
      if (!Hcv.empty()) {
        Mat3 Hk;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) Hk(a, b) = Hcv.at<double>(a, b);
        inliers = static_cast<int>(std::count(mask.begin(), mask.end(), 1));
        const Corners kc = CornersOf(*ob, Hk);
        const Corners pc = CornersOf(*ob, H_pred);
        const double area_ratio =
            std::abs(SignedArea(kc)) / std::max(std::abs(SignedArea(pc)), 1e-9);
        const bool sane = IsConvex(kc) && area_ratio > 0.5 && area_ratio < 2.0;
        if (sane && inliers >= o.min_inliers) {
          strong = true;
          H = Hk;
        } else if (sane && inliers >= 4 && area_ratio > 0.8 && area_ratio < 1.25) {
          H = Hk;  // a few points (a plain object's corners): better than the prediction alone
        }
      }
    }
    t.keypoints = inliers;
    const Corners kp_corners = CornersOf(*ob, H);
    // Edge refinement (the side polarities learnt at Start).
    EdgeRefinement e;
    Corners final_corners = kp_corners;
    // With a trusted keypoint homography, the edges refine it only for an object whose outline
    // was found at Start (a known polarity per side): on an object without a clear outline (or
    // one blurred at Start) an edge fit is noise that would drag the points with it.
    const bool outline_known = ob->side_sign[0] != 0;
    // After a recovery the matched homography is coarser (ORB keypoints of a pyramid level):
    // the coarse pass runs and its shift is allowed.
    const bool coarse = !strong || t.recovered;
    const double max_shift = t.recovered ? o.coarse_search_px : o.max_refine_shift_px;
    if ((!strong || outline_known) && Refine(*ob, gray, kp_corners, coarse, &e) &&
        (!strong || MaxCornerDistance(e.corners_undistorted, kp_corners) <= max_shift)) {
      final_corners = e.corners_undistorted;
      t.edge_refined = true;
    }
    Mat3 H_final = H;
    if (t.edge_refined && !HomographyFrom4(ob->obj_corners, final_corners, &H_final)) {
      t.edge_refined = false;
      final_corners = kp_corners;
      H_final = H;
    }
    bool lost = !strong && !t.edge_refined;
    double visible = 0.0;
    if (!lost) {
      t.appearance = Appearance(*ob, levels, H_final, &visible);
      lost = visible < o.min_visible || t.appearance < o.min_appearance;
    }
    if (lost) {
      ob->active = false;
      ob->pt_obj.clear();
      ob->pt_img.clear();
      return t;
    }
    t.tracked = true;
    t.corners_undistorted = final_corners;
    t.in_view = true;
    for (int i = 0; i < 4; ++i) {
      const Vec2 d = ToDistorted(final_corners[i]);
      t.corners_px[i] = d;
      t.in_view = t.in_view && camera.InImage(d);
    }
    const double a =
        std::clamp((t.appearance - o.min_appearance) / (1.0 - o.min_appearance + 1e-9), 0.0, 1.0);
    t.score = 0.5 * a + 0.25 * (t.edge_refined ? 1.0 : 0.0) +
              0.25 * std::min(1.0, inliers / (2.0 * o.min_inliers));
    // Next frame's points: the correspondences that agree with the final homography (flow points
    // and recovered matches), at their measured positions.
    std::vector<Vec2> new_obj;
    std::vector<cv::Point2f> new_img;
    const double keep2 = 2.25 * o.ransac_px * o.ransac_px;
    for (size_t k = 0; k < obj_pts.size(); ++k) {
      const Vec2 X(obj_pts[k].x, obj_pts[k].y);
      if ((Apply(H_final, X) - Vec2(img_pts[k].x, img_pts[k].y)).squaredNorm() > keep2) continue;
      if (static_cast<int>(k) >= n_flow) {  // a match: skip when a flow point holds it already
        bool dup = false;
        for (const cv::Point2f& q : new_img) dup |= cv::norm(q - obj_dist[k]) < 2.0;
        if (dup) continue;
      }
      new_obj.push_back(X);
      if (t.edge_refined) {
        // The edges fix the homography to the object's outline: points follow it, so that the
        // flow cannot drift away from the model (each point keeps only this frame's LK error).
        const Vec2 d = ToDistorted(Apply(H_final, X));
        new_img.emplace_back(static_cast<float>(d.x()), static_cast<float>(d.y()));
      } else {
        new_img.push_back(obj_dist[k]);
      }
    }
    ob->pt_obj.swap(new_obj);
    ob->pt_img.swap(new_img);
    ob->H_prev = ob->H;
    ob->H = H_final;
    // Constant velocity only from a steady frame: after a recovery or a weak consensus the
    // last motion may be a jump.
    ob->has_motion = strong && !t.recovered;
    ++ob->frames_since_refresh;
    // New points take their object-plane position from this frame's homography: only from a
    // homography fixed by the edges, or by the flow alone for an object without a known outline.
    const bool confident = t.appearance >= o.refresh_appearance &&
                           (t.edge_refined || (!outline_known && strong && !t.recovered));
    if (confident && (ob->frames_since_refresh >= o.refresh_every ||
                      2 * static_cast<int>(ob->pt_obj.size()) < ob->seeded)) {
      SeedPoints(ob, gray);
      ob->seeded = static_cast<int>(ob->pt_obj.size());
      ob->frames_since_refresh = 0;
    } else {
      ResetCornerPoints(ob, t.corners_px, gray);  // corners always follow the final quad
    }
    return t;
  }

  std::vector<TrackedObject> Track(const cv::Mat& gray, const std::map<int, Corners>& predicted) {
    CheckFrame(gray);
    std::vector<cv::Mat> pyr = Pyramid(gray);
    std::vector<TrackedObject> out;
    std::vector<Object*> act;
    for (auto& [id, ob] : objects)
      if (ob.active) act.push_back(&ob);
    if (!act.empty() && !prev_pyr.empty()) {
      // Predictions: the caller's corners, else constant velocity of the homography
      // (H_pred = M H with M = H H_prev^-1, the last frame-to-frame motion in the image).
      std::vector<Mat3> H_pred(act.size());
      std::vector<cv::Point2f> p0, p1;
      std::vector<size_t> offset(act.size());
      for (size_t a = 0; a < act.size(); ++a) {
        Object* ob = act[a];
        Mat3 Hp = ob->has_motion ? Mat3(ob->H * ob->H_prev.inverse() * ob->H) : ob->H;
        const auto it = predicted.find(ob->id);
        Mat3 Hc;
        if (it != predicted.end() && HomographyFrom4(ob->obj_corners, it->second, &Hc)) Hp = Hc;
        if (!IsConvex(CornersOf(*ob, Hp))) Hp = ob->H;
        H_pred[a] = Hp;
        offset[a] = p0.size();
        // Initial flow: the points moved by the predicted motion (the prediction's image of
        // their object-plane position, shifted by their last residual).
        for (size_t k = 0; k < ob->pt_obj.size(); ++k) {
          const Vec2 last = ToDistorted(Apply(ob->H, ob->pt_obj[k]));
          const Vec2 pred = ToDistorted(Apply(Hp, ob->pt_obj[k]));
          const cv::Point2f q = ob->pt_img[k];
          p0.push_back(q);
          p1.emplace_back(static_cast<float>(q.x + pred.x() - last.x()),
                          static_cast<float>(q.y + pred.y() - last.y()));
        }
      }
      std::vector<uint8_t> good(p0.size(), 0);
      const std::vector<cv::Point2f> p1_init = p1;
      if (!p0.empty()) {
        std::vector<uint8_t> st, st_back;
        std::vector<float> err;
        const cv::TermCriteria crit(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                    o.lk_iterations, 0.03);
        const cv::Size win(o.lk_window, o.lk_window);
        // The backward pass starts from where the point was (the answer a correct forward match
        // gives), so it needs no coarse levels: one level above the image absorbs a forward error
        // of a few pixels and anything worse fails the check anyway.
        const int back_levels = std::min(1, o.lk_levels);
        cv::calcOpticalFlowPyrLK(prev_pyr, pyr, p0, p1, st, err, win, o.lk_levels, crit,
                                 cv::OPTFLOW_USE_INITIAL_FLOW);
        std::vector<cv::Point2f> back = p0;
        cv::calcOpticalFlowPyrLK(pyr, prev_pyr, p1, back, st_back, err, win, back_levels, crit,
                                 cv::OPTFLOW_USE_INITIAL_FLOW);
        const double fb2 = o.max_fb_error_px * o.max_fb_error_px;
        auto check = [&](size_t k, const cv::Point2f& q, const cv::Point2f& b, bool ok) {
          const cv::Point2f d = b - p0[k];
          return ok && d.x * d.x + d.y * d.y <= fb2 && q.x >= 0 && q.y >= 0 &&
                 q.x <= gray.cols - 1 && q.y <= gray.rows - 1;
        };
        std::vector<size_t> retry;
        for (size_t k = 0; k < p0.size(); ++k) {
          good[k] = check(k, p1[k], back[k], st[k] && st_back[k]);
          if (!good[k] && cv::norm(p1_init[k] - p0[k]) > 2.0) retry.push_back(k);
        }
        // Points lost with a motion prediction get a second chance from where they were: the
        // prediction is wrong when the motion stops or turns abruptly.
        if (!retry.empty()) {
          std::vector<cv::Point2f> q0, q1, qb;
          for (const size_t k : retry) q0.push_back(p0[k]);
          q1 = q0;
          cv::calcOpticalFlowPyrLK(prev_pyr, pyr, q0, q1, st, err, win, o.lk_levels, crit,
                                   cv::OPTFLOW_USE_INITIAL_FLOW);
          qb = q0;
          cv::calcOpticalFlowPyrLK(pyr, prev_pyr, q1, qb, st_back, err, win, back_levels, crit,
                                   cv::OPTFLOW_USE_INITIAL_FLOW);
          for (size_t j = 0; j < retry.size(); ++j)
            if (check(retry[j], q1[j], qb[j], st[j] && st_back[j])) {
              good[retry[j]] = 1;
              p1[retry[j]] = q1[j];
            }
        }
      }
      const std::vector<cv::Mat> levels = Levels(pyr, true);
      for (size_t a = 0; a < act.size(); ++a)
        out.push_back(TrackOne(act[a], gray, levels, H_pred[a], p1, good, offset[a]));
    }
    prev_pyr.swap(pyr);
    prev_gray = gray.clone();
    return out;
  }
};

ObjectTracker::ObjectTracker(const PinholeRadtan& camera, Options options)
    : options_(std::move(options)) {
  std::string why;
  if (!options_.Check(&why)) throw InputError("ObjectTracker options: " + why);
  if (!camera.Check(&why)) throw InputError("ObjectTracker camera: " + why);
  impl_ = std::make_unique<Impl>(camera, options_);
}

ObjectTracker::~ObjectTracker() = default;

bool ObjectTracker::Start(int id, const cv::Mat& gray, const Corners& corners_undistorted) {
  impl_->CheckFrame(gray);
  Impl::Object ob;
  ob.id = id;
  if (!impl_->Init(&ob, gray, corners_undistorted, true)) return false;
  impl_->SetPrevFrame(gray);
  impl_->objects[id] = std::move(ob);
  return true;
}

std::vector<TrackedObject> ObjectTracker::Track(const cv::Mat& gray,
                                                const std::map<int, Corners>& predicted) {
  return impl_->Track(gray, predicted);
}

std::optional<double> ObjectTracker::Similarity(int id, const cv::Mat& gray,
                                                const Corners& corners) const {
  impl_->CheckFrame(gray);
  const auto it = impl_->objects.find(id);
  if (it == impl_->objects.end()) return std::nullopt;
  const Impl::Object& ob = it->second;
  Mat3 H;
  if (!IsConvex(corners) || !HomographyFrom4(ob.obj_corners, corners, &H)) return -1.0;
  std::vector<cv::Mat> levels;
  cv::buildPyramid(gray, levels, 4);
  double visible = 0.0;
  const double ncc = impl_->Appearance(ob, levels, H, &visible);
  // As in Track: an object mostly out of view has no appearance to compare (-1).
  return visible >= impl_->o.min_visible ? ncc : -1.0;
}

bool ObjectTracker::Reacquire(int id, const cv::Mat& gray, const Corners& predicted,
                              Corners* corners, double* similarity) {
  impl_->CheckFrame(gray);
  const auto it = impl_->objects.find(id);
  if (it == impl_->objects.end() || !IsConvex(predicted)) return false;
  for (const Vec2& c : predicted)
    if (!impl_->camera.InImage(impl_->ToDistorted(c))) return false;
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
