#include "fsp/frontend/frontend.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <opencv2/core.hpp>

#include "frontend_internal.h"
#include "fsp/common/error.h"
#include "fsp/frontend/rect_geometry.h"

namespace fsp::frontend {

const char* ToString(DetectorKind kind) {
  return kind == DetectorKind::kAprilTag ? "apriltag" : "rect";
}

bool ParseDetectorKind(const std::string& name, DetectorKind* kind) {
  if (name == "rect") {
    *kind = DetectorKind::kRect;
  } else if (name == "apriltag") {
    *kind = DetectorKind::kAprilTag;
  } else {
    return false;
  }
  return true;
}

bool FrontEndOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& what) {
    *why = what;
    return false;
  };
  if (detect_every < 1) return fail("detect_every must be >= 1");
  if (confirm_detections < 1) return fail("confirm_detections must be >= 1");
  if (confirm_within_frames < 1) return fail("confirm_within_frames must be >= 1");
  if (!(match_gate_frac > 0.0)) return fail("match_gate_frac must be > 0");
  if (!(reid_gate_frac > 0.0)) return fail("reid_gate_frac must be > 0");
  if (!(reid_reject_frac >= reid_gate_frac))
    return fail("reid_reject_frac must be >= reid_gate_frac");
  if (!(reid_min_similarity >= -1.0 && reid_min_similarity <= 1.0))
    return fail("reid_min_similarity must be in [-1, 1]");
  if (!(reid_min_similarity_predicted >= -1.0 && reid_min_similarity_predicted <= 1.0))
    return fail("reid_min_similarity_predicted must be in [-1, 1]");
  if (!(tag_crop_margin_frac >= 0.0)) return fail("tag_crop_margin_frac must be >= 0");
  if (!(reid_min_margin >= 0.0)) return fail("reid_min_margin must be >= 0");
  if (!(correct_px > 0.0)) return fail("correct_px must be > 0");
  for (const double sigma : {edge_sigma_px, keypoint_sigma_px, edge_sigma_min_motion_px})
    if (!(sigma >= 0.0) || !std::isfinite(sigma))
      return fail(
          "edge_sigma_px, keypoint_sigma_px and edge_sigma_min_motion_px must be finite and >= 0");
  if (!(border_margin_px >= 0.0)) return fail("border_margin_px must be >= 0");
  if (!(reacquire_margin_px >= 0.0)) return fail("reacquire_margin_px must be >= 0");
  if (!(reid_max_shape_px >= 0.0)) return fail("reid_max_shape_px must be >= 0");
  if (tag_scan_every < 0) return fail("tag_scan_every must be >= 0");
  if (first_rect_id < 0) return fail("first_rect_id must be >= 0");
  if (min_visible_corners < 2 || min_visible_corners > 4)
    return fail("min_visible_corners must be 2, 3 or 4");
  std::string sub;
  if (!rect.Check(&sub)) return fail("rect: " + sub);
  if (!apriltag.Check(&sub)) return fail("apriltag: " + sub);
  if (!tracker.Check(&sub)) return fail("tracker: " + sub);
  if (!points.Check(&sub)) return fail("points: " + sub);
  return true;
}

// x_cur ~ K R_Ccur_Cprev K^-1 x_prev: where a pixel of the previous frame appears after a pure
// rotation of the camera (the infinite homography; exact for distant points, a prediction for near
// ones).
Corners RotateCorners(const Corners& c, const Mat3& K, const Mat3& R_Cprev_Ccur) {
  const Mat3 H = K * R_Cprev_Ccur.transpose() * K.inverse();
  Corners out;
  for (int j = 0; j < 4; ++j) {
    const Vec3 x = H * Vec3(c[j].x(), c[j].y(), 1.0);
    out[j] = x.z() > 1e-9 ? Vec2(x.head<2>() / x.z()) : c[j];
  }
  return out;
}

