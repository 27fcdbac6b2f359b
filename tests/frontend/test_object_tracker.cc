// ObjectTracker on synthetic sequences with exactly known corners (tracker_scenes.h): one object
// through zoom and roll, motion and blur; and the rendered room.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "fsp/common/calibration.h"
#include "fsp/common/median.h"
#include "fsp/common/observations_io.h"
#include "fsp/frontend/object_tracker.h"
#include "fsp/frontend/rect_detector.h"
#include "rendered_crops.h"
#include "test_util.h"
#include "tracker_scenes.h"

namespace fsp::frontend::tracker_test {
namespace {

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
      const std::vector<TrackedObject> res = tracker.Track(img);
      const TrackedObject* t = Find(res, 7);
      EXPECT_TRUE(t && t->tracked) << "frame " << k;
      if (!t || !t->tracked) return r;
      const double worst = MaxCornerDistance(t->corners_undistorted, corners(k));
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

// A textured poster seen sharp, then moving 16 px per frame while it approaches the camera (3 m ->
// 1.6 m over 20 frames), its image smeared over 13 px along the motion. The flow follows the
// smeared texture, which changes from frame to frame, and drifts; blur_align_* aligns the
// homography to the reference patch in the blurred frames and the points follow it. Without the
// alignment, blur_shape_from_prediction keeps the drift from the shape (the prediction is the
// constant-velocity one here, no caller's).
TEST(ObjectTracker, BlurredZoomDoesNotDrift) {
  const cv::Mat tex = Texture(17);
  const int n = 26;
  auto moving = [](int k) { return k >= 3 && k <= 22; };
  auto corners = [&](int k) {
    const double t = std::clamp(k - 2, 0, 20) / 20.0;
    const double z = 3.0 - 1.4 * t;
    return Pose(0.5, 0.6, Vec3((-0.5 + 0.9 * t) * z / 3.0, 0.05, z), 0.1, 0.05, 0.0);
  };
  const cv::Mat bg = Background();
  auto run = [&](double min_appearance, bool shape, int* aligned) {
    const OneThread one_thread;
    ObjectTracker::Options o;
    o.blur_align_min_appearance = min_appearance;
    o.blur_shape_from_prediction = shape;
    ObjectTracker tracker(Camera(), o);
    EXPECT_TRUE(tracker.Start(3, Render(bg, {{tex, corners(0)}}, 1), corners(0)));
    std::vector<double> err;  // worst corner per moving frame
    *aligned = 0;
    for (int k = 1; k < n; ++k) {
      const cv::Mat img = Render(bg, {{tex, corners(k)}}, 1 + k, moving(k) ? 13 : 0, 0.0);
      const std::vector<TrackedObject> res = tracker.Track(img);
      const TrackedObject* t = Find(res, 3);
      EXPECT_TRUE(t && t->tracked) << "frame " << k;
      if (!t || !t->tracked) return 1e9;
      const double worst = MaxCornerDistance(t->corners_undistorted, corners(k));
      if (moving(k)) err.push_back(worst);
      *aligned += t->aligned;
    }
    return *std::max_element(err.begin(), err.end());
  };
  int aligned_off = 0, aligned_on = 0, aligned_shape = 0;
  const double off = run(0.0, false, &aligned_off), on = run(0.85, true, &aligned_on),
               shape = run(0.0, true, &aligned_shape);
  std::printf(
      "blurred zoom, worst corner error while moving: %.2f px without the alignment, %.2f "
      "px with it (%d frames aligned), %.2f px with the prediction's shape alone\n",
      off, on, aligned_on, shape);
  EXPECT_EQ(aligned_off, 0);
  // Measured: 2.77 px without, 1.16 px with (20 of 20 moving frames aligned), 1.47 px with the
  // prediction's shape alone.
  EXPECT_GE(aligned_on, 15);
  EXPECT_LE(on, 1.6);
  EXPECT_LE(shape, 2.0);
  EXPECT_GT(off, 2.2);  // the drift the test guards against is real
}

// A fast pan: a textured poster seen still, then moving 45 px per frame for four frames, its image
// smeared over 22 px (half the frame interval's motion), then still again. The caller's prediction
// (a gyroscope's rotation) is 1 px off. The keypoints' flow cannot follow the first frame of the
// pan and the object is lost; fast_align_* finds it at the prediction by its reference smeared
// along the predicted motion, and its points follow from there.
TEST(ObjectTracker, FastPanFoundAtThePrediction) {
  const cv::Mat tex = Texture(23);
  auto fast = [](int k) { return k >= 4 && k <= 7; };
  auto corners = [](int k) {
    const double x = -0.6 + 0.225 * std::clamp(k - 3, 0, 4);
    return Pose(0.5, 0.6, Vec3(x, 0.05, 2.5), 0.15, 0.05, 0.0);
  };
  const cv::Mat bg = Background();
  struct Run {
    int tracked = 0, found_fast = 0;
    double worst = 0.0, worst_found_fast = 0.0;
  };
  auto run = [&](double min_motion_px) {
    const OneThread one_thread;
    ObjectTracker::Options o;
    o.fast_align_min_motion_px = min_motion_px;
    ObjectTracker tracker(Camera(), o);
    Run r;
    EXPECT_TRUE(tracker.Start(5, Render(bg, {{tex, corners(0)}}, 1), corners(0)));
    for (int k = 1; k < 11; ++k) {
      const cv::Mat img = Render(bg, {{tex, corners(k)}}, 1 + k, fast(k) ? 22 : 0, 0.0);
      Corners predicted = corners(k);
      for (Vec2& c : predicted) c += Vec2(0.8, -0.6);
      const std::vector<TrackedObject> res = tracker.Track(img, {{5, predicted}});
      const TrackedObject* t = Find(res, 5);
      if (!t || !t->tracked) continue;
      ++r.tracked;
      const double worst = MaxCornerDistance(t->corners_undistorted, corners(k));
      r.worst = std::max(r.worst, worst);
      if (t->fast) {
        ++r.found_fast;
        r.worst_found_fast = std::max(r.worst_found_fast, worst);
      }
    }
    return r;
  };
  const Run off = run(0.0), on = run(15.0);
  std::printf(
      "fast pan: tracked in %d of 10 frames without fast_align, %d with it (%d found by the "
      "smeared reference, worst corner there %.2f px, over all frames %.2f px)\n",
      off.tracked, on.tracked, on.found_fast, on.worst_found_fast, on.worst);
  // Measured: 3 of 10 (lost in the pan's first frame) without; 10 of 10 with, the first frame of
  // the pan found by the smeared reference 0.59 px off; the next three, held by the keypoints and
  // aligned to the sharp reference (blur_align_*), 2.3-2.9 px off in their 22 px smear.
  EXPECT_LE(off.tracked, 3);  // the loss the option guards against is real
  EXPECT_EQ(off.found_fast, 0);
  EXPECT_EQ(on.tracked, 10);
  EXPECT_GE(on.found_fast, 1);
  EXPECT_LE(on.worst_found_fast, 1.0);
  EXPECT_LE(on.worst, 3.5);
}

// A vertical dash: a textured poster seen at an angle, still, then moving up by 55 px per frame
// for five frames, its image smeared over 22 px, then still again; the caller's prediction (a
// gyroscope's) 1 px off. The flow on the smear skews the keypoint homography by ~10 px at a
// corner, too far for the alignment to the reference (blur_align_max_shift_px) to be kept;
// blur_shape_from_prediction keeps the prediction's shape, scaled and shifted onto the flow.
TEST(ObjectTracker, VerticalDashKeepsThePredictedShape) {
  const cv::Mat tex = Texture(29);
  auto fast = [](int k) { return k >= 4 && k <= 8; };
  auto corners = [](int k) {
    const double y = 0.6 - 55.0 / kF * 2.5 * std::clamp(k - 3, 0, 5);
    return Pose(0.5, 0.6, Vec3(0.1, y, 2.5), 0.35, 0.1, 0.05);
  };
  const cv::Mat bg = Background();
  struct Run {
    int tracked = 0;
    double worst = 0.0;  // worst corner error in the dash
  };
  auto run = [&](bool shape) {
    const OneThread one_thread;
    ObjectTracker::Options o;
    o.blur_shape_from_prediction = shape;
    ObjectTracker tracker(Camera(), o);
    Run r;
    EXPECT_TRUE(tracker.Start(5, Render(bg, {{tex, corners(0)}}, 1), corners(0)));
    for (int k = 1; k < 12; ++k) {
      const cv::Mat img = Render(bg, {{tex, corners(k)}}, 1 + k, fast(k) ? 22 : 0, -M_PI / 2);
      Corners predicted = corners(k);
      for (Vec2& c : predicted) c += Vec2(0.8, -0.6);
      const std::vector<TrackedObject> res = tracker.Track(img, {{5, predicted}});
      const TrackedObject* t = Find(res, 5);
      if (!t || !t->tracked) continue;
      ++r.tracked;
      if (fast(k))
        r.worst = std::max(r.worst, MaxCornerDistance(t->corners_undistorted, corners(k)));
    }
    return r;
  };
  const Run off = run(false), on = run(true);
  std::printf(
      "vertical dash, worst corner in the dash: %.2f px without the predicted shape, %.2f px "
      "with it (tracked in %d / %d of 11 frames)\n",
      off.worst, on.worst, off.tracked, on.tracked);
  // Measured: 10.36 px without, 2.06 px with; 11 of 11 frames tracked in both.
  EXPECT_EQ(on.tracked, 11);
  EXPECT_LE(on.worst, 2.5);
  EXPECT_GT(off.worst, 5.0);  // the skew the option guards against is real
}

// A poster started in a smeared view (12 px of diagonal motion blur: the detector's outline, the
// tracker's first view), then seen sharp, moving 1 px per frame. The side polarities learnt from
// the smear are not the sharp view's, so its edges are not fitted; RelearnOutline in the first
// sharp frame that the front end would confirm it in learns them again, and the edges carry the
// corners.
TEST(ObjectTracker, OutlineRelearntAfterASmearedStart) {
  const cv::Mat tex = Texture(31);
  auto corners = [](int k) {
    return Pose(0.5, 0.6, Vec3(-0.1 + 0.005 * k, 0.05, 2.5), 0.2, 0.1, 0.0);
  };
  const cv::Mat bg = Background();
  struct Run {
    int fitted = 0;  // frames after the relearning whose corners the edges fixed
    double worst = 0.0;
    bool relearnt = false;
  };
  auto run = [&](bool relearn) {
    const OneThread one_thread;
    ObjectTracker tracker(Camera());
    Run r;
    EXPECT_TRUE(tracker.Start(5, Render(bg, {{tex, corners(0)}}, 1, 12, M_PI / 4), corners(0)));
    for (int k = 1; k < 16; ++k) {
      const cv::Mat img = Render(bg, {{tex, corners(k)}}, 1 + k);
      const std::vector<TrackedObject> res = tracker.Track(img);
      const TrackedObject* t = Find(res, 5);
      EXPECT_TRUE(t && t->tracked) << "frame " << k;
      if (!t || !t->tracked) continue;
      if (k == 2 && relearn) r.relearnt = tracker.RelearnOutline(5, img, corners(k), 1.25);
      if (k <= 2) continue;
      r.fitted += t->edge_refined;
      r.worst = std::max(r.worst, MaxCornerDistance(t->corners_undistorted, corners(k)));
    }
    return r;
  };
  const Run off = run(false), on = run(true);
  std::printf(
      "smeared start: edges fitted in %d / %d of the 13 frames after, worst corner %.2f / %.2f px "
      "(without / with the relearning)\n",
      off.fitted, on.fitted, off.worst, on.worst);
  // Measured: fitted in 0 / 13 frames, worst corner 1.71 / 0.29 px.
  EXPECT_TRUE(on.relearnt);
  EXPECT_EQ(on.fitted, 13);
  EXPECT_LE(on.worst, 0.6);
  EXPECT_LT(off.fitted, 13);  // the failure the relearning guards against is real
  EXPECT_GT(off.worst, 1.0);
  // Started sharp: no view is clearly sharper, nothing is relearnt.
  ObjectTracker sharp(Camera());
  const cv::Mat img = Render(bg, {{tex, corners(0)}}, 1);
  ASSERT_TRUE(sharp.Start(6, img, corners(0)));
  EXPECT_FALSE(sharp.RelearnOutline(6, img, corners(0), 1.25));
  EXPECT_FALSE(sharp.RelearnOutline(7, img, corners(0), 1.25));  // unknown id
}

// Two crops (x 232-362, y 160-310) of `fsp render assets/scenes/clip_blur.yaml --seed 2`: frames
// 8.95 s (poster 4 as it comes to rest, 2 px from its place in the next frame; the front end starts
// its track here) and 9.25 s (still). Poster 4 is 43 px wide with a 1.2 px dark frame: refined with
// either polarity per side, its sides find edges of both and the fit is refused, so a track started
// without the detector's polarities never fits its edges and is carried by its keypoints with its
// first view's error.
TEST(ObjectTracker, StartTakesTheDetectorsPolaritiesOnAThinFrame) {
  const test::BlurPoster4Crops crops;
  const cv::Mat& first = crops.coming_to_rest.image;
  const cv::Mat& still = crops.still.image;
  ASSERT_FALSE(first.empty());
  ASSERT_FALSE(still.empty());
  const PinholeRadtan& cam = crops.camera;
  const Corners& gt_first = crops.coming_to_rest.gt;
  const Corners& gt_still = crops.still.gt;
  const Detection* det = nullptr;
  const std::vector<Detection> dets = RectDetector().Detect(first, &cam).detections;
  for (const Detection& d : dets)
    if (MaxCornerDistance(d.corners_undistorted, gt_first) < 2.0) det = &d;
  ASSERT_NE(det, nullptr);
  for (const int s : det->side_sign) EXPECT_NE(s, 0);
  auto run = [&](const std::array<int, 4>& hint) {
    const OneThread one_thread;
    ObjectTracker tracker(cam);
    EXPECT_TRUE(tracker.Start(4, first, det->corners_undistorted, hint));
    const std::vector<TrackedObject> res = tracker.Track(still);
    const TrackedObject* t = Find(res, 4);
    EXPECT_TRUE(t && t->tracked);
    return t && t->tracked ? std::make_pair(t->edge_refined,
                                            MaxCornerDistance(t->corners_undistorted, gt_still))
                           : std::make_pair(false, 1e9);
  };
  const auto [fitted_off, err_off] = run({0, 0, 0, 0});
  const auto [fitted_on, err_on] = run(det->side_sign);
  std::printf(
      "thin frame started in motion: detection %.2f px; still frame %s %.2f px without the "
      "detector's polarities, %s %.2f px with them\n",
      MaxCornerDistance(det->corners_undistorted, gt_first), fitted_off ? "fitted" : "not fitted",
      err_off, fitted_on ? "fitted" : "not fitted", err_on);
  // Measured: detection 0.66 px; not fitted, 0.95 px without; fitted, 0.57 px with (1.94, 1.79
  // and 1.32 px before the sides on the frame's outer edge moved to its centre,
  // rect.band_thin_inside_max_dip).
  EXPECT_FALSE(fitted_off);  // the failure the polarities guard against is real
  EXPECT_TRUE(fitted_on);
  EXPECT_LT(err_on, 0.8);
  EXPECT_LT(err_on, err_off);
}

// The FrontEnd's one pyramid per frame, built for the point tracker's window and levels too: the
// tracker's results are the same as on its own pyramid, to the bit.
// A glossy screen: a plain dark rectangle, still, with a textured reflection sliding across it
// (4 px per frame: more than the edges may correct a trusted keypoint homography in one frame). The
// keypoints are the reflection's, so their homography slides with it. With the outline check the
// screen's corners are reported only while its sides are on its edges, and the track is lost once
// they stay off; without it the reported quad slides with the reflection.
TEST(ObjectTracker, KeypointsSlidingWithAReflectionAreNotReported) {
  const cv::Mat bg = Background();
  const cv::Mat screen(8, 8, CV_8U, cv::Scalar(25));
  const cv::Mat reflection = Texture(5, 80, 60);
  const Corners screen_c = Pose(0.8, 0.5, Vec3(0.0, 0.0, 2.0), 0.2, 0.1, 0.05);
  auto reflection_at = [](int k) {  // image px: 80 x 60, from the screen's left part rightwards
    const double x0 = 245.0 + 4.0 * k, y0 = 210.0;
    return Corners{Vec2(x0, y0 + 60.0), Vec2(x0 + 80.0, y0 + 60.0), Vec2(x0 + 80.0, y0),
                   Vec2(x0, y0)};
  };
  struct Outcome {
    int reported = 0, lost_at = -1;
    double worst_reported_px = 0.0;
  };
  auto run = [&](int max_unsupported_frames) {
    const OneThread one_thread;
    ObjectTrackerOptions options;
    options.max_unsupported_frames = max_unsupported_frames;
    ObjectTracker tracker(Camera(), options);
    EXPECT_TRUE(tracker.Start(
        3, Render(bg, {{screen, screen_c}, {reflection, reflection_at(0)}}, 1), screen_c));
    Outcome out;
    for (int k = 1; k <= 20; ++k) {
      const auto r =
          tracker.Track(Render(bg, {{screen, screen_c}, {reflection, reflection_at(k)}}, 1 + k));
      const TrackedObject* t = Find(r, 3);
      if (!t || !t->tracked) {
        out.lost_at = k;
        break;
      }
      if (t->outline_off) continue;
      ++out.reported;
      for (int i = 0; i < 4; ++i)
        out.worst_reported_px =
            std::max(out.worst_reported_px, (t->corners_undistorted[i] - screen_c[i]).norm());
    }
    std::printf(
        "[tracker] reflection sliding 4 px/frame, outline check after %d frames: %d "
        "frames reported, worst corner %.2f px, lost at frame %d\n",
        max_unsupported_frames, out.reported, out.worst_reported_px, out.lost_at);
    return out;
  };
  const Outcome off = run(0);
  EXPECT_GT(off.worst_reported_px, 10.0) << "the scene no longer makes the keypoints slide";
  // Measured: without the check 14 frames reported, up to 48 px off, until the appearance check
  // loses it at frame 15; with it the first frame only (one side 4 px off, the other three on
  // their edges), lost at frame 10 (8 sharp frames with two sides off, one smeared frame).
  const Outcome on = run(ObjectTrackerOptions().max_unsupported_frames);
  EXPECT_LE(on.reported, 2);
  EXPECT_LE(on.worst_reported_px, 5.0);
  EXPECT_GT(on.lost_at, 0);
  EXPECT_LE(on.lost_at, 12);
}

TEST(ObjectTracker, SharedPyramidGivesTheSameResults) {
  const OneThread one_thread;
  const cv::Mat tex = Texture(3), bg = Background();
  const int n = 40;
  auto corners = [&](int k) {
    const double t = static_cast<double>(k) / (n - 1);
    return Pose(0.6, 0.45, Vec3(0.2 * std::sin(3.0 * t), 0.05, 3.0 - 1.2 * t), 0.3 * t, 0.1,
                0.3 * t);
  };
  ObjectTracker own(Camera()), shared(Camera());
  const cv::Mat f0 = Render(bg, {{tex, corners(0)}}, 1);
  ASSERT_TRUE(own.Start(7, f0, corners(0)));
  ASSERT_TRUE(shared.Start(7, f0, corners(0)));
  for (int k = 1; k < n; ++k) {
    const cv::Mat img = Render(bg, {{tex, corners(k)}}, 1 + k);
    const auto a = own.Track(img);
    const auto b = shared.Track(BuildFlowPyramid(img, 21, 5));
    ASSERT_EQ(a.size(), 1u);
    ASSERT_EQ(b.size(), 1u);
    EXPECT_EQ(a[0].tracked, b[0].tracked);
    EXPECT_EQ(a[0].keypoints, b[0].keypoints);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(a[0].corners_undistorted[i], b[0].corners_undistorted[i]);
    EXPECT_EQ(a[0].appearance, b[0].appearance);
  }
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
}  // namespace fsp::frontend::tracker_test
