// The rectangle detector on hand-labelled real frames (tests/frontend/data/dmvio_walk_labels.json:
// 32 frames of the DM-VIO room walk's first 60 s; how they were labelled: data/README.md), and
// the scoring itself (ReadFrameLabels, ScoreLabelledFrame) on labels made up here.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "fsp/common/calibration.h"
#include "fsp/common/error.h"
#include "fsp/frontend/detection_eval.h"
#include "fsp/frontend/image_io.h"
#include "fsp/frontend/rect_detector.h"
#include "test_util.h"

namespace fsp::frontend {
namespace {

const std::string kWalkLabels = std::string(FSP_FRONTEND_TEST_DATA) + "/dmvio_walk_labels.json";

Detection At(const Corners& c) {
  Detection d;
  d.corners_px = d.corners_undistorted = c;
  return d;
}

Corners Box(double x0, double y0, double x1, double y1) {
  return {Vec2(x0, y1), Vec2(x1, y1), Vec2(x1, y0), Vec2(x0, y0)};
}

// The project's label file: it parses, its frames lie in the walk's first 60 s, and each object id
// keeps one class in every frame (the tracker is scored on these ids).
TEST(RealLabels, WalkLabelFileIsConsistent) {
  const FrameLabels labels = ReadFrameLabels(kWalkLabels);
  EXPECT_EQ(labels.width, 1280);
  EXPECT_EQ(labels.height, 720);
  ASSERT_GE(labels.frames.size(), 30u);
  std::map<int, std::string> class_of;
  int full = 0;
  for (const LabelledFrame& f : labels.frames) {
    EXPECT_LT(f.t_ns, 1'650'458'776'850'000'000LL) << "beyond the walk's first 60 s";
    for (const LabelledObject& o : f.objects) {
      const auto [it, added] = class_of.emplace(o.id, o.label_class);
      EXPECT_EQ(it->second, o.label_class) << "id " << o.id << " changes class";
      if (o.state == LabelledObject::State::kFull) {
        ++full;
        for (const Vec2& c : o.corners) {
          EXPECT_TRUE(c.x() >= 0 && c.x() < 1280 && c.y() >= 0 && c.y() < 720)
              << "a full label's corner outside the image, id " << o.id;
        }
      }
    }
  }
  EXPECT_GE(full, 30);
}

TEST(RealLabels, MalformedLabelFilesAreRefusedWithTheEntry) {
  const std::filesystem::path dir = test::ScratchDir();
  const auto refused = [&](const std::string& text) {
    std::ofstream(dir / "l.json") << text;
    try {
      ReadFrameLabels((dir / "l.json").string());
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string head = R"({"image_size": [640, 480], "frames": [{"t_ns": 5, "objects": [)";
  EXPECT_NE(refused("{"), "");
  EXPECT_NE(refused(R"({"frames": []})").find("image_size"), std::string::npos);
  EXPECT_NE(refused(head + R"({"id": 1, "class": "door", "state": "whole",
                               "corners": [[0,0],[1,0],[1,1],[0,1]]}]}]})")
                .find("state"),
            std::string::npos);
  EXPECT_NE(refused(head + R"({"id": 1, "class": "door", "state": "cut",
                               "corners": [[0,0],[1,0],[1,1],[0,1]]}]}]})")
                .find("visible"),
            std::string::npos);
  EXPECT_NE(refused(head + R"({"id": 1, "class": "door", "state": "full",
                               "corners": [[0,0],[1,0],[1,1]]}]}]})")
                .find("frames[0].objects[0]"),
            std::string::npos);
  EXPECT_EQ(refused(head + R"({"id": 1, "class": "door", "state": "full",
                               "corners": [[0,0],[1,0],[1,1],[0,1]]}]}]})"),
            "");
}

