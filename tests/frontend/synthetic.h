// Synthetic test frames for the detectors: rectangles with exactly known corners, drawn with OpenCV
// at 8x resolution (sub-pixel polygon fill), averaged down (INTER_AREA), blurred and given seeded
// Gaussian noise. Straight edges stay straight under a homography, so filling the projected polygon
// is exact.
#pragma once

#include <random>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/types.h"

namespace fsp::test {

// A pinhole camera without lens distortion.
inline PinholeRadtan PinholeCamera(int width, int height, double f, double cx, double cy) {
  PinholeRadtan c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = f;
  c.cx = cx;
  c.cy = cy;
  return c;
}

struct SyntheticRect {
  Corners corners;  // s1..s4, pixels (OpenCV convention), counter-clockwise on screen
  int grey = 200;   // fill
};

struct SyntheticFrame {
  cv::Mat image;  // CV_8UC1
  std::vector<SyntheticRect> rects;
};

// Draws the quads (in order, later ones on top) over a background with a smooth intensity gradient.
inline cv::Mat RenderQuads(int width, int height, const std::vector<SyntheticRect>& rects,
                           double blur_sigma, double noise_sigma, uint32_t seed,
                           int background = 90) {
  constexpr int kSuper = 8;
  constexpr int kShift = 4;  // fillConvexPoly sub-pixel bits
  cv::Mat hi(height * kSuper, width * kSuper, CV_8UC1);
  for (int y = 0; y < hi.rows; ++y)  // gentle vertical gradient: the background is not flat
    hi.row(y).setTo(background + static_cast<int>(20.0 * y / hi.rows));
  for (const auto& r : rects) {
    std::vector<cv::Point> poly;
    for (const auto& c : r.corners) {
      // Low-res pixel centre x maps to high-res coordinate kSuper (x + 0.5) - 0.5.
      const double hx = kSuper * (c.x() + 0.5) - 0.5, hy = kSuper * (c.y() + 0.5) - 0.5;
      poly.emplace_back(static_cast<int>(std::lround(hx * (1 << kShift))),
                        static_cast<int>(std::lround(hy * (1 << kShift))));
    }
    cv::fillConvexPoly(hi, poly, cv::Scalar(r.grey), cv::LINE_8, kShift);
  }
  cv::Mat lo;
  cv::resize(hi, lo, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  cv::Mat f;
  lo.convertTo(f, CV_32F);
  if (blur_sigma > 0) cv::GaussianBlur(f, f, cv::Size(0, 0), blur_sigma);
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.f, static_cast<float>(noise_sigma));
  for (int y = 0; y < f.rows; ++y)
    for (int x = 0; x < f.cols; ++x) f.at<float>(y, x) += noise(rng);
  cv::Mat out;
  f.convertTo(out, CV_8U);  // rounds and saturates
  return out;
}

// Corners of a w x h rectangle (s1 at the origin, x along the width, y UP) centred at `centre` [m]
// in the camera frame after rotating by (roll about the normal, yaw about the vertical, pitch about
// x), projected with a pinhole (f, cx, cy). Returned in s1..s4 order.
inline Corners ProjectRect(double w, double h, const Vec3& centre, double yaw, double pitch,
                           double roll, double f, double cx, double cy) {
  const Mat3 R = (Eigen::AngleAxisd(yaw, Vec3::UnitY()) * Eigen::AngleAxisd(pitch, Vec3::UnitX()) *
                  Eigen::AngleAxisd(roll, Vec3::UnitZ()))
                     .toRotationMatrix();
  // Object axes in the camera frame (y down): x right, "up" is −y.
  const Vec3 s[4] = {Vec3(-w / 2, h / 2, 0), Vec3(w / 2, h / 2, 0), Vec3(w / 2, -h / 2, 0),
                     Vec3(-w / 2, -h / 2, 0)};
  Corners c;
  for (int i = 0; i < 4; ++i) {
    const Vec3 p = centre + R * s[i];
    c[i] = Vec2(f * p.x() / p.z() + cx, f * p.y() / p.z() + cy);
  }
  return c;
}

// A 640x480 frame with a few rectangles under perspective (f = 500 px): a door, a window, a poster
// and a panel, of different contrasts. Deterministic for a seed.
inline SyntheticFrame MakeSyntheticFrame(uint32_t seed, double blur_sigma = 0.8,
                                         double noise_sigma = 2.0) {
  const double f = 500.0, cx = 319.5, cy = 239.5;
  SyntheticFrame fr;
  fr.rects.push_back({ProjectRect(0.9, 2.0, Vec3(-1.0, 0.1, 4.0), 0.35, 0.0, 0.0, f, cx, cy), 150});
  fr.rects.push_back({ProjectRect(1.2, 1.0, Vec3(0.9, -0.5, 4.5), -0.5, 0.1, 0.0, f, cx, cy), 220});
  fr.rects.push_back({ProjectRect(0.6, 0.8, Vec3(0.2, 0.9, 3.5), 0.2, -0.3, 0.03, f, cx, cy), 30});
  fr.rects.push_back({ProjectRect(0.7, 0.5, Vec3(1.5, 1.1, 4.5), 0.5, 0.2, -0.05, f, cx, cy), 160});
  fr.image = RenderQuads(640, 480, fr.rects, blur_sigma, noise_sigma, seed);
  return fr;
}

}  // namespace fsp::test
