// AprilTag front end: the reference corners of the apriltag repository's own regression photos, and
// a synthetic upright tag that pins the s1..s4 order and the 0.5 px offset.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag.h>
#include <tag36h11.h>
}

#include "fsp/common/error.h"
#include "fsp/frontend/apriltag_detector.h"
#include "fsp/frontend/image_io.h"
#include "fsp/frontend/rect_geometry.h"
#include "synthetic.h"
#include "test_util.h"

namespace fsp::frontend {
namespace {

// Reference lines: "id, (x0 y0), (x1 y1), (x2 y2), (x3 y3)" = det->p[0..3] in libapriltag's pixel
// convention (pixel centre at +0.5), see the data folder's README.txt.
struct RefTag {
  int id;
  Corners p;
};
std::vector<RefTag> ReadReference(const std::string& path) {
  std::ifstream in(path);
  std::vector<RefTag> out;
  std::string line;
  const std::regex re(
      R"(\s*(\d+)\s*,\s*\(([-\d.]+)\s+([-\d.]+)\)\s*,\s*\(([-\d.]+)\s+([-\d.]+)\)\s*,\s*\(([-\d.]+)\s+([-\d.]+)\)\s*,\s*\(([-\d.]+)\s+([-\d.]+)\)\s*)");
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_match(line, m, re)) continue;
    RefTag t;
    t.id = std::stoi(m[1]);
    for (int i = 0; i < 4; ++i) t.p[i] = Vec2(std::stod(m[2 + 2 * i]), std::stod(m[3 + 2 * i]));
    out.push_back(t);
  }
  return out;
}

TEST(AprilTag, UmichPhotosMatchTheReferenceCorners) {
  FSP_REQUIRE_TEST_DATA(dir, "apriltag_umich_test");
  // The reference's settings (upstream test/test_detection.c): tag36h11, decimate 1, no edge
  // refinement.
  AprilTagDetector::Options o;
  o.decimate = 1.0;
  o.refine_edges = false;
  AprilTagDetector det(o);
  const char* names[] = {"33369213973_9d9bb4cc96_c", "34085369442_304b6bafd9_c",
                         "34139872896_defdb2f8d9_c"};
  int total = 0;
  double worst = 0.0;
  for (const char* name : names) {
    const auto ref = ReadReference(dir + "/" + name + ".expected.txt");
    ASSERT_FALSE(ref.empty()) << name;
    const auto res = det.Detect(ReadGray8(dir + "/" + name + ".jpg"));
    EXPECT_EQ(res.detections.size(), ref.size()) << name;
    total += static_cast<int>(res.detections.size());
    for (const auto& r : ref) {
      // Our corners have the 0.5 px offset removed: add it back to compare. Same order, no shift.
      double best = 1e9;
      for (const auto& d : res.detections) {
        if (d.tag_id != r.id) continue;
        double e = 0.0;
        for (int i = 0; i < 4; ++i)
          e = std::max(e, (d.corners_px[i] + Vec2(0.5, 0.5) - r.p[i]).norm());
        best = std::min(best, e);
      }
      // 0.2 px: the reference decoded the JPEGs with apriltag's own decoder (README.txt: up to 0.14
      // px).
      EXPECT_LE(best, 0.2) << name << " tag at " << r.p[0].transpose();
      worst = std::max(worst, best);
    }
  }
  EXPECT_EQ(total, 47);
  std::printf("apriltag umich: %d tags, worst corner distance to reference %.3f px\n", total,
              worst);
}

// Renders tag36h11 id `id` (libapriltag's own pattern) upright under a mild perspective and returns
// the image and the corners of the black border square in s1..s4 order, OpenCV pixel convention.
cv::Mat RenderTag(int id, const std::array<Vec2, 4>& pattern_corners_px, Corners* tag_corners) {
  apriltag_family_t* tf = tag36h11_create();
  image_u8_t* pat = apriltag_to_image(tf, id);
  const int n = pat->width;  // total_width cells (10 for tag36h11), border square spans [b, n - b]
  const int b = (n - tf->width_at_border) / 2;
  // Homography from pattern coordinates (cell edges, x right, y down, [0, n]) to image pixels.
  const std::vector<cv::Point2f> src = {{0.f, static_cast<float>(n)},
                                        {static_cast<float>(n), static_cast<float>(n)},
                                        {static_cast<float>(n), 0.f},
                                        {0.f, 0.f}};
  std::vector<cv::Point2f> dst;
  for (const auto& c : pattern_corners_px)
    dst.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
  const cv::Mat H = cv::getPerspectiveTransform(src, dst);
  auto map = [&](double x, double y) {
    const cv::Mat p = H * (cv::Mat_<double>(3, 1) << x, y, 1.0);
    return Vec2(p.at<double>(0) / p.at<double>(2), p.at<double>(1) / p.at<double>(2));
  };
  std::vector<test::SyntheticRect> cells;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      test::SyntheticRect r;
      r.corners = {map(x, y + 1), map(x + 1, y + 1), map(x + 1, y), map(x, y)};
      r.grey = pat->buf[y * pat->stride + x] ? 235 : 20;
      cells.push_back(r);
    }
  *tag_corners = {map(b, n - b), map(n - b, n - b), map(n - b, b), map(b, b)};
  // image_u8_destroy is not exported by the Debian libapriltag; the image is a calloc'd struct +
  // buffer.
  free(pat->buf);
  free(pat);
  tag36h11_destroy(tf);
  return test::RenderQuads(640, 480, cells, 0.6, 1.0, 3, 120);
}

