#include "shi_tomasi.h"

#include <algorithm>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace fsp::frontend {

std::vector<cv::Point2f> ShiTomasiCorners(const cv::Mat& img, const cv::Mat& mask, double min_dist,
                                          double min_gradient, int max_count) {
  constexpr int kBlock = 5;
  cv::Mat eig;
  cv::cornerMinEigenVal(img, eig, kBlock, 3, cv::BORDER_REPLICATE);
  // cornerMinEigenVal scales the 3x3 Sobel (8 x the gradient in grey levels / px) by
  // 1 / (4 kBlock 255) and sums over the block; its value is half the smaller eigenvalue.
  const double g = min_gradient * 8.0 / (4.0 * kBlock * 255.0);
  double max_eig = 0.0;
  cv::minMaxLoc(eig, nullptr, &max_eig, nullptr, nullptr, mask);
  const float thr = static_cast<float>(std::max(0.01 * max_eig, 0.5 * kBlock * kBlock * g * g));
  cv::Mat dil;
  cv::dilate(eig, dil, cv::Mat());
  std::vector<std::pair<float, cv::Point>> cand;
  for (int y = 1; y < eig.rows - 1; ++y) {
    const float* e = eig.ptr<float>(y);
    const float* d = dil.ptr<float>(y);
    const uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 1; x < eig.cols - 1; ++x)
      if (m[x] && e[x] >= thr && e[x] >= d[x]) cand.emplace_back(e[x], cv::Point(x, y));
  }
  std::sort(cand.begin(), cand.end(), [](const auto& a, const auto& b) {
    return a.first != b.first
               ? a.first > b.first
               : (a.second.y != b.second.y ? a.second.y < b.second.y : a.second.x < b.second.x);
  });
  std::vector<cv::Point2f> out;
  const double d2 = min_dist * min_dist;
  for (const auto& c : cand) {
    bool near = false;
    for (const cv::Point2f& q : out) {
      const double dx = q.x - c.second.x, dy = q.y - c.second.y;
      if (dx * dx + dy * dy < d2) {
        near = true;
        break;
      }
    }
    if (near) continue;
    out.emplace_back(static_cast<float>(c.second.x), static_cast<float>(c.second.y));
    if (static_cast<int>(out.size()) >= max_count) break;
  }
  return out;
}

}  // namespace fsp::frontend
