// Point features beside the objects (see point_tracker.h for the design).
#include "fsp/frontend/point_tracker.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "fsp/common/error.h"
#include "shi_tomasi.h"

namespace fsp::frontend {

bool PointTrackerOptions::Check(std::string* why) const {
  auto fail = [&](const char* w) {
    if (why) *why = w;
    return false;
  };
  if (max_points < 1) return fail("max_points must be >= 1");
  if (cell_px < 8) return fail("cell_px must be >= 8");
  if (max_image_width_px < 64) return fail("max_image_width_px must be >= 64");
  if (!(cell_overflow >= 1.0)) return fail("cell_overflow must be >= 1");
  if (!(min_distance_px >= 0.0)) return fail("min_distance_px must be >= 0");
  if (!(refill_fraction > 0.0 && refill_fraction <= 1.0))
    return fail("refill_fraction must be in (0, 1]");
  if (empty_cell_retry_frames < 0) return fail("empty_cell_retry_frames must be >= 0");
  if (!(min_corner_gradient >= 0.0)) return fail("min_corner_gradient must be >= 0");
  if (!(faint_corner_gradient >= 0.0) || faint_corner_gradient > min_corner_gradient)
    return fail("faint_corner_gradient must be in [0, min_corner_gradient]");
  if (!(faint_below_fraction >= 0.0 && faint_below_fraction <= 1.0))
    return fail("faint_below_fraction must be in [0, 1]");
  if (!(faint_sigma_scale >= 1.0)) return fail("faint_sigma_scale must be >= 1");
  if (subpixel_px < 0 || subpixel_px > 10) return fail("subpixel_px must be in [0, 10]");
  if (!(border_px >= 0.0)) return fail("border_px must be >= 0");
  if (lk_window < 5 || lk_window % 2 == 0) return fail("lk_window must be odd and >= 5");
  if (lk_levels < 0 || lk_levels > 6) return fail("lk_levels must be in [0, 6]");
  if (lk_iterations < 1) return fail("lk_iterations must be >= 1");
  if (!(max_fb_error_px > 0.0)) return fail("max_fb_error_px must be > 0");
  if (!(ransac_px > 0.0)) return fail("ransac_px must be > 0");
  if (!(ransac_confidence > 0.0 && ransac_confidence < 1.0))
    return fail("ransac_confidence must be in (0, 1)");
  if (ransac_max_iterations < 1) return fail("ransac_max_iterations must be >= 1");
  return true;
}

struct PointTracker::Impl {
  struct Point {
    int64_t id = -1;
    cv::Point2f px;           // distorted px of the working level
    Vec2 und = Vec2::Zero();  // undistorted px
    int age = 0;
    bool faint = false;  // found at faint_corner_gradient
  };

  PinholeRadtan camera;
  const Options& o;
  // The pyramid level the tracker works on (the widest no wider than max_image_width_px), its
  // size and its scale: full-resolution px = working px * scale (OpenCV's pyramid convention,
  // as its LK uses between levels).
  int level = 0;
  int width = 0, height = 0;
  double scale = 1.0;
  bool distorted = false;
  Mat3 K, K_inv;
  double focal = 1.0;  // mean focal length [px]: normalised -> pixel distances
  int max_points = 0;
  int cols = 1, rows = 1, capacity = 1, overflow_capacity = 1;
  std::vector<Point> points;  // live, by id
  std::vector<cv::Mat> prev_levels;
  int64_t next_id = 0;
  int frame_index = 0;
  std::vector<int> retry_at;         // per cell: the first frame it is searched again
  std::vector<uint8_t> textureless;  // per cell: its last search found no corner, no point since
  std::vector<int> faint_retry_at;   // per cell: the first frame it is searched again, faint

