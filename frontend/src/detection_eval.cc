#include "fsp/frontend/detection_eval.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "fsp/common/csv.h"
#include "fsp/common/error.h"
#include "fsp/frontend/image_io.h"
#include "fsp/frontend/rect_geometry.h"

namespace fsp::frontend {

double MatchStats::Recall() const {
  return gt_eligible ? double(gt_eligible_found) / gt_eligible : 1.0;
}
double MatchStats::Precision() const {
  return detections ? double(true_positives) / detections : 1.0;
}

double MatchStats::ErrorQuantile(double q) const {
  if (corner_err_px.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::vector<double> e = corner_err_px;
  const size_t k =
      std::min(e.size() - 1, static_cast<size_t>(std::floor(q * (e.size() - 1) + 0.5)));
  std::nth_element(e.begin(), e.begin() + k, e.end());
  return e[k];
}

void MatchStats::Merge(const MatchStats& o) {
  frames += o.frames;
  gt_eligible += o.gt_eligible;
  gt_eligible_found += o.gt_eligible_found;
  detections += o.detections;
  true_positives += o.true_positives;
  order_mismatches += o.order_mismatches;
  corner_err_px.insert(corner_err_px.end(), o.corner_err_px.begin(), o.corner_err_px.end());
}

MatchStats MatchFrame(const std::vector<Detection>& dets, const std::vector<GtObservation>& gt,
                      const MatchOptions& o) {
  MatchStats s;
  s.frames = 1;
  s.detections = static_cast<int>(dets.size());
  auto tolerance = [&](const GtObservation& g) {
    return std::max(o.match_px, o.match_frac * ShortestSide(g.corners));
  };
  for (const Detection& d : dets) {
    bool tp = false;
    for (const GtObservation& g : gt)
      tp = tp || CornerDistanceBestShift(d.corners_undistorted, g.corners) <= tolerance(g);
    s.true_positives += tp;
  }
  for (const GtObservation& g : gt) {
    if (!g.FullyVisible() || ShortestSide(g.corners) < o.min_shortest_side_px) continue;
    ++s.gt_eligible;
    double best = std::numeric_limits<double>::infinity();
    int best_shift = 0;
    const Detection* best_det = nullptr;
    for (const Detection& d : dets) {
      int shift = 0;
      const double e = CornerDistanceBestShift(g.corners, d.corners_undistorted, &shift);
      if (e < best) {
        best = e;
        best_shift = shift;
        best_det = &d;
      }
    }
    if (!best_det || best > tolerance(g)) continue;
    ++s.gt_eligible_found;
    if (best_shift != 0) ++s.order_mismatches;
    for (int i = 0; i < 4; ++i)
      s.corner_err_px.push_back(
          (g.corners[i] - best_det->corners_undistorted[(i + best_shift) % 4]).norm());
  }
  return s;
}

MatchStats EvaluateSequence(const std::string& dir, const DetectFn& detect,
                            const MatchOptions& options, int every) {
  FSP_CHECK(every >= 1);
  const std::vector<GtObservation> gt = ReadCornerRows(dir + "/observations_gt.csv");
  std::map<int64_t, std::vector<GtObservation>> by_time;
  for (const auto& g : gt) by_time[g.t_ns].push_back(g);
  TableReader r(dir + "/mav0/cam0/data.csv", "camera csv");
  std::vector<std::string> f;
  MatchStats total;
  int index = 0;
  while (r.NextRow(&f)) {
    r.ExpectColumns(f, 2, 2);
    const int64_t t_ns = r.Int64(f, 0, "t_ns");
    if (index++ % every != 0) continue;
    const cv::Mat gray = ReadGray8(dir + "/mav0/cam0/data/" + f[1]);
    const auto it = by_time.find(t_ns);
    total.Merge(MatchFrame(
        detect(gray), it == by_time.end() ? std::vector<GtObservation>() : it->second, options));
  }
  return total;
}

// --- Hand labels ---------------------------------------------------------------------------------

FrameLabels ReadFrameLabels(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open the label file");
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path, 0, std::string("not valid JSON: ") + e.what());
  }
  const auto fail = [&](const std::string& where, const std::string& what) {
    throw InputError(path + ": " + where + ": " + what);
  };
  if (!root.is_object() || !root.contains("frames") || !root.at("frames").is_array() ||
      !root.contains("image_size") || !root.at("image_size").is_array() ||
      root.at("image_size").size() != 2)
    fail("top level", "expected {\"image_size\": [w, h], \"frames\": [...]}");
  FrameLabels labels;
  if (root.contains("recording") && root.at("recording").is_string())
    labels.recording = root.at("recording").get<std::string>();
  labels.width = root.at("image_size")[0].get<int>();
  labels.height = root.at("image_size")[1].get<int>();
  if (labels.width <= 0 || labels.height <= 0) fail("image_size", "must be positive");
  const nlohmann::json& frames = root.at("frames");
  for (size_t f = 0; f < frames.size(); ++f) {
    const nlohmann::json& jf = frames[f];
    const std::string where = "frames[" + std::to_string(f) + "]";
    if (!jf.is_object() || !jf.contains("t_ns") || !jf.at("t_ns").is_number_integer() ||
        !jf.contains("objects") || !jf.at("objects").is_array())
      fail(where, "expected {\"t_ns\": integer, \"objects\": [...]}");
    LabelledFrame frame;
    frame.t_ns = jf.at("t_ns").get<int64_t>();
    if (!labels.frames.empty() && frame.t_ns <= labels.frames.back().t_ns)
      fail(where, "t_ns not increasing");
    std::set<int> ids;
    for (size_t i = 0; i < jf.at("objects").size(); ++i) {
      const nlohmann::json& jo = jf.at("objects")[i];
      const std::string w = where + ".objects[" + std::to_string(i) + "]";
      LabelledObject o;
      if (!jo.is_object() || !jo.contains("id") || !jo.at("id").is_number_integer())
        fail(w, "\"id\" missing or not an integer");
      o.id = jo.at("id").get<int>();
      if (!ids.insert(o.id).second) fail(w, "id repeated in the frame");
      if (!jo.contains("class") || !jo.at("class").is_string()) fail(w, "\"class\" missing");
      o.label_class = jo.at("class").get<std::string>();
      const std::string state = jo.contains("state") && jo.at("state").is_string()
                                    ? jo.at("state").get<std::string>()
                                    : std::string();
      if (state == "full")
        o.state = LabelledObject::State::kFull;
      else if (state == "cut")
        o.state = LabelledObject::State::kCut;
      else if (state == "ignore")
        o.state = LabelledObject::State::kIgnore;
      else
        fail(w, "\"state\" must be full, cut or ignore, got '" + state + "'");
      if (!jo.contains("corners") || !jo.at("corners").is_array() || jo.at("corners").size() != 4)
        fail(w, "\"corners\" must be 4 points [x, y]");
      for (int j = 0; j < 4; ++j) {
        const nlohmann::json& c = jo.at("corners")[static_cast<size_t>(j)];
        if (!c.is_array() || c.size() != 2 || !c[0].is_number() || !c[1].is_number() ||
            !std::isfinite(c[0].get<double>()) || !std::isfinite(c[1].get<double>()))
          fail(w, "corners[" + std::to_string(j) + "] is not a finite [x, y]");
        o.corners[j] = Vec2(c[0].get<double>(), c[1].get<double>());
      }
      if (o.state == LabelledObject::State::kCut) {
        if (!jo.contains("visible") || !jo.at("visible").is_array() || jo.at("visible").size() != 4)
          fail(w, "a cut object needs \"visible\": 4 booleans");
        for (int j = 0; j < 4; ++j)
          o.visible[j] = jo.at("visible")[static_cast<size_t>(j)].get<bool>();
      }
      frame.objects.push_back(o);
    }
    labels.frames.push_back(std::move(frame));
  }
  return labels;
}

