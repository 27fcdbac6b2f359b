// One frame of the object tracker (ObjectTracker::Impl, see object_tracker_internal.h): the
// forward-backward optical flow of all objects' points (Track) and the per-object step (TrackOne)
// in its stages: flow correspondences, descriptor matching (recovery), consensus homography, edge
// refinement, appearance check, next frame's points.
#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/video/tracking.hpp>

#include "fsp/frontend/edge_refine.h"
#include "fsp/frontend/rect_geometry.h"
#include "object_tracker_internal.h"

namespace fsp::frontend {

using object_tracker_internal::Apply;
using object_tracker_internal::HomographyFrom4;

// The flow points that survived, as correspondences; returns their number.
int ObjectTracker::Impl::FlowCorrespondences(const Object& ob, const std::vector<cv::Point2f>& p1,
                                             const std::vector<uint8_t>& good, size_t offset,
                                             Correspondences* c) const {
  std::vector<cv::Point2f>& obj_pts = c->obj_pts;
  std::vector<cv::Point2f>& img_pts = c->img_pts;
  std::vector<cv::Point2f>& obj_dist = c->obj_dist;
  const size_t n = ob.pt_obj.size();
  int survived = 0;
  for (size_t k = 0; k < n; ++k) {
    if (!good[offset + k]) continue;
    ++survived;
    const Vec2 u = ToUndistorted(Vec2(p1[offset + k].x, p1[offset + k].y));
    obj_pts.emplace_back(static_cast<float>(ob.pt_obj[k].x()),
                         static_cast<float>(ob.pt_obj[k].y()));
    img_pts.emplace_back(static_cast<float>(u.x()), static_cast<float>(u.y()));
    obj_dist.push_back(p1[offset + k]);
  }
  c->n_flow = static_cast<int>(obj_pts.size());
  return survived;
}

// Recovery: descriptors of the predicted region (dilated) matched against the model, appended
// to the correspondences.
void ObjectTracker::Impl::MatchModel(const Object& ob, const cv::Mat& gray, const Mat3& H_pred,
                                     Correspondences* c) {
  std::vector<cv::Point2f>& obj_pts = c->obj_pts;
  std::vector<cv::Point2f>& img_pts = c->img_pts;
  std::vector<cv::Point2f>& obj_dist = c->obj_dist;
  // Search region: the predicted and the last quad, grown by the object's size.
  const Corners pc = CornersOf(ob, H_pred);
  const double size = std::sqrt(std::abs(SignedArea(pc)));
  const cv::Rect r = Box(pc, size + 30.0) | Box(CornersOf(ob, ob.H), size + 30.0);
  if (r.width > 40 && r.height > 40) {
    std::vector<cv::KeyPoint> kps;
    cv::Mat desc;
    orb->setMaxFeatures(std::max(2 * o.model_keypoints, 100));
    orb->detectAndCompute(gray(r), cv::noArray(), kps, desc);
    if (!kps.empty()) {
      cv::BFMatcher matcher(cv::NORM_HAMMING);
      std::vector<std::vector<cv::DMatch>> knn;
      matcher.knnMatch(desc, ob.model_desc, knn, 2);
      for (const auto& m : knn) {
        if (m.empty()) continue;
        if (m.size() == 2 && m[0].distance > o.match_ratio * m[1].distance) continue;
        const cv::Point2f p = kps[m[0].queryIdx].pt + cv::Point2f(r.x, r.y);
        const Vec2 u = ToUndistorted(Vec2(p.x, p.y));
        const Vec2& X = ob.model_xy[m[0].trainIdx];
        obj_pts.emplace_back(static_cast<float>(X.x()), static_cast<float>(X.y()));
        img_pts.emplace_back(static_cast<float>(u.x()), static_cast<float>(u.y()));
        obj_dist.push_back(p);
      }
    }
  }
}

// Consensus: RANSAC homography object plane -> undistorted image.
ObjectTracker::Impl::Consensus ObjectTracker::Impl::FitHomography(const Object& ob,
                                                                  const Mat3& H_pred,
                                                                  const Correspondences& c,
                                                                  bool recovered) const {
  const std::vector<cv::Point2f>& obj_pts = c.obj_pts;
  const std::vector<cv::Point2f>& img_pts = c.img_pts;
  Mat3 H = H_pred;
  bool strong = false;
  int inliers = 0;
  if (obj_pts.size() >= 4) {
    std::vector<uint8_t> mask;
    cv::Mat Hcv;
    // Cheap path first (most frames: flow points only, nearly all right): a least-squares fit
    // to all points; when >= 90 % of them lie within ransac_px it is refitted to those and
    // RANSAC is not needed (~5x cheaper). Otherwise, or after a recovery, RANSAC.
    if (!recovered && obj_pts.size() >= 8) {
      const double r2 = o.ransac_px * o.ransac_px;
      for (int pass = 0; pass < 2; ++pass) {
        std::vector<cv::Point2f> a, b;
        for (size_t k = 0; k < obj_pts.size(); ++k)
          if (pass == 0 || mask[k]) {
            a.push_back(obj_pts[k]);
            b.push_back(img_pts[k]);
          }
        Hcv = cv::findHomography(a, b, 0);
        if (Hcv.empty()) break;
        const cv::Matx33d Hm(Hcv);
        mask.assign(obj_pts.size(), 0);
        size_t n_in = 0;
        for (size_t k = 0; k < obj_pts.size(); ++k) {
          const cv::Vec3d q = Hm * cv::Vec3d(obj_pts[k].x, obj_pts[k].y, 1.0);
          const double dx = q[0] / q[2] - img_pts[k].x, dy = q[1] / q[2] - img_pts[k].y;
          mask[k] = dx * dx + dy * dy <= r2;
          n_in += mask[k];
        }
        if (n_in < 0.9 * obj_pts.size()) {
          Hcv = cv::Mat();
          break;
        }
      }
    }
    if (Hcv.empty()) Hcv = cv::findHomography(obj_pts, img_pts, cv::RANSAC, o.ransac_px, mask, 500);
    if (!Hcv.empty()) {
      Mat3 Hk;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) Hk(a, b) = Hcv.at<double>(a, b);
      inliers = static_cast<int>(std::count(mask.begin(), mask.end(), 1));
      const Corners kc = CornersOf(ob, Hk);
      const Corners pc = CornersOf(ob, H_pred);
      const double area_ratio = std::abs(SignedArea(kc)) / std::max(std::abs(SignedArea(pc)), 1e-9);
      const bool sane = IsConvex(kc) && area_ratio > 0.5 && area_ratio < 2.0;
      if (sane && inliers >= o.min_inliers) {
        strong = true;
        H = Hk;
      } else if (sane && inliers >= 4 && area_ratio > 0.8 && area_ratio < 1.25) {
        H = Hk;  // a few points (a plain object's corners): better than the prediction alone
      }
    }
  }
  Consensus k;
  k.H = H;
  k.strong = strong;
  k.inliers = inliers;
  return k;
}