  Impl(const PinholeRadtan& cam, const Options& opt) : camera(cam), o(opt) {
    distorted = camera.HasDistortion();
    K = camera.K();
    K_inv = K.inverse();
    focal = 0.5 * (camera.fx + camera.fy);
    width = camera.width;
    height = camera.height;
    while (width > o.max_image_width_px) {
      width = (width + 1) / 2;  // cv::pyrDown's size
      height = (height + 1) / 2;
      ++level;
    }
    scale = std::ldexp(1.0, level);
    const double area = static_cast<double>(width) * height;
    max_points = std::max(1, static_cast<int>(std::lround(o.max_points * area / (640.0 * 480.0))));
    cols = std::max(1, static_cast<int>(std::lround(static_cast<double>(width) / o.cell_px)));
    rows = std::max(1, static_cast<int>(std::lround(static_cast<double>(height) / o.cell_px)));
    capacity = (max_points + cols * rows - 1) / (cols * rows);
    overflow_capacity = std::max(1, static_cast<int>(std::lround(o.cell_overflow * capacity)));
    retry_at.assign(cols * rows, 0);
    textureless.assign(cols * rows, 0);
    faint_retry_at.assign(cols * rows, 0);
  }

  // Working px <-> undistorted full-resolution px.
  Vec2 ToUndistorted(const cv::Point2f& p) const {
    const Vec2 d(scale * p.x, scale * p.y);
    return distorted ? camera.UndistortPixel(d) : d;
  }
  Vec2 ToWorking(const Vec2& u) const { return (distorted ? camera.DistortPixel(u) : u) / scale; }

  int CellOf(double x, double y) const {
    const int cx = std::clamp(static_cast<int>(x * cols / width), 0, cols - 1);
    const int cy = std::clamp(static_cast<int>(y * rows / height), 0, rows - 1);
    return cy * cols + cx;
  }
  cv::Rect CellRect(int c) const {
    const int cx = c % cols, cy = c / cols;
    const int x0 = cx * width / cols, x1 = (cx + 1) * width / cols;
    const int y0 = cy * height / rows, y1 = (cy + 1) * height / rows;
    return cv::Rect(x0, y0, x1 - x0, y1 - y0);
  }
  bool Inside(const cv::Point2f& p) const {
    return std::isfinite(p.x) && std::isfinite(p.y) && p.x >= o.border_px && p.y >= o.border_px &&
           p.x <= width - 1 - o.border_px && p.y <= height - 1 - o.border_px;
  }