namespace {

// IoU of a detection with the part of a labelled outline inside the image.
double IouInImage(const Corners& det, const Corners& label, int width, int height) {
  const std::vector<cv::Point2f> image = {
      {-0.5f, -0.5f}, {width - 0.5f, -0.5f}, {width - 0.5f, height - 0.5f}, {-0.5f, height - 0.5f}};
  std::vector<cv::Point2f> in_image;
  if (cv::intersectConvexConvex(QuadHull(label), image, in_image) <= 0.0f) return 0.0;
  return ConvexIou(QuadHull(det), in_image);
}

}  // namespace

void LabelScore::PerClass::Add(const PerClass& o) {
  full += o.full;
  found += o.found;
  cut += o.cut;
  cut_found += o.cut_found;
  corner_err_px.insert(corner_err_px.end(), o.corner_err_px.begin(), o.corner_err_px.end());
}

LabelScore::PerClass LabelScore::Total() const {
  PerClass t;
  for (const auto& [name, c] : per_class) t.Add(c);
  return t;
}

double LabelScore::Recall() const {
  const PerClass t = Total();
  return t.full ? double(t.found) / t.full : 1.0;
}

double LabelScore::Precision() const {
  return detections ? double(true_positives) / detections : 1.0;
}

void LabelScore::Merge(const LabelScore& o) {
  frames += o.frames;
  detections += o.detections;
  true_positives += o.true_positives;
  for (const auto& [name, c] : o.per_class) per_class[name].Add(c);
}

LabelScore ScoreLabelledFrame(const std::vector<Detection>& dets, const LabelledFrame& labels,
                              int width, int height, const LabelMatchOptions& o) {
  using State = LabelledObject::State;
  LabelScore s;
  s.frames = 1;
  const auto iou = [&](const Detection& d, const LabelledObject& l) {
    return l.state == State::kFull ? QuadIou(d.corners_px, l.corners)
                                   : IouInImage(d.corners_px, l.corners, width, height);
  };
  for (const Detection& d : dets) {
    bool ignored = false, hit = false;
    for (const LabelledObject& l : labels.objects) {
      if (iou(d, l) < o.min_iou) continue;
      (l.state == State::kIgnore ? ignored : hit) = true;
    }
    if (ignored && !hit) continue;
    ++s.detections;
    s.true_positives += hit;
  }
  for (const LabelledObject& l : labels.objects) {
    if (l.state == State::kIgnore) continue;
    LabelScore::PerClass& c = s.per_class[l.label_class];
    const bool full = l.state == State::kFull;
    if (full && ShortestSide(l.corners) < o.min_shortest_side_px) continue;
    const Detection* best = nullptr;
    double best_iou = o.min_iou;
    for (const Detection& d : dets) {
      const double v = iou(d, l);
      if (v >= best_iou) {
        best_iou = v;
        best = &d;
      }
    }
    if (!full) {
      ++c.cut;
      c.cut_found += best != nullptr;
      continue;
    }
    ++c.full;
    if (!best) continue;
    ++c.found;
    int shift = 0;
    MeanCornerDistanceBestShift(l.corners, best->corners_px, &shift);
    for (int i = 0; i < 4; ++i)
      c.corner_err_px.push_back((l.corners[i] - best->corners_px[(i + shift) % 4]).norm());
  }
  return s;
}

}  // namespace fsp::frontend
