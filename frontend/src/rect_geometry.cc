#include "fsp/frontend/rect_geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace fsp::frontend {

RectangleTest ZhangHeTest(const Corners& px, const Mat3& K) {
  RectangleTest t;
  const Mat3 K_inv = K.inverse();
  Vec3 m[4];
  for (int i = 0; i < 4; ++i) m[i] = K_inv * Vec3(px[i].x(), px[i].y(), 1.0);
  // c2 = ((m̃1 × m̃3)·m̃4) / ((m̃2 × m̃3)·m̃4), c4 = ((m̃1 × m̃3)·m̃2) / ((m̃4 × m̃3)·m̃2)
  const double den2 = m[1].cross(m[2]).dot(m[3]);
  const double den4 = m[3].cross(m[2]).dot(m[1]);
  if (std::abs(den2) < 1e-15 || std::abs(den4) < 1e-15) return t;
  t.c2 = m[0].cross(m[2]).dot(m[3]) / den2;
  t.c4 = m[0].cross(m[2]).dot(m[1]) / den4;
  if (!(t.c2 > 0.0) || !(t.c4 > 0.0) || !std::isfinite(t.c2) || !std::isfinite(t.c4)) return t;
  // n2 = c2 m̃2 − m̃1, n4 = c4 m̃4 − m̃1 (3-D edges s1→s2, s1→s4 with corner 1 at unit depth)
  t.n2 = t.c2 * m[1] - m[0];
  t.n4 = t.c4 * m[3] - m[0];
  const double l2 = t.n2.norm(), l4 = t.n4.norm();
  if (l2 < 1e-15 || l4 < 1e-15) return t;
  t.abs_cos = std::abs(t.n2.dot(t.n4)) / (l2 * l4);
  t.aspect_12_14 = l2 / l4;
  t.valid = true;
  return t;
}

Mat3 DefaultK(int width, int height, double hfov_deg) {
  // fx = (W/2) / tan(hfov/2); square pixels; principal point at the image centre (pixel-centre
  // convention).
  const double f = 0.5 * width / std::tan(0.5 * hfov_deg * M_PI / 180.0);
  Mat3 K;
  K << f, 0.0, 0.5 * (width - 1), 0.0, f, 0.5 * (height - 1), 0.0, 0.0, 1.0;
  return K;
}

double SignedArea(const Corners& c) {
  double a = 0.0;
  for (int i = 0; i < 4; ++i) {
    const Vec2& p = c[i];
    const Vec2& q = c[(i + 1) % 4];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * a;
}

namespace {
double Cross2(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}
}  // namespace

bool IsConvex(const Corners& c) {
  int pos = 0, neg = 0;
  for (int i = 0; i < 4; ++i) {
    const double z = Cross2(c[(i + 1) % 4] - c[i], c[(i + 2) % 4] - c[(i + 1) % 4]);
    if (z > 0) ++pos;
    if (z < 0) ++neg;
  }
  return (pos == 4) || (neg == 4);
}

bool InsideConvex(const Corners& c, const Vec2& p) {
  int pos = 0, neg = 0;
  for (int i = 0; i < 4; ++i) {
    const double z = Cross2(c[(i + 1) % 4] - c[i], p - c[i]);
    if (z >= 0) ++pos;
    if (z <= 0) ++neg;
  }
  return pos == 4 || neg == 4;
}

Corners MovedFromCentroid(const Corners& c, double px) {
  const Vec2 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  Corners moved;
  for (int i = 0; i < 4; ++i) {
    const Vec2 r = c[i] - centre;
    moved[i] = c[i] + px * r / std::max(r.norm(), 1e-9);
  }
  return moved;
}

bool ContainsWithMargin(const Corners& outer, const Corners& inner, double margin_px) {
  const Corners grown = MovedFromCentroid(outer, margin_px);
  for (const Vec2& p : inner)
    if (!InsideConvex(grown, p)) return false;
  return true;
}

std::optional<Vec2> GravityImageDirection(const Vec2& m, const Mat3& K, const Vec3& g) {
  const double fx = K(0, 0), fy = K(1, 1);
  const double xn = (m.x() - K(0, 2)) / fx, yn = (m.y() - K(1, 2)) / fy;
  // d x_n / dt = (g_x − x_n g_z) / Z (and likewise y); Z > 0 keeps the sign.
  const Vec2 d(fx * (g.x() - xn * g.z()), fy * (g.y() - yn * g.z()));
  const double gn = g.norm();
  if (gn <= 0.0) return std::nullopt;
  // Too short: gravity nearly along the viewing ray (|component across the ray| < ~0.17 of |g|).
  const Vec3 ray = Vec3(xn, yn, 1.0).normalized();
  const double across = (g - g.dot(ray) * ray).norm() / gn;
  if (across < 0.17) return std::nullopt;
  return d.normalized();
}

Corners CanonicalOrder(const Corners& in, const Mat3* K, const Vec3* gravity_C) {
  Corners c = in;
  if (SignedArea(c) > 0.0) std::swap(c[1], c[3]);  // counter-clockwise on screen
  Vec2 down(0.0, 1.0);
  if (K && gravity_C) {
    const Vec2 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
    if (auto d = GravityImageDirection(centre, *K, *gravity_C)) down = *d;
  }
  // Score of start corner k: the height edges s4→s1 and s3→s2 along "down".
  int best = 0;
  double best_score = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k) {
    const Vec2& s1 = c[k];
    const Vec2& s2 = c[(k + 1) % 4];
    const Vec2& s3 = c[(k + 2) % 4];
    const Vec2& s4 = c[(k + 3) % 4];
    const double score = down.dot((s1 - s4).normalized() + (s2 - s3).normalized());
    if (score > best_score) {
      best_score = score;
      best = k;
    }
  }
  Corners out;
  for (int i = 0; i < 4; ++i) out[i] = c[(best + i) % 4];
  return out;
}