// AprilTag decoding of the tag-like rectangles: the crop around each is given to the AprilTag
// detector, and a decoded tag whose corners match the rectangle's replaces it (with its id and
// the tag's own corner order).
void FrontEnd::Impl::DecodeTags(const cv::Mat& gray, const FrontEndOptions& o,
                                std::vector<Detection>* dets) {
  for (Detection& d : *dets) {
    if (d.object_class != ObjectClass::kTag || d.tag_id >= 0) continue;
    const Eigen::AlignedBox2d box = BoundingBox(d.corners_px);
    const double m = o.tag_crop_margin_frac * box.sizes().maxCoeff() + 4.0;
    const cv::Rect roi = PixelBox(box, m, gray.cols, gray.rows);
    if (roi.width < 8 || roi.height < 8) continue;
    const AprilTagDetector::Result r = crops.Detect(gray(roi).clone());
    const double gate = std::max(3.0, o.match_gate_frac * ShortestSide(d.corners_px));
    for (const Detection& t : r.detections) {
      Corners px = t.corners_px;
      for (Vec2& c : px) c += Vec2(roi.x, roi.y);
      if (MeanCornerDistanceBestShift(d.corners_px, px) > gate) continue;
      d.tag_id = t.tag_id;
      d.corners_px = px;
      for (int j = 0; j < 4; ++j) d.corners_undistorted[j] = camera.UndistortPixel(px[j]);
      d.score = t.score;
      d.side_sign = {0, 0, 0, 0};  // the tag's corners, not the rectangle's sides
      break;
    }
  }
}

std::vector<Detection> FrontEnd::Impl::Detect(const cv::Mat& gray,
                                              const FramePrediction& prediction,
                                              const std::map<int, Corners>& tracked,
                                              const FrontEndOptions& o) {
  if (o.detector == DetectorKind::kAprilTag) return tags.Detect(gray, &camera).detections;
  const Vec3* gravity = prediction.gravity_C ? &*prediction.gravity_C : nullptr;
  // The insides of the confirmed objects tracked in this frame, in image pixels.
  std::vector<Corners> skip;
  if (o.detect_skip_tracked_frac > 0.0)
    for (const auto& [id, und] : tracked) {
      if (!objects.at(id).confirmed) continue;
      Corners px;
      for (int i = 0; i < 4; ++i) px[i] = camera.DistortPixel(und[i]);
      if (!IsConvex(px)) continue;
      skip.push_back(
          MovedFromCentroid(px, -std::max(4.0, o.detect_skip_tracked_frac * ShortestSide(px))));
    }
  std::vector<Detection> dets = rect.Detect(gray, &camera, gravity, &skip).detections;
  DecodeTags(gray, o, &dets);
  if (o.tag_scan_every > 0 && frame_index - last_tag_scan >= o.tag_scan_every) {
    last_tag_scan = frame_index;
    // Tags found by the scan replace the rectangles that are the same quad (decoded or not) and
    // are added where the rectangle detector saw nothing.
    for (const Detection& t : tags.Detect(gray, &camera).detections) {
      const double gate = std::max(3.0, o.match_gate_frac * ShortestSide(t.corners_px));
      bool replaced = false;
      for (Detection& d : dets)
        if (MeanCornerDistanceBestShift(d.corners_px, t.corners_px) <= gate) {
          d = t;
          replaced = true;
        }
      if (!replaced) dets.push_back(t);
    }
    // The same tag twice (replaced twice): keep the first.
    std::vector<Detection> unique;
    for (const Detection& d : dets) {
      bool dup = false;
      for (const Detection& u : unique) dup = dup || (d.tag_id >= 0 && u.tag_id == d.tag_id);
      if (!dup) unique.push_back(d);
    }
    dets = std::move(unique);
  }
  return dets;
}