  // 1. Flow: KEEP[i] set for the points followed into LEVELS (positions updated in place).
  void Flow(const std::vector<cv::Mat>& levels, const std::optional<Mat3>& R_Cprev_Ccur,
            std::vector<uint8_t>* keep, std::vector<cv::Point2f>* p1_out) const;
  // 2. Geometry: clears KEEP[i] of the points not on one camera motion; returns whether the
  // gyroscope's rotation was used.
  bool Geometry(const std::vector<Vec2>& und1, const std::optional<Mat3>& R_Cprev_Ccur,
                std::vector<uint8_t>* keep) const;
  // The most points a cell holds: the wanted points shared among the cells with texture (all but
  // those whose last search found no corner and that no point has entered since), at least the
  // cell's share, at most cell_overflow shares.
  int SharedCapacity() const {
    const int textured =
        static_cast<int>(std::count(textureless.begin(), textureless.end(), uint8_t{0}));
    const int shared = (max_points + std::max(1, textured) - 1) / std::max(1, textured);
    return std::clamp(shared, capacity, overflow_capacity);
  }
  // 3. Spread: drops points too close to an older one or in a full cell; returns how many.
  int Spread();
  // 4. Detection in the cells short of points; returns how many were added.
  int Detect(const cv::Mat& gray);
  PointTrackerResult Track(const cv::Mat& gray, const std::vector<cv::Mat>& levels, int64_t t_ns,
                           const std::optional<Mat3>& R_Cprev_Ccur);
};

void PointTracker::Impl::Flow(const std::vector<cv::Mat>& levels,
                              const std::optional<Mat3>& R_Cprev_Ccur, std::vector<uint8_t>* keep,
                              std::vector<cv::Point2f>* p1_out) const {
  const size_t n = points.size();
  std::vector<cv::Point2f> p0(n), p1(n), back(n);
  std::vector<cv::Point2f> shift(n, cv::Point2f(0.f, 0.f));  // predicted motion
  // The infinite homography of the rotation, in undistorted pixels: x_cur ~ K R_Ccur_Cprev K^-1
  // x_prev (exact for distant points, a prediction for near ones).
  const bool predict = R_Cprev_Ccur && o.use_rotation_prior;
  const Mat3 H = predict ? Mat3(K * R_Cprev_Ccur->transpose() * K_inv) : Mat3::Identity();
  for (size_t i = 0; i < n; ++i) {
    p0[i] = points[i].px;
    p1[i] = p0[i];
    if (!predict) continue;
    const Vec3 q = H * points[i].und.homogeneous();
    if (!(q.z() > 1e-9)) continue;
    const Vec2 d = ToWorking(q.head<2>() / q.z());
    if (!d.allFinite()) continue;
    shift[i] =
        cv::Point2f(static_cast<float>(d.x()) - p0[i].x, static_cast<float>(d.y()) - p0[i].y);
    p1[i] = p0[i] + shift[i];
  }
  std::vector<uint8_t> st, st_back;
  std::vector<float> err;
  const cv::TermCriteria crit(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, o.lk_iterations,
                              0.01);
  const cv::Size win(o.lk_window, o.lk_window);
  cv::calcOpticalFlowPyrLK(prev_levels, levels, p0, p1, st, err, win, o.lk_levels, crit,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  // Backwards from the new position, started where the predicted motion undone puts it, through
  // every level (from one level, as the object tracker does, the way back misses points whose
  // motion the prediction did not know, and good tracks end sooner: 225 -> 254 tracks in the
  // default room's 4 s).
  for (size_t i = 0; i < n; ++i) back[i] = p1[i] - shift[i];
  cv::calcOpticalFlowPyrLK(levels, prev_levels, p1, back, st_back, err, win, o.lk_levels, crit,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  keep->assign(n, 0);
  for (size_t i = 0; i < n; ++i) {
    // A faint point's flow is noisier (LK's error grows as the gradient falls): its way back is
    // allowed the gradients' ratio more.
    const double fb = o.max_fb_error_px *
                      (points[i].faint ? o.min_corner_gradient / o.faint_corner_gradient : 1.0);
    const cv::Point2f d = back[i] - p0[i];
    (*keep)[i] = st[i] && st_back[i] && d.x * d.x + d.y * d.y <= fb * fb && Inside(p1[i]);
  }
  *p1_out = std::move(p1);
}

bool PointTracker::Impl::Geometry(const std::vector<Vec2>& und1,
                                  const std::optional<Mat3>& R_Cprev_Ccur,
                                  std::vector<uint8_t>* keep) const {
  std::vector<size_t> idx;
  for (size_t i = 0; i < keep->size(); ++i)
    if ((*keep)[i]) idx.push_back(i);
  const size_t n = idx.size();
  const bool with_rotation = R_Cprev_Ccur && o.use_rotation_prior;
  if (n < (with_rotation ? 5u : 8u)) return false;  // too few to tell outliers
  std::vector<uint8_t> best(n, 1);
  int best_count = -1;
  bool used_rotation = false;
  if (with_rotation) {
    // Bearings of the previous frame turned into the current one (r = R_Ccur_Cprev f0) and of the
    // current frame (f1); the epipolar constraint with the known rotation, f1 . (t x r) = 0, is
    // linear in the translation's direction t: t . (r x f1) = 0. Two points give t = a_i x a_j.
    const Mat3 R_Ccur_Cprev = R_Cprev_Ccur->transpose();
    std::vector<Vec3> r(n), f1(n), a(n);
    for (size_t k = 0; k < n; ++k) {
      r[k] = R_Ccur_Cprev * (K_inv * points[idx[k]].und.homogeneous());
      f1[k] = K_inv * und1[idx[k]].homogeneous();
      a[k] = r[k].cross(f1[k]);
    }
    const double thr = o.ransac_px * scale / focal;  // working px -> normalised
    // Distance of f1 from the epipolar line of r under translation direction t (normalised
    // coordinates); for t = 0 (or along r: the point at the epipole) from r itself.
    auto residual = [&](const Vec3& t, size_t k) {
      const Vec3 l = t.cross(r[k]);
      const double ln = std::hypot(l.x(), l.y());
      if (ln < 1e-9) return (f1[k].head<2>() - r[k].head<2>() / r[k].z()).norm();
      return std::abs(f1[k].dot(l)) / ln;
    };
    auto score = [&](const Vec3& t, std::vector<uint8_t>* in) {
      int count = 0;
      for (size_t k = 0; k < n; ++k) count += ((*in)[k] = residual(t, k) <= thr);
      return count;
    };
    std::vector<uint8_t> in(n);
    int needed = o.ransac_max_iterations;
    // Draws needed for an all-inlier pair with ransac_confidence at inlier ratio COUNT / n.
    auto update_needed = [&](int count) {
      const double w = static_cast<double>(count) / n;
      const double miss = std::log(std::max(1e-12, 1.0 - w * w));
      if (miss < 0.0)
        needed = static_cast<int>(std::ceil(std::log(1.0 - o.ransac_confidence) / miss));
    };
    // The pure rotation first (a camera that does not translate: every hypothesis fits).
    best_count = score(Vec3::Zero(), &best);
    update_needed(best_count);
    std::seed_seq seq{o.seed, static_cast<uint32_t>(frame_index)};
    std::mt19937 rng(seq);
    std::uniform_int_distribution<size_t> pick(0, n - 1);
    for (int it = 0; it < std::min(needed, o.ransac_max_iterations); ++it) {
      const size_t i = pick(rng), j = pick(rng);
      if (i == j) continue;
      Vec3 t = a[i].cross(a[j]);
      if (!(t.norm() > 1e-12)) continue;
      t.normalize();
      const int count = score(t, &in);
      if (count > best_count) {
        best_count = count;
        best = in;
        update_needed(count);
      }
    }
    used_rotation = true;
    // Local optimisation: the epipolar geometry refitted to the rotation's inliers and every
    // point scored against it (Sampson distance), kept when it explains more. A real gyroscope's
    // rotation is off by a fraction of a degree (noise, a time offset, a rolling shutter), which
    // at the threshold cuts good points; a point moving on its own is not among the inliers the
    // refit sees. The refit is the normalised 8-point least squares over all those inliers (a
    // fundamental matrix in normalised coordinates). DM-VIO walk's first 10 s, points lost a
    // frame: 4.1 with the rotation alone; 1.1 refitted so; 1.6 with least median of squares over
    // 5-point essential matrices, which cost 20 ms a frame there (degree-10 polynomials; 11 % of
    // the rendered room's CPU); RANSAC's 5-point models (fitted to 5 noisy points) lost so many
    // that the walk diverged after 9 s, and a Gauss-Newton refit of the rotation and translation
    // direction kept 2.6 and the walk diverged too.
    if (best_count >= 8 && best_count < static_cast<int>(n)) {
      std::vector<cv::Point2f> a_in, b_in;
      std::vector<Vec3> f0(n);
      for (size_t k = 0; k < n; ++k) {
        f0[k] = K_inv * points[idx[k]].und.homogeneous();
        if (!best[k]) continue;
        a_in.emplace_back(static_cast<float>(f0[k].x()), static_cast<float>(f0[k].y()));
        b_in.emplace_back(static_cast<float>(f1[k].x()), static_cast<float>(f1[k].y()));
      }
      const cv::Mat E = cv::findFundamentalMat(a_in, b_in, cv::FM_8POINT);
      if (E.rows >= 3 && E.cols == 3) {
        Mat3 Em;
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) Em(i, j) = E.at<double>(i, j);
        int count = 0;
        for (size_t k = 0; k < n; ++k) {
          const Vec3 Ex0 = Em * f0[k], Etx1 = Em.transpose() * f1[k];
          const double e = f1[k].dot(Ex0);
          const double d2 = e * e / (Ex0.head<2>().squaredNorm() + Etx1.head<2>().squaredNorm());
          count += (in[k] = d2 <= thr * thr);
        }
        if (count > best_count) {
          best_count = count;
          best = in;
        }
      }
    }
  }
  // Without the rotation, or when it explains fewer than half of the points (a wrong rotation:
  // a bad gyroscope, a large time offset), the fundamental matrix.
  if (n >= 8 && 2 * best_count < static_cast<int>(n)) {
    std::vector<cv::Point2f> a(n), b(n);
    for (size_t k = 0; k < n; ++k) {
      const Vec2& u0 = points[idx[k]].und;
      const Vec2& u1 = und1[idx[k]];
      a[k] = cv::Point2f(static_cast<float>(u0.x()), static_cast<float>(u0.y()));
      b[k] = cv::Point2f(static_cast<float>(u1.x()), static_cast<float>(u1.y()));
    }
    std::vector<uint8_t> mask;
    const cv::Mat F =
        cv::findFundamentalMat(a, b, cv::FM_RANSAC, o.ransac_px * scale, o.ransac_confidence, mask);
    if (!F.empty() && mask.size() == n) {
      const int count = static_cast<int>(std::count(mask.begin(), mask.end(), 1));
      if (count > best_count) {
        best_count = count;
        best = mask;
        used_rotation = false;
      }
    }
  }
  if (best_count < 0) return false;
  for (size_t k = 0; k < n; ++k) (*keep)[idx[k]] = best[k];
  return used_rotation;
}

int PointTracker::Impl::Spread() {
  std::vector<size_t> order(points.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return points[a].age > points[b].age; });
  std::vector<int> count(cols * rows, 0);
  for (const Point& p : points) textureless[CellOf(p.px.x, p.px.y)] = 0;
  const int cap = SharedCapacity();
  std::vector<uint8_t> kept(points.size(), 0);
  std::vector<cv::Point2f> kept_px;
  const double d2 = o.min_distance_px * o.min_distance_px;
  for (const size_t i : order) {
    const cv::Point2f& p = points[i].px;
    const int c = CellOf(p.x, p.y);
    if (count[c] >= cap) continue;
    bool near = false;
    for (const cv::Point2f& q : kept_px) {
      const double dx = p.x - q.x, dy = p.y - q.y;
      if (dx * dx + dy * dy < d2) {
        near = true;
        break;
      }
    }
    if (near) continue;
    ++count[c];
    kept[i] = 1;
    kept_px.push_back(p);
  }
  std::vector<Point> out;
  for (size_t i = 0; i < points.size(); ++i)
    if (kept[i]) out.push_back(points[i]);
  const int dropped = static_cast<int>(points.size() - out.size());
  points.swap(out);
  return dropped;
}

int PointTracker::Impl::Detect(const cv::Mat& gray) {
  const int live = static_cast<int>(points.size());
  if (live >= o.refill_fraction * max_points) return 0;
  // Where new points may go: inside the border, away from the live points.
  cv::Mat mask(gray.size(), CV_8U, cv::Scalar(0));
  const int b = static_cast<int>(std::ceil(o.border_px));
  if (gray.cols > 2 * b && gray.rows > 2 * b)
    mask(cv::Rect(b, b, gray.cols - 2 * b, gray.rows - 2 * b)).setTo(255);
  const int radius = static_cast<int>(std::ceil(o.min_distance_px));
  std::vector<int> count(cols * rows, 0);
  for (const Point& p : points) {
    ++count[CellOf(p.px.x, p.px.y)];
    if (radius > 0) cv::circle(mask, cv::Point(cvRound(p.px.x), cvRound(p.px.y)), radius, 0, -1);
  }
  // Passes over the cells short of points, the neediest first: up to each cell's share, then
  // (budget left: cells without texture) up to cell_overflow shares; then, at the faint threshold,
  // up to its share in each cell where the first threshold found nothing.
  int budget = max_points - live, added = 0;
  constexpr int kContext = 4;  // image around a cell for the eigenvalues' block and the maxima
  std::vector<uint8_t> bare(cols * rows, 0);  // the first threshold found no corner there
  struct Pass {
    bool overflow, faint;
  };
  for (const Pass pass : {Pass{false, false}, Pass{true, false}, Pass{false, true}}) {
    if (pass.faint &&
        !(o.faint_corner_gradient > 0.0 && live + added < o.faint_below_fraction * max_points))
      break;
    const int cap = pass.overflow ? SharedCapacity() : capacity;
    std::vector<int> cells;
    for (int c = 0; c < cols * rows; ++c) {
      if (count[c] >= cap) continue;
      if (pass.faint ? (bare[c] && faint_retry_at[c] <= frame_index) : retry_at[c] <= frame_index)
        cells.push_back(c);
      else if (!pass.faint && count[c] == 0)
        bare[c] = 1;  // searched in vain within empty_cell_retry_frames
    }
    std::stable_sort(cells.begin(), cells.end(), [&](int a, int c) { return count[a] < count[c]; });
    for (const int c : cells) {
      if (budget <= 0) break;
      const cv::Rect cell = CellRect(c);
      const cv::Rect roi = cv::Rect(cell.x - kContext, cell.y - kContext, cell.width + 2 * kContext,
                                    cell.height + 2 * kContext) &
                           cv::Rect(0, 0, gray.cols, gray.rows);
      cv::Mat cell_mask(roi.size(), CV_8U, cv::Scalar(0));
      const cv::Rect in_roi(cell.x - roi.x, cell.y - roi.y, cell.width, cell.height);
      mask(cell).copyTo(cell_mask(in_roi));
      const std::vector<cv::Point2f> found =
          ShiTomasiCorners(gray(roi), cell_mask, o.min_distance_px,
                           pass.faint ? o.faint_corner_gradient : o.min_corner_gradient,
                           std::min(cap - count[c], budget));
      if (found.empty()) {
        if (pass.faint) {
          faint_retry_at[c] = frame_index + o.empty_cell_retry_frames;
        } else {
          textureless[c] = count[c] == 0;
          bare[c] = count[c] == 0;
          retry_at[c] = frame_index + o.empty_cell_retry_frames;
        }
        continue;
      }
      if (!pass.faint) textureless[c] = 0;
      for (const cv::Point2f& f : found) {
        Point p;
        p.id = next_id++;
        p.px = cv::Point2f(f.x + roi.x, f.y + roi.y);
        p.age = 0;
        p.faint = pass.faint;
        points.push_back(p);
        if (radius > 0)
          cv::circle(mask, cv::Point(cvRound(p.px.x), cvRound(p.px.y)), radius, 0, -1);
      }
      count[c] += static_cast<int>(found.size());
      budget -= static_cast<int>(found.size());
      added += static_cast<int>(found.size());
    }
  }
  // The new points moved onto their corner's vertex (the flow then follows the vertex, which
  // stays put as the view deforms the patch, not a pixel beside it, which does not).
  if (added > 0 && o.subpixel_px == 0)
    for (size_t i = points.size() - added; i < points.size(); ++i)
      points[i].und = ToUndistorted(points[i].px);
  if (added > 0 && o.subpixel_px > 0) {
    std::vector<cv::Point2f> fresh;
    for (size_t i = points.size() - added; i < points.size(); ++i) fresh.push_back(points[i].px);
    cv::cornerSubPix(gray, fresh, cv::Size(o.subpixel_px, o.subpixel_px), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01));
    for (size_t i = 0; i < fresh.size(); ++i) {
      Point& p = points[points.size() - added + i];
      const cv::Point2f d = fresh[i] - p.px;
      if (d.x * d.x + d.y * d.y <= o.subpixel_px * o.subpixel_px && Inside(fresh[i]) &&
          CellOf(fresh[i].x, fresh[i].y) == CellOf(p.px.x, p.px.y))  // the cell's count holds
        p.px = fresh[i];
      p.und = ToUndistorted(p.px);
    }
  }
  return added;
}