// Least motion of a side across itself between frames [px] for it to count as smeared.
constexpr double kBlurMinMotionPx = 8.0;

// Motion blur (ObjectTrackerOptions::blur_sharpness_ratio): a side of quad C that is less sharp
// than half (the ratio) its sharpest view so far and moved across itself by more than
// kBlurMinMotionPx since the last frame. Updates the object's sharpest views (decaying by 2 % per
// frame).
bool ObjectTracker::Impl::Smeared(Object* ob, const cv::Mat& gray, const Corners& c) {
  const Corners prev = CornersOf(*ob, ob->H);
  const std::array<double, 4> sharp = SideSharpness(gray, c);
  bool smeared = false;
  for (int i = 0; i < 4; ++i) {
    const Vec2 P = c[(i + 3) % 4], Q = c[i];
    const Vec2 u = (Q - P).normalized();
    const double across =
        std::abs(Vec2(-u.y(), u.x()).dot(0.5 * (P + Q) - 0.5 * (prev[(i + 3) % 4] + prev[i])));
    smeared = smeared || (sharp[i] >= 0.0 && across > kBlurMinMotionPx &&
                          sharp[i] < o.blur_sharpness_ratio * ob->sharpness[i]);
    ob->sharpness[i] = std::max(sharp[i], 0.98 * ob->sharpness[i]);
  }
  return smeared;
}