// A detection on a full label is a hit with its corner error (best cyclic shift); on the in-image
// part of a cut label a hit on the cut one; on an ignored label it is not counted at all; elsewhere
// it is a false positive. Full labels under 30 px are not counted for recall.
TEST(RealLabels, ScoreCountsHitsMissesAndIgnoredRegions) {
  LabelledFrame frame;
  frame.objects.push_back({1, "door", LabelledObject::State::kFull, Box(100, 100, 200, 300)});
  frame.objects.push_back({2, "screen", LabelledObject::State::kCut, Box(500, 100, 700, 200)});
  frame.objects.back().visible = {true, false, false, true};
  frame.objects.push_back({3, "cabinet", LabelledObject::State::kIgnore, Box(300, 300, 400, 400)});
  frame.objects.push_back({4, "plate", LabelledObject::State::kFull, Box(50, 50, 70, 70)});
  frame.objects.push_back({5, "plate", LabelledObject::State::kFull, Box(450, 400, 500, 450)});
  Corners door = Box(101, 100, 200, 302);
  std::rotate(door.begin(), door.begin() + 1, door.end());  // its s1 is the label's s2
  const std::vector<Detection> dets = {At(door), At(Box(500, 100, 639, 200)),
                                       At(Box(305, 300, 400, 400)), At(Box(10, 400, 60, 470))};
  const LabelScore s = ScoreLabelledFrame(dets, frame, 640, 480);
  EXPECT_EQ(s.detections, 3);  // the one on the ignored cabinet left out
  EXPECT_EQ(s.true_positives, 2);
  EXPECT_EQ(s.per_class.at("door").full, 1);
  EXPECT_EQ(s.per_class.at("door").found, 1);
  ASSERT_EQ(s.per_class.at("door").corner_err_px.size(), 4u);
  EXPECT_NEAR(s.per_class.at("door").corner_err_px[0], std::hypot(1.0, 2.0), 1e-9);
  EXPECT_EQ(s.per_class.at("screen").cut, 1);
  EXPECT_EQ(s.per_class.at("screen").cut_found, 1);
  EXPECT_EQ(s.per_class.at("plate").full, 1);  // the 20 px one not counted
  EXPECT_EQ(s.per_class.at("plate").found, 0);
  EXPECT_EQ(s.per_class.count("cabinet"), 0u);
  EXPECT_NEAR(s.Recall(), 0.5, 1e-12);
  EXPECT_NEAR(s.Precision(), 2.0 / 3.0, 1e-12);
}

// The detector with the walk's camera on the 32 labelled frames, as `fsp detect IMAGES --calib
// cam0/camera.txt --labels tests/frontend/data/dmvio_walk_labels.json [--config C]`, with its
// defaults (the corner error in the rectangle test and the sizes in pixels:
// RectDetectorOptions::rectangle_corner_px 0.5, min_side_px 32) and with both off (the plain
// test). Measured, defaults: 14 of 31 full rectangles (45 %: screens 5 / 11, monitor id 12 in 5 of
// its 6 frames, id 13 none; the sheet of paper 4 / 5, switch and socket plates 5 / 12, the box
// 0 / 3), 16 detections, 15 on labelled objects (94 %). Both off: 5 of 31 (16 %: monitor id 12's
// screen), precision 100 %. The targets of the detector on real video (recall 85 %, precision
// 90 %) are still far: this pins today's figures against regressions.
TEST(RealLabels, DetectorOnTheWalksLabelledFrames) {
  FSP_REQUIRE_DMVIO_WALK(walk);
  const FrameLabels labels = ReadFrameLabels(kWalkLabels);
  const PinholeRadtan camera = ReadDsoCamera(walk + "/cam0/camera.txt");
  RectDetectorOptions plain;
  plain.rectangle_corner_px = 0.0;
  plain.min_side_px = 0.0;
  for (const bool defaults : {true, false}) {
    RectDetector detector(defaults ? RectDetectorOptions() : plain);
    LabelScore score;
    for (const LabelledFrame& f : labels.frames) {
      const cv::Mat gray = ReadGray8(walk + "/cam0/images/" + std::to_string(f.t_ns) + ".jpg");
      score.Merge(
          ScoreLabelledFrame(detector.Detect(gray, &camera).detections, f, gray.cols, gray.rows));
    }
    std::printf("%s:\n", defaults ? "defaults" : "rectangle_corner_px 0, min_side_px 0");
    for (const auto& [name, c] : score.per_class)
      std::printf("%-8s full %2d found %2d  cut %2d found %2d\n", name.c_str(), c.full, c.found,
                  c.cut, c.cut_found);
    std::printf("recall %.3f, precision %.3f over %d detections\n", score.Recall(),
                score.Precision(), score.detections);
    EXPECT_GE(score.Recall(), defaults ? 0.45 : 0.16);
    EXPECT_GE(score.Precision(), defaults ? 0.93 : 0.9);
  }
}

}  // namespace
}  // namespace fsp::frontend
