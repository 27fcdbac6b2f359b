// Front-end tracking metrics (id map, success, boxes out of view, re-identification) and the
// geometric object matching on small hand-made cases with exact answers.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "fsp/eval/frontend_metrics.h"
#include "fsp/eval/object_metrics.h"

namespace fsp::eval {
namespace {

// A 10 px square with s1 (bottom-left) at (x, y), corners counter-clockwise on screen (v grows
// down).
CornerRow Square(int64_t t_ns, int id, double x, double y, bool fully_visible = true) {
  CornerRow r;
  r.t_ns = t_ns;
  r.object_id = id;
  r.corners = {Vec2(x, y), Vec2(x + 10, y), Vec2(x + 10, y - 10), Vec2(x, y - 10)};
  if (!fully_visible) r.visible = {false, false, false, false};
  return r;
}

std::vector<int64_t> FrameTimes(int n) {
  std::vector<int64_t> t;
  for (int k = 0; k < n; ++k) t.push_back(100 * k);
  return t;
}

// Ten frames (t = 100 k). Object 1 at (100, 100) in view in frames 0..5, object 2 at (300, 300) in
// all. The tracker: object 1 from frame 1 (confirmation takes a frame) as id 7, then id 8 from
// frame 4 (one switch); in frame 5 its s3 is 3 px off (matched, not a success); in frames 6 and 7
// id 8 is still reported although object 1 has left the view (two boxes out of view). Object 2 as
// id 9 in frames 0..8, missed in frame 9. And a spurious id 50 in frame 2.
void SwitchAndOutOfView(std::vector<CornerRow>* gt, std::vector<CornerRow>* est) {
  for (int k = 0; k < 10; ++k) {
    const int64_t t = 100 * k;
    if (k <= 5) gt->push_back(Square(t, 1, 100, 100));
    gt->push_back(Square(t, 2, 300, 300));
    if (k >= 1 && k <= 7) {
      CornerRow e = Square(t, k < 4 ? 7 : 8, 100, 100);
      if (k == 5) e.corners[2].x() += 3.0;
      est->push_back(e);
    }
    if (k <= 8) est->push_back(Square(t, 9, 300, 300));
    if (k == 2) est->push_back(Square(t, 50, 600, 600));
  }
}

TEST(TrackingMetrics, IdSwitchSuccessAndBoxesOutOfView) {
  std::vector<CornerRow> gt, est;
  SwitchAndOutOfView(&gt, &est);
  const FrontendMetrics m = EvaluateFrontend(gt, est, FrontendOptions{}, FrameTimes(10));
  EXPECT_EQ(m.frames, 10u);
  EXPECT_EQ(m.est_rows, 17u);
  EXPECT_EQ(m.matched, 14u);  // object 1 in frames 1..5, object 2 in frames 0..8
  EXPECT_DOUBLE_EQ(*m.recall, 14.0 / 16.0);
  EXPECT_EQ(m.unmatched_est_rows, 3u);  // two boxes out of view and the spurious one
  EXPECT_EQ(m.boxes_out_of_view, 2u);   // id 50 maps to nothing, so it is not one of them
  EXPECT_EQ(m.id_map, (std::map<int, int>{{7, 1}, {8, 1}, {9, 2}}));
  EXPECT_EQ(m.id_switches, 1);
  ASSERT_TRUE(m.id_switches_per_1000.has_value());
  EXPECT_DOUBLE_EQ(*m.id_switches_per_1000, 1000.0 / 14.0);
  // Object 1: fully visible rows from frame 1 (its first match): 5, of which frames 1..4 succeed.
  // Object 2: from frame 0: 10, of which 9 (frame 9 missed).
  EXPECT_EQ(m.success_total, 15u);
  EXPECT_EQ(m.success_frames, 13u);
  EXPECT_DOUBLE_EQ(*m.success_rate, 13.0 / 15.0);
  EXPECT_EQ(m.returns, 0u);
  EXPECT_FALSE(m.reid_rate.has_value());
  // A looser success threshold forgives the 3 px corner.
  FrontendOptions loose;
  loose.success_px = 3.0;
  EXPECT_EQ(EvaluateFrontend(gt, est, loose, FrameTimes(10)).success_frames, 14u);
  // Per object: object 1 matched in frames 1..5 by ids 7 and 8, its worst corner 3 px off in
  // frame 5 (median 0, p90 1.8 px by numpy's interpolation), 4 of 5 frames a success; object 2 by
  // id 9 in 9 of its 10 frames.
  ASSERT_EQ(m.per_object.size(), 2u);
  const ObjectTracking& o1 = m.per_object[0];
  EXPECT_EQ(o1.gt_id, 1);
  EXPECT_EQ(o1.matched, 5u);
  EXPECT_EQ(o1.est_ids, (std::vector<int>{7, 8}));
  EXPECT_DOUBLE_EQ(o1.worst_corner_median_px, 0.0);
  EXPECT_NEAR(o1.worst_corner_p90_px, 1.8, 1e-12);
  EXPECT_EQ(o1.success_frames, 4u);
  EXPECT_EQ(o1.success_total, 5u);
  const ObjectTracking& o2 = m.per_object[1];
  EXPECT_EQ(o2.gt_id, 2);
  EXPECT_EQ(o2.est_ids, (std::vector<int>{9}));
  EXPECT_EQ(o2.success_frames, 9u);
  EXPECT_EQ(o2.success_total, 10u);
  EXPECT_EQ(o1.success_frames + o2.success_frames, m.success_frames);
}

// Forty frames. Object 1 fully visible in 0..4, gone in 5..19, fully visible in 20..24, partly
// visible in 25..29, gone in 30..34, fully visible in 35..39: two absences of >= 10 frames without
// a fully visible row. The tracker: id 3 in 0..4; id 3 again in 21..24 (re-identified; frame 20
// missed); id 3 on the partly visible rows 25..27 (during the absence: ignored); id 4 in 35..39
// (not re-identified). Object 2, fully visible throughout as id 1, when WITH_SECOND.
void TwoReturns(bool with_second, std::vector<CornerRow>* gt, std::vector<CornerRow>* est) {
  for (int k = 0; k < 40; ++k) {
    const int64_t t = 100 * k;
    const bool full = k <= 4 || (k >= 20 && k <= 24) || k >= 35;
    if (full || (k >= 25 && k <= 29)) gt->push_back(Square(t, 1, 100, 100, full));
    if (k <= 4 || (k >= 21 && k <= 27)) est->push_back(Square(t, 3, 100, 100));
    if (k >= 35) est->push_back(Square(t, 4, 100, 100));
    if (with_second) {
      gt->push_back(Square(t, 2, 300, 300));
      est->push_back(Square(t, 1, 300, 300));
    }
  }
}

TEST(TrackingMetrics, OneReturnReidentifiedAndOneNot) {
  std::vector<CornerRow> gt, est;
  TwoReturns(true, &gt, &est);
  const FrontendMetrics m = EvaluateFrontend(gt, est, FrontendOptions{}, FrameTimes(40));
  EXPECT_EQ(m.returns, 2u);
  EXPECT_EQ(m.reidentified, 1u);
  ASSERT_TRUE(m.reid_rate.has_value());
  EXPECT_DOUBLE_EQ(*m.reid_rate, 0.5);
  EXPECT_EQ(m.id_switches, 1);  // 3 -> 4 on object 1
  EXPECT_EQ(m.id_map, (std::map<int, int>{{1, 2}, {3, 1}, {4, 1}}));
  EXPECT_EQ(m.boxes_out_of_view, 0u);  // ids 3 on 25..27: object 1 is partly in view there
  // Object 1: 15 fully visible rows, 14 matched exactly (frame 20 missed); object 2: 40 of 40.
  EXPECT_EQ(m.success_total, 55u);
  EXPECT_EQ(m.success_frames, 54u);
  // An 11-frame gap makes only the first absence (15 frames) count; the second has 10.
  FrontendOptions longer;
  longer.return_gap_frames = 11;
  const FrontendMetrics l = EvaluateFrontend(gt, est, longer, FrameTimes(40));
  EXPECT_EQ(l.returns, 1u);
  EXPECT_EQ(l.reidentified, 1u);
}

TEST(TrackingMetrics, AbsencesNeedTheSequenceFrames) {
  // Without object 2 no file has rows in frames 5..19 and 30..34: from the files alone the absences
  // are 0 and 5 frames long (no returns); the sequence's frame list shows them.
  std::vector<CornerRow> gt, est;
  TwoReturns(false, &gt, &est);
  const FrontendMetrics files_only = EvaluateFrontend(gt, est, FrontendOptions{});
  EXPECT_EQ(files_only.frames, 20u);
  EXPECT_EQ(files_only.returns, 0u);
  const FrontendMetrics with_frames = EvaluateFrontend(gt, est, FrontendOptions{}, FrameTimes(40));
  EXPECT_EQ(with_frames.frames, 40u);
  EXPECT_EQ(with_frames.returns, 2u);
  EXPECT_EQ(with_frames.reidentified, 1u);
  // A frame list stamped 0.4 ms off the ground truth: rows snap to it, no frame is doubled.
  std::vector<int64_t> shifted = FrameTimes(40);
  for (int64_t& t : shifted) t += 400'000;
  for (CornerRow& r : gt)
    r.t_ns *= 10'000;  // frames 1 ms apart, so the 0.4 ms offset is in tolerance
  for (CornerRow& r : est) r.t_ns *= 10'000;
  for (int64_t& t : shifted) t = (t - 400'000) * 10'000 + 400'000;
  const FrontendMetrics snapped = EvaluateFrontend(gt, est, FrontendOptions{}, shifted);
  EXPECT_EQ(snapped.frames, 40u);
  EXPECT_EQ(snapped.returns, 2u);
  EXPECT_EQ(snapped.matched, with_frames.matched);
}

TEST(TrackingMetrics, BoxOnAnAbsentObjectNeedsNoRowAtAll) {
  // Object 1 in frames 0..2; the tracker keeps id 5 on it through frame 4. Frame 3: object 1 partly
  // visible (a row exists): not out of view, although the box is off (unmatched); frame 4: no row.
  std::vector<CornerRow> gt = {Square(0, 1, 100, 100), Square(100, 1, 100, 100),
                               Square(200, 1, 100, 100), Square(300, 1, 95, 100, false)};
  std::vector<CornerRow> est = {Square(0, 5, 100, 100), Square(100, 5, 100, 100),
                                Square(200, 5, 100, 100), Square(300, 5, 140, 100),
                                Square(400, 5, 100, 100)};
  const FrontendMetrics m = EvaluateFrontend(gt, est, FrontendOptions{}, FrameTimes(5));
  EXPECT_EQ(m.matched, 3u);
  EXPECT_EQ(m.unmatched_est_rows, 2u);
  EXPECT_EQ(m.boxes_out_of_view, 1u);
  EXPECT_EQ(m.success_frames, 3u);
  EXPECT_EQ(m.success_total, 3u);
}

// Objects: a door and a window on the wall y = 0.
std::vector<ObjectRecord> GtObjects() {
  ObjectRecord door{
      1, "door", {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 0, 2), Vec3(0, 0, 2)}, 1.0, 2.0};
  ObjectRecord window{
      2, "window", {Vec3(2, 0, 1), Vec3(3, 0, 1), Vec3(3, 0, 2), Vec3(2, 0, 2)}, 1.0, 1.0};
  return {door, window};
}

TEST(ObjectMatching, PermutedIdsGiveTheSameErrors) {
  // The map: the door 0.05 m off at every corner (tracker id 2), the window exact (tracker id 1),
  // and an object far from both (id 7).
  std::vector<ObjectRecord> est = GtObjects();
  for (Vec3& c : est[0].corners_W) c += Vec3(0.03, 0.04, 0.0);
  est[0].id = 2;
  est[1].id = 1;
  est.push_back(
      {7, "poster", {Vec3(9, 0, 0), Vec3(10, 0, 0), Vec3(10, 0, 1), Vec3(9, 0, 1)}, 1.0, 1.0});
  const ObjectMetrics m = EvaluateObjects(GtObjects(), est, Alignment{});
  EXPECT_EQ(m.matched, 2u);
  ASSERT_EQ(m.per_object.size(), 2u);
  EXPECT_EQ(m.per_object[0].id, 1);
  EXPECT_EQ(m.per_object[0].est_id, 2);
  EXPECT_EQ(m.per_object[1].id, 2);
  EXPECT_EQ(m.per_object[1].est_id, 1);
  EXPECT_NEAR(m.per_object[0].corner_err_mean_m, 0.05, 1e-12);
  EXPECT_NEAR(m.per_object[1].corner_err_mean_m, 0.0, 1e-12);
  EXPECT_NEAR(m.corner_err.mean, 0.025, 1e-12);
  EXPECT_NEAR(m.corner_err.median, 0.025, 1e-12);
  EXPECT_EQ(m.corner_order_errors, 0u);
  // The same map with the ground truth's ids: identical errors.
  std::vector<ObjectRecord> same_ids = est;
  same_ids[0].id = 1;
  same_ids[1].id = 2;
  const ObjectMetrics s = EvaluateObjects(GtObjects(), same_ids, Alignment{});
  EXPECT_EQ(s.matched, m.matched);
  EXPECT_EQ(s.corner_err.mean, m.corner_err.mean);
  EXPECT_EQ(s.corner_err.median, m.corner_err.median);
  EXPECT_EQ(s.width_err.max, m.width_err.max);
}

TEST(ObjectMatching, CyclicShiftMatchesAndGateRejects) {
  // The window listed from s2 (an order error) and the door 0.6 m to the side.
  std::vector<ObjectRecord> est = GtObjects();
  std::rotate(est[1].corners_W.begin(), est[1].corners_W.begin() + 1, est[1].corners_W.end());
  for (Vec3& c : est[0].corners_W) c += Vec3(0.0, 0.6, 0.0);
  const ObjectMetrics m = EvaluateObjects(GtObjects(), est, Alignment{});
  ASSERT_EQ(m.matched, 1u);
  EXPECT_EQ(m.per_object[0].id, 2);
  EXPECT_EQ(m.per_object[0].corner_shift, 3);  // e_(j+3) mod 4 = g_j
  EXPECT_EQ(m.corner_order_errors, 1u);
  // Errors in the files' order: each corner sits on its neighbour, 1 m away.
  EXPECT_NEAR(m.corner_err.mean, 1.0, 1e-12);
  ObjectOptions wide;
  wide.match_gate_m = 0.7;
  const ObjectMetrics w = EvaluateObjects(GtObjects(), est, Alignment{}, wide);
  EXPECT_EQ(w.matched, 2u);
  EXPECT_NEAR(w.per_object[0].corner_err_mean_m, 0.6, 1e-12);
}

}  // namespace
}  // namespace fsp::eval
