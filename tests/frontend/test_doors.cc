// Rectangle detector on real door photographs ($FSP_TEST_DATA/doors_dev: 35 photos, one whole door
// each, hand-drawn loose boxes in YOLO format, no calibration). Scores overlap only: a door is
// found when the axis-aligned bounding box of a reported quadrilateral has IoU >= 0.6 with the
// labelled door box; every other reported rectangle counts as an extra. Prints a table per photo
// (found, IoU, extras, ms). With $FSP_DOORS_DRAW set to a folder, the drawn detections are written
// there (PNG).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fsp/frontend/draw.h"
#include "fsp/frontend/image_io.h"
#include "fsp/frontend/rect_detector.h"
#include "fsp/frontend/rect_geometry.h"
#include "test_util.h"

namespace fsp::frontend {
namespace {

using Box = Eigen::AlignedBox2d;

// The door box (class 0) of a YOLO label file, in pixels of a W x H image.
bool ReadDoorBox(const std::string& path, int w, int h, Box* box) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream is(line);
    int cls = -1;
    double cx = 0, cy = 0, bw = 0, bh = 0;
    if (!(is >> cls >> cx >> cy >> bw >> bh) || cls != 0) continue;
    *box =
        Box(Vec2((cx - bw / 2) * w, (cy - bh / 2) * h), Vec2((cx + bw / 2) * w, (cy + bh / 2) * h));
    return true;
  }
  return false;
}

