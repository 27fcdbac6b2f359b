// Rectangle detector on real door photographs (../shared/data/doors_dev: 35 photos, one whole door
// each, hand-drawn loose boxes in YOLO format, no calibration). Scores overlap only: a door is
// found when the axis-aligned bounding box of a reported quadrilateral has IoU >= 0.6 with the
// labelled door box; every other reported rectangle counts as an extra. Prints a table per photo
// (found, IoU, extras, ms). With $FSP_DOORS_DRAW set to a folder, the drawn detections are written
// there.
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
#include "test_util.h"

namespace fsp::frontend {
namespace {

struct Box {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double Area() const { return std::max(0.0, x1 - x0) * std::max(0.0, y1 - y0); }
};

double Iou(const Box& a, const Box& b) {
  const Box i{std::max(a.x0, b.x0), std::max(a.y0, b.y0), std::min(a.x1, b.x1),
              std::min(a.y1, b.y1)};
  const double inter = i.Area();
  const double uni = a.Area() + b.Area() - inter;
  return uni > 0 ? inter / uni : 0.0;
}

Box BoxOf(const Corners& c) {
  Box b{c[0].x(), c[0].y(), c[0].x(), c[0].y()};
  for (const Vec2& p : c) {
    b.x0 = std::min(b.x0, p.x());
    b.y0 = std::min(b.y0, p.y());
    b.x1 = std::max(b.x1, p.x());
    b.y1 = std::max(b.y1, p.y());
  }
  return b;
}

// The door box (class 0) of a YOLO label file, in pixels of a W x H image.
bool ReadDoorBox(const std::string& path, int w, int h, Box* box) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream is(line);
    int cls = -1;
    double cx = 0, cy = 0, bw = 0, bh = 0;
    if (!(is >> cls >> cx >> cy >> bw >> bh) || cls != 0) continue;
    *box = Box{(cx - bw / 2) * w, (cy - bh / 2) * h, (cx + bw / 2) * w, (cy + bh / 2) * h};
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
  ASSERT_EQ(names.size(), 35u);
  const char* draw_env = std::getenv("FSP_DOORS_DRAW");
  const std::string draw = draw_env ? draw_env : "";
  const RectDetector det;
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
      best = std::max(best, Iou(BoxOf(d.corners_px), truth));
    const bool ok = best >= 0.6;
    const int n = static_cast<int>(res.detections.size());
    const int extra = n - (ok ? 1 : 0);
    found += ok;
    extras += extra;
    total_ms += res.times.Total();
    std::printf("%-22s %5s %5.2f %6d %6.1f %dx%d\n", name.c_str(), ok ? "yes" : "NO", best, extra,
                res.times.Total(), gray.cols, gray.rows);
    if (!draw.empty()) {
      cv::Mat img = DrawDetections(gray, res.detections);
      cv::rectangle(img, cv::Point2d(truth.x0, truth.y0), cv::Point2d(truth.x1, truth.y1),
                    cv::Scalar(255, 0, 255), std::max(1, gray.cols / 400));
      const double s = 800.0 / std::max(img.cols, img.rows);
      if (s < 1) cv::resize(img, img, cv::Size(), s, s, cv::INTER_AREA);
      cv::imwrite(draw + "/" + stem + ".jpg", img);
    }
  }
  std::printf("doors found %d/35, extras %d (%.2f per photo), mean %.1f ms\n", found, extras,
              extras / 35.0, total_ms / 35);
  EXPECT_GE(found, 2);
  EXPECT_LE(extras, 35);
}

}  // namespace
}  // namespace fsp::frontend