TEST(AprilTag, UprightTagCornersAreS1ToS4WithoutTheHalfPixelOffset) {
  Corners truth;
  const cv::Mat img = RenderTag(
      5, {Vec2(212.3, 371.8), Vec2(431.6, 362.2), Vec2(418.9, 141.4), Vec2(221.7, 120.5)}, &truth);
  AprilTagDetector::Options o;
  o.decimate = 1.0;
  o.refine_edges = true;
  const auto res = AprilTagDetector(o).Detect(img);
  ASSERT_EQ(res.detections.size(), 1u);
  const Detection& d = res.detections[0];
  EXPECT_EQ(d.tag_id, 5);
  EXPECT_EQ(d.object_class, ObjectClass::kTag);
  for (int i = 0; i < 4; ++i)
    EXPECT_LT((d.corners_px[i] - truth[i]).norm(), 0.2) << "corner s" << i + 1;
  // s1..s4 of an upright tag: bottom-left, bottom-right, top-right, top-left (counter-clockwise on
  // screen).
  EXPECT_LT(SignedArea(d.corners_px), 0.0);
  EXPECT_GT(d.corners_px[0].y(), d.corners_px[3].y());
  EXPECT_LT(d.corners_px[0].x(), d.corners_px[1].x());
}

TEST(AprilTag, UnknownFamilyIsAnInputError) {
  AprilTagDetector::Options o;
  o.family = "tag99h99";
  EXPECT_THROW(AprilTagDetector{o}, InputError);
  EXPECT_EQ(AprilTagDetector::Families().size(), 8u);
  // Only the small families: the big ones (tagStandard52h13) take seconds to build their tables.
  for (const char* f : {"tag36h11", "tag25h9", "tag16h5"}) {
    o.family = f;
    EXPECT_NO_THROW(AprilTagDetector{o}) << f;
  }
}

// `fsp detect --frontend apriltag` with its defaults on the three reference photos: decimation from
// the image size (1 for these 799 px photos) and edge refinement only when decimating find all 47
// tags within 0.2 px of the reference (with the library defaults, decimate 2 and refine_edges: 34,
// median 0.51 px).
TEST(AprilTag, DetectCliDefaultsFindAllUmichTags) {
  FSP_REQUIRE_TEST_DATA(dir, "apriltag_umich_test");
  const auto out = ::fsp::test::ScratchDir();
  const char* names[] = {"33369213973_9d9bb4cc96_c", "34085369442_304b6bafd9_c",
                         "34139872896_defdb2f8d9_c"};
  std::string args = "detect --frontend apriltag --out " + out.string();
  for (const char* name : names) args += " " + dir + "/" + name + ".jpg";
  const auto r = ::fsp::test::RunFsp(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // detections.csv: image,tag_id,class,u1,v1,...,u4,v4,score
  std::map<std::string, std::vector<RefTag>> got;
  std::ifstream csv(out / "detections.csv");
  std::string line;
  std::getline(csv, line);
  while (std::getline(csv, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) f.push_back(cell);
    ASSERT_EQ(f.size(), 12u) << line;
    RefTag t;
    t.id = std::stoi(f[1]);
    for (int i = 0; i < 4; ++i) t.p[i] = Vec2(std::stod(f[3 + 2 * i]), std::stod(f[4 + 2 * i]));
    got[f[0]].push_back(t);
  }
  int within = 0, total = 0;
  for (const char* name : names) {
    for (const RefTag& ref : ReadReference(dir + "/" + name + ".expected.txt")) {
      ++total;
      double best = 1e9;
      for (const RefTag& d : got[std::string(name) + ".jpg"]) {
        if (d.id != ref.id) continue;
        double e = 0.0;
        for (int i = 0; i < 4; ++i) e = std::max(e, (d.p[i] + Vec2(0.5, 0.5) - ref.p[i]).norm());
        best = std::min(best, e);
      }
      within += best <= 0.2;
    }
  }
  EXPECT_EQ(total, 47);
  EXPECT_EQ(within, 47);
}

}  // namespace
}  // namespace fsp::frontend
