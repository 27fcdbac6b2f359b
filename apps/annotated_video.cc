#include "annotated_video.h"

#include "run_outputs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "fsp/common/atomic_file.h"
#include "fsp/common/error.h"
#include "fsp/frontend/draw.h"

namespace fsp::apps {

namespace {

cv::Point ToPoint(const Vec2& p) {
  return {static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y()))};
}

}  // namespace

struct AnnotatedVideo::Impl {
  Calibration calibration;
  std::string path;  // empty: drawing only
  std::string part;  // the file being written (PartPath(path))
  cv::VideoWriter writer;
  std::vector<Vec3> trajectory;  // body positions so far
};

AnnotatedVideo::AnnotatedVideo(const std::string& path, const Calibration& calibration, double fps)
    : impl_(std::make_unique<Impl>()) {
  impl_->calibration = calibration;
  impl_->path = path;
  if (path.empty()) return;
  impl_->part = PartPath(path);
  const cv::Size size(calibration.camera.width, calibration.camera.height);
  if (!impl_->writer.open(impl_->part, cv::VideoWriter::fourcc('m', 'p', '4', 'v'),
                          fps > 0.0 ? fps : 20.0, size, true)) {
    std::error_code ec;
    std::filesystem::remove(impl_->part, ec);
    throw InputError(path + ": cannot write the video (--video)");
  }
}

AnnotatedVideo::~AnnotatedVideo() {
  if (impl_->writer.isOpened()) {
    // Not closed: the run failed; no half video is left behind.
    impl_->writer.release();
    std::error_code ec;
    std::filesystem::remove(impl_->part, ec);
  }
}

void AnnotatedVideo::AddSummary(const std::vector<backend::MapObject>& map) {
  if (last_.empty()) return;
  std::vector<std::pair<std::string, cv::Scalar>> rows;
  rows.emplace_back("the map after the final solve (width x height, +- 1 sigma):",
                    cv::Scalar(255, 255, 255));
  for (const backend::MapObject& o : map)
    rows.emplace_back(MapObjectLine(o), frontend::ClassColour(o.object_class));
  cv::Mat out = last_ * 0.35;
  // The font as large as fits: 0.42 per 640 px of width, smaller when a row is wider than the
  // frame.
  double font = 0.42 * out.cols / 640.0;
  int widest = 0, baseline = 0;
  for (const auto& [text, colour] : rows)
    widest =
        std::max(widest, cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline).width);
  if (widest > out.cols - 16) font *= static_cast<double>(out.cols - 16) / widest;
  const int line = std::max(8, static_cast<int>(std::lround(40 * font)));
  const size_t fit = static_cast<size_t>(std::max(2, out.rows / line - 1));
  if (rows.size() > fit) {
    const size_t more = rows.size() - (fit - 1);
    rows.resize(fit - 1);
    rows.emplace_back("... " + std::to_string(more) + " more in map.json",
                      cv::Scalar(255, 255, 255));
  }
  int y = line;
  for (const auto& [text, colour] : rows) {
    cv::putText(out, text, cv::Point(8, y), cv::FONT_HERSHEY_SIMPLEX, font, colour, 1, cv::LINE_AA);
    y += line;
  }
  for (int k = 0; k < kSummaryFrames && impl_->writer.isOpened(); ++k) impl_->writer.write(out);
  last_ = out;
}

void AnnotatedVideo::Close() {
  if (!impl_->writer.isOpened()) return;
  impl_->writer.release();
  CommitPart(impl_->part, impl_->path);
}