// Edge refinement (the side polarities learnt at Start) of the consensus quad: FINAL_CORNERS and
// H_FINAL, the refined ones when it succeeds (returns true), else the consensus'. BLURRED: the
// object's sides are smeared in this frame (Smeared); a trusted keypoint homography then keeps
// the corners.
bool ObjectTracker::Impl::RefineOnEdges(Object* ob, const cv::Mat& gray, const Consensus& k,
                                        bool recovered, Corners* final_corners, Mat3* H_final,
                                        bool* blurred) {
  const Mat3& H = k.H;
  const bool strong = k.strong;
  const Corners kp_corners = CornersOf(*ob, H);
  EdgeRefinement e;
  *final_corners = kp_corners;
  // With a trusted keypoint homography, the edges refine it only for an object whose outline
  // was found at Start (a known polarity per side): on an object without a clear outline (or
  // one blurred at Start) an edge fit is noise that would drag the points with it.
  const bool outline_known = ob->side_sign[0] != 0;
  // After a recovery the matched homography is coarser (ORB keypoints of a pyramid level):
  // the coarse pass runs and its shift is allowed.
  const bool coarse = !strong || recovered;
  const double max_shift = recovered ? o.coarse_search_px : o.max_refine_shift_px;
  // A smeared outline is not where the object is, the flow's homography is (the flow follows the
  // smeared texture's centre); without a trusted homography nothing is (see AlignFastMotion).
  *blurred = o.blur_sharpness_ratio > 0.0 && outline_known && Smeared(ob, gray, kp_corners);
  bool edge_refined = false;
  if (!*blurred && (!strong || outline_known) && Refine(*ob, gray, kp_corners, coarse, &e) &&
      (!strong || MaxCornerDistance(e.corners_undistorted, kp_corners) <= max_shift)) {
    *final_corners = e.corners_undistorted;
    edge_refined = true;
  }
  *H_final = H;
  if (edge_refined && !HomographyFrom4(ob->obj_corners, *final_corners, H_final)) {
    edge_refined = false;
    *final_corners = kp_corners;
    *H_final = H;
  }
  return edge_refined;
}

// A blurred object's keypoint homography aligned to its reference patch (blur_align_*):
// FINAL_CORNERS and H_FINAL replaced when the alignment is kept (returns true).
bool ObjectTracker::Impl::AlignBlurred(const Object& ob, const std::vector<cv::Mat>& levels,
                                       Corners* final_corners, Mat3* H_final) const {
  if (o.blur_align_min_appearance <= 0.0) return false;
  double visible = 0.0;
  if (Appearance(ob, levels, *H_final, &visible) < o.blur_align_min_appearance) return false;
  Mat3 H = *H_final;
  AlignToReference(ob, levels, ob.ref, ob.ref_valid, false, &H);
  const Corners c = CornersOf(ob, H);
  if (MaxCornerDistance(c, *final_corners) > o.blur_align_max_shift_px) return false;
  *final_corners = c;
  *H_final = H;
  return true;
}

