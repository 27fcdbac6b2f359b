// Pinhole + radial-tangential camera against OpenCV (projectPoints / undistortPoints) and numeric
// Jacobians.
#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "fsp/common/camera.h"

namespace fsp {
namespace {

// The EuRoC cam0 calibration: strong barrel distortion, a realistic test.
PinholeRadtan EurocCam0() {
  PinholeRadtan cam;
  cam.width = 752;
  cam.height = 480;
  cam.fx = 458.654;
  cam.fy = 457.296;
  cam.cx = 367.215;
  cam.cy = 248.375;
  cam.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  return cam;
}

std::vector<Vec3> RandomPointsInView(const PinholeRadtan& cam, int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> pts;
  while (static_cast<int>(pts.size()) < n) {
    // Undistorted pixel inside the image (with margin), depth 0.5..10 m.
    const Vec2 uv(20 + u(rng) * (cam.width - 40), 20 + u(rng) * (cam.height - 40));
    const double z = 0.5 + 9.5 * u(rng);
    pts.emplace_back((uv.x() - cam.cx) / cam.fx * z, (uv.y() - cam.cy) / cam.fy * z, z);
  }
  return pts;
}

TEST(Camera, ProjectMatchesOpenCv) {
  const PinholeRadtan cam = EurocCam0();
  std::mt19937 rng(7);
  const auto pts = RandomPointsInView(cam, 500, rng);
  std::vector<cv::Point3d> cv_pts;
  for (const auto& p : pts) cv_pts.emplace_back(p.x(), p.y(), p.z());
  cv::Mat K = (cv::Mat_<double>(3, 3) << cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  cv::Mat dist = (cv::Mat_<double>(1, 4) << cam.distortion[0], cam.distortion[1], cam.distortion[2],
                  cam.distortion[3]);
  std::vector<cv::Point2d> projected;
  cv::projectPoints(cv_pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, projected);
  double max_err = 0.0;
  for (size_t i = 0; i < pts.size(); ++i) {
    const Vec2 uv = cam.Project(pts[i]);
    max_err = std::max(max_err, (uv - Vec2(projected[i].x, projected[i].y)).norm());
  }
  EXPECT_LT(max_err, 1e-6) << "max |ours - cv::projectPoints| in px";
}

TEST(Camera, UndistortMatchesOpenCv) {
  const PinholeRadtan cam = EurocCam0();
  std::mt19937 rng(8);
  const auto pts = RandomPointsInView(cam, 500, rng);
  std::vector<cv::Point2d> distorted, undistorted;
  for (const auto& p : pts) {
    const Vec2 uv = cam.Project(p);
    distorted.emplace_back(uv.x(), uv.y());
  }
  cv::Mat K = (cv::Mat_<double>(3, 3) << cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  cv::Mat dist = (cv::Mat_<double>(1, 4) << cam.distortion[0], cam.distortion[1], cam.distortion[2],
                  cam.distortion[3]);
  // OpenCV's default 5 iterations are not enough for EuRoC's lens; ask for convergence.
  cv::undistortPoints(
      distorted, undistorted, K, dist, cv::noArray(), K,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-14));
  double max_cv = 0.0, max_truth = 0.0;
  for (size_t i = 0; i < pts.size(); ++i) {
    const Vec2 ours = cam.UndistortPixel(Vec2(distorted[i].x, distorted[i].y));
    max_cv = std::max(max_cv, (ours - Vec2(undistorted[i].x, undistorted[i].y)).norm());
    max_truth = std::max(max_truth, (ours - cam.ProjectIdeal(pts[i])).norm());
  }
  EXPECT_LT(max_cv, 1e-6) << "max |ours - cv::undistortPoints| in px";
  EXPECT_LT(max_truth, 1e-8) << "round trip against the ideal projection, px";
}

TEST(Camera, ProjectJacobiansMatchNumeric) {
  const PinholeRadtan cam = EurocCam0();
  std::mt19937 rng(9);
  for (const Vec3& p : RandomPointsInView(cam, 50, rng)) {
    for (bool ideal : {false, true}) {
      Mat23 J;
      ideal ? cam.ProjectIdeal(p, &J) : cam.Project(p, &J);
      Mat23 numeric;
      const double h = 1e-6;
      for (int k = 0; k < 3; ++k) {
        const Vec3 e = Vec3::Unit(k) * h;
        numeric.col(k) = ideal ? (cam.ProjectIdeal(p + e) - cam.ProjectIdeal(p - e)) / (2 * h)
                               : (cam.Project(p + e) - cam.Project(p - e)) / (2 * h);
      }
      EXPECT_LT((J - numeric).norm(), 1e-5 * (1.0 + J.norm())) << "ideal=" << ideal << "\n"
                                                               << J << "\n"
                                                               << numeric;
    }
  }
}

TEST(Camera, CheckRejectsBadIntrinsics) {
  PinholeRadtan cam = EurocCam0();
  std::string why;
  EXPECT_TRUE(cam.Check(&why)) << why;
  cam.fx = -1.0;
  EXPECT_FALSE(cam.Check(&why));
  EXPECT_NE(why.find("focal"), std::string::npos);
  cam = EurocCam0();
  cam.cx = 2000.0;
  EXPECT_FALSE(cam.Check(&why));
  EXPECT_NE(why.find("principal point"), std::string::npos);
}

}  // namespace
}  // namespace fsp