// Tracks every live object (corners predicted through the gyroscope's rotation). Returns whether
// a confirmed object was lost; a candidate lost before confirmation is forgotten.
bool FrontEnd::Impl::TrackAll(FrameWork* w) {
  std::map<int, Corners> predicted;
  if (w->prediction.R_Cprev_Ccur)
    for (const auto& [id, info] : objects)
      if (info.active) predicted[id] = RotateCorners(info.last, K, *w->prediction.R_Cprev_Ccur);
  bool lost = false;
  for (const TrackedObject& t : tracker.Track(w->pyramid, predicted)) {
    ObjectInfo& info = objects[t.id];
    // A candidate not confirmed within confirm_within_frames is a stray detection: forgotten (it
    // would keep the detector running on every frame).
    const bool expired = !info.confirmed && ++info.candidate_frames > w->o.confirm_within_frames;
    if (t.tracked && !expired) {
      double moved = 0.0;  // mean corner motion since the previous frame [px]
      for (int j = 0; j < 4; ++j) moved += 0.25 * (t.corners_undistorted[j] - info.last[j]).norm();
      if (t.blurred || !t.edge_refined || moved < w->o.edge_sigma_min_motion_px)
        w->coarse.insert(t.id);
      info.last = t.corners_undistorted;
      w->tracked[t.id] = t.corners_undistorted;
      if (!t.in_view) w->out_of_view[t.id] = t.seen;  // partly in view
      w->score[t.id] = t.score;
      if (t.blurred) w->blurred.insert(t.id);
      if (t.edge_refined) w->edge_fitted.insert(t.id);
      if (t.outline_off) w->outline_off.insert(t.id);
      continue;
    }
    info.active = false;
    if (info.confirmed) {
      ++w->result.lost;
      lost = true;
    } else {
      tracker.Drop(t.id);
      objects.erase(t.id);
    }
  }
  return lost;
}

// The confirmed dormant objects the back end predicts wholly in view, MARGIN_PX inside the image
// (their entries of prediction.objects): they are coming back.
std::vector<const std::pair<int, Corners>*> FrontEnd::Impl::PredictedDormant(
    const FramePrediction& prediction, double margin_px) const {
  std::vector<const std::pair<int, Corners>*> out;
  for (const auto& entry : prediction.objects) {
    const auto it = objects.find(entry.first);
    if (it == objects.end() || it->second.active || !it->second.confirmed) continue;
    bool in_view = true;
    for (const Vec2& p : entry.second)
      in_view = in_view && camera.InImage(camera.DistortPixel(p), margin_px);
    if (in_view) out.push_back(&entry);
  }
  return out;
}

bool FrontEnd::Impl::DetectionDue(bool lost_now, const FramePrediction& prediction,
                                  const FrontEndOptions& o) const {
  int candidates = 0, confirmed_live = 0;
  for (const auto& [id, info] : objects)
    if (info.active) (info.confirmed ? confirmed_live : candidates)++;
  return frame_index - last_detect_frame >= o.detect_every || candidates > 0 || lost_now ||
         lost_last_frame || confirmed_live == 0 ||
         (o.detect_on_predicted_return && !PredictedDormant(prediction, 0.0).empty());
}

// One more detection run that saw the object; confirms a candidate after confirm_detections.
void FrontEnd::Impl::Vote(ObjectInfo& info, const Detection& d, FrameWork* w) const {
  ++info.detections;
  ++info.class_votes[d.object_class];
  // A plain detection touching the border may be an outline closed by an inner edge (the
  // object's side just out of view): it does not confirm a candidate.
  const bool may_confirm =
      !w->o.confirm_away_from_border || d.tag_id >= 0 || AwayFromBorder(d, w->o);
  if (!info.confirmed && info.detections >= w->o.confirm_detections && may_confirm) {
    info.confirmed = true;
    ++w->result.started;
  }
}

// Makes object ID live at CORNERS from detection D (a new one, or a resumed one).
void FrontEnd::Impl::Activate(int id, const Corners& corners, const Detection& d, FrameWork* w) {
  ObjectInfo& info = objects[id];
  info.active = true;
  info.last = corners;
  Vote(info, d, w);
  w->from_detection[id] = corners;
  w->score[id] = d.score;
}