// A blurred object whose alignment was refused (blur_shape_from_prediction): the prediction's
// shape, scaled and shifted onto the flow.
bool ObjectTracker::Impl::ShapeFromPrediction(const Object& ob, const std::vector<cv::Mat>& levels,
                                              const Mat3& H_pred, const Correspondences& c,
                                              Corners* final_corners, Mat3* H_final) const {
  if (!o.blur_shape_from_prediction) return false;
  // The correspondences the consensus holds, at the prediction (p) and as measured (m).
  std::vector<Vec2> p, m;
  const double r2 = o.ransac_px * o.ransac_px;
  for (size_t k = 0; k < c.obj_pts.size(); ++k) {
    const Vec2 X(c.obj_pts[k].x, c.obj_pts[k].y);
    const Vec2 x(c.img_pts[k].x, c.img_pts[k].y);
    if ((Apply(*H_final, X) - x).squaredNorm() > r2) continue;
    p.push_back(Apply(H_pred, X));
    m.push_back(x);
  }
  if (p.size() < 4) return false;
  // Least squares of m = s (p - p̄) + m̄.
  Vec2 p_mean = Vec2::Zero(), m_mean = Vec2::Zero();
  for (size_t k = 0; k < p.size(); ++k) {
    p_mean += p[k];
    m_mean += m[k];
  }
  p_mean /= static_cast<double>(p.size());
  m_mean /= static_cast<double>(p.size());
  double num = 0.0, den = 0.0;
  for (size_t k = 0; k < p.size(); ++k) {
    num += (p[k] - p_mean).dot(m[k] - m_mean);
    den += (p[k] - p_mean).squaredNorm();
  }
  if (!(den > 0.0)) return false;
  const double s = num / den;
  Mat3 S = Mat3::Identity();
  S(0, 0) = S(1, 1) = s;
  S.block<2, 1>(0, 2) = m_mean - s * p_mean;
  const Mat3 H = S * H_pred;
  double visible = 0.0;
  if (Appearance(ob, levels, H, &visible) <= Appearance(ob, levels, *H_final, &visible))
    return false;
  *H_final = H;
  *final_corners = CornersOf(ob, H);
  return true;
}

// An object the keypoints lost in a fast move, looked for at its prediction (fast_align_*).
bool ObjectTracker::Impl::AlignFastMotion(const Object& ob, const std::vector<cv::Mat>& levels,
                                          const Mat3& H_pred, const Corners& motion,
                                          Corners* final_corners, Mat3* H_final, double* ncc,
                                          double* visible) const {
  double longest = 0.0;
  for (const Vec2& m : motion) longest = std::max(longest, m.norm());
  if (o.fast_align_min_motion_px <= 0.0 || longest < o.fast_align_min_motion_px) return false;
  // The exposure's share of the frame interval: the one whose smear matches best at the start.
  cv::Mat patch, valid;
  Warp(ob, levels, H_pred, &patch, &valid);
  cv::Mat target, target_valid;
  double best = -2.0;
  for (const double exposure : {0.25, 0.5, 0.75, 1.0}) {
    cv::Mat smeared, smeared_valid;
    SmearedReference(ob, H_pred, motion, exposure, &smeared, &smeared_valid);
    const double score = Ncc(smeared, smeared_valid, patch, valid);
    if (score > best) {
      best = score;
      target = smeared;
      target_valid = smeared_valid;
    }
  }
  // One shift of the predicted quad: in a smear of tens of pixels the shape is poorly seen, and
  // the prediction (the last quad turned by the gyroscope's rotation) has it.
  Mat3 H = H_pred;
  AlignToReference(ob, levels, target, target_valid, true, &H);
  const Corners c = CornersOf(ob, H);
  const double in_view = Warp(ob, levels, H, &patch, &valid);
  *ncc = Ncc(target, target_valid, patch, valid);
  if (MaxCornerDistance(c, CornersOf(ob, H_pred)) > o.fast_align_max_shift_px ||
      *ncc < o.fast_align_min_ncc)
    return false;
  *final_corners = c;
  *H_final = H;
  *visible = in_view;
  return true;
}