PointTrackerResult PointTracker::Impl::Track(const cv::Mat& gray,
                                             const std::vector<cv::Mat>& levels, int64_t t_ns,
                                             const std::optional<Mat3>& R_Cprev_Ccur) {
  PointTrackerResult r;
  Stopwatch sw;
  std::vector<uint8_t> keep;
  std::vector<cv::Point2f> p1;
  std::vector<Vec2> und1;
  if (!points.empty() && !prev_levels.empty()) {
    Flow(levels, R_Cprev_Ccur, &keep, &p1);
    und1.resize(points.size());
    for (size_t i = 0; i < points.size(); ++i)
      if (keep[i]) und1[i] = ToUndistorted(p1[i]);
    const int after_flow = static_cast<int>(std::count(keep.begin(), keep.end(), 1));
    r.lost_flow = static_cast<int>(points.size()) - after_flow;
    r.times.Add("flow", sw.Lap());
    r.used_rotation = Geometry(und1, R_Cprev_Ccur, &keep);
    r.tracked = static_cast<int>(std::count(keep.begin(), keep.end(), 1));
    r.lost_geometry = after_flow - r.tracked;
    std::vector<Point> next;
    for (size_t i = 0; i < points.size(); ++i) {
      if (!keep[i]) continue;
      Point p = points[i];
      p.px = p1[i];
      p.und = und1[i];
      ++p.age;
      next.push_back(p);
    }
    points.swap(next);
    r.dropped_spread = Spread();
    r.tracked -= r.dropped_spread;
    r.times.Add("geometry", sw.Lap());
  } else {
    points.clear();
  }
  r.detected = Detect(gray);
  r.times.Add("detect", sw.Lap());
  r.points.reserve(points.size());
  r.points_px.reserve(points.size());
  for (const Point& p : points) {
    PointObservation obs;
    obs.t_ns = t_ns;
    obs.point_id = p.id;
    obs.uv_undistorted = p.und;
    obs.age = p.age;
    obs.sigma_scale = scale * (p.faint ? o.faint_sigma_scale : 1.0);
    r.points.push_back(obs);
    r.points_px.emplace_back(scale * p.px.x, scale * p.px.y);
  }
  prev_levels = levels;
  ++frame_index;
  return r;
}

