// ObjectTracker's lifecycle on synthetic sequences (tracker_scenes.h): an object leaving the view
// and coming back, re-acquisition where predicted, two objects keeping their ids, recovery from a
// jump, the caller's prediction, bad starts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "fsp/common/error.h"
#include "fsp/frontend/object_tracker.h"
#include "tracker_scenes.h"

namespace fsp::frontend::tracker_test {
namespace {

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

// Re-acquisition in a fast move: the object comes back into view while it moves 45 px per frame,
// smeared over 22 px. Its edges are smeared too; with the predicted motion the tracker looks for it
// by its reference smeared along that motion (fast_align_*), a prediction 1 px off is put within a
// pixel of the smear's centre, and another object's model does not match there.
TEST(ObjectTracker, ReacquiredInAFastMove) {
  const cv::Mat bg = Background();
  const cv::Mat ta = Texture(31), tb = Texture(32);
  const Corners ca0 = Pose(0.5, 0.6, Vec3(0.1, 0.05, 2.5), 0.15, 0.05, 0.0);
  const Corners cb = Pose(0.5, 0.5, Vec3(-1.0, -0.4, 3.5), -0.3, 0.1, -0.1);
  ObjectTracker tracker(Camera());
  ASSERT_TRUE(tracker.Start(1, Render(bg, {{ta, ca0}, {tb, cb}}, 1), ca0));
  ASSERT_TRUE(tracker.Start(2, Render(bg, {{ta, ca0}, {tb, cb}}, 1), cb));
  const Corners ca = Pose(0.5, 0.6, Vec3(-0.4, 0.05, 2.5), 0.15, 0.05, 0.0);
  const cv::Mat img = Render(bg, {{ta, ca}}, 2, 22, 0.0);
  Corners predicted = ca, motion;
  for (Vec2& c : predicted) c += Vec2(0.8, -0.6);
  for (Vec2& m : motion) m = Vec2(45.0, 0.0);
  Corners found;
  double sim = -1.0, sim_b = -1.0;
  bool smeared = false;
  ASSERT_TRUE(tracker.Reacquire(1, img, predicted, &found, &sim, &motion, &smeared));
  EXPECT_TRUE(smeared);
  double worst = 0.0;
  for (int i = 0; i < 4; ++i) worst = std::max(worst, (found[i] - ca[i]).norm());
  EXPECT_LT(worst, 1.0);
  EXPECT_GE(sim, 0.9);
  bool smeared_b = false;
  Corners found_b;
  if (tracker.Reacquire(2, img, predicted, &found_b, &sim_b, &motion, &smeared_b)) {
    EXPECT_FALSE(smeared_b);
  }
  std::printf(
      "[tracker] re-acquired in a 22 px smear: worst corner %.2f px, smeared reference NCC %.3f "
      "(other model: %s)\n",
      worst, sim, smeared_b ? "found smeared" : "not found smeared");
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

}  // namespace
}  // namespace fsp::frontend::tracker_test