// The object's state after a tracked frame: its flow points for the next frame, its homography,
// and new points when due.
void ObjectTracker::Impl::Advance(Object* ob, const cv::Mat& gray, const TrackedObject& t,
                                  const Correspondences& c, const Mat3& H_final,
                                  bool strong) const {
  const std::vector<cv::Point2f>& obj_pts = c.obj_pts;
  const std::vector<cv::Point2f>& img_pts = c.img_pts;
  const std::vector<cv::Point2f>& obj_dist = c.obj_dist;
  const int n_flow = c.n_flow;
  const bool outline_known = ob->side_sign[0] != 0;  // as in RefineOnEdges
  // Next frame's points: the correspondences that agree with the final homography (flow points
  // and recovered matches), at their measured positions.
  std::vector<Vec2> new_obj;
  std::vector<cv::Point2f> new_img;
  const double keep2 = 2.25 * o.ransac_px * o.ransac_px;
  for (size_t k = 0; k < obj_pts.size(); ++k) {
    const Vec2 X(obj_pts[k].x, obj_pts[k].y);
    if ((Apply(H_final, X) - Vec2(img_pts[k].x, img_pts[k].y)).squaredNorm() > keep2) continue;
    if (static_cast<int>(k) >= n_flow) {  // a match: skip when a flow point holds it already
      bool dup = false;
      for (const cv::Point2f& q : new_img) dup |= cv::norm(q - obj_dist[k]) < 2.0;
      if (dup) continue;
    }
    new_obj.push_back(X);
    if (t.edge_refined || t.blurred) {
      // The edges fix the homography to the object's outline: points follow it, so that the
      // flow cannot drift away from the model (each point keeps only this frame's LK error). In
      // a blurred frame they follow the aligned (or the consensus) homography: each point's flow
      // on the smeared texture drifts on its own.
      const Vec2 d = ToDistorted(Apply(H_final, X));
      new_img.emplace_back(static_cast<float>(d.x()), static_cast<float>(d.y()));
    } else {
      new_img.push_back(obj_dist[k]);
    }
  }
  ob->pt_obj.swap(new_obj);
  ob->pt_img.swap(new_img);
  ob->H_prev = ob->H;
  ob->H = H_final;
  // Constant velocity only from a steady frame: after a recovery or a weak consensus the
  // last motion may be a jump.
  ob->has_motion = strong && !t.recovered;
  ++ob->frames_since_refresh;
  // New points take their object-plane position from this frame's homography: only from a
  // homography fixed by the edges or the reference, or by the flow alone for an object without a
  // known outline.
  const bool confident =
      !t.fast && t.appearance >= o.refresh_appearance &&
      (t.edge_refined || t.aligned || (!outline_known && strong && !t.recovered));
  if (confident && (ob->frames_since_refresh >= o.refresh_every ||
                    2 * static_cast<int>(ob->pt_obj.size()) < ob->seeded)) {
    SeedPoints(ob, gray);
    ob->seeded = static_cast<int>(ob->pt_obj.size());
    ob->frames_since_refresh = 0;
  } else {
    ResetCornerPoints(ob, t.corners_px, gray);  // corners always follow the final quad
  }
}