void AnnotatedVideo::Add(const cv::Mat& image, const std::vector<ObjectObservation>& observations,
                         const std::vector<backend::MapObject>& map,
                         const std::optional<Rigid3>& T_W_B) {
  const PinholeRadtan& cam = impl_->calibration.camera;
  cv::Mat out;
  if (image.empty()) {
    out = cv::Mat(cam.height, cam.width, CV_8UC3, cv::Scalar(90, 90, 90));
  } else if (image.channels() == 1) {
    cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  } else {
    out = image.clone();
  }
  const double scale = std::max(1.0, out.cols / 640.0);
  const int thick = std::max(1, static_cast<int>(std::lround(2 * scale)));
  const double font = 0.45 * scale;

  // The objects of this frame, with their map size when the map holds them.
  for (const ObjectObservation& o : observations) {
    const cv::Scalar colour = frontend::ClassColour(o.object_class);
    std::vector<cv::Point> poly;
    for (const Vec2& c : o.corners) poly.push_back(ToPoint(cam.DistortPixel(c)));
    cv::polylines(out, poly, true, colour, thick, cv::LINE_AA);
    char label[96];
    const auto in_map = std::find_if(
        map.begin(), map.end(), [&](const backend::MapObject& m) { return m.id == o.object_id; });
    if (in_map != map.end()) {
      std::snprintf(label, sizeof(label), "%d %s %.2f x %.2f m", o.object_id,
                    ToString(o.object_class), in_map->width, in_map->height);
    } else {
      std::snprintf(label, sizeof(label), "%d %s", o.object_id, ToString(o.object_class));
    }
    const cv::Point top = *std::min_element(
        poly.begin(), poly.end(), [](const cv::Point& a, const cv::Point& b) { return a.y < b.y; });
    int baseline = 0;
    const cv::Size text = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, font, thick, &baseline);
    const cv::Point at(std::clamp(top.x, 2, std::max(2, out.cols - text.width - 2)),
                       std::max(text.height + 2, top.y - 4));
    cv::putText(out, label, at, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), thick + 2,
                cv::LINE_AA);
    cv::putText(out, label, at, cv::FONT_HERSHEY_SIMPLEX, font, colour, thick, cv::LINE_AA);
  }

  // The top view so far (x right, y up), fitted into a corner.
  if (T_W_B) impl_->trajectory.push_back(T_W_B->translation());
  if (!impl_->trajectory.empty()) {
    const int side = std::min(out.cols, out.rows) / 3;
    const cv::Rect box(out.cols - side - 6, out.rows - side - 6, side, side);
    cv::Mat roi = out(box);
    roi = roi * 0.35;
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    const auto grow = [&](const Vec3& p) {
      x0 = std::min(x0, p.x());
      x1 = std::max(x1, p.x());
      y0 = std::min(y0, p.y());
      y1 = std::max(y1, p.y());
    };
    for (const Vec3& p : impl_->trajectory) grow(p);
    for (const backend::MapObject& m : map)
      for (const Vec3& c : m.corners_W) grow(c);
    const double span = std::max({x1 - x0, y1 - y0, 1.0}) * 1.1;
    const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
    const auto px = [&](const Vec3& p) {
      return cv::Point(box.x + static_cast<int>((p.x() - cx) / span * side + side / 2),
                       box.y + static_cast<int>((cy - p.y()) / span * side + side / 2));
    };
    for (const backend::MapObject& m : map)
      cv::line(out, px(m.corners_W[0]), px(m.corners_W[1]), frontend::ClassColour(m.object_class),
               thick, cv::LINE_AA);
    for (size_t i = 1; i < impl_->trajectory.size(); ++i)
      cv::line(out, px(impl_->trajectory[i - 1]), px(impl_->trajectory[i]), cv::Scalar(60, 60, 230),
               1, cv::LINE_AA);
    cv::circle(out, px(impl_->trajectory.back()), thick + 2, cv::Scalar(255, 255, 255), -1);
    cv::rectangle(out, box, cv::Scalar(200, 200, 200), 1);
    char label[48];
    std::snprintf(label, sizeof(label), "top view, %.0f m", span);
    cv::putText(out, label, cv::Point(box.x + 4, box.y + static_cast<int>(14 * scale)),
                cv::FONT_HERSHEY_SIMPLEX, 0.8 * font, cv::Scalar(230, 230, 230), 1, cv::LINE_AA);
  }
  if (impl_->writer.isOpened()) impl_->writer.write(out);
  last_ = out;
}

}  // namespace fsp::apps
