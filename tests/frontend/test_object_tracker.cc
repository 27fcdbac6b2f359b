// ObjectTracker on synthetic sequences with exactly known corners: a textured patch or a plain
// rectangle warped (4x supersampled, then area-averaged) onto a static, weakly textured background
// through the homography of a rectangle posed in 3-D (ProjectRect), blurred and given pixel noise.
// The exact corners are the texture's outline (-0.5 .. size - 0.5) mapped through that homography.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fsp/common/calibration.h"
#include "fsp/common/error.h"
#include "fsp/common/median.h"
#include "fsp/common/observations_io.h"
#include "fsp/frontend/edge_refine.h"
#include "fsp/frontend/object_tracker.h"
#include "synthetic.h"
#include "test_util.h"

namespace fsp::frontend {
namespace {

constexpr int kW = 640, kH = 480;
constexpr double kF = 500.0, kCx = 319.5, kCy = 239.5;

PinholeRadtan Camera() {
  PinholeRadtan c;
  c.width = kW;
  c.height = kH;
  c.fx = c.fy = kF;
  c.cx = kCx;
  c.cy = kCy;
  return c;
}

// A texture of smooth blobs plus sharp discs and boxes (corners for the flow, structure for ORB).
cv::Mat Texture(uint32_t seed, int w = 160, int h = 120) {
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

cv::Mat Background() {
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
Corners TexCorners(const cv::Mat& tex) {
  const double w = tex.cols - 0.5, h = tex.rows - 0.5;
  return {Vec2(-0.5, h), Vec2(w, h), Vec2(w, -0.5), Vec2(-0.5, -0.5)};
}

cv::Mat H33(const Corners& from, const Corners& to) {
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
cv::Mat Render(const cv::Mat& bg, const std::vector<Thing>& things, uint32_t seed,
               int motion_len = 0, double motion_dir = 0.0) {
  constexpr int kS = 4;
  cv::Mat f = bg.clone();
  for (const Thing& t : things) {
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (const Vec2& c : t.corners) {
      x0 = std::min(x0, c.x());
      y0 = std::min(y0, c.y());
      x1 = std::max(x1, c.x());
      y1 = std::max(y1, c.y());
    }
    const cv::Rect box = cv::Rect(cv::Point(static_cast<int>(x0) - 2, static_cast<int>(y0) - 2),
                                  cv::Point(static_cast<int>(x1) + 3, static_cast<int>(y1) + 3)) &
                         cv::Rect(0, 0, kW, kH);
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
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.f, 2.f);
  for (int y = 0; y < f.rows; ++y)
    for (int x = 0; x < f.cols; ++x) f.at<float>(y, x) += noise(rng);
  cv::Mat out;
  f.convertTo(out, CV_8U);
  return out;
}

Corners Pose(double w, double h, const Vec3& centre, double yaw, double pitch, double roll) {
  return test::ProjectRect(w, h, centre, yaw, pitch, roll, kF, kCx, kCy);
}

bool FullyVisible(const Corners& c) {
  for (const Vec2& p : c)
    if (p.x() < 0 || p.y() < 0 || p.x() > kW - 1 || p.y() > kH - 1) return false;
  return true;
}

bool Outside(const Corners& c) {  // wholly out of the image
  double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
  for (const Vec2& p : c) {
    x0 = std::min(x0, p.x());
    x1 = std::max(x1, p.x());
    y0 = std::min(y0, p.y());
    y1 = std::max(y1, p.y());
  }
  return x1 < 0 || y1 < 0 || x0 > kW - 1 || y0 > kH - 1;
}

const TrackedObject* Find(const std::vector<TrackedObject>& r, int id) {
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
  double Median() const {
    if (errors.empty()) return 1e9;
    std::vector<double> e = errors;
    std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
    return e[e.size() / 2];
  }
  void Print(const char* name, double ms_per_frame) const {
    std::printf(
        "[tracker] %s: %d frames, tracked %d, all corners <= 2 px in %.1f %%, median %.3f px, "
        "worst %.2f px, least NCC %.3f, %.2f ms CPU per frame\n",
        name, frames, tracked, 100.0 * Success(), Median(), worst, min_appearance, ms_per_frame);
  }
};

// Thread CPU time [ms]: the machine running the tests is shared, wall time would count other
// processes' turns. OpenCV runs on this one thread while a OneThread is alive.
double CpuMs() {
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
Score RunSingle(const cv::Mat& tex, int frames, const std::function<Corners(int)>& corners,
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

TEST(ObjectTracker, TexturedObjectZoomsHalfToTwiceAndRolls45Degrees) {
  const cv::Mat tex = Texture(3);
  // Depth 3 m -> 1.5 m (2x) -> 6 m (0.5x), roll 0 -> 45 deg, yaw up to 0.5 rad, drifting centre.
  const int n = 150;
  auto corners = [&](int k) {
    const double t = static_cast<double>(k) / (n - 1);
    const double z = t < 0.35 ? 3.0 - 1.5 * t / 0.35 : 1.5 + 4.5 * (t - 0.35) / 0.65;
    return Pose(0.6, 0.45, Vec3(0.15 * std::sin(6.0 * t) * z / 3.0, 0.05 * z, z),
                0.5 * std::sin(3.0 * t), 0.2 * t, 0.25 * M_PI * t);
  };
  double ms = 0.0;
  const Score s = RunSingle(tex, n, corners, 0, 0.0, &ms);
  s.Print("textured zoom 0.5-2x, roll 45 deg", ms);
  EXPECT_EQ(s.tracked, n - 1);
  EXPECT_GE(s.Success(), 0.95);
  EXPECT_LE(s.Median(), 0.5);
}

TEST(ObjectTracker, PlainRectangleIsCarriedByItsEdges) {
  const cv::Mat plain(8, 8, CV_8U, cv::Scalar(200));
  const int n = 80;
  auto corners = [&](int k) {
    const double t = static_cast<double>(k) / (n - 1);
    return Pose(0.5, 0.8, Vec3(-0.6 + 1.2 * t, 0.1 * std::sin(4 * t), 3.0 + 0.5 * t),
                0.3 * std::sin(2 * t), 0.0, 0.15 * t);
  };
  double ms = 0.0;
  std::vector<int> refined;
  const Score s = RunSingle(plain, n, corners, 0, 0.0, &ms, &refined);
  s.Print("plain rectangle moving", ms);
  EXPECT_EQ(s.tracked, n - 1);
  EXPECT_GE(s.Success(), 0.95);
  EXPECT_LE(s.Median(), 0.5);
  EXPECT_EQ(std::count(refined.begin(), refined.end(), 1), static_cast<long>(refined.size()));
}

TEST(ObjectTracker, MotionBlurredObjectIsStillTracked) {
  const cv::Mat tex = Texture(5);
  const int n = 40;
  // 8 px per frame to the right and a little down, blurred over 9 px along the motion.
  auto corners = [&](int k) {
    return Pose(0.6, 0.45, Vec3(-0.9 + 0.048 * k, -0.1 + 0.008 * k, 3.0), 0.2, 0.1, 0.1);
  };
  double ms = 0.0;
  const Score s = RunSingle(tex, n, corners, 9, std::atan2(0.008, 0.048), &ms);
  s.Print("motion blur 9 px, 8 px/frame", ms);
  EXPECT_EQ(s.tracked, s.frames);
  EXPECT_GE(s.Success(), 0.95);
  EXPECT_LE(s.Median(), 0.8);
}

// A poster with a thin dark frame (3.4 px) round its light margin, seen sharp at rest, then moved
// 20 px per frame with its image smeared over 13 px, then at rest again. Smeared, the frame's outer
// edge has its step at the smear's outer end, ~5 px outside, and the edge refinement pulls the
// sides there; the points then follow the edge-fixed homography and keep the error after the
// motion (no detector here to correct it). With blur_sharpness_ratio the tracker sees the sides go
// soft as they move across themselves and keeps the keypoint homography in those frames; the
// edges take over again once the object is sharp.
TEST(ObjectTracker, SmearedThinFrameDoesNotPullTheCornersOutwards) {
  cv::Mat tex = Texture(21);
  cv::rectangle(tex, cv::Rect(0, 0, tex.cols, tex.rows), cv::Scalar(20), 12);  // 6 texels inside
  const int n = 30;
  auto x_at = [](int k) { return -0.6 + 0.131 * std::clamp(k - 7, 0, 10); };  // 20 px per frame
  auto moving = [](int k) { return k >= 8 && k <= 17; };
  auto corners = [&](int k) { return Pose(0.6, 0.45, Vec3(x_at(k), 0.1, 3.0), 0.1, 0.05, 0.0); };
  const cv::Mat bg = Background();
  struct Run {
    int flagged = 0;
    std::vector<double> moving_err;  // worst corner per frame
    double after_max = 0.0;
  };
  auto run = [&](double ratio) {
    const OneThread one_thread;
    ObjectTracker::Options o;
    o.blur_sharpness_ratio = ratio;
    ObjectTracker tracker(Camera(), o);
    EXPECT_TRUE(tracker.Start(7, Render(bg, {{tex, corners(0)}}, 1), corners(0)));
    Run r;
    for (int k = 1; k < n; ++k) {
      const cv::Mat img = Render(bg, {{tex, corners(k)}}, 1 + k, moving(k) ? 13 : 0, 0.0);
      const TrackedObject* t = Find(tracker.Track(img), 7);
      EXPECT_TRUE(t && t->tracked) << "frame " << k;
      if (!t || !t->tracked) return r;
      double worst = 0.0;
      for (int j = 0; j < 4; ++j)
        worst = std::max(worst, (t->corners_undistorted[j] - corners(k)[j]).norm());
      if (moving(k)) r.moving_err.push_back(worst);
      if (k > 17) r.after_max = std::max(r.after_max, worst);
      r.flagged += t->blurred;
      EXPECT_TRUE(!t->blurred || moving(k)) << "frame " << k;
    }
    return r;
  };
  const Run off = run(0.0), on = run(0.5);
  ASSERT_EQ(on.moving_err.size(), 10u);
  ASSERT_EQ(off.moving_err.size(), 10u);
  std::printf(
      "smeared thin frame, worst corner error: moving median %.2f px, after %.2f px "
      "without the blur test; %.2f / %.2f px with it (%d of 10 moving frames blurred)\n",
      Median(off.moving_err), off.after_max, Median(on.moving_err), on.after_max, on.flagged);
  EXPECT_EQ(off.flagged, 0);
  EXPECT_GE(on.flagged, 8);
  EXPECT_LT(Median(on.moving_err), Median(off.moving_err));
  EXPECT_LE(on.after_max, 1.0);
  EXPECT_GT(off.after_max, 2.0);  // the failure the test guards against is real
}

// Object A leaves the view to the right and comes back; object B stays. A must be lost (no
// corners) before it is out of view; Similarity knows A from B; Resume picks A up again.
TEST(ObjectTracker, LostWhenLeavingTheViewThenReidentifiedAndResumed) {
  const cv::Mat bg = Background();
  const cv::Mat ta = Texture(11), tb = Texture(12);
  auto a_at = [&](int k) {  // out to the right by frame ~40, back from frame 60
    const double x = k < 50 ? 0.3 + 0.05 * k : 0.3 + 0.05 * (100 - k);
    return Pose(0.6, 0.45, Vec3(x, 0.2, 3.0), 0.1, 0.0, 0.05);
  };
  const Corners cb = Pose(0.5, 0.5, Vec3(-1.0, -0.4, 3.5), -0.3, 0.1, -0.1);
  ObjectTracker tracker(Camera());
  cv::Mat img = Render(bg, {{ta, a_at(0)}, {tb, cb}}, 1);
  ASSERT_TRUE(tracker.Start(1, img, a_at(0)));
  ASSERT_TRUE(tracker.Start(2, img, cb));
  int lost_at = -1, reported_outside = 0, partial = 0;
  for (int k = 1; k < 100; ++k) {
    img = Render(bg, {{ta, a_at(k)}, {tb, cb}}, 1 + k);
    const auto r = tracker.Track(img);
    const TrackedObject* b = Find(r, 2);
    ASSERT_TRUE(b && b->tracked) << "frame " << k;
    EXPECT_LT((b->corners_undistorted[0] - cb[0]).norm(), 1.0);
    const TrackedObject* a = Find(r, 1);
    if (a && a->tracked && Outside(a_at(k))) ++reported_outside;
    if (a && a->tracked && !FullyVisible(a_at(k))) {
      // Partly out of view: the corners inside the image are named and where they are.
      ++partial;
      const Corners truth = a_at(k);
      for (int j = 0; j < 4; ++j) {
        const Vec2& p = truth[j];
        EXPECT_EQ(a->seen[j], p.x() >= 0 && p.y() >= 0 && p.x() <= kW - 1 && p.y() <= kH - 1)
            << "frame " << k << " corner " << j + 1;
        if (a->seen[j]) {
          EXPECT_LT((a->corners_undistorted[j] - p).norm(), 1.0) << "frame " << k;
        }
      }
    }
    if (a && !a->tracked && lost_at < 0) lost_at = k;
    if (k > 60 && FullyVisible(a_at(k)) && lost_at > 0 && !a) {
      // Back in view: re-identify against both models, then resume.
      const double sim_a = tracker.Similarity(1, img, a_at(k)).value();
      const double sim_b = tracker.Similarity(2, img, a_at(k)).value();
      std::printf(
          "[tracker] leaving the view: lost at frame %d (A outside from frame %d); "
          "back at frame %d: similarity A %.3f, B %.3f\n",
          lost_at,
          [&] {
            for (int j = 0;; ++j)
              if (Outside(a_at(j))) return j;
          }(),
          k, sim_a, sim_b);
      EXPECT_GT(sim_a, 0.85);
      EXPECT_LT(sim_b, 0.5);
      ASSERT_TRUE(tracker.Resume(1, img, a_at(k)));
      EXPECT_EQ(tracker.ActiveIds(), std::vector<int>({1, 2}));
      // Tracked again for the rest of the sequence.
      for (int j = k + 1; j < std::min(k + 20, 100); ++j) {
        img = Render(bg, {{ta, a_at(j)}, {tb, cb}}, 1 + j);
        const auto r2 = tracker.Track(img);
        const TrackedObject* a2 = Find(r2, 1);
        ASSERT_TRUE(a2 && a2->tracked) << "frame " << j;
        for (int i = 0; i < 4; ++i)
          EXPECT_LT((a2->corners_undistorted[i] - a_at(j)[i]).norm(), 2.0) << "frame " << j;
      }
      break;
    }
    if (lost_at > 0 && k == lost_at) {
      EXPECT_EQ(tracker.DormantIds(), std::vector<int>({1}));
      EXPECT_EQ(tracker.ActiveIds(), std::vector<int>({2}));
    }
  }
  EXPECT_GT(lost_at, 0);
  EXPECT_EQ(reported_outside, 0);
  std::printf("[tracker] leaving the view: tracked partly out of view in %d frames\n", partial);
  EXPECT_GE(partial, 2);
  EXPECT_EQ(tracker.ActiveIds(), std::vector<int>({1, 2}));
}

// Re-acquisition where the caller predicts a dormant object (the map projected): a prediction a few
// pixels off is refined onto the object's edges, and the appearance tells it from another object's
// model predicted at the same place.
TEST(ObjectTracker, ReacquiredWherePredicted) {
  const cv::Mat bg = Background();
  const cv::Mat ta = Texture(11), tb = Texture(12);
  const Corners ca0 = Pose(0.6, 0.45, Vec3(0.3, 0.2, 3.0), 0.1, 0.0, 0.05);
  const Corners cb = Pose(0.5, 0.5, Vec3(-1.0, -0.4, 3.5), -0.3, 0.1, -0.1);
  const Corners ca = Pose(0.6, 0.45, Vec3(-0.2, 0.4, 2.6), 0.25, -0.1, 0.1);  // later, elsewhere
  ObjectTracker tracker(Camera());
  ASSERT_TRUE(tracker.Start(1, Render(bg, {{ta, ca0}, {tb, cb}}, 1), ca0));
  ASSERT_TRUE(tracker.Start(2, Render(bg, {{ta, ca0}, {tb, cb}}, 1), cb));
  const cv::Mat img = Render(bg, {{ta, ca}, {tb, cb}}, 2);
  Corners predicted = ca;
  for (Vec2& c : predicted) c += Vec2(3.0, -2.0);
  Corners found;
  double sim_a = -1.0, sim_b = -1.0;
  ASSERT_TRUE(tracker.Reacquire(1, img, predicted, &found, &sim_a));
  for (int i = 0; i < 4; ++i) EXPECT_LT((found[i] - ca[i]).norm(), 0.5) << "corner " << i;
  EXPECT_GT(sim_a, 0.9);
  Corners found_b;
  if (tracker.Reacquire(2, img, predicted, &found_b, &sim_b)) {
    EXPECT_LT(sim_b, 0.5);
  }
  std::printf(
      "[tracker] re-acquired 3.6 px off the prediction: similarity %.3f (other model %.3f)\n",
      sim_a, sim_b);
  EXPECT_FALSE(tracker.Reacquire(7, img, predicted, &found, &sim_a));  // unknown id
  Corners outside = ca;
  for (Vec2& c : outside) c += Vec2(-400.0, 0.0);
  EXPECT_FALSE(tracker.Reacquire(1, img, outside, &found, &sim_a));  // not in the image
}

// A textured and a plain object moving towards each other; in the last ~10 frames the plain one
// (drawn last) covers part of the textured one: its NCC falls (0.79 measured) but it stays tracked.
TEST(ObjectTracker, TwoObjectsKeepTheirIds) {
  const cv::Mat bg = Background();
  const cv::Mat ta = Texture(21);
  const cv::Mat plain(8, 8, CV_8U, cv::Scalar(210));
  const int n = 60;
  auto a_at = [&](int k) {
    return Pose(0.6, 0.45, Vec3(-0.7 + 0.01 * k, -0.3, 3.0 - 0.01 * k), 0.2, 0.0, 0.004 * k);
  };
  auto b_at = [&](int k) {
    return Pose(0.45, 0.9, Vec3(0.8 - 0.008 * k, 0.2, 3.5), -0.3, 0.0, -0.002 * k);
  };
  const OneThread one_thread;
  ObjectTracker tracker(Camera());
  cv::Mat img = Render(bg, {{ta, a_at(0)}, {plain, b_at(0)}}, 1);
  ASSERT_TRUE(tracker.Start(10, img, a_at(0)));
  ASSERT_TRUE(tracker.Start(20, img, b_at(0)));
  Score sa, sb;
  double total = 0.0;
  for (int k = 1; k < n; ++k) {
    img = Render(bg, {{ta, a_at(k)}, {plain, b_at(k)}}, 1 + k);
    const double t0 = CpuMs();
    const auto r = tracker.Track(img);
    total += CpuMs() - t0;
    ASSERT_EQ(r.size(), 2u);
    sa.Add(Find(r, 10), a_at(k));
    sb.Add(Find(r, 20), b_at(k));
  }
  sa.Print("two objects: textured (id 10)", total / (n - 1));
  sb.Print("two objects: plain (id 20)", total / (n - 1));
  std::printf("[tracker] two objects: %.2f ms CPU per object per frame\n", 0.5 * total / (n - 1));
  EXPECT_EQ(sa.tracked, n - 1);
  EXPECT_EQ(sb.tracked, n - 1);
  EXPECT_GE(sa.Success(), 0.95);
  EXPECT_GE(sb.Success(), 0.95);
  EXPECT_LE(sa.Median(), 0.5);
  EXPECT_LE(sb.Median(), 0.5);
}

// A sudden jump (170 px between two frames, against the constant-velocity prediction): the flow
// loses the points, the model's descriptors find the object again.
TEST(ObjectTracker, RecoversFromAJumpByDescriptorMatching) {
  const cv::Mat bg = Background();
  const cv::Mat tex = Texture(31);
  auto at = [&](int k) {
    const double x = -0.6 + 0.01 * k + (k >= 10 ? 1.0 : 0.0);
    return Pose(0.6, 0.45, Vec3(x, 0.0, 3.0), 0.1, 0.0, 0.0);
  };
  ObjectTracker tracker(Camera());
  cv::Mat img = Render(bg, {{tex, at(0)}}, 1);
  ASSERT_TRUE(tracker.Start(3, img, at(0)));
  bool recovered = false;
  for (int k = 1; k < 20; ++k) {
    img = Render(bg, {{tex, at(k)}}, 1 + k);
    const auto r = tracker.Track(img);
    const TrackedObject* t = Find(r, 3);
    ASSERT_TRUE(t && t->tracked) << "frame " << k;
    recovered |= t->recovered;
    for (int i = 0; i < 4; ++i)
      EXPECT_LT((t->corners_undistorted[i] - at(k)[i]).norm(), 2.0) << "frame " << k;
  }
  EXPECT_TRUE(recovered);
}

// The same jump with the caller's prediction (e.g. from the IMU), 1 px off: no recovery needed.
TEST(ObjectTracker, FollowsTheCallersPrediction) {
  const cv::Mat bg = Background();
  const cv::Mat tex = Texture(31);
  auto at = [&](int k) {
    const double x = -0.6 + 0.01 * k + (k >= 5 ? 1.0 : 0.0);
    return Pose(0.6, 0.45, Vec3(x, 0.0, 3.0), 0.1, 0.0, 0.0);
  };
  ObjectTracker tracker(Camera());
  cv::Mat img = Render(bg, {{tex, at(0)}}, 1);
  ASSERT_TRUE(tracker.Start(4, img, at(0)));
  for (int k = 1; k < 10; ++k) {
    img = Render(bg, {{tex, at(k)}}, 1 + k);
    Corners pred = at(k);
    for (Vec2& c : pred) c += Vec2(1.0, -0.7);
    const auto r = tracker.Track(img, {{4, pred}});
    const TrackedObject* t = Find(r, 4);
    ASSERT_TRUE(t && t->tracked) << "frame " << k;
    EXPECT_FALSE(t->recovered) << "frame " << k;
    for (int i = 0; i < 4; ++i)
      EXPECT_LT((t->corners_undistorted[i] - at(k)[i]).norm(), 1.0) << "frame " << k;
  }
}

TEST(ObjectTracker, RejectsBadStartsAndUnknownIds) {
  const cv::Mat img = Render(Background(), {}, 1);
  ObjectTracker tracker(Camera());
  const Corners tiny = Pose(0.02, 0.02, Vec3(0, 0, 3), 0, 0, 0);
  EXPECT_FALSE(tracker.Start(1, img, tiny));
  const Corners outside = Pose(0.6, 0.45, Vec3(2.0, 0, 3), 0, 0, 0);
  EXPECT_FALSE(tracker.Start(1, img, outside));
  EXPECT_TRUE(tracker.ActiveIds().empty());
  EXPECT_FALSE(tracker.Similarity(5, img, Pose(0.6, 0.45, Vec3(0, 0, 3), 0, 0, 0)).has_value());
  EXPECT_FALSE(tracker.Resume(5, img, Pose(0.6, 0.45, Vec3(0, 0, 3), 0, 0, 0)));
  EXPECT_TRUE(tracker.Track(img).empty());
  ObjectTrackerOptions bad;
  bad.lk_window = 4;
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW({ ObjectTracker t(Camera(), bad); }, fsp::InputError);
}

// The simulator's rendered room (lens distortion, rendered textures, camera motion), 3 s: every
// object is started (or resumed) on its ground truth when fully visible with sides >= 30 px and
// scored on the frames where it is fully visible; no corners may be reported for an object that is
// not in view at all.
TEST(ObjectTracker, RenderedRoom) {
  const auto dir = test::ScratchDir() / "tracker_seq";
  const std::string scene = std::string(FSP_SOURCE_DIR) + "/assets/scenes/default_room.yaml";
  const auto run =
      test::RunFsp("render " + scene + " --out " + dir.string() + " --duration 3 --no-video");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const Calibration calib = ReadCalibration((dir / "calib.yaml").string());
  std::map<int64_t, std::map<int, CornerRow>> gt;
  for (const CornerRow& r : ReadCornerRows((dir / "observations_gt.csv").string()))
    gt[r.t_ns][r.object_id] = r;
  std::ifstream list(dir / "mav0" / "cam0" / "data.csv");
  std::vector<std::pair<int64_t, std::string>> frames;
  for (std::string line; std::getline(list, line);) {
    if (line.empty() || line[0] == '#') continue;
    const size_t comma = line.find(',');
    frames.emplace_back(std::stoll(line.substr(0, comma)), line.substr(comma + 1));
  }
  ASSERT_GT(frames.size(), 50u);
  const OneThread one_thread;
  ObjectTracker tracker(calib.camera);
  Score s;
  int out_of_view_reports = 0, starts = 0, resumes = 0, object_frames = 0;
  double total = 0.0;
  for (const auto& [t_ns, name] : frames) {
    const cv::Mat img =
        cv::imread((dir / "mav0" / "cam0" / "data" / name).string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(img.empty()) << name;
    const auto& g = gt[t_ns];
    const double t0 = CpuMs();
    const auto r = tracker.Track(img);
    total += CpuMs() - t0;
    for (const TrackedObject& o : r) {
      ++object_frames;
      const auto it = g.find(o.id);
      if (it == g.end()) {
        out_of_view_reports += o.tracked;
        continue;
      }
      if (it->second.FullyVisible()) s.Add(&o, it->second.corners);
    }
    const std::vector<int> active = tracker.ActiveIds(), dormant = tracker.DormantIds();
    for (const auto& [id, row] : g) {
      if (!row.FullyVisible() || std::count(active.begin(), active.end(), id)) continue;
      double shortest = 1e9;
      for (int i = 0; i < 4; ++i)
        shortest = std::min(shortest, (row.corners[(i + 1) % 4] - row.corners[i]).norm());
      if (shortest < 30.0) continue;
      if (std::count(dormant.begin(), dormant.end(), id))
        resumes += tracker.Resume(id, img, row.corners);
      else
        starts += tracker.Start(id, img, row.corners);
    }
  }
  s.Print("rendered room 3 s", total / frames.size());
  std::printf(
      "[tracker] rendered room: %d starts, %d resumes, %d object-frames, %.2f ms CPU per "
      "object per frame, %d reports out of view\n",
      starts, resumes, object_frames, total / std::max(object_frames, 1), out_of_view_reports);
  EXPECT_GE(s.frames, 100);
  EXPECT_GE(s.Success(), 0.95);
  EXPECT_LE(s.Median(), 0.5);
  EXPECT_EQ(out_of_view_reports, 0);
}

}  // namespace
}  // namespace fsp::frontend