TEST(RealPhotos, DoorsDevSet) {
  FSP_REQUIRE_TEST_DATA(dir, "doors_dev");
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir + "/images"))
    names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  // $FSP_DOORS_ANY: score another folder of the same layout ($FSP_TEST_DATA/doors_dev/images and
  // labels/, YOLO boxes) without the set's size check.
  if (!std::getenv("FSP_DOORS_ANY")) {
    ASSERT_EQ(names.size(), 35u);
  }
  const char* draw_env = std::getenv("FSP_DOORS_DRAW");
  const std::string draw = draw_env ? draw_env : "";
  RectDetector::Options opt;
  // Experiments: $FSP_DOORS_OPTS = "name=value,..." for a few options.
  if (const char* env = std::getenv("FSP_DOORS_OPTS")) {
    std::istringstream is(env);
    std::string kv;
    while (std::getline(is, kv, ',')) {
      const auto eq = kv.find('=');
      const std::string k = kv.substr(0, eq);
      const double v = std::stod(kv.substr(eq + 1));
      if (k == "merge_line_px") opt.merge_line_px = v;
      if (k == "merge_angle_deg") opt.merge_angle_deg = v;
      if (k == "merge_gap_frac") opt.merge_gap_frac = v;
      if (k == "junction_gap_frac") opt.junction_gap_frac = v;
      if (k == "junction_overshoot_frac") opt.junction_overshoot_frac = v;
      if (k == "min_side_support") opt.min_side_support = v;
      if (k == "max_side_continuation") opt.max_side_continuation = v;
      if (k == "min_corner_reach") opt.min_corner_reach = v;
      if (k == "canny_noise_multiple") opt.canny_noise_multiple = v;
      if (k == "min_edge_contrast") opt.min_edge_contrast = v;
      if (k == "max_abs_cos") opt.max_abs_cos = v;
      if (k == "detect_long_side") opt.detect_long_side = static_cast<int>(v);
      if (k == "nest_score_margin") opt.nest_score_margin = v;
      if (k == "drop_contained") opt.drop_contained = v != 0;
      if (k == "segment_fit_px") opt.segment_fit_px = v;
      if (k == "min_side_frac") opt.min_side_frac = v;
      if (k == "search_px") opt.search_px = v;
      if (k == "reach_frac") opt.reach_frac = v;
      if (k == "reach_failures") opt.uncalibrated_reach_failures_allowed = static_cast<int>(v);
      if (k == "door_reach_failures")
        opt.uncalibrated_door_reach_failures_allowed = static_cast<int>(v);
      if (k == "prefer_door_leaf") opt.uncalibrated_prefer_door_leaf = v != 0;
      if (k == "door_leaf_min_area_frac") opt.door_leaf_min_area_frac = v;
      if (k == "door_rule_max_overlap") opt.door_rule_max_overlap = v;
      if (k == "door_hypotheses") opt.door_hypotheses = v != 0;
      if (k == "door_max_tilt_deg") opt.door_max_tilt_deg = v;
      if (k == "door_min_height_frac") opt.door_min_height_frac = v;
      if (k == "door_jamb_gap_frac") opt.door_jamb_gap_frac = v;
      if (k == "door_bottom_max_deg") opt.door_bottom_max_deg = v;
      if (k == "door_min_aspect") opt.door_min_aspect = v;
      if (k == "door_max_aspect") opt.door_max_aspect = v;
      if (k == "reach_min_px") opt.reach_min_px = v;
      if (k == "reach_start_px") opt.reach_start_px = v;
      if (k == "ransac_inlier_px") opt.ransac_inlier_px = v;
      if (k == "container_outside_frac") opt.uncalibrated_container_outside_frac = v;
    }
  }
  const RectDetector det(opt);
  if (std::getenv("FSP_DOORS_OPTS"))
    for (const char* other : {"sudoku.png", "building.jpg"}) {
      const std::string path = ::fsp::test::TestDataDir() + "/opencv_samples/" + other;
      std::printf("%s: %zu detections\n", other, det.Detect(ReadGray8(path)).detections.size());
    }
  int found = 0, extras = 0;
  double total_ms = 0;
  std::printf("%-22s %5s %5s %6s %6s %6s\n", "photo", "found", "IoU", "extras", "ms", "size");
  for (const std::string& name : names) {
    const cv::Mat gray = ReadGray8(dir + "/images/" + name);
    Box truth;
    const std::string stem = std::filesystem::path(name).stem().string();
    ASSERT_TRUE(ReadDoorBox(dir + "/labels/" + stem + ".txt", gray.cols, gray.rows, &truth))
        << name;
    const auto res = det.Detect(gray);
    double best = 0;
    for (const Detection& d : res.detections)
      best = std::max(best, BoxIou(BoundingBox(d.corners_px), truth));
    const bool ok = best >= 0.6;
    const int n = static_cast<int>(res.detections.size());
    const int extra = n - (ok ? 1 : 0);
    found += ok;
    extras += extra;
    total_ms += res.times.Total();
    std::printf("%-22s %5s %5.2f %6d %6.1f %dx%d\n", name.c_str(), ok ? "yes" : "NO", best, extra,
                res.times.Total(), gray.cols, gray.rows);
    if (std::getenv("FSP_DOORS_TIMES")) std::printf("    %s\n", res.times.ToString().c_str());
    if (!draw.empty() && std::getenv("FSP_DOORS_DEBUG")) {
      // The detection level's pipeline with its debug output: segments (blue), hypotheses (orange),
      // quads that passed verification (green), detections (red).
      RectDetector::Options dbg_o = opt;
      dbg_o.debug = true;
      dbg_o.detect_long_side = 0;
      cv::Mat level;
      const int k = std::max(1, std::max(gray.cols, gray.rows) / std::max(1, opt.detect_long_side));
      cv::resize(gray, level, cv::Size(gray.cols / k, gray.rows / k), 0, 0, cv::INTER_AREA);
      const auto dr = RectDetector(dbg_o).Detect(level);
      cv::Mat img;
      cv::cvtColor(level, img, cv::COLOR_GRAY2BGR);
      for (const auto& [a, b] : dr.segment_ends)
        cv::line(img, cv::Point2d(a.x(), a.y()), cv::Point2d(b.x(), b.y()), cv::Scalar(255, 0, 0));
      for (const Corners& c : dr.hypothesis_quads)
        for (int i = 0; i < 4; ++i)
          cv::line(img, cv::Point2d(c[i].x(), c[i].y()),
                   cv::Point2d(c[(i + 1) % 4].x(), c[(i + 1) % 4].y()), cv::Scalar(0, 200, 255));
      for (const auto& [c, sc] : dr.verified_quads)
        for (int i = 0; i < 4; ++i)
          cv::line(img, cv::Point2d(c[i].x(), c[i].y()),
                   cv::Point2d(c[(i + 1) % 4].x(), c[(i + 1) % 4].y()), cv::Scalar(0, 255, 0));
      for (const Detection& d : dr.detections)
        for (int i = 0; i < 4; ++i)
          cv::line(img, cv::Point2d(d.corners_px[i].x(), d.corners_px[i].y()),
                   cv::Point2d(d.corners_px[(i + 1) % 4].x(), d.corners_px[(i + 1) % 4].y()),
                   cv::Scalar(0, 0, 255), 2);
      std::printf("    level: %d segments, %d hypotheses, %d refined, %zu verified\n", dr.segments,
                  dr.hypotheses, dr.refined, dr.verified_quads.size());
      cv::imwrite(draw + "/" + stem + "_debug.png", img);
    }
    if (!draw.empty()) {
      cv::Mat img = DrawDetections(gray, res.detections);
      cv::rectangle(img, cv::Point2d(truth.min().x(), truth.min().y()),
                    cv::Point2d(truth.max().x(), truth.max().y()), cv::Scalar(255, 0, 255),
                    std::max(1, gray.cols / 400));
      const double s = 800.0 / std::max(img.cols, img.rows);
      if (s < 1) cv::resize(img, img, cv::Size(), s, s, cv::INTER_AREA);
      cv::imwrite(draw + "/" + stem + ".png", img);
    }
  }
  const double n_photos = static_cast<double>(names.size());
  std::printf("doors found %d/%zu, extras %d (%.2f per photo), mean %.1f ms\n", found, names.size(),
              extras, extras / n_photos, total_ms / n_photos);
  // The target, >= 90 % (32 / 35); reached with door_min_aspect 1.25 (31 with 1.6, 30
  // before lintels broken by an occluder were bridged).
  EXPECT_GE(found, 32);
  EXPECT_LE(extras, static_cast<int>(names.size()));  // at most one other rectangle per photo
}

}  // namespace
}  // namespace fsp::frontend
