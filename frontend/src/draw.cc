#include "fsp/frontend/draw.h"

#include <algorithm>
#include <cstdio>

#include <opencv2/imgproc.hpp>

namespace fsp::frontend {

cv::Scalar ClassColour(ObjectClass c) {
  switch (c) {
    case ObjectClass::kTag:
      return {0, 220, 0};
    case ObjectClass::kDoor:
      return {0, 140, 255};
    case ObjectClass::kWindow:
      return {255, 200, 0};
    case ObjectClass::kCabinet:
      return {200, 0, 200};
    case ObjectClass::kPoster:
      return {0, 0, 255};
    default:
      return {0, 255, 255};
  }
}

cv::Mat DrawDetections(const cv::Mat& image, const std::vector<Detection>& detections) {
  cv::Mat out;
  if (image.channels() == 1)
    cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  else
    out = image.clone();
  // Sub-pixel drawing: coordinates in 1/16 px (shift 4).
  constexpr int kShift = 4;
  constexpr double kScale = 1 << kShift;
  const double s = std::max(1.0, std::min(out.cols, out.rows) / 480.0);
  const int thick = std::max(1, static_cast<int>(std::lround(s)));
  const double font = 0.45 * s;
  auto P = [&](const Vec2& p) {
    return cv::Point(static_cast<int>(std::lround((p.x()) * kScale)),
                     static_cast<int>(std::lround((p.y()) * kScale)));
  };
  for (const Detection& d : detections) {
    const cv::Scalar col = ClassColour(d.object_class);
    for (int i = 0; i < 4; ++i)
      cv::line(out, P(d.corners_px[i]), P(d.corners_px[(i + 1) % 4]), col, thick, cv::LINE_AA,
               kShift);
    const Vec2 centre =
        0.25 * (d.corners_px[0] + d.corners_px[1] + d.corners_px[2] + d.corners_px[3]);
    for (int i = 0; i < 4; ++i) {
      cv::circle(out, P(d.corners_px[i]), static_cast<int>(2.5 * s * kScale), {0, 0, 255}, thick,
                 cv::LINE_AA, kShift);
      // Number placed just outside the corner (away from the centre) so it never covers the object.
      const Vec2 away = (d.corners_px[i] - centre).normalized();
      const Vec2 p = d.corners_px[i] + 9.0 * s * away;
      const std::string num = std::to_string(i + 1);
      const cv::Point at(static_cast<int>(p.x() - 4 * s), static_cast<int>(p.y() + 5 * s));
      cv::putText(out, num, at, cv::FONT_HERSHEY_SIMPLEX, font, {0, 0, 0}, thick + 2, cv::LINE_AA);
      cv::putText(out, num, at, cv::FONT_HERSHEY_SIMPLEX, font, {255, 255, 255}, thick,
                  cv::LINE_AA);
    }
    char label[96];
    if (d.tag_id >= 0)
      std::snprintf(label, sizeof(label), "tag %d %.2f", d.tag_id, d.score);
    else
      std::snprintf(label, sizeof(label), "%s %.2f", ToString(d.object_class), d.score);
    // Label above the quad's top-most corner.
    double top = d.corners_px[0].y();
    for (const auto& c : d.corners_px) top = std::min(top, c.y());
    const cv::Point at(static_cast<int>(centre.x() - 20 * s), static_cast<int>(top - 14 * s));
    cv::putText(out, label, at, cv::FONT_HERSHEY_SIMPLEX, font, {0, 0, 0}, thick + 2, cv::LINE_AA);
    cv::putText(out, label, at, cv::FONT_HERSHEY_SIMPLEX, font, col, thick, cv::LINE_AA);
  }
  return out;
}

}  // namespace fsp::frontend
