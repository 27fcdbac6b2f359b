#include "fsp/frontend/frontend.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <set>

#include <opencv2/core.hpp>

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
  if (!(border_margin_px >= 0.0)) return fail("border_margin_px must be >= 0");
  if (tag_scan_every < 0) return fail("tag_scan_every must be >= 0");
  if (first_rect_id < 0) return fail("first_rect_id must be >= 0");
  std::string sub;
  if (!rect.Check(&sub)) return fail("rect: " + sub);
  if (!apriltag.Check(&sub)) return fail("apriltag: " + sub);
  if (!tracker.Check(&sub)) return fail("tracker: " + sub);
  return true;
}

namespace {

Corners Shifted(const Corners& c, int r) {
  Corners out;
  for (int j = 0; j < 4; ++j) out[j] = c[(j + r) % 4];
  return out;
}

Vec2 Centroid(const Corners& c) {
  return 0.25 * (c[0] + c[1] + c[2] + c[3]);
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

struct ObjectInfo {
  bool confirmed = false;
  bool active = false;
  bool is_tag = false;       // a decoded AprilTag (its id is the tag id)
  int detections = 0;        // detection runs that matched it
  int candidate_frames = 0;  // frames tracked as a candidate
  std::map<ObjectClass, int> class_votes;
  Corners last;  // last tracked corners (undistorted px)

  ObjectClass Class() const {
    ObjectClass best = ObjectClass::kUnknown;
    int best_n = 0;
    for (const auto& [c, n] : class_votes)
      if (n > best_n) {
        best = c;
        best_n = n;
      }
    return best;
  }
};

}  // namespace

struct FrontEnd::Impl {
  PinholeRadtan camera;
  Mat3 K;
  RectDetector rect;
  AprilTagDetector tags;   // full frames (kAprilTag)
  AprilTagDetector crops;  // tag-like rectangles (kRect): small crops, decimate 1
  ObjectTracker tracker;
  std::map<int, ObjectInfo> objects;
  int next_rect_id = 0;
  int frame_index = 0;
  int last_detect_frame = -1000000;
  int last_tag_scan = -1000000;
  bool lost_last_frame = false;

  Impl(const PinholeRadtan& cam, const FrontEndOptions& o)
      : camera(cam),
        K(cam.K()),
        rect(o.rect),
        tags(o.apriltag),
        crops([&] {
          AprilTagDetectorOptions c = o.apriltag;
          c.decimate = 1.0;
          return c;
        }()),
        tracker(cam,
                [&] {
                  ObjectTrackerOptions t = o.tracker;
                  t.refine = o.rect;  // one set of refinement options for detector and tracker
                  return t;
                }()),
        next_rect_id(o.first_rect_id) {}

  // AprilTag decoding of the tag-like rectangles: the crop around each is given to the AprilTag
  // detector, and a decoded tag whose corners match the rectangle's replaces it (with its id and
  // the tag's own corner order).
  void DecodeTags(const cv::Mat& gray, const FrontEndOptions& o, std::vector<Detection>* dets) {
    for (Detection& d : *dets) {
      if (d.object_class != ObjectClass::kTag || d.tag_id >= 0) continue;
      double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
      for (const Vec2& c : d.corners_px) {
        x0 = std::min(x0, c.x());
        y0 = std::min(y0, c.y());
        x1 = std::max(x1, c.x());
        y1 = std::max(y1, c.y());
      }
      const double m = o.tag_crop_margin_frac * std::max(x1 - x0, y1 - y0) + 4.0;
      const cv::Rect roi = cv::Rect(cv::Point(static_cast<int>(std::floor(x0 - m)),
                                              static_cast<int>(std::floor(y0 - m))),
                                    cv::Point(static_cast<int>(std::ceil(x1 + m)) + 1,
                                              static_cast<int>(std::ceil(y1 + m)) + 1)) &
                           cv::Rect(0, 0, gray.cols, gray.rows);
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
        break;
      }
    }
  }