// One observation per confirmed object seen in this frame with its four corners in view.
void FrontEnd::Impl::Emit(int64_t t_ns, FrameWork* w) {
  for (const std::map<int, Corners>* source : {&w->tracked, &w->from_detection})
    for (const auto& [id, c] : *source) {
      const ObjectInfo& info = objects[id];
      const bool by_track = source == &w->tracked;
      if (!info.confirmed) continue;
      if (by_track && (w->from_detection.count(id) || w->outline_off.count(id))) continue;
      ObjectObservation obs;
      const auto partial = by_track ? w->out_of_view.find(id) : w->out_of_view.end();
      if (partial != w->out_of_view.end()) {
        if (CountSeen(partial->second) < w->o.min_visible_corners) continue;
        obs.seen = partial->second;
      }
      obs.t_ns = t_ns;
      obs.object_id = id;
      obs.object_class = info.Class();
      obs.corners = c;
      obs.score = w->score[id];
      // Coarse: tracked without fitted edges, or re-acquired in its smear (ReacquirePredicted).
      const bool coarse = w->coarse.count(id) && (by_track || w->blurred.count(id));
      obs.sigma_px = coarse ? w->o.keypoint_sigma_px : w->o.edge_sigma_px;
      w->result.observations.push_back(obs);
    }
  std::sort(w->result.observations.begin(), w->result.observations.end(),
            [](const ObjectObservation& a, const ObjectObservation& b) {
              return a.object_id < b.object_id;
            });
  for (const auto& [id, info] : objects) w->result.candidates += info.active && !info.confirmed;
}

FrontEnd::FrontEnd(const PinholeRadtan& camera, Options options)
    : options_(std::move(options)), impl_(std::make_unique<Impl>(camera, options_)) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
}

FrontEnd::~FrontEnd() = default;

ObjectClass FrontEnd::ClassOf(int object_id) const {
  const auto it = impl_->objects.find(object_id);
  return it == impl_->objects.end() ? ObjectClass::kUnknown : it->second.Class();
}

FrontEndResult FrontEnd::Process(const Frame& frame, const FramePrediction& prediction) {
  Impl& m = *impl_;
  const cv::Mat& gray = frame.image;
  if (gray.empty() || gray.type() != CV_8UC1)
    throw InputError(frame.source + ": the front end needs an 8-bit grey image");
  if (gray.cols != m.camera.width || gray.rows != m.camera.height)
    throw InputError(frame.source + ": image is " + std::to_string(gray.cols) + "x" +
                     std::to_string(gray.rows) + " but the calibration is " +
                     std::to_string(m.camera.width) + "x" + std::to_string(m.camera.height));
  Stopwatch sw;
  // One pyramid for the objects' flow and the points' (each uses its own window and levels).
  const bool points = m.points != nullptr;
  const FlowPyramid pyramid =
      BuildFlowPyramid(gray,
                       points ? std::max(options_.tracker.lk_window, options_.points.lk_window)
                              : options_.tracker.lk_window,
                       points ? std::max(options_.tracker.lk_levels, m.points->pyramid_levels())
                              : options_.tracker.lk_levels);
  Impl::FrameWork w(gray, pyramid, prediction, options_);
  const bool lost_now = m.TrackAll(&w);
  w.result.times.Add("track", sw.Lap());
  std::vector<Detection> dets;
  if (m.DetectionDue(lost_now, prediction, options_)) {
    dets = m.Detect(gray, prediction, w.tracked, options_);
    m.last_detect_frame = m.frame_index;
    w.result.detected = true;
    w.result.detections = static_cast<int>(dets.size());
  }
  m.lost_last_frame = lost_now;
  w.result.times.Add("detect", sw.Lap());
  // Tags by id first, then plain rectangles to live tracks by corner distance (greedy, nearest
  // first), then re-identification or a new candidate.
  std::vector<bool> used(dets.size(), false);
  m.AssociateTags(dets, &used, &w);
  m.EndPlainTracksOnTags(dets, &w);
  m.MatchTracks(dets, &used, &w);
  m.StartOrResume(dets, used, &w);
  m.ReacquirePredicted(&w);
  w.result.times.Add("associate", sw.Lap());
  m.Emit(frame.t_ns, &w);
  if (points) {
    w.result.points = m.points->Track(pyramid, frame.t_ns, prediction.R_Cprev_Ccur).points;
    w.result.times.Add("points", sw.Lap());
  }
  ++m.frame_index;
  return std::move(w.result);
}

}  // namespace fsp::frontend