TrackedObject ObjectTracker::Impl::TrackOne(Object* ob, const cv::Mat& gray,
                                            const std::vector<cv::Mat>& levels, const Mat3& H_pred,
                                            const std::vector<cv::Point2f>& p1,
                                            const std::vector<uint8_t>& good, size_t offset) {
  TrackedObject t;
  t.id = ob->id;
  const size_t n = ob->pt_obj.size();
  Correspondences c;
  const int survived = FlowCorrespondences(*ob, p1, good, offset, &c);
  // Recovery: descriptors of the predicted region (dilated) matched against the model.
  if (ob->model_desc.rows >= o.min_inliers &&
      (survived < o.recover_fraction * static_cast<double>(n) || survived < o.min_inliers)) {
    t.recovered = true;
    MatchModel(*ob, gray, H_pred, &c);
  }
  const Consensus k = FitHomography(*ob, H_pred, c, t.recovered);
  const bool strong = k.strong;
  const int inliers = k.inliers;
  t.keypoints = inliers;
  Corners final_corners;
  Mat3 H_final;
  t.edge_refined = RefineOnEdges(ob, gray, k, t.recovered, &final_corners, &H_final, &t.blurred);
  if (t.blurred) t.aligned = AlignBlurred(*ob, levels, &final_corners, &H_final);
  if (t.blurred && !t.aligned && strong)
    ShapeFromPrediction(*ob, levels, H_pred, c, &final_corners, &H_final);
  bool lost = !strong && !t.edge_refined;
  double visible = 0.0;
  if (!lost) {
    t.appearance = Appearance(*ob, levels, H_final, &visible);
    lost = visible < o.min_visible || t.appearance < o.min_appearance;
  }
  bool outline_lost = false;
  if (!lost && o.max_unsupported_frames > 0 && ob->side_sign[0] != 0) {
    t.outline_off = UnsupportedSides(gray, final_corners) >= 2;
    if (!t.blurred) {  // a smeared frame neither counts nor resets
      ob->unsupported_frames = t.outline_off ? ob->unsupported_frames + 1 : 0;
      outline_lost = ob->unsupported_frames >= o.max_unsupported_frames;
    }
  }
  if (lost) {  // the keypoints lost it: a fast move?
    const Corners pred = CornersOf(*ob, H_pred), last = CornersOf(*ob, ob->H);
    Corners motion;
    for (int i = 0; i < 4; ++i) motion[i] = pred[i] - last[i];
    if (AlignFastMotion(*ob, levels, H_pred, motion, &final_corners, &H_final, &t.appearance,
                        &visible)) {
      lost = visible < o.min_visible;
      t.fast = t.blurred = !lost;
    }
  }
  if (lost || outline_lost) {
    ob->active = false;
    ob->pt_obj.clear();
    ob->pt_img.clear();
    return t;
  }
  t.tracked = true;
  t.corners_undistorted = final_corners;
  for (int i = 0; i < 4; ++i) {
    const Vec2 d = ToDistorted(final_corners[i]);
    t.corners_px[i] = d;
    t.seen[i] = camera.InImage(d);
  }
  t.in_view = t.seen == kAllCorners;
  const double a =
      std::clamp((t.appearance - o.min_appearance) / (1.0 - o.min_appearance + 1e-9), 0.0, 1.0);
  t.score = 0.5 * a + 0.25 * (t.edge_refined ? 1.0 : 0.0) +
            0.25 * std::min(1.0, inliers / (2.0 * o.min_inliers));
  Advance(ob, gray, t, c, H_final, strong);
  return t;
}

