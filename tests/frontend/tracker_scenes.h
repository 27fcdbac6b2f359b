// Synthetic sequences for the ObjectTracker tests: a textured patch or a plain rectangle warped (4x
// supersampled, then area-averaged) onto a static, weakly textured background through the
// homography of a rectangle posed in 3-D (ProjectRect), optionally smeared along a motion, blurred
// and given pixel noise. The exact corners are the texture's outline (-0.5 .. size - 0.5) mapped
// through that homography. Also the scoring and timing the tests share.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <functional>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/median.h"
#include "fsp/common/types.h"
#include "fsp/frontend/object_tracker.h"
#include "fsp/frontend/rect_geometry.h"
#include "synthetic.h"
#include "test_util.h"

namespace fsp::frontend::tracker_test {

constexpr int kW = 640, kH = 480;
constexpr double kF = 500.0, kCx = 319.5, kCy = 239.5;

inline PinholeRadtan Camera() {
  return test::PinholeCamera(kW, kH, kF, kCx, kCy);
}

// A texture of smooth blobs plus sharp discs and boxes (corners for the flow, structure for ORB).
inline cv::Mat Texture(uint32_t seed, int w = 160, int h = 120) {
  std::mt19937 rng(seed);
  cv::Mat lo(h / 8, w / 8, CV_32F);
  std::uniform_real_distribution<float> u(-60.f, 60.f);
  for (int y = 0; y < lo.rows; ++y)
    for (int x = 0; x < lo.cols; ++x) lo.at<float>(y, x) = 130.f + u(rng);
  cv::Mat tex;
  cv::resize(lo, tex, cv::Size(w, h), 0, 0, cv::INTER_CUBIC);
  std::uniform_int_distribution<int> px(0, w - 1), py(0, h - 1), grey(20, 235), rad(3, 12);
  for (int k = 0; k < 25; ++k) {
    const cv::Point c(px(rng), py(rng));
    if (k % 2)
      cv::circle(tex, c, rad(rng), cv::Scalar(grey(rng)), cv::FILLED, cv::LINE_AA);
    else
      cv::rectangle(tex, cv::Rect(c.x, c.y, rad(rng) * 2, rad(rng)), cv::Scalar(grey(rng)),
                    cv::FILLED);
  }
  cv::GaussianBlur(tex, tex, cv::Size(0, 0), 0.8);
  // A plain light margin (a print's border) of 8 % of the height: the outline has an edge.
  const int m = std::max(2, h * 8 / 100);
  tex.rowRange(0, m).setTo(225);
  tex.rowRange(h - m, h).setTo(225);
  tex.colRange(0, m).setTo(225);
  tex.colRange(w - m, w).setTo(225);
  cv::Mat out;
  tex.convertTo(out, CV_8U);
  return out;
}

inline cv::Mat Background() {
  std::mt19937 rng(99);
  cv::Mat lo(12, 16, CV_32F);
  std::uniform_real_distribution<float> u(-12.f, 12.f);
  for (int y = 0; y < lo.rows; ++y)
    for (int x = 0; x < lo.cols; ++x) lo.at<float>(y, x) = u(rng);
  cv::Mat bg;
  cv::resize(lo, bg, cv::Size(kW, kH), 0, 0, cv::INTER_CUBIC);
  for (int y = 0; y < kH; ++y) bg.row(y) += 80.0 + 20.0 * y / kH;
  return bg;  // CV_32F
}

struct Thing {
  cv::Mat tex;  // CV_8U (a plain object: a small constant image)
  Corners corners;
};

// Texture outline in texture pixels, s1..s4 (s1 bottom-left: the texture's last row).
inline Corners TexCorners(const cv::Mat& tex) {
  const double w = tex.cols - 0.5, h = tex.rows - 0.5;
  return {Vec2(-0.5, h), Vec2(w, h), Vec2(w, -0.5), Vec2(-0.5, -0.5)};
}

inline cv::Mat H33(const Corners& from, const Corners& to) {
  std::vector<cv::Point2f> a, b;
  for (int i = 0; i < 4; ++i) {
    a.emplace_back(static_cast<float>(from[i].x()), static_cast<float>(from[i].y()));
    b.emplace_back(static_cast<float>(to[i].x()), static_cast<float>(to[i].y()));
  }
  cv::Mat H = cv::getPerspectiveTransform(a, b);
  H.convertTo(H, CV_64F);
  return H;
}

// Renders things over the background. motion_len > 1: box blur of that length along `motion_dir`
// [rad] (the exposure's motion), before the optics blur and noise.
// A float image with Gaussian noise (sigma 2 grey levels, seeded) as an 8-bit frame.
inline cv::Mat WithNoise8U(cv::Mat f, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.f, 2.f);
  for (int y = 0; y < f.rows; ++y)
    for (int x = 0; x < f.cols; ++x) f.at<float>(y, x) += noise(rng);
  cv::Mat out;
  f.convertTo(out, CV_8U);
  return out;
}

