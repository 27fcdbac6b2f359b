// Internal to the object tracker (not installed): ObjectTracker::Impl and the state it keeps per
// object. Its member functions live in three files:
//   object_tracker.cc     options, the object model (Init), flow point seeding, edge refinement
//                         and the public ObjectTracker interface;
//   object_appearance.cc  the appearance model: the frame warped into the reference patch, NCC,
//                         boxes and masks of a quad; ObjectTracker::Similarity;
//   object_track_step.cc  one frame: the optical flow of all objects (Track) and the per-object
//                         step (TrackOne) in its stages.
//
// Coordinates: the object plane is the reference patch's pixel grid without its margin ring: the
// object's outline runs from (-0.5, -0.5) (s4, top-left) to (W - 0.5, H - 0.5) (s2, bottom-right),
// patch pixel (i, j) samples object point (i - mx, j - my). Homographies map the object plane to
// UNDISTORTED pixels (a plane seen by a pinhole); flow points and the pyramid live in the distorted
// image as stored.
#pragma once

#include <algorithm>
#include <array>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/error.h"
#include "fsp/common/types.h"
#include "fsp/frontend/edge_refine.h"
#include "fsp/frontend/object_tracker.h"

namespace fsp::frontend {
namespace object_tracker_internal {

inline Vec2 Apply(const Mat3& H, const Vec2& p) {
  const Vec3 q = H * Vec3(p.x(), p.y(), 1.0);
  return Vec2(q.x() / q.z(), q.y() / q.z());
}

// Exact homography of four point pairs (DLT with h33 = 1, 8x8 solve in double).
bool HomographyFrom4(const Corners& from, const Corners& to, Mat3* H);

}  // namespace object_tracker_internal

struct ObjectTracker::Impl {
  struct Object {
    int id = -1;
    bool active = false;
    // Model: object-plane size (patch pixels without the margin) and margin.
    int w = 0, h = 0, mx = 0, my = 0;
    Corners obj_corners;                          // s1..s4 in the object plane
    std::vector<Vec2> model_xy;                   // descriptor keypoints in the object plane
    cv::Mat model_desc;                           // ORB descriptors (rows of model_xy)
    cv::Mat ref;                                  // reference patch, CV_32F, smoothed
    cv::Mat ref_valid;                            // CV_8U, 1 where the reference was in view
    std::array<int, 4> side_sign = {0, 0, 0, 0};  // edge polarity per side, 0 = unknown
    // Per side, the sharpest view so far (SideSharpness, decaying; see blur_sharpness_ratio).
    std::array<double, 4> sharpness = {0.0, 0.0, 0.0, 0.0};
    // SideSharpness of the view the model was built from (or its outline relearnt from).
    std::array<double, 4> start_sharpness = {0.0, 0.0, 0.0, 0.0};
    bool textured_interior = false;  // the reference's interior has structure (grey std >= 8)
    // State.
    Mat3 H = Mat3::Identity(), H_prev = Mat3::Identity();
    bool has_motion = false;          // H_prev valid (constant-velocity prediction)
    std::vector<Vec2> pt_obj;         // flow points in the object plane
    std::vector<cv::Point2f> pt_img;  // and in the last frame (distorted px)
    int frames_since_refresh = 0;
    int seeded = 0;              // flow points right after the last seeding
    int unsupported_frames = 0;  // sharp frames in a row with its outline off the edges
  };

  // One object's point correspondences in one frame (TrackOne): the flow points that survived,
  // then the descriptor matches of a recovery.
  struct Correspondences {
    std::vector<cv::Point2f> obj_pts, img_pts;  // object plane, undistorted px
    std::vector<cv::Point2f> obj_dist;          // their distorted image positions
    int n_flow = 0;                             // the first n_flow are flow points
  };

  // The homography the correspondences agree on (TrackOne); the prediction when they do not.
  struct Consensus {
    Mat3 H;
    bool strong = false;  // sane and with at least min_inliers inliers
    int inliers = 0;
  };

  PinholeRadtan camera;
  const Options& o;
  bool distorted = false;
  std::map<int, Object> objects;
  std::vector<cv::Mat> prev_pyr;  // with derivatives (buildOpticalFlowPyramid)
  cv::Mat prev_gray;
  cv::Mat smooth;  // EdgeRefineImage, filled per object region
  cv::Ptr<cv::ORB> orb;

  Impl(const PinholeRadtan& cam, const Options& opt) : camera(cam), o(opt) {
    distorted = camera.HasDistortion();
    orb = cv::ORB::create(std::max(o.model_keypoints, 1), 1.3f, 4, 31, 0, 2, cv::ORB::HARRIS_SCORE,
                          31, 10);
  }

  Vec2 ToDistorted(const Vec2& u) const { return distorted ? camera.DistortPixel(u) : u; }
  Vec2 ToUndistorted(const Vec2& d) const { return distorted ? camera.UndistortPixel(d) : d; }

  Corners CornersOf(const Object& ob, const Mat3& H) const {
    Corners c;
    for (int i = 0; i < 4; ++i) c[i] = object_tracker_internal::Apply(H, ob.obj_corners[i]);
    return c;
  }