  std::vector<Detection> Detect(const cv::Mat& gray, const FramePrediction& prediction,
                                const std::map<int, Corners>& tracked, const FrontEndOptions& o) {
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

  // Whether every corner of D is at least `border_margin_px` inside the image: near the border the
  // detector may have closed the quad with an inner edge (the object's own side just out of view).
  bool AwayFromBorder(const Detection& d, const FrontEndOptions& o) const {
    for (const Vec2& c : d.corners_px)
      if (c.x() < o.border_margin_px || c.y() < o.border_margin_px ||
          c.x() > camera.width - 1 - o.border_margin_px ||
          c.y() > camera.height - 1 - o.border_margin_px)
        return false;
    return true;
  }

  // A dormant object that detection D is a view of, with the corner order that fits it; -1 if none.
  int Reidentify(const cv::Mat& gray, const Detection& d, const FramePrediction& prediction,
                 const FrontEndOptions& o, Corners* corners) const {
    // With gravity known the corner order is canonical (s1 bottom-left): only that order is tried;
    // without it, all four.
    const int orders = prediction.gravity_C ? 1 : 4;
    // A detection touching the border may be an outline closed by an inner edge: its corners may
    // lie near another object's prediction and its look match a plain look-alike. It gets no lower
    // bar, and once the map is known it returns only where the map predicts it.
    const bool whole = AwayFromBorder(d, o);
    int best_id = -1;
    double best_sim = -2.0, second_sim = -2.0;    // best over objects, and the next object's best
    bool best_near = false, second_near = false;  // ... predicted at the detection by the map
    for (const auto& [id, info] : objects) {
      if (info.active || !info.confirmed) continue;
      // The back end's prediction: behind the camera or far from the detection, geometry says no;
      // near it, a lower bar.
      const auto& behind = prediction.objects_behind;
      if (std::find(behind.begin(), behind.end(), id) != behind.end()) continue;
      const auto predicted =
          std::find_if(prediction.objects.begin(), prediction.objects.end(),
                       [id = id](const std::pair<int, Corners>& p) { return p.first == id; });
      if (prediction.map_known && predicted == prediction.objects.end()) continue;
      double need = o.reid_min_similarity;
      bool elsewhere = false, near = false;
      for (const auto& [pid, pc] : prediction.objects) {
        if (pid != id) continue;
        const double dist = MeanCornerDistanceBestShift(pc, d.corners_undistorted);
        near = dist <= o.reid_gate_frac * ShortestSide(pc);
        if (near && whole) need = o.reid_min_similarity_predicted;
        elsewhere = dist > o.reid_reject_frac * ShortestSide(pc);
      }
      if (elsewhere) continue;
      if (prediction.map_known && !near && !whole) continue;
      double object_best = -2.0;
      Corners object_corners = d.corners_undistorted;
      for (int r = 0; r < orders; ++r) {
        const Corners c = Shifted(d.corners_undistorted, r);
        const std::optional<double> sim = tracker.Similarity(id, gray, c);
        if (sim && *sim > object_best) {
          object_best = *sim;
          object_corners = c;
        }
      }
      if (object_best < need) continue;
      if (object_best > best_sim) {
        second_sim = best_sim;
        second_near = best_near;
        best_sim = object_best;
        best_near = near;
        best_id = id;
        *corners = object_corners;
      } else if (object_best > second_sim) {
        second_sim = object_best;
        second_near = near;
      }
    }
    // Two dormant objects that both look like the detection (a row of identical windows): which one
    // came back is not known, and a wrong identity would corrupt the map: a new object instead;
    // unless the map predicts the best one at the detection and the other one not.
    const bool map_decides = o.reid_map_decides && best_near && !second_near;
    if (best_id >= 0 && !map_decides && best_sim - second_sim < o.reid_min_margin) return -1;
    return best_id;
  }

  // What one Process call builds up.
  struct FrameWork {
    FrameWork(const cv::Mat& g, const FramePrediction& p, const FrontEndOptions& opt)
        : gray(g), prediction(p), o(opt) {}
    const cv::Mat& gray;
    const FramePrediction& prediction;
    const FrontEndOptions& o;
    FrontEndResult result;
    std::map<int, Corners> tracked;         // this frame's corners of the live objects
    std::map<int, Corners> from_detection;  // corners of objects (re)started in this frame
    std::map<int, double> score;            // their confidence (tracker or detector)
    std::set<int> out_of_view;              // tracked, but a corner is outside the image
  };

  // Tracks every live object (corners predicted through the gyroscope's rotation). Returns whether
  // a confirmed object was lost; a candidate lost before confirmation is forgotten.
  bool TrackAll(FrameWork* w) {
    std::map<int, Corners> predicted;
    if (w->prediction.R_Cprev_Ccur)
      for (const auto& [id, info] : objects)
        if (info.active) predicted[id] = RotateCorners(info.last, K, *w->prediction.R_Cprev_Ccur);
    bool lost = false;
    for (const TrackedObject& t : tracker.Track(w->gray, predicted)) {
      ObjectInfo& info = objects[t.id];
      // A candidate not confirmed within confirm_within_frames is a stray detection: forgotten (it
      // would keep the detector running on every frame).
      const bool expired = !info.confirmed && ++info.candidate_frames > w->o.confirm_within_frames;
      if (t.tracked && !expired) {
        info.last = t.corners_undistorted;
        w->tracked[t.id] = t.corners_undistorted;
        if (!t.in_view) w->out_of_view.insert(t.id);  // tracked on, not observed
        w->score[t.id] = t.score;
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

  // Whether the back end predicts a dormant object wholly in view: it is coming back, and the
  // detector runs so that it is re-identified in its first frame in view.
  bool DormantPredictedInView(const FramePrediction& prediction) const {
    for (const auto& [id, c] : prediction.objects) {
      const auto it = objects.find(id);
      if (it == objects.end() || it->second.active || !it->second.confirmed) continue;
      bool in_view = true;
      for (const Vec2& p : c) in_view = in_view && camera.InImage(camera.DistortPixel(p));
      if (in_view) return true;
    }
    return false;
  }

  bool DetectionDue(bool lost_now, const FramePrediction& prediction,
                    const FrontEndOptions& o) const {
    int candidates = 0, confirmed_live = 0;
    for (const auto& [id, info] : objects)
      if (info.active) (info.confirmed ? confirmed_live : candidates)++;
    return frame_index - last_detect_frame >= o.detect_every || candidates > 0 || lost_now ||
           lost_last_frame || confirmed_live == 0 ||
           (o.detect_on_predicted_return && DormantPredictedInView(prediction));
  }

  // One more detection run that saw the object; confirms a candidate after confirm_detections.
  void Vote(ObjectInfo& info, const Detection& d, FrameWork* w) const {
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
  void Activate(int id, const Corners& corners, const Detection& d, FrameWork* w) {
    ObjectInfo& info = objects[id];
    info.active = true;
    info.last = corners;
    Vote(info, d, w);
    w->from_detection[id] = corners;
    w->score[id] = d.score;
  }

  // Decoded tags: the tag id is the identity (a live one is confirmed, a dormant one resumed, an
  // unknown one started).
  void AssociateTags(const std::vector<Detection>& dets, std::vector<bool>* used, FrameWork* w) {
    for (size_t i = 0; i < dets.size(); ++i) {
      const Detection& d = dets[i];
      if (d.tag_id < 0) continue;
      (*used)[i] = true;
      auto it = objects.find(d.tag_id);
      if (it != objects.end() && it->second.active) {
        Vote(it->second, d, w);
        // A decoded tag's corners are the better measurement: a track more than correct_px off
        // (resumed on an undecoded outline, say) is put onto them.
        if (w->o.correct_tags && w->tracked.count(d.tag_id)) Correct(d.tag_id, d, w);
        continue;
      }
      const bool known = it != objects.end();
      if (known ? !tracker.Resume(d.tag_id, w->gray, d.corners_undistorted)
                : !tracker.Start(d.tag_id, w->gray, d.corners_undistorted))
        continue;
      ObjectInfo& info = objects[d.tag_id];
      info.is_tag = true;
      if (known && info.confirmed) ++w->result.reidentified;
      Activate(d.tag_id, d.corners_undistorted, d, w);
    }
  }

  // A plain track on a decoded tag is the tag seen as a rectangle (a mix of its black square and
  // its margin, say): the tag's identity wins and the plain track ends.
  void EndPlainTracksOnTags(const std::vector<Detection>& dets, FrameWork* w) {
    for (const Detection& d : dets) {
      if (d.tag_id < 0) continue;
      for (auto it = w->tracked.begin(); it != w->tracked.end();) {
        const int id = it->first;
        if (objects[id].is_tag || !InsideConvex(d.corners_undistorted, Centroid(it->second)) ||
            MeanCornerDistanceBestShift(it->second, d.corners_undistorted) >
                0.5 * ShortestSide(d.corners_undistorted)) {
          ++it;
          continue;
        }
        tracker.Drop(id);
        objects.erase(id);
        it = w->tracked.erase(it);
      }
    }
  }

  // Plain detections to live tracks, nearest first; a matched track that is more than correct_px
  // off the detection is put onto it (unless the detection touches the border).
  void MatchTracks(const std::vector<Detection>& dets, std::vector<bool>* used, FrameWork* w) {
    struct Pair {
      double dist;
      size_t det;
      int id;
    };
    std::vector<Pair> pairs;
    for (size_t i = 0; i < dets.size(); ++i) {
      if ((*used)[i]) continue;
      for (const auto& [id, c] : w->tracked) {
        const double dist = MeanCornerDistanceBestShift(c, dets[i].corners_undistorted);
        if (dist <= std::max(3.0, w->o.match_gate_frac * ShortestSide(c)))
          pairs.push_back({dist, i, id});
      }
    }
    std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
      return a.dist != b.dist ? a.dist < b.dist : a.det != b.det ? a.det < b.det : a.id < b.id;
    });
    std::set<int> track_matched;
    for (const Pair& p : pairs) {
      if ((*used)[p.det] || track_matched.count(p.id)) continue;
      (*used)[p.det] = true;
      track_matched.insert(p.id);
      const Detection& d = dets[p.det];
      if (ReidentifyAtConfirmation(p.id, d, w)) continue;
      Vote(objects[p.id], d, w);
      if (AwayFromBorder(d, w->o)) Correct(p.id, d, w);
    }
  }

  // A candidate about to be confirmed by detection D (whole, away from the border) that is a
  // dormant object coming back (Reidentify) becomes that object: the candidate, never reported, is
  // dropped and the old object resumes at D under its old id. A returning object is mostly first
  // detected at the border as it comes into view, where its outline is not trusted for
  // re-identification. Returns whether it did.
  bool ReidentifyAtConfirmation(int id, const Detection& d, FrameWork* w) {
    const ObjectInfo& info = objects[id];
    if (!w->o.reid_at_confirmation || info.confirmed || info.is_tag ||
        info.detections + 1 < w->o.confirm_detections || !AwayFromBorder(d, w->o))
      return false;
    Corners corners;
    const int old = Reidentify(w->gray, d, w->prediction, w->o, &corners);
    if (old < 0 || !tracker.Resume(old, w->gray, corners)) return false;
    tracker.Drop(id);
    objects.erase(id);
    w->tracked.erase(id);
    ++w->result.reidentified;
    Activate(old, corners, d, w);
    return true;
  }

  // Puts live object ID's track onto detection D's corners when a corner is more than correct_px
  // off (the tracker resumes from them, keeping its model).
  void Correct(int id, const Detection& d, FrameWork* w) {
    Corners& track = w->tracked[id];
    int shift = 0;
    MeanCornerDistanceBestShift(track, d.corners_undistorted, &shift);
    const Corners c = Shifted(d.corners_undistorted, shift);  // in the track's order
    double worst = 0.0;
    for (int j = 0; j < 4; ++j) worst = std::max(worst, (c[j] - track[j]).norm());
    if (worst > w->o.correct_px && tracker.Resume(id, w->gray, c)) {
      track = c;
      objects[id].last = c;
      ++w->result.corrected;
    }
  }

  // Detections no track took: re-identified dormant objects resume, others start candidates. A
  // detection on a live object (an outline nested in it, a track a little off) starts nothing, nor
  // does an undecoded tag.
  void StartOrResume(const std::vector<Detection>& dets, const std::vector<bool>& used,
                     FrameWork* w) {
    for (size_t i = 0; i < dets.size(); ++i) {
      if (used[i]) continue;
      const Detection& d = dets[i];
      const Vec2 centre = Centroid(d.corners_undistorted);
      // A candidate whose quad and the detection's overlap (each holds the other's centre) but do
      // not match: the candidate was started from a wrong outline (one closed by an inner edge
      // at the border, a side caught by a nearby edge) and its track follows that outline. The
      // detection replaces it and keeps its votes. Not a detection at the border: it may be the one
      // closed by an inner edge.
      int replaced_votes = 0;
      if (w->o.replace_candidates && d.object_class != ObjectClass::kTag && AwayFromBorder(d, w->o))
        for (auto it = w->tracked.begin(); it != w->tracked.end(); ++it) {
          const ObjectInfo& info = objects[it->first];
          const double area_ratio = std::abs(SignedArea(d.corners_undistorted)) /
                                    std::max(std::abs(SignedArea(it->second)), 1e-9);
          if (info.confirmed || info.is_tag || !InsideConvex(it->second, centre) ||
              !InsideConvex(d.corners_undistorted, Centroid(it->second)) || area_ratio < 0.5 ||
              area_ratio > 2.0)
            continue;
          replaced_votes = info.detections;
          tracker.Drop(it->first);
          objects.erase(it->first);
          w->tracked.erase(it);
          break;
        }
      bool on_live = false;
      for (const auto& [id, c] : w->tracked) on_live = on_live || InsideConvex(c, centre);
      if (on_live) continue;
      Corners corners;
      int id = Reidentify(w->gray, d, w->prediction, w->o, &corners);
      if (id < 0 && d.object_class == ObjectClass::kTag) continue;
      if (id >= 0) {
        if (!tracker.Resume(id, w->gray, corners)) continue;
        ++w->result.reidentified;
      } else {
        corners = d.corners_undistorted;
        id = next_rect_id;
        if (!tracker.Start(id, w->gray, corners)) continue;
        ++next_rect_id;
        objects[id].detections = replaced_votes;
      }
      Activate(id, corners, d, w);
    }
  }

  // One observation per confirmed object seen in this frame with its four corners in view.
  void Emit(int64_t t_ns, FrameWork* w) {
    for (const std::map<int, Corners>* source : {&w->tracked, &w->from_detection})
      for (const auto& [id, c] : *source) {
        const ObjectInfo& info = objects[id];
        const bool by_track = source == &w->tracked;
        if (!info.confirmed) continue;
        if (by_track && (w->from_detection.count(id) || w->out_of_view.count(id))) continue;
        ObjectObservation obs;
        obs.t_ns = t_ns;
        obs.object_id = id;
        obs.object_class = info.Class();
        obs.corners = c;
        obs.score = w->score[id];
        w->result.observations.push_back(obs);
      }
    std::sort(w->result.observations.begin(), w->result.observations.end(),
              [](const ObjectObservation& a, const ObjectObservation& b) {
                return a.object_id < b.object_id;
              });
    for (const auto& [id, info] : objects) w->result.candidates += info.active && !info.confirmed;
  }
};

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
  Impl::FrameWork w(gray, prediction, options_);
  Stopwatch sw;
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
  w.result.times.Add("associate", sw.Lap());
  m.Emit(frame.t_ns, &w);
  ++m.frame_index;
  return std::move(w.result);
}

}  // namespace fsp::frontend