inline cv::Mat Render(const cv::Mat& bg, const std::vector<Thing>& things, uint32_t seed,
                      int motion_len = 0, double motion_dir = 0.0) {
  constexpr int kS = 4;
  cv::Mat f = bg.clone();
  for (const Thing& t : things) {
    const cv::Rect box = PixelBox(BoundingBox(t.corners), 2.0, kW, kH);
    if (box.area() <= 0) continue;
    // Texture -> hi-res box: low-res pixel x maps to kS (x - box.x + 0.5) - 0.5.
    const cv::Mat H = H33(TexCorners(t.tex), t.corners);
    cv::Mat S = (cv::Mat_<double>(3, 3) << kS, 0, kS * (0.5 - box.x) - 0.5, 0, kS,
                 kS * (0.5 - box.y) - 0.5, 0, 0, 1);
    const cv::Mat Hh = S * H;
    const cv::Size hs(box.width * kS, box.height * kS);
    cv::Mat tex_f, col, alpha;
    t.tex.convertTo(tex_f, CV_32F);
    cv::warpPerspective(tex_f, col, Hh, hs, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    // Coverage: the outline filled at kS x resolution with 4 sub-pixel bits, area-averaged below.
    std::vector<cv::Point> poly;
    for (const Vec2& c : t.corners)
      poly.emplace_back(static_cast<int>(std::lround((kS * (c.x() - box.x + 0.5) - 0.5) * 16)),
                        static_cast<int>(std::lround((kS * (c.y() - box.y + 0.5) - 0.5) * 16)));
    alpha = cv::Mat::zeros(hs, CV_32F);
    cv::fillConvexPoly(alpha, poly, cv::Scalar(1.0), cv::LINE_8, 4);
    cv::Mat premul = col.mul(alpha), a_lo, c_lo;
    cv::resize(premul, c_lo, box.size(), 0, 0, cv::INTER_AREA);
    cv::resize(alpha, a_lo, box.size(), 0, 0, cv::INTER_AREA);
    cv::Mat roi = f(box);
    roi = c_lo + roi.mul(1.0 - a_lo);
  }
  if (motion_len > 1) {
    cv::Mat k = cv::Mat::zeros(motion_len, motion_len, CV_32F);
    const double c = 0.5 * (motion_len - 1);
    for (int i = 0; i < 8 * motion_len; ++i) {  // a line of length motion_len through the centre
      const double s = (i + 0.5) / (8 * motion_len) * motion_len - 0.5 * motion_len;
      const int x = static_cast<int>(std::lround(c + s * std::cos(motion_dir)));
      const int y = static_cast<int>(std::lround(c + s * std::sin(motion_dir)));
      k.at<float>(std::clamp(y, 0, motion_len - 1), std::clamp(x, 0, motion_len - 1)) += 1.f;
    }
    k /= cv::sum(k)[0];
    cv::filter2D(f, f, -1, k, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  }
  cv::GaussianBlur(f, f, cv::Size(0, 0), 0.7);
  return WithNoise8U(f, seed);
}

inline Corners Pose(double w, double h, const Vec3& centre, double yaw, double pitch, double roll) {
  return test::ProjectRect(w, h, centre, yaw, pitch, roll, kF, kCx, kCy);
}

inline bool FullyVisible(const Corners& c) {
  for (const Vec2& p : c)
    if (p.x() < 0 || p.y() < 0 || p.x() > kW - 1 || p.y() > kH - 1) return false;
  return true;
}

inline bool Outside(const Corners& c) {  // wholly out of the image
  const Eigen::AlignedBox2d b = BoundingBox(c);
  return b.max().x() < 0 || b.max().y() < 0 || b.min().x() > kW - 1 || b.min().y() > kH - 1;
}

inline const TrackedObject* Find(const std::vector<TrackedObject>& r, int id) {
  for (const auto& t : r)
    if (t.id == id) return &t;
  return nullptr;
}

// Accumulates corner errors over fully visible frames.
struct Score {
  int frames = 0, tracked = 0, within2 = 0;
  std::vector<double> errors;  // every corner
  double worst = 0.0, min_appearance = 1.0;
  void Add(const TrackedObject* t, const Corners& truth) {
    ++frames;
    if (!t || !t->tracked) return;
    ++tracked;
    min_appearance = std::min(min_appearance, t->appearance);
    double m = 0.0;
    for (int i = 0; i < 4; ++i) {
      const double e = (t->corners_undistorted[i] - truth[i]).norm();
      errors.push_back(e);
      m = std::max(m, e);
    }
    worst = std::max(worst, m);
    within2 += m <= 2.0;
  }
  double Success() const { return frames ? static_cast<double>(within2) / frames : 0.0; }
  double Median() const { return errors.empty() ? 1e9 : fsp::Median(errors); }
  void Print(const char* name, double ms_per_frame) const {
    std::printf(
        "[tracker] %s: %d frames, tracked %d, all corners <= 2 px in %.1f %%, median %.3f px, "
        "worst %.2f px, least NCC %.3f, %.2f ms CPU per frame\n",
        name, frames, tracked, 100.0 * Success(), Median(), worst, min_appearance, ms_per_frame);
  }
};

// Thread CPU time [ms]: the machine running the tests is shared, wall time would count other
// processes' turns. OpenCV runs on this one thread while a OneThread is alive.
inline double CpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}
struct OneThread {
  int before = cv::getNumThreads();
  OneThread() { cv::setNumThreads(1); }
  ~OneThread() { cv::setNumThreads(before); }
};

// Runs one object through `frames` frames of corners(k) with the tracker started at frame 0 on the
// truth; returns the score over the fully visible frames and the mean Track time.
inline Score RunSingle(const cv::Mat& tex, int frames, const std::function<Corners(int)>& corners,
                       int motion_len, double motion_dir, double* ms,
                       std::vector<int>* refined = nullptr) {
  const OneThread one_thread;
  const cv::Mat bg = Background();
  ObjectTracker tracker(Camera());
  const Corners c0 = corners(0);
  const cv::Mat f0 = Render(bg, {{tex, c0}}, 1, motion_len, motion_dir);
  EXPECT_TRUE(tracker.Start(7, f0, c0));
  Score s;
  double total = 0.0;
  for (int k = 1; k < frames; ++k) {
    const Corners c = corners(k);
    const cv::Mat img = Render(bg, {{tex, c}}, 1 + k, motion_len, motion_dir);
    const double t0 = CpuMs();
    const auto r = tracker.Track(img);
    total += CpuMs() - t0;
    const TrackedObject* t = Find(r, 7);
    if (refined && t && t->tracked) refined->push_back(t->edge_refined);
    if (FullyVisible(c)) s.Add(t, c);
    if (!t || !t->tracked) break;  // lost: the rest counts as failures
  }
  s.frames = std::max(s.frames, frames - 1);
  *ms = total / (frames - 1);
  return s;
}

}  // namespace fsp::frontend::tracker_test
