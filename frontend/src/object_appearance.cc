// The object tracker's appearance model (ObjectTracker::Impl, see object_tracker_internal.h): the
// frame warped into the reference patch, normalised cross-correlation against the reference, the
// bounding box and mask of a quad; ObjectTracker::Similarity.
#include <algorithm>
#include <cmath>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "fsp/frontend/rect_geometry.h"
#include "object_tracker_internal.h"

namespace fsp::frontend {
namespace {

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

// Patch values normalised to zero mean and unit variance over MASK (CV_32F, 0 elsewhere).
cv::Mat Normalised(const cv::Mat& p, const cv::Mat& mask) {
  cv::Scalar mean, sd;
  cv::meanStdDev(p, mean, sd, mask);
  cv::Mat n = (p - mean[0]) / std::max(sd[0], 1e-3);
  n.setTo(0.f, mask == 0);
  return n;
}

}  // namespace

using object_tracker_internal::Apply;
using object_tracker_internal::HomographyFrom4;

// Image levels of a pyramid (every other entry when it holds derivatives).
std::vector<cv::Mat> ObjectTracker::Impl::Levels(const std::vector<cv::Mat>& pyr,
                                                 bool with_derivatives) {
  std::vector<cv::Mat> lv;
  for (size_t i = 0; i < pyr.size(); i += with_derivatives ? 2 : 1) lv.push_back(pyr[i]);
  return lv;
}

std::vector<cv::Mat> ObjectTracker::Impl::AppearanceLevels(const cv::Mat& gray) {
  std::vector<cv::Mat> levels;
  cv::buildPyramid(gray, levels, 4);
  return levels;
}

// Image pixels per patch pixel of the object seen through H: its perimeter in the image over its
// perimeter in the patch.
double ObjectTracker::Impl::PatchScale(const Object& ob, const Mat3& H) const {
  const Corners c = CornersOf(ob, H);
  double perim = 0.0;
  for (int i = 0; i < 4; ++i) perim += (c[(i + 1) % 4] - c[i]).norm();
  return perim / (2.0 * (ob.w + ob.h));
}

// The frame warped into the patch through H (object plane -> undistorted px): CV_32F patch and
// a validity mask; the pyramid level is chosen so that one patch pixel covers about one level
// pixel (no aliasing when the object is large). Returns the fraction of patch pixels in view.
double ObjectTracker::Impl::Warp(const Object& ob, const std::vector<cv::Mat>& levels,
                                 const Mat3& H, cv::Mat* patch, cv::Mat* valid) const {
  const int pw = ob.w + 2 * ob.mx, ph = ob.h + 2 * ob.my;
  patch->create(ph, pw, CV_32F);
  valid->create(ph, pw, CV_8U);
  const double scale = PatchScale(ob, H);
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

double ObjectTracker::Impl::Ncc(const cv::Mat& a, const cv::Mat& va, const cv::Mat& b,
                                const cv::Mat& vb) {
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
double ObjectTracker::Impl::Appearance(const Object& ob, const std::vector<cv::Mat>& levels,
                                       const Mat3& H, double* visible) const {
  cv::Mat patch, valid;
  *visible = Warp(ob, levels, H, &patch, &valid);
  double ncc = Ncc(ob.ref, ob.ref_valid, patch, valid);
  if (ob.textured_interior) {
    const cv::Rect in = Interior(ob);
    ncc = std::min(ncc, Ncc(ob.ref(in), ob.ref_valid(in), patch(in), valid(in)));
  }
  return ncc;
}

void ObjectTracker::Impl::AlignToReference(const Object& ob, const std::vector<cv::Mat>& levels,
                                           const cv::Mat& target, const cv::Mat& target_valid,
                                           bool shift_only, Mat3* H) const {
  cv::Mat patch, valid;
  Warp(ob, levels, *H, &patch, &valid);
  const cv::Mat mask = valid & target_valid;
  const cv::Mat ref = Normalised(target, mask);
  Corners c = CornersOf(ob, *H);
  // Difference step: a quarter of the image pixels per patch pixel, at least half a pixel.
  const double step = std::max(0.5, 0.25 * PatchScale(ob, *H));
  auto residual = [&](const Corners& q, cv::Mat* r) {
    Mat3 Hq;
    if (!HomographyFrom4(ob.obj_corners, q, &Hq)) return false;
    cv::Mat pq, vq;
    Warp(ob, levels, Hq, &pq, &vq);
    *r = Normalised(pq, mask) - ref;
    return true;
  };
  cv::Mat r0 = Normalised(patch, mask) - ref;  // at H itself: the warp above
  double cost = r0.dot(r0);
  // Parameter k moves corner coordinate k, or with `shift_only` coordinate k of every corner.
  const int n = shift_only ? 2 : 8;
  auto moved = [&](const Corners& from, int k, double by) {
    Corners q = from;
    for (int i = 0; i < 4; ++i)
      if (shift_only || i == k / 2) q[i][k % 2] += by;
    return q;
  };
  for (int it = 0; it < 5; ++it) {
    std::array<cv::Mat, 8> J;  // numeric, per parameter
    for (int k = 0; k < n; ++k) {
      cv::Mat rk;
      if (!residual(moved(c, k, step), &rk)) return;
      J[k] = (rk - r0) / step;
    }
    Eigen::MatrixXd JtJ(n, n);
    Eigen::VectorXd Jtr(n);
    for (int a = 0; a < n; ++a) {
      Jtr(a) = J[a].dot(r0);
      for (int b = a; b < n; ++b) JtJ(a, b) = JtJ(b, a) = J[a].dot(J[b]);
    }
    JtJ.diagonal() *= 1.0 + 1e-3;  // a little damping: a corner may be poorly determined
    const Eigen::VectorXd d = -JtJ.ldlt().solve(Jtr);
    if (!d.allFinite() || d.norm() > 20.0 * step) break;
    Corners q = c;
    for (int k = 0; k < n; ++k) q = moved(q, k, d(k));
    cv::Mat rq;
    if (!residual(q, &rq) || rq.dot(rq) >= cost) break;
    c = q;
    r0 = rq;
    cost = rq.dot(rq);
    if (d.norm() < 0.05) break;
  }
  Mat3 Hc;
  if (HomographyFrom4(ob.obj_corners, c, &Hc)) *H = Hc;
}

// The blurred frame is the mean of the sharp ones over the exposure: through H0 the frame shows
// at patch pixel q the mean over the exposure's instants s of ref(T H_s^-1 H0 T^-1 q), H_s the
// homography of the corners c0 + s MOTION and T the patch's offset (object plane -> patch pixel).
// One instant per patch pixel of the smear.
void ObjectTracker::Impl::SmearedReference(const Object& ob, const Mat3& H0, const Corners& motion,
                                           double exposure, cv::Mat* smeared,
                                           cv::Mat* valid) const {
  const Corners c0 = CornersOf(ob, H0);
  double longest = 0.0;
  for (const Vec2& m : motion) longest = std::max(longest, m.norm());
  const double smear = exposure * longest / std::max(PatchScale(ob, H0), 1e-6);  // patch px
  const int n = static_cast<int>(std::clamp(std::ceil(smear) + 1.0, 2.0, 64.0));
  Mat3 T = Mat3::Identity();
  T(0, 2) = ob.mx;
  T(1, 2) = ob.my;
  cv::Mat sum = cv::Mat::zeros(ob.ref.size(), CV_32F), warped, warped_valid;
  *valid = ob.ref_valid.clone();
  int used = 0;
  for (int k = 0; k < n; ++k) {
    const double s = exposure * ((k + 0.5) / n - 0.5);
    Corners c;
    for (int i = 0; i < 4; ++i) c[i] = c0[i] + s * motion[i];
    Mat3 Hs;
    if (!HomographyFrom4(ob.obj_corners, c, &Hs)) continue;
    const Mat3 M = T * Hs.inverse() * H0 * T.inverse();
    cv::Mat Mcv(3, 3, CV_64F);
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 3; ++q) Mcv.at<double>(r, q) = M(r, q);
    cv::warpPerspective(ob.ref, warped, Mcv, ob.ref.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                        cv::BORDER_REPLICATE);
    cv::warpPerspective(ob.ref_valid, warped_valid, Mcv, ob.ref.size(),
                        cv::INTER_NEAREST | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT, 0);
    sum += warped;
    *valid &= warped_valid;
    ++used;
  }
  *smeared = used > 0 ? cv::Mat(sum / used) : ob.ref.clone();
}

// The object part of the patch without its outer 15 % (away from the outline).
cv::Rect ObjectTracker::Impl::Interior(const Object& ob) {
  const int bx = std::max(1, static_cast<int>(0.15 * ob.w)),
            by = std::max(1, static_cast<int>(0.15 * ob.h));
  return cv::Rect(ob.mx + bx, ob.my + by, std::max(1, ob.w - 2 * bx), std::max(1, ob.h - 2 * by));
}

// Bounding box of a quad (distorted px) grown by `margin`, clipped to the image.
cv::Rect ObjectTracker::Impl::Box(const Corners& und, double margin) const {
  Corners d;
  for (int i = 0; i < 4; ++i) d[i] = ToDistorted(und[i]);
  return PixelBox(BoundingBox(d), margin, camera.width, camera.height);
}

// Mask of the quad (distorted) in box `r`, shrunk by `erode` px (negative: grown).
cv::Mat ObjectTracker::Impl::QuadMask(const Corners& und, const cv::Rect& r, int erode) const {
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

std::optional<double> ObjectTracker::Similarity(int id, const cv::Mat& gray,
                                                const Corners& corners) const {
  impl_->CheckFrame(gray);
  const auto it = impl_->objects.find(id);
  if (it == impl_->objects.end()) return std::nullopt;
  const Impl::Object& ob = it->second;
  Mat3 H;
  if (!IsConvex(corners) || !HomographyFrom4(ob.obj_corners, corners, &H)) return -1.0;
  double visible = 0.0;
  const double ncc = impl_->Appearance(ob, Impl::AppearanceLevels(gray), H, &visible);
  // As in Track: an object mostly out of view has no appearance to compare (-1).
  return visible >= impl_->o.min_visible ? ncc : -1.0;
}

}  // namespace fsp::frontend
