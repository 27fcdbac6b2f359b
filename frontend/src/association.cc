// The front end's association (FrontEnd::Impl, see frontend_internal.h): decoded tags by id, plain
// detections to live tracks by corner distance, unmatched ones to dormant objects by appearance and
// the back end's prediction (re-identification) or to new candidates; a track more than correct_px
// off its detection is put onto it.
#include <algorithm>
#include <optional>
#include <set>
#include <vector>

#include "frontend_internal.h"
#include "fsp/frontend/rect_geometry.h"

namespace fsp::frontend {

namespace {

// The corners of C starting at corner R: out[j] = c[(j + r) % 4].
Corners Shifted(const Corners& c, int r) {
  Corners out;
  for (int j = 0; j < 4; ++j) out[j] = c[(j + r) % 4];
  return out;
}

// Detection corners D in the corner order of track corners TRACK (the start that fits best).
Corners InTrackOrder(const Corners& track, const Corners& d) {
  int shift = 0;
  MeanCornerDistanceBestShift(track, d, &shift);
  return Shifted(d, shift);
}

// The mean of the four corners.
Vec2 Centroid(const Corners& c) {
  return 0.25 * (c[0] + c[1] + c[2] + c[3]);
}

}  // namespace

// The image borders (bits: left, top, right, bottom) that corner C lies within `border_margin_px`
// of.
int FrontEnd::Impl::NearBorders(const Vec2& c, const FrontEndOptions& o) const {
  const double m = o.border_margin_px;
  return (c.x() < m ? 1 : 0) | (c.y() < m ? 2 : 0) | (c.x() > camera.width - 1 - m ? 4 : 0) |
         (c.y() > camera.height - 1 - m ? 8 : 0);
}

// Whether every corner of D is at least `border_margin_px` inside the image: near the border the
// detector may have closed the quad with an inner edge (the object's own side just out of view).
bool FrontEnd::Impl::AwayFromBorder(const Detection& d, const FrontEndOptions& o) const {
  for (const Vec2& c : d.corners_px)
    if (NearBorders(c, o)) return false;
  return true;
}

bool FrontEnd::Impl::SideAlongBorder(const Detection& d, const FrontEndOptions& o) const {
  for (int i = 0; i < 4; ++i)
    if (NearBorders(d.corners_px[i], o) & NearBorders(d.corners_px[(i + 1) % 4], o)) return true;
  return false;
}

// A dormant object that detection D is a view of, with the corner order that fits it; -1 if none.
int FrontEnd::Impl::Reidentify(const cv::Mat& gray, const Detection& d,
                               const FramePrediction& prediction, const FrontEndOptions& o,
                               Corners* corners) const {
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
      near = dist <= o.reid_gate_frac * ShortestSide(pc) &&
             (!(o.reid_max_shape_px > 0.0) ||
              ShapeDifference(pc, d.corners_undistorted) <= o.reid_max_shape_px);
      if (near && whole) need = o.reid_min_similarity_predicted;
      elsewhere = dist > o.reid_reject_frac * ShortestSide(pc);
    }
    if (elsewhere) continue;
    if (prediction.map_known && !near && (!whole || o.reid_only_where_predicted)) continue;
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

// Decoded tags: the tag id is the identity (a live one is confirmed, a dormant one resumed, an
// unknown one started).
void FrontEnd::Impl::AssociateTags(const std::vector<Detection>& dets, std::vector<bool>* used,
                                   FrameWork* w) {
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
void FrontEnd::Impl::EndPlainTracksOnTags(const std::vector<Detection>& dets, FrameWork* w) {
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
void FrontEnd::Impl::MatchTracks(const std::vector<Detection>& dets, std::vector<bool>* used,
                                 FrameWork* w) {
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
    const bool was_confirmed = objects[p.id].confirmed;
    Vote(objects[p.id], d, w);
    // Confirmed in a view clearly sharper than its first: its polarities are relearnt on the
    // detection's outline (the track's may be off the edges it never found).
    if (!was_confirmed && objects[p.id].confirmed && w->o.relearn_outline_sharper > 0.0 &&
        !w->blurred.count(p.id))
      tracker.RelearnOutline(p.id, w->gray, InTrackOrder(w->tracked[p.id], d.corners_undistorted),
                             w->o.relearn_outline_sharper);
    if (AwayFromBorder(d, w->o) || (!w->edge_fitted.count(p.id) && !SideAlongBorder(d, w->o)))
      Correct(p.id, d, w);
  }
}

// A candidate about to be confirmed by detection D (whole, away from the border) that is a
// dormant object coming back (Reidentify) becomes that object: the candidate, never reported, is
// dropped and the old object resumes at D under its old id. A returning object is mostly first
// detected at the border as it comes into view, where its outline is not trusted for
// re-identification. Returns whether it did.
bool FrontEnd::Impl::ReidentifyAtConfirmation(int id, const Detection& d, FrameWork* w) {
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
// off (the tracker resumes from them, keeping its model); not while the object's edges are smeared
// (the detection's outline lies towards the smear's end, see ObjectTrackerOptions::
// blur_sharpness_ratio).
void FrontEnd::Impl::Correct(int id, const Detection& d, FrameWork* w) {
  if (w->blurred.count(id)) return;
  Corners& track = w->tracked[id];
  const Corners c = InTrackOrder(track, d.corners_undistorted);
  if (MaxCornerDistance(c, track) > w->o.correct_px && tracker.Resume(id, w->gray, c)) {
    track = c;
    objects[id].last = c;
    w->coarse.erase(id);
    ++w->result.corrected;
  }
}

// Detections no track took: re-identified dormant objects resume, others start candidates. A
// detection on a live object (an outline nested in it, a track a little off) starts nothing, nor
// does an undecoded tag.
void FrontEnd::Impl::StartOrResume(const std::vector<Detection>& dets,
                                   const std::vector<bool>& used, FrameWork* w) {
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
    int id = d.object_class == ObjectClass::kTag || !w->o.reid_away_from_border ||
                     AwayFromBorder(d, w->o)
                 ? Reidentify(w->gray, d, w->prediction, w->o, &corners)
                 : -1;
    if (id < 0 && d.object_class == ObjectClass::kTag) continue;
    if (id >= 0) {
      if (!tracker.Resume(id, w->gray, corners)) continue;
      ++w->result.reidentified;
    } else {
      corners = d.corners_undistorted;
      id = next_rect_id;
      if (!tracker.Start(id, w->gray, corners, d.side_sign)) continue;
      ++next_rect_id;
      objects[id].detections = replaced_votes;
    }
    Activate(id, corners, d, w);
  }
}

// Dormant objects the map predicts wholly in view that no detection resumed: each is looked for at
// its predicted corners (refined on the edges) and resumes there when it looks like itself.
void FrontEnd::Impl::ReacquirePredicted(FrameWork* w) {
  const FrontEndOptions& o = w->o;
  if (!o.reacquire_predicted || !w->prediction.map_known) return;
  for (const auto* predicted : PredictedDormant(w->prediction, o.reacquire_margin_px)) {
    const auto& [id, pc] = *predicted;
    // Not where a live object is (a nested outline, a look-alike tracked there). A plain candidate
    // there is more likely this object coming back, seen anew (the blur clip's poster returning
    // in a fast turn, started as a candidate on its smeared outline): it does not block the
    // re-acquisition, and is dropped when the object resumes.
    bool on_live = false;
    std::set<int> candidates;
    for (const std::map<int, Corners>* live : {&w->tracked, &w->from_detection})
      for (const auto& [lid, lc] : *live) {
        if (!InsideConvex(lc, Centroid(pc)) && !InsideConvex(pc, Centroid(lc))) continue;
        const ObjectInfo& info = objects.at(lid);
        if (o.reacquire_over_candidates && !info.confirmed && !info.is_tag)
          candidates.insert(lid);
        else
          on_live = true;
      }
    if (on_live) continue;
    // Its motion since the previous frame as the gyroscope's rotation moves it: in a fast turn the
    // tracker looks for it by its smeared reference instead of on edges.
    std::optional<Corners> motion;
    if (w->prediction.R_Cprev_Ccur) {
      const Corners before = RotateCorners(pc, K, w->prediction.R_Cprev_Ccur->transpose());
      motion.emplace();
      for (int i = 0; i < 4; ++i) (*motion)[i] = pc[i] - before[i];
    }
    Corners corners;
    double similarity = -1.0;
    bool smeared = false;
    const bool refined =
        tracker.Reacquire(id, w->gray, pc, &corners, &similarity, motion ? &*motion : nullptr,
                          &smeared) &&
        MeanCornerDistanceBestShift(pc, corners) <= o.reid_gate_frac * ShortestSide(pc);
    if (!refined) {
      // No edges where it is predicted (a thin frame blurred into one edge of the other polarity
      // on a small view): the prediction itself, when the object looks like itself there. The
      // track resumes from it, but this frame reports nothing: the prediction is the back end's
      // own estimate, not a measurement.
      corners = pc;
      similarity = tracker.Similarity(id, w->gray, pc).value_or(-1.0);
    }
    if (similarity < o.reid_min_similarity_predicted || !tracker.Resume(id, w->gray, corners))
      continue;
    ++w->result.reidentified;
    for (const int cid : candidates) {
      tracker.Drop(cid);
      objects.erase(cid);
      w->tracked.erase(cid);
      w->from_detection.erase(cid);
    }
    ObjectInfo& info = objects.at(id);
    info.active = true;
    info.last = corners;
    if (refined) w->from_detection[id] = corners;
    if (refined && smeared) {  // found in its smear: not fitted to edges
      w->coarse.insert(id);
      w->blurred.insert(id);
    }
    w->score[id] = similarity;
  }
}

}  // namespace fsp::frontend
