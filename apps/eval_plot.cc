#include "eval_plot.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fsp/common/error.h"
#include "fsp/eval/object_metrics.h"
#include "fsp/eval/trajectory_metrics.h"

namespace fsp::apps {

namespace {

// Metric x-y to image pixels with a margin, equal scale on both axes, y up.
struct View {
  double x0 = 0, y0 = 0, scale = 1;
  int height = 0, margin = 60;
  cv::Point Px(const Vec3& p) const {
    return cv::Point(margin + static_cast<int>((p.x() - x0) * scale),
                     height - margin - static_cast<int>((p.y() - y0) * scale));
  }
};

void DrawPolyline(cv::Mat* img, const View& v, const std::vector<Vec3>& pts,
                  const cv::Scalar& color, int thick) {
  for (size_t i = 1; i < pts.size(); ++i)
    cv::line(*img, v.Px(pts[i - 1]), v.Px(pts[i]), color, thick, cv::LINE_AA);
}

void DrawObjects(cv::Mat* img, const View& v, const std::vector<eval::ObjectRecord>& objects,
                 const cv::Scalar& color, int thick, bool labels) {
  for (const auto& o : objects) {
    bool finite = true;
    for (const Vec3& c : o.corners_W) finite = finite && c.allFinite();
    if (!finite) continue;
    std::vector<cv::Point> poly;
    for (const Vec3& c : o.corners_W) poly.push_back(v.Px(c));
    cv::polylines(*img, poly, true, color, thick, cv::LINE_AA);
    if (labels) {
      cv::putText(*img, std::to_string(o.id), v.Px(o.corners_W[3]) + cv::Point(3, -3),
                  cv::FONT_HERSHEY_SIMPLEX, 0.4, color, 1, cv::LINE_AA);
    }
  }
}

}  // namespace

void WriteEvalTopView(const eval::Metrics& metrics, const std::string& png_path) {
  if (!metrics.trajectory) return;
  const eval::Trajectory gt = eval::ReadTrajectory(metrics.paths.gt_trajectory);
  const eval::Trajectory est = eval::ReadTrajectory(metrics.paths.est_trajectory);
  const eval::Alignment& align = metrics.trajectory->alignment;
  std::vector<Vec3> p_gt, p_est;
  for (const Rigid3& T : gt.T_W_B) p_gt.push_back(T.translation());
  for (const Rigid3& T : est.T_W_B) p_est.push_back(align.Apply(T.translation()));
  std::vector<eval::ObjectRecord> obj_gt, obj_est;
  if (!metrics.paths.objects_gt.empty() && !metrics.paths.map.empty()) {
    obj_gt = eval::ReadObjectsJson(metrics.paths.objects_gt);
    obj_est = eval::ReadObjectsJson(metrics.paths.map);
    for (auto& o : obj_est)
      for (Vec3& c : o.corners_W) c = align.Apply(c);
  }
  // The view frames the ground truth (and its objects) with 20 % room: a diverged estimate is drawn
  // clipped rather than shrinking the truth to a dot.
  Vec3 lo = Vec3::Constant(1e18), hi = Vec3::Constant(-1e18);
  auto extend = [&](const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const Vec3& p : p_gt) extend(p);
  for (const auto& o : obj_gt)
    for (const Vec3& c : o.corners_W) extend(c);
  const Vec3 pad = 0.2 * (hi - lo) + Vec3::Constant(0.2);
  lo -= pad;
  hi += pad;
  View v;
  const int width = 1000;
  v.x0 = lo.x();
  v.y0 = lo.y();
  v.scale = (width - 2 * v.margin) / std::max(hi.x() - lo.x(), 1e-6);
  v.height = 2 * v.margin + static_cast<int>((hi.y() - lo.y()) * v.scale);
  cv::Mat img(v.height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  DrawObjects(&img, v, obj_gt, cv::Scalar(0, 0, 0), 2, true);
  DrawObjects(&img, v, obj_est, cv::Scalar(0, 0, 220), 1, false);
  DrawPolyline(&img, v, p_gt, cv::Scalar(150, 150, 150), 2);
  DrawPolyline(&img, v, p_est, cv::Scalar(0, 0, 220), 1);
  char text[256];
  std::snprintf(text, sizeof(text),
                "ground truth (grey/black) vs estimate (red), %s alignment: ATE rmse %.3f m",
                eval::ToString(align.mode), metrics.trajectory->ate.rmse);
  cv::putText(img, text, cv::Point(10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1,
              cv::LINE_AA);
  // 1 m scale bar.
  const cv::Point bar0(v.margin, v.height - 20);
  cv::line(img, bar0, bar0 + cv::Point(static_cast<int>(v.scale), 0), cv::Scalar(0, 0, 0), 2);
  cv::putText(img, "1 m", bar0 + cv::Point(static_cast<int>(v.scale) + 6, 5),
              cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  if (!cv::imwrite(png_path, img)) throw InputError(png_path, 0, "cannot write the picture");
}

}  // namespace fsp::apps
