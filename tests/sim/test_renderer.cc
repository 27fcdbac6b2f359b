// Ray-casting renderer: its images agree with its ground truth (corners found in the image against
// the camera model's projection, AprilTag decoding), quads crossing the camera plane, occlusion,
// determinism.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <thread>
#include <vector>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>
#include <opencv2/core.hpp>

#include "fsp/sim/renderer.h"

namespace fsp::sim {
namespace {

PinholeRadtan SmallCamera(bool distorted) {
  PinholeRadtan cam;
  cam.width = 320;
  cam.height = 240;
  cam.fx = 262.0;
  cam.fy = 260.5;
  cam.cx = 161.3;
  cam.cy = 118.6;
  // EuRoC cam0-like barrel distortion (scaled image, same normalised model).
  if (distorted) cam.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  return cam;
}

// Camera at eye looking at target, world z up, then rolled about the optical axis.
Rigid3 LookAt(const Vec3& eye, const Vec3& target, double roll_rad) {
  const Vec3 z = (target - eye).normalized();
  const Vec3 x = z.cross(Vec3::UnitZ()).normalized();
  const Vec3 y = z.cross(x);
  Mat3 R_W_C;
  R_W_C << x, y, z;
  return Rigid3(R_W_C * RotZ(roll_rad), eye);
}

TexturedQuad Quad(int id, const Vec3& origin, const Vec3& u, const Vec3& v, TextureKind kind,
                  uint32_t seed = 1) {
  TexturedQuad q;
  q.id = id;
  q.origin_W = origin;
  q.axis_u_W = u;
  q.axis_v_W = v;
  q.texture = kind;
  q.seed = seed;
  return q;
}

std::array<Vec3, 4> Corners(const TexturedQuad& q) {
  return {q.origin_W, q.origin_W + q.axis_u_W, q.origin_W + q.axis_u_W + q.axis_v_W,
          q.origin_W + q.axis_v_W};
}

double Pixel(const cv::Mat& img, int x, int y) {
  x = std::clamp(x, 0, img.cols - 1);
  y = std::clamp(y, 0, img.rows - 1);
  return img.at<uint8_t>(y, x);
}

// Sub-pixel edge points (distorted pixels) of one side of a rectangle whose border contrasts with
// its surroundings. The expected side (a -> b) only places the search window: along each integer
// column (row, for steep sides) near the side, the grey profile is scanned across the edge and the
// crossing of the level halfway between the far-inside and far-outside values is interpolated
// linearly.
std::vector<Vec2> EdgePoints(const cv::Mat& img, const PinholeRadtan& cam, const Vec2& a,
                             const Vec2& b, const Vec2& inside) {
  const Vec2 A = cam.UndistortPixel(a), B = cam.UndistortPixel(b);
  const bool horizontal = std::abs(b.x() - a.x()) > std::abs(b.y() - a.y());
  const int steps = static_cast<int>((b - a).norm());
  std::set<int> done;
  std::vector<Vec2> pts;
  for (int k = 0; k <= steps; ++k) {
    const double f = 0.15 + 0.7 * k / std::max(steps, 1);
    const Vec2 p = cam.DistortPixel(A + f * (B - A));
    const int line = static_cast<int>(std::lround(horizontal ? p.x() : p.y()));
    if (!done.insert(line).second) continue;
    const double centre = horizontal ? p.y() : p.x();
    const double in_dir = (horizontal ? inside.y() - p.y() : inside.x() - p.x()) > 0 ? 1.0 : -1.0;
    auto at = [&](int s) { return horizontal ? Pixel(img, line, s) : Pixel(img, s, line); };
    const int c = static_cast<int>(std::lround(centre));
    const double v_in = at(c + static_cast<int>(3 * in_dir)),
                 v_out = at(c - static_cast<int>(4 * in_dir));
    if (std::abs(v_in - v_out) < 40) continue;  // no clear edge here
    const double mid = 0.5 * (v_in + v_out);
    double best = 1e9, pos = 0.0;
    for (int s = c - 4; s < c + 4; ++s) {
      const double v0 = at(s) - mid, v1 = at(s + 1) - mid;
      if (v0 == v1 || v0 * v1 > 0) continue;
      const double q = s + v0 / (v0 - v1);
      if (std::abs(q - centre) < std::abs(best - centre)) best = q, pos = q;
    }
    if (best > 1e8) continue;
    pts.push_back(horizontal ? Vec2(line, pos) : Vec2(pos, line));
  }
  return pts;
}

// Total-least-squares line n.x = d through points.
Vec3 FitLine(const std::vector<Vec2>& pts) {
  Vec2 mean = Vec2::Zero();
  for (const Vec2& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  Mat2 S = Mat2::Zero();
  for (const Vec2& p : pts) S += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Mat2> es(S);
  const Vec2 n = es.eigenvectors().col(0);  // smallest eigenvalue: the normal
  return Vec3(n.x(), n.y(), n.dot(mean));
}

// Corners of the rectangle found in the image (distorted px): edge points of each side are
// undistorted with the camera model, fitted with lines, and adjacent lines intersected.
std::array<Vec2, 4> FindCorners(const cv::Mat& img, const PinholeRadtan& cam,
                                const std::array<Vec2, 4>& approx) {
  const Vec2 inside = 0.25 * (approx[0] + approx[1] + approx[2] + approx[3]);
  std::array<Vec3, 4> lines;
  for (int j = 0; j < 4; ++j) {
    std::vector<Vec2> pts = EdgePoints(img, cam, approx[j], approx[(j + 1) % 4], inside);
    EXPECT_GE(pts.size(), 20u) << "side " << j;
    for (Vec2& p : pts) p = cam.UndistortPixel(p);
    lines[j] = FitLine(pts);
  }
  std::array<Vec2, 4> corners;
  for (int j = 0; j < 4; ++j) {
    const Vec3& l1 = lines[(j + 3) % 4];
    const Vec3& l2 = lines[j];
    // Lines n.x = d in homogeneous form (nx, ny, -d); their cross product is the intersection.
    const Vec3 h = Vec3(l1.x(), l1.y(), -l1.z()).cross(Vec3(l2.x(), l2.y(), -l2.z()));
    corners[j] = cam.DistortPixel(Vec2(h.x() / h.z(), h.y() / h.z()));
  }
  return corners;
}

// A kPlain rectangle (dark border) on a bright kPlain wall, coplanar with the wall (the object must
// win the depth tie), seen obliquely.
void CheckPlainRectangleCorners(bool distorted) {
  const PinholeRadtan cam = SmallCamera(distorted);
  const TexturedQuad wall = Quad(-1, {-3, 2, -2}, {6, 0, 0}, {0, 0, 4}, TextureKind::kPlain);
  const TexturedQuad obj =
      Quad(5, {-0.35, 2, -0.25}, {0.7, 0, 0}, {0, 0, 0.5}, TextureKind::kPlain);
  const Renderer renderer(cam, {wall, obj}, RenderOptions{});
  const std::vector<Rigid3> poses = {LookAt({-0.7, 0.7, 0.35}, {0.02, 2, 0.01}, 0.14),
                                     LookAt({0.9, 0.9, -0.3}, {-0.05, 2, 0.03}, -0.2)};
  for (size_t k = 0; k < poses.size(); ++k) {
    const cv::Mat img = renderer.Render(poses[k]);
    const Rigid3 T_C_W = poses[k].Inverse();
    std::array<Vec2, 4> expected;
    const auto P = Corners(obj);
    for (int j = 0; j < 4; ++j) expected[j] = cam.Project(T_C_W * P[j]);
    const std::array<Vec2, 4> got = FindCorners(img, cam, expected);
    for (int j = 0; j < 4; ++j) {
      std::printf(
          "distorted=%d pose %zu corner s%d: got (%.3f, %.3f) expected (%.3f, %.3f) err %.3f px\n",
          distorted, k, j + 1, got[j].x(), got[j].y(), expected[j].x(), expected[j].y(),
          (got[j] - expected[j]).norm());
      EXPECT_LT((got[j] - expected[j]).norm(), 0.3) << "pose " << k << " corner s" << j + 1;
    }
  }
}

TEST(Renderer, PlainRectangleCornersMatchProjection) {
  CheckPlainRectangleCorners(false);
}

TEST(Renderer, PlainRectangleCornersMatchProjectionWithDistortion) {
  CheckPlainRectangleCorners(true);
}

// A floor quad from 5 m behind to 5 m in front of the camera, 1 m below it: only rays below the
// horizon that meet it within 5 m in front (y_n >= 0.2, |x_n| <= 2 y_n) may be covered.
TEST(Renderer, QuadCrossingTheCameraPlaneShowsOnlyItsVisiblePart) {
  PinholeRadtan cam = SmallCamera(false);
  cam.fx = cam.fy = 200.0;
  cam.cx = 160.0;
  cam.cy = 120.0;
  // In C (T_W_C = identity): plane y = 1, x in [-2, 2], z in [-5, 5]; normal u x v = -y (towards
  // the camera).
  const TexturedQuad floor = Quad(-1, {-2, 1, -5}, {4, 0, 0}, {0, 0, 10}, TextureKind::kPlain);
  RenderOptions opt;
  opt.background = 0.0;
  const Renderer renderer(cam, {floor}, opt);
  const cv::Mat img = renderer.Render(Rigid3::Identity());
  int must_cover = 0, must_not = 0, wrong = 0;
  const double margin =
      1.5 / cam.fx;  // pixels whose footprint straddles the boundary are not judged
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const double x = (u - cam.cx) / cam.fx, y = (v - cam.cy) / cam.fy;
      const bool inside = y >= 0.2 + margin && std::abs(x) <= 2.0 * y - 2 * margin;
      const bool outside = y <= 0.2 - margin || std::abs(x) >= 2.0 * y + 2 * margin;
      const bool covered = img.at<uint8_t>(v, u) > 0;
      if (inside) {
        ++must_cover;
        wrong += !covered;
      } else if (outside) {
        ++must_not;
        wrong += covered;
      }
    }
  EXPECT_GT(must_cover, 3000);
  EXPECT_GT(must_not, 40000);
  EXPECT_EQ(wrong, 0) << "pixels covered where they must not be, or not covered where they must";
}

// Tags rendered at several poses are decoded with the right id, and AprilTag's corners (minus its
// +0.5 px offset) are the projections of the quad's corners s1..s4 in AprilTag's p[0..3] order.
TEST(Renderer, TagsDecodeWithTheirIdAndCorners) {
  const PinholeRadtan cam = SmallCamera(false);
  apriltag_family_t* fam = tag36h11_create();
  apriltag_detector_t* det = apriltag_detector_create();
  apriltag_detector_add_family(det, fam);
  det->quad_decimate = 1.0;
  det->nthreads = 1;
  det->refine_edges = 1;
  struct Case {
    int id;
    double size, yaw_deg;
    Vec3 eye;
  };
  const Case cases[] = {{0, 0.16, 0, {0.0, 1.2, 0.0}},
                        {42, 0.2, 25, {-0.5, 1.1, 0.25}},
                        {300, 0.12, -30, {0.4, 1.4, -0.1}},
                        {586, 0.25, 10, {0.1, 0.9, 0.3}}};
  for (const Case& c : cases) {
    const TexturedQuad wall = Quad(-1, {-3, 2, -2}, {6, 0, 0}, {0, 0, 4}, TextureKind::kWall, 3);
    TexturedQuad tag = Quad(c.id, {-0.5 * c.size, 2, -0.5 * c.size}, {c.size, 0, 0}, {0, 0, c.size},
                            TextureKind::kTag);
    tag.tag_id = c.id;
    const Renderer renderer(cam, {wall, tag}, RenderOptions{});
    const Rigid3 T_W_C = LookAt(c.eye, {0, 2, 0}, c.yaw_deg * M_PI / 180.0 * 0.3);
    cv::Mat img = renderer.Render(T_W_C);
    image_u8_t im{img.cols, img.rows, static_cast<int32_t>(img.step), img.data};
    zarray_t* dets = apriltag_detector_detect(det, &im);
    ASSERT_EQ(zarray_size(dets), 1) << "tag " << c.id;
    apriltag_detection_t* d = nullptr;
    zarray_get(dets, 0, &d);
    EXPECT_EQ(d->id, c.id);
    EXPECT_EQ(d->hamming, 0);
    const auto P = Corners(tag);
    for (int j = 0; j < 4; ++j) {
      const Vec2 expected = cam.Project(T_W_C.Inverse() * P[j]);
      const Vec2 got(d->p[j][0] - 0.5, d->p[j][1] - 0.5);
      std::printf("tag %d corner p[%d]: got (%.3f, %.3f) expected (%.3f, %.3f) err %.3f px\n", c.id,
                  j, got.x(), got.y(), expected.x(), expected.y(), (got - expected).norm());
      EXPECT_LT((got - expected).norm(), 0.5) << "tag " << c.id << " corner " << j;
    }
    apriltag_detections_destroy(dets);
  }
  apriltag_detector_destroy(det);
  tag36h11_destroy(fam);
}

// The tag texture follows the library's own rendering of the code (apriltag_to_image), upright.
TEST(Renderer, TagTextureMatchesLibraryImage) {
  apriltag_family_t* fam = tag36h11_create();
  for (int id : {0, 1, 17, 586}) {
    TexturedQuad q = Quad(id, Vec3::Zero(), Vec3::UnitX(), Vec3::UnitY(), TextureKind::kTag);
    q.tag_id = id;
    const cv::Mat tex =
        MakeTexture(q, 101, 101);  // 10 cells of 10 texels, boundaries on texel centres
    image_u8_t* ref = apriltag_to_image(fam, id);
    ASSERT_EQ(ref->width, 10);
    for (int r = 0; r < 10; ++r)
      for (int c = 0; c < 10; ++c) {
        const bool white = tex.at<uint8_t>(r * 10 + 5, c * 10 + 5) > 128;
        EXPECT_EQ(white, ref->buf[r * ref->stride + c] > 128)
            << "tag " << id << " cell row " << r << " col " << c;
      }
    // image_u8_destroy is not exported by the Debian library; it frees the buffer and the struct.
    std::free(ref->buf);
    std::free(ref);
  }
  tag36h11_destroy(fam);
}

// An occluder in front of the object's top-right corner hides it; the other three stay visible.
TEST(Renderer, PointVisibleAccountsForOcclusion) {
  const PinholeRadtan cam = SmallCamera(false);
  const TexturedQuad wall = Quad(-1, {-3, 2, -2}, {6, 0, 0}, {0, 0, 4}, TextureKind::kWall);
  const TexturedQuad obj = Quad(1, {-0.3, 2, -0.2}, {0.6, 0, 0}, {0, 0, 0.4}, TextureKind::kPlain);
  // 0.2 x 0.2 m plate 0.5 m in front of the wall, over the corner s3 = (0.3, 2, 0.2).
  const TexturedQuad occluder =
      Quad(2, {0.15, 1.5, 0.08}, {0.2, 0, 0}, {0, 0, 0.2}, TextureKind::kPlain);
  const Renderer renderer(cam, {wall, obj, occluder}, RenderOptions{});
  const Rigid3 T_W_C = LookAt({0, 0.5, 0}, {0, 2, 0}, 0.0);
  const auto P = Corners(obj);
  EXPECT_TRUE(renderer.PointVisible(T_W_C, P[0], 1));
  EXPECT_TRUE(renderer.PointVisible(T_W_C, P[1], 1));
  EXPECT_FALSE(renderer.PointVisible(T_W_C, P[2], 1));
  EXPECT_TRUE(renderer.PointVisible(T_W_C, P[3], 1));
  // The occluder's own corners are in front of everything.
  for (const Vec3& p : Corners(occluder)) EXPECT_TRUE(renderer.PointVisible(T_W_C, p, 2));
  // A point behind the camera is never visible.
  EXPECT_FALSE(renderer.PointVisible(LookAt({0, 0.5, 0}, {0, -1, 0}, 0.0), P[0], 1));
  // The image agrees: the hidden corner shows the occluder's bright face, not the object's dark
  // border.
  const cv::Mat img = renderer.Render(T_W_C);
  const Vec2 uv = cam.Project(T_W_C.Inverse() * P[2]);
  EXPECT_GT(
      Pixel(img, static_cast<int>(std::lround(uv.x())), static_cast<int>(std::lround(uv.y()))),
      150);
}

std::vector<TexturedQuad> RoomScene() {
  std::vector<TexturedQuad> q;
  // A 4 x 3 x 2.5 m room (x, y, z) with walls facing inwards, and one object of every kind.
  q.push_back(Quad(-1, {0, 0, 0}, {0, 3, 0}, {4, 0, 0}, TextureKind::kFloor, 1));
  q.push_back(Quad(-1, {0, 0, 2.5}, {4, 0, 0}, {0, 3, 0}, TextureKind::kCeiling, 2));
  q.push_back(Quad(-1, {0, 3, 0}, {4, 0, 0}, {0, 0, 2.5}, TextureKind::kWall, 3));
  q.push_back(Quad(-1, {4, 0, 0}, {0, 3, 0}, {0, 0, 2.5}, TextureKind::kWall, 4));
  q.push_back(Quad(-1, {0, 3, 0}, {0, -3, 0}, {0, 0, 2.5}, TextureKind::kWall, 5));
  q.push_back(Quad(1, {0.3, 3, 0}, {0.9, 0, 0}, {0, 0, 2.0}, TextureKind::kWood, 6));
  q.push_back(Quad(2, {1.5, 3, 0.9}, {1.2, 0, 0}, {0, 0, 1.2}, TextureKind::kGlass, 7));
  q.push_back(Quad(3, {3.0, 3, 0.0}, {0.8, 0, 0}, {0, 0, 1.0}, TextureKind::kCabinet, 8));
  q.push_back(Quad(4, {4, 0.5, 1.0}, {0, 0.7, 0}, {0, 0, 1.0}, TextureKind::kPoster, 9));
  TexturedQuad tag = Quad(5, {4, 1.8, 1.2}, {0, 0.3, 0}, {0, 0, 0.3}, TextureKind::kTag, 10);
  tag.tag_id = 7;
  q.push_back(tag);
  return q;
}

TEST(Renderer, DeterministicAcrossCallsInstancesAndThreads) {
  const PinholeRadtan cam = SmallCamera(true);
  const Rigid3 T_W_C = LookAt({1.0, 0.5, 1.4}, {2.5, 3, 1.0}, 0.05);
  const Renderer a(cam, RoomScene(), RenderOptions{});
  const Renderer b(cam, RoomScene(), RenderOptions{});
  const cv::Mat first = a.Render(T_W_C);
  EXPECT_EQ(cv::norm(first, a.Render(T_W_C), cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(first, b.Render(T_W_C), cv::NORM_INF), 0.0);
  cv::Mat t1, t2;
  std::thread th1([&] { t1 = a.Render(T_W_C); });
  std::thread th2([&] { t2 = a.Render(T_W_C); });
  th1.join();
  th2.join();
  EXPECT_EQ(cv::norm(first, t1, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(first, t2, cv::NORM_INF), 0.0);
  // Not a blank image: the room has texture and contrast.
  cv::Scalar mean, stddev;
  cv::meanStdDev(first, mean, stddev);
  EXPECT_GT(stddev[0], 15.0);
  EXPECT_GT(mean[0], 60.0);
}

// Motion blur spreads each pixel's rays over the exposure's poses (alpha = 1/8, 3/8, 5/8, 7/8 for 4
// samples): a still camera gives exactly the sharp image; a moving one approximates the mean of the
// sharp renders at those poses far better than any single sharp render does.
TEST(Renderer, MotionBlurAveragesPosesAlongTheExposure) {
  const PinholeRadtan cam = SmallCamera(false);
  RenderOptions opt;
  opt.motion_blur_samples = 4;
  const Renderer renderer(cam, RoomScene(), opt);
  const Rigid3 open = LookAt({1.0, 0.5, 1.4}, {2.5, 3, 1.0}, 0.0);
  const Rigid3 close(open.R() * RotY(0.04), open.translation());  // ~10 px of motion
  EXPECT_EQ(cv::norm(renderer.Render(open), renderer.Render(open, open), cv::NORM_INF), 0.0);
  cv::Mat mean(cam.height, cam.width, CV_32F, cv::Scalar(0));
  for (double alpha : {0.125, 0.375, 0.625, 0.875}) {
    cv::Mat f;
    renderer.Render(Interpolate(open, close, alpha)).convertTo(f, CV_32F, 0.25);
    mean += f;
  }
  cv::Mat blurred, sharp;
  renderer.Render(open, close).convertTo(blurred, CV_32F);
  renderer.Render(Interpolate(open, close, 0.5)).convertTo(sharp, CV_32F);
  const double err_blurred = cv::norm(blurred, mean, cv::NORM_L1) / mean.total();
  const double err_sharp = cv::norm(sharp, mean, cv::NORM_L1) / mean.total();
  std::printf(
      "mean |blurred - mean of 4 renders| = %.3f, |sharp midpoint - mean| = %.3f grey levels\n",
      err_blurred, err_sharp);
  EXPECT_LT(err_blurred, 0.5 * err_sharp);
  EXPECT_GT(err_sharp, 1.0);
}

// Image sizes that are not multiples of the internal tile size: every pixel is rendered, including
// the last partial rows and columns.
TEST(Renderer, OddImageSizeRendersEveryPixel) {
  PinholeRadtan cam;
  cam.width = 75;
  cam.height = 53;
  cam.fx = cam.fy = 60.0;
  cam.cx = 37.0;
  cam.cy = 26.0;
  // A 20 x 20 m bright plate 2 m ahead (its dark border far outside the view), facing the camera.
  const TexturedQuad plate = Quad(-1, {-10, 2, -10}, {20, 0, 0}, {0, 0, 20}, TextureKind::kPlain);
  RenderOptions opt;
  opt.background = 0.0;
  opt.room_texels_per_m = 20.0;
  const Renderer renderer(cam, {plate}, opt);
  const cv::Mat img = renderer.Render(LookAt({0, 0, 0}, {0, 1, 0}, 0.0));
  ASSERT_EQ(img.cols, 75);
  ASSERT_EQ(img.rows, 53);
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(img, &lo, &hi);
  EXPECT_GT(lo, 150.0) << "some pixel was not covered by the plate";
}

TEST(Renderer, OptionsCheck) {
  std::string why;
  EXPECT_TRUE(RenderOptions{}.Check(&why)) << why;
  RenderOptions bad;
  bad.supersampling = 0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("supersampling"), std::string::npos);
  bad = RenderOptions{};
  bad.ambient = 1.5;
  EXPECT_FALSE(bad.Check(&why));
}

}  // namespace
}  // namespace fsp::sim
