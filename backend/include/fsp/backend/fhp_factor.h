// Ceres reprojection factor of one corner of a Framed-Homogeneous-Points rectangle (the FSP paper's
// baseline, backend/README.md, "Landmark models"): every corner is an independent anchored
// inverse-depth point, 2 residuals.
//
//   h = R_C_W ( ω (p_W_F − p_W_C) + R_W_F (u, v, 1) ),   z = π(K h),   e = (z − z^obs) / σ_px
//
// Block fhp[3] = (u, v, log ω) (fsp_landmark.h; d/dlog ω = ω d/dω). Same homogeneous trick as the
// FSP factor: when C = F the prediction is π(K (u, v, 1)), independent of ω. Cheirality as in
// fsp_factor.h: h_z ≤ min_h_z makes Evaluate return false (check PredictFhpCorners(...).in_front
// before adding).
#pragma once

#include <ceres/sized_cost_function.h>

#include "fsp/backend/fsp_factor.h"
#include "fsp/backend/fsp_landmark.h"

namespace fsp::backend {

CornerPrediction PredictFhpCorners(const Mat3& K, const Rigid3& T_W_C, const Rigid3& T_W_F,
                                   const FhpLandmark& landmark);

// Blocks (camera body pose[7], anchor body pose[7], fhp corner[3]); ambient Jacobians.
class FhpFactor final : public ceres::SizedCostFunction<2, 7, 7, 3> {
 public:
  FhpFactor(const Vec2& corner_px, const Mat3& K, const Rigid3& T_B_C,
            const FspFactorOptions& options);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vec2 obs_;
  Mat3 K_;
  Rigid3 T_B_C_;
  FspFactorOptions options_;
};

// Observation in the anchor keyframe (C = F): z = π(K (u, v, 1)). Block (fhp corner[3]); the log ω
// column is identically zero.
class FhpAnchorFactor final : public ceres::SizedCostFunction<2, 3> {
 public:
  FhpAnchorFactor(const Vec2& corner_px, const Mat3& K, const FspFactorOptions& options);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vec2 obs_;
  Mat3 K_;
  FspFactorOptions options_;
};

}  // namespace fsp::backend