  // object_tracker.cc
  void CheckFrame(const cv::Mat& gray) const;
  std::vector<cv::Mat> Pyramid(const cv::Mat& gray) const;
  void SetPrevFrame(const cv::Mat& gray);
  std::vector<cv::Point2f> Corners2D(const cv::Mat& img, const cv::Mat& mask,
                                     double min_dist) const;
  void ResetCornerPoints(Object* ob, const Corners& corners_px, const cv::Mat& gray) const;
  void SeedPoints(Object* ob, const cv::Mat& gray) const;
  // SIDE_SIGN: the polarities to refine with instead of the object's (all 0: any).
  bool Refine(const Object& ob, const cv::Mat& gray, const Corners& c, bool coarse,
              EdgeRefinement* out, const std::array<int, 4>* side_sign = nullptr);
  // SIDE_SIGN (build_model only): the polarities tried when either polarity per side fails.
  bool Init(Object* ob, const cv::Mat& gray, const Corners& corners, bool build_model,
            const std::array<int, 4>& side_sign = {0, 0, 0, 0});

  // object_appearance.cc
  static std::vector<cv::Mat> Levels(const std::vector<cv::Mat>& pyr, bool with_derivatives);
  // Direct alignment of the frame to the reference patch: H moved (Gauss-Newton on the quad's
  // corners, normalised residuals) so that the warped frame matches the reference best.
  // Gauss-Newton on the 8 corner coordinates of H (with SHIFT_ONLY on one image shift of all
  // four): the frame warped through H matched to TARGET (the reference patch, or a smeared copy of
  // it) where TARGET_VALID, both normalised.
  void AlignToReference(const Object& ob, const std::vector<cv::Mat>& levels, const cv::Mat& target,
                        const cv::Mat& target_valid, bool shift_only, Mat3* H) const;
  // The reference patch as the frame shows it through H0 when its corners move by MOTION (per
  // corner, over one frame interval) during an exposure of `exposure` frame intervals, and where
  // that is known (every instant within the reference patch).
  void SmearedReference(const Object& ob, const Mat3& H0, const Corners& motion, double exposure,
                        cv::Mat* smeared, cv::Mat* valid) const;
  double PatchScale(const Object& ob, const Mat3& H) const;
  double Warp(const Object& ob, const std::vector<cv::Mat>& levels, const Mat3& H, cv::Mat* patch,
              cv::Mat* valid) const;
  static double Ncc(const cv::Mat& a, const cv::Mat& va, const cv::Mat& b, const cv::Mat& vb);
  double Appearance(const Object& ob, const std::vector<cv::Mat>& levels, const Mat3& H,
                    double* visible) const;
  static cv::Rect Interior(const Object& ob);
  cv::Rect Box(const Corners& und, double margin) const;
  cv::Mat QuadMask(const Corners& und, const cv::Rect& r, int erode) const;

  // object_track_step.cc
  int FlowCorrespondences(const Object& ob, const std::vector<cv::Point2f>& p1,
                          const std::vector<uint8_t>& good, size_t offset,
                          Correspondences* c) const;
  void MatchModel(const Object& ob, const cv::Mat& gray, const Mat3& H_pred, Correspondences* c);
  Consensus FitHomography(const Object& ob, const Mat3& H_pred, const Correspondences& c,
                          bool recovered) const;
  std::array<double, 4> SideSharpness(const cv::Mat& gray, const Corners& c);
  int UnsupportedSides(const cv::Mat& gray, const Corners& c);
  bool Smeared(Object* ob, const cv::Mat& gray, const Corners& c);
  bool RefineOnEdges(Object* ob, const cv::Mat& gray, const Consensus& k, bool recovered,
                     Corners* final_corners, Mat3* H_final, bool* blurred);
  bool AlignBlurred(const Object& ob, const std::vector<cv::Mat>& levels, Corners* final_corners,
                    Mat3* H_final) const;
  // blur_shape_from_prediction: H_pred moved by the scale and shift that map it onto the
  // correspondences H_FINAL holds (within ransac_px); replaces H_FINAL and FINAL_CORNERS when it
  // matches the reference better (returns true).
  bool ShapeFromPrediction(const Object& ob, const std::vector<cv::Mat>& levels, const Mat3& H_pred,
                           const Correspondences& c, Corners* final_corners, Mat3* H_final) const;
  // fast_align_*: where the object is near H_pred when its corners moved by MOTION (per corner,
  // over a frame interval) of at least fast_align_min_motion_px: H_pred shifted so that the frame
  // matches the reference smeared by MOTION (with the exposure that fits best at H_pred). False
  // when the motion is slower, the shift too large or the match too poor; else the corners,
  // homography, NCC and fraction in view there.
  bool AlignFastMotion(const Object& ob, const std::vector<cv::Mat>& levels, const Mat3& H_pred,
                       const Corners& motion, Corners* final_corners, Mat3* H_final, double* ncc,
                       double* visible) const;
  // The image levels the appearance model warps from (the frame and 3 halvings).
  static std::vector<cv::Mat> AppearanceLevels(const cv::Mat& gray);
  void Advance(Object* ob, const cv::Mat& gray, const TrackedObject& t, const Correspondences& c,
               const Mat3& H_final, bool strong) const;
  TrackedObject TrackOne(Object* ob, const cv::Mat& gray, const std::vector<cv::Mat>& levels,
                         const Mat3& H_pred, const std::vector<cv::Point2f>& p1,
                         const std::vector<uint8_t>& good, size_t offset);
  // PYR: GRAY's flow pyramid (Pyramid, or a shared one's first lk_levels levels).
  std::vector<TrackedObject> Track(const cv::Mat& gray, const std::vector<cv::Mat>& pyr,
                                   const std::map<int, Corners>& predicted);
};

}  // namespace fsp::frontend