PointTracker::PointTracker(const PinholeRadtan& camera, Options options)
    : options_(std::move(options)) {
  std::string why;
  if (!options_.Check(&why)) throw InputError("PointTracker options: " + why);
  if (!camera.Check(&why)) throw InputError("PointTracker camera: " + why);
  impl_ = std::make_unique<Impl>(camera, options_);
}

PointTracker::~PointTracker() = default;

PointTrackerResult PointTracker::Track(const FlowPyramid& frame, int64_t t_ns,
                                       const std::optional<Mat3>& R_Cprev_Ccur) {
  const cv::Mat& gray = frame.image;
  FSP_CHECK(!gray.empty() && gray.type() == CV_8UC1);
  if (gray.cols != impl_->camera.width || gray.rows != impl_->camera.height)
    throw InputError("PointTracker: frame of " + std::to_string(gray.cols) + "x" +
                     std::to_string(gray.rows) + " px, calibration of " +
                     std::to_string(impl_->camera.width) + "x" +
                     std::to_string(impl_->camera.height));
  FSP_CHECK(frame.window >= options_.lk_window);
  const int level = impl_->level;
  FSP_CHECK(frame.max_level >= level);
  const std::vector<cv::Mat> all = frame.Levels(level + options_.lk_levels);
  const std::vector<cv::Mat> levels(all.begin() + 2 * level, all.end());
  return impl_->Track(levels.front(), levels, t_ns, R_Cprev_Ccur);
}

PointTrackerResult PointTracker::Track(const cv::Mat& gray, int64_t t_ns,
                                       const std::optional<Mat3>& R_Cprev_Ccur) {
  FSP_CHECK(!gray.empty() && gray.type() == CV_8UC1);
  return Track(BuildFlowPyramid(gray, options_.lk_window, pyramid_levels()), t_ns, R_Cprev_Ccur);
}

int PointTracker::pyramid_levels() const {
  return impl_->level + options_.lk_levels;
}

int PointTracker::working_level() const {
  return impl_->level;
}

int PointTracker::max_points() const {
  return impl_->max_points;
}

cv::Size PointTracker::grid() const {
  return cv::Size(impl_->cols, impl_->rows);
}

int PointTracker::cell_capacity() const {
  return impl_->capacity;
}

int PointTracker::CellOf(const Vec2& px) const {
  return impl_->CellOf(px.x() / impl_->scale, px.y() / impl_->scale);
}

}  // namespace fsp::frontend