std::vector<TrackedObject> ObjectTracker::Impl::Track(const cv::Mat& gray,
                                                      const std::vector<cv::Mat>& pyr,
                                                      const std::map<int, Corners>& predicted) {
  CheckFrame(gray);
  std::vector<TrackedObject> out;
  std::vector<Object*> act;
  for (auto& [id, ob] : objects)
    if (ob.active) act.push_back(&ob);
  if (!act.empty() && !prev_pyr.empty()) {
    // Predictions: the caller's corners, else constant velocity of the homography
    // (H_pred = M H with M = H H_prev^-1, the last frame-to-frame motion in the image).
    std::vector<Mat3> H_pred(act.size());
    std::vector<cv::Point2f> p0, p1;
    std::vector<size_t> offset(act.size());
    for (size_t a = 0; a < act.size(); ++a) {
      Object* ob = act[a];
      Mat3 Hp = ob->has_motion ? Mat3(ob->H * ob->H_prev.inverse() * ob->H) : ob->H;
      const auto it = predicted.find(ob->id);
      Mat3 Hc;
      if (it != predicted.end() && HomographyFrom4(ob->obj_corners, it->second, &Hc)) Hp = Hc;
      if (!IsConvex(CornersOf(*ob, Hp))) Hp = ob->H;
      H_pred[a] = Hp;
      offset[a] = p0.size();
      // Initial flow: the points moved by the predicted motion (the prediction's image of
      // their object-plane position, shifted by their last residual).
      for (size_t k = 0; k < ob->pt_obj.size(); ++k) {
        const Vec2 last = ToDistorted(Apply(ob->H, ob->pt_obj[k]));
        const Vec2 pred = ToDistorted(Apply(Hp, ob->pt_obj[k]));
        const cv::Point2f q = ob->pt_img[k];
        p0.push_back(q);
        p1.emplace_back(static_cast<float>(q.x + pred.x() - last.x()),
                        static_cast<float>(q.y + pred.y() - last.y()));
      }
    }
    std::vector<uint8_t> good(p0.size(), 0);
    const std::vector<cv::Point2f> p1_init = p1;
    if (!p0.empty()) {
      std::vector<uint8_t> st, st_back;
      std::vector<float> err;
      const cv::TermCriteria crit(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, o.lk_iterations,
                                  0.03);
      const cv::Size win(o.lk_window, o.lk_window);
      // The backward pass starts from where the point was (the answer a correct forward match
      // gives), so it needs no coarse levels: one level above the image absorbs a forward error
      // of a few pixels and anything worse fails the check anyway.
      const int back_levels = std::min(1, o.lk_levels);
      cv::calcOpticalFlowPyrLK(prev_pyr, pyr, p0, p1, st, err, win, o.lk_levels, crit,
                               cv::OPTFLOW_USE_INITIAL_FLOW);
      std::vector<cv::Point2f> back = p0;
      cv::calcOpticalFlowPyrLK(pyr, prev_pyr, p1, back, st_back, err, win, back_levels, crit,
                               cv::OPTFLOW_USE_INITIAL_FLOW);
      const double fb2 = o.max_fb_error_px * o.max_fb_error_px;
      auto check = [&](size_t k, const cv::Point2f& q, const cv::Point2f& b, bool ok) {
        const cv::Point2f d = b - p0[k];
        return ok && d.x * d.x + d.y * d.y <= fb2 && q.x >= 0 && q.y >= 0 && q.x <= gray.cols - 1 &&
               q.y <= gray.rows - 1;
      };
      std::vector<size_t> retry;
      for (size_t k = 0; k < p0.size(); ++k) {
        good[k] = check(k, p1[k], back[k], st[k] && st_back[k]);
        if (!good[k] && cv::norm(p1_init[k] - p0[k]) > 2.0) retry.push_back(k);
      }
      // Points lost with a motion prediction get a second chance from where they were: the
      // prediction is wrong when the motion stops or turns abruptly.
      if (!retry.empty()) {
        std::vector<cv::Point2f> q0, q1, qb;
        for (const size_t k : retry) q0.push_back(p0[k]);
        q1 = q0;
        cv::calcOpticalFlowPyrLK(prev_pyr, pyr, q0, q1, st, err, win, o.lk_levels, crit,
                                 cv::OPTFLOW_USE_INITIAL_FLOW);
        qb = q0;
        cv::calcOpticalFlowPyrLK(pyr, prev_pyr, q1, qb, st_back, err, win, back_levels, crit,
                                 cv::OPTFLOW_USE_INITIAL_FLOW);
        for (size_t j = 0; j < retry.size(); ++j)
          if (check(retry[j], q1[j], qb[j], st[j] && st_back[j])) {
            good[retry[j]] = 1;
            p1[retry[j]] = q1[j];
          }
      }
    }
    const std::vector<cv::Mat> levels = Levels(pyr, true);
    for (size_t a = 0; a < act.size(); ++a)
      out.push_back(TrackOne(act[a], gray, levels, H_pred[a], p1, good, offset[a]));
  }
  prev_pyr = pyr;
  prev_gray = gray.clone();
  return out;
}

}  // namespace fsp::frontend