double CornerDistanceBestShift(const Corners& a, const Corners& b, int* best_shift) {
  double best = std::numeric_limits<double>::infinity();
  for (int s = 0; s < 4; ++s) {
    double worst = 0.0;
    for (int i = 0; i < 4; ++i) worst = std::max(worst, (a[i] - b[(i + s) % 4]).norm());
    if (worst < best) {
      best = worst;
      if (best_shift) *best_shift = s;
    }
  }
  return best;
}

double MaxCornerDistance(const Corners& a, const Corners& b) {
  double d = 0.0;
  for (int i = 0; i < 4; ++i) d = std::max(d, (a[i] - b[i]).norm());
  return d;
}

double MeanCornerDistanceBestShift(const Corners& a, const Corners& b, int* best_shift) {
  double best = std::numeric_limits<double>::infinity();
  for (int s = 0; s < 4; ++s) {
    double sum = 0.0;
    for (int i = 0; i < 4; ++i) sum += (a[i] - b[(i + s) % 4]).norm();
    if (sum < best) {
      best = sum;
      if (best_shift) *best_shift = s;
    }
  }
  return 0.25 * best;
}

double ShapeDifference(const Corners& a, const Corners& b) {
  int s = 0;
  MeanCornerDistanceBestShift(a, b, &s);
  Vec2 mean = Vec2::Zero();
  for (int i = 0; i < 4; ++i) mean += 0.25 * (b[(i + s) % 4] - a[i]);
  double worst = 0.0;
  for (int i = 0; i < 4; ++i) worst = std::max(worst, (b[(i + s) % 4] - a[i] - mean).norm());
  return worst;
}

double ShortestSide(const Corners& c) {
  double s = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 4; ++i) s = std::min(s, (c[(i + 1) % 4] - c[i]).norm());
  return s;
}

Eigen::AlignedBox2d BoundingBox(const Corners& c) {
  Eigen::AlignedBox2d b;
  for (const Vec2& p : c) b.extend(p);
  return b;
}

std::vector<cv::Point2f> QuadHull(const Corners& c) {
  std::vector<cv::Point2f> p, h;
  for (const Vec2& v : c) p.emplace_back(static_cast<float>(v.x()), static_cast<float>(v.y()));
  cv::convexHull(p, h);
  return h;
}

double ConvexIou(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
  std::vector<cv::Point2f> inter;
  const double i = std::max(0.0, static_cast<double>(cv::intersectConvexConvex(a, b, inter)));
  const double u = cv::contourArea(a) + cv::contourArea(b) - i;
  return u > 0.0 ? i / u : 0.0;
}

double QuadIou(const Corners& a, const Corners& b) {
  return ConvexIou(QuadHull(a), QuadHull(b));
}

double BoxIou(const Eigen::AlignedBox2d& a, const Eigen::AlignedBox2d& b) {
  const Eigen::AlignedBox2d i = a.intersection(b);
  const double inter = i.isEmpty() ? 0.0 : i.volume();
  const double uni = (a.isEmpty() ? 0.0 : a.volume()) + (b.isEmpty() ? 0.0 : b.volume()) - inter;
  return uni > 0.0 ? inter / uni : 0.0;
}

cv::Rect PixelBox(const Eigen::AlignedBox2d& box, double margin, int cols, int rows) {
  const cv::Rect r(cv::Point(static_cast<int>(std::floor(box.min().x() - margin)),
                             static_cast<int>(std::floor(box.min().y() - margin))),
                   cv::Point(static_cast<int>(std::ceil(box.max().x() + margin)) + 1,
                             static_cast<int>(std::ceil(box.max().y() + margin)) + 1));
  return r & cv::Rect(0, 0, cols, rows);
}

}  // namespace fsp::frontend
