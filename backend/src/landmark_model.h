// The estimator's landmark model (backend/README.md, "Landmark models"): an object's rectangle as
// FSP (8 DoF) or FHP (12 DoF) behind one value type, so the estimator never asks which one it
// holds. A model owns its parameter blocks (with their manifold and the depth box), the factors of
// one observation, the prediction (corners, pose, size), the re-anchoring, the width/height σ from
// a covariance and the initialisation from a single view. Internal: included by the estimator's
// files only.
#pragma once

#include <utility>
#include <variant>
#include <vector>

#include <ceres/ceres.h>

#include "fsp/backend/estimator.h"
#include "fsp/backend/fhp_factor.h"
#include "fsp/backend/fsp_factor.h"
#include "fsp/backend/fsp_landmark.h"
#include "marginal_covariance.h"

namespace fsp::backend::internal {

// What a landmark needs from the estimator to enter a problem: the camera, the corner noise and
// loss, the depth box [min_depth_m, max_depth_m] on the inverse depths, the σ of the width prior,
// and the quaternion manifold (the estimator's, shared by its problems; they do not own it).
struct LandmarkContext {
  Mat3 K;
  Rigid3 T_B_C;
  FspFactorOptions factor;
  RobustLossOptions robust;
  double min_depth_m = 0.3, max_depth_m = 30.0;
  double prior_log_omega_sigma = 1.0;
  ceres::Manifold* quaternion_manifold = nullptr;
};

class Landmark {
 public:
  Landmark() = default;  // an FSP landmark at its defaults (a placeholder until assigned)
  // The factory: the single-view initialisation (an FSP landmark in the new anchor) as `type`.
  static Landmark FromSingleView(LandmarkType type, const FspLandmark& init);

  // --- Problem --------------------------------------------------------------------------------
  // The factor(s) of one observation (corners in pixels, those in `seen`: an object partly in
  // view gives the corners it shows) from the keyframe with body pose block `camera_pose` (camera
  // pose T_W_C) of the landmark anchored at the keyframe with `anchor_pose` (T_W_F); the same
  // block: the anchor's own view. Adds the landmark's blocks with their manifold and clamps and
  // bounds the inverse depth(s) to the box. Adds nothing and returns false when the landmark is
  // behind the camera.
  bool AddObservation(ceres::Problem* problem, const Corners& corners, const CornerMask& seen,
                      double* camera_pose, double* anchor_pose, const Rigid3& T_W_C,
                      const Rigid3& T_W_F, const LandmarkContext& c);
  // The prior on the metric width (the class's typical width `width_m`, σ prior_log_omega_sigma
  // in log) when the landmark's blocks are in the problem (priors.h: FSP's LogWidthPrior, FHP's
  // MakeFhpLogWidthPrior). Without parallax (hover) it is all that holds the depth.
  void AddWidthPrior(ceres::Problem* problem, double width_m, const LandmarkContext& c);
  bool InProblem(const ceres::Problem& problem) const;

  // --- Geometry (anchor camera pose T_W_F) ----------------------------------------------------
  CornerPrediction Predict(const Mat3& K, const Rigid3& T_W_C, const Rigid3& T_W_F) const;
  std::array<Vec3, 4> CornersW(const Rigid3& T_W_F) const;
  Rigid3 T_W_O(const Rigid3& T_W_F) const;
  std::pair<double, double> Size() const;  // (width, height) [m]
  // Whether the depth of s1 (FSP) or of every corner (FHP) lies strictly inside the box.
  bool DepthInBox(double min_depth_m, double max_depth_m) const;
  // Moves the anchor from T_W_F to T_W_Fnew, the geometry unchanged (reanchor.h); false (and the
  // landmark unchanged) when it would not be in front of the new anchor.
  bool Reanchor(const Rigid3& T_W_F, const Rigid3& T_W_Fnew);

  // --- Covariance -----------------------------------------------------------------------------
  // The covariance blocks SizeSigmas needs.
  void AppendCovarianceBlocks(std::vector<std::pair<const double*, const double*>>* blocks) const;
  // (σ_w, σ_h) [m], first order.
  std::pair<double, double> SizeSigmas(const MarginalCovariance& covariance) const;
  // The block the map's log scale s = ½ (log w + log h) is linear in; nullptr when the model
  // reports no scale σ (FHP).
  const double* ScaleBlock() const;
  // Cov(s, s_other) from the covariance block of the two ScaleBlocks (both non-null).
  double ScaleCovariance(const MarginalCovariance& covariance, const Landmark& other) const;

 private:
  explicit Landmark(std::variant<FspLandmark, FhpLandmark> l) : l_(std::move(l)) {}
  // Ceres keeps the addresses of the blocks inside: a landmark in a problem must not move (copy
  // assignment keeps them: the alternative never changes).
  std::variant<FspLandmark, FhpLandmark> l_;
};

}  // namespace fsp::backend::internal
