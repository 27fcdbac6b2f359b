// Ceres reprojection factor of a point feature (backend/README.md, "Points"): one scene point in
// anchored inverse depth, as VINS-Mono's ProjectionFactor, written with the FHP factor's
// homogeneous point (fhp_factor.h) so that the prediction stays finite for far points:
//
//   a = (x_F, y_F, 1)                       (the anchor view's normalised bearing, K⁻¹ (u, v, 1):
//                                            fixed by that observation, not a parameter)
//   h = R_C_W ( ρ (p_W_F − p_W_C) + R_W_F a )    (= ρ p_C: the point, scaled by its inverse depth
//                                                  ρ = 1 / z_F along F's optical axis)
//   z = π(K h),   e = (z − z^obs) / σ_px         (UNDISTORTED pixels, 2 residuals)
//
// Poses come from body pose blocks: T_W_C = T_W_B(camera kf) T_B_C, T_W_F = T_W_B(anchor kf) T_B_C
// with the calibration's T_B_C, as the FSP/FHP factors. In the anchor view (C = F) the prediction
// is the observation itself, independent of ρ: that view adds no factor. Cheirality as in
// fsp_factor.h: h_z ≤ min_h_z makes Evaluate return false (check PredictPoint(...).in_front before
// adding).
#pragma once

#include <ceres/sized_cost_function.h>

#include "fsp/backend/fsp_factor.h"
#include "fsp/common/geometry.h"

namespace fsp::backend {

// The point's prediction in camera T_W_C (CAMERA poses here, not bodies): pixel, homogeneous depth
// h_z = ρ z_C, in front when h_z > 0.
struct PointPrediction {
  Vec2 uv = Vec2::Zero();
  double h_z = 0.0;
  bool in_front = false;
};
PointPrediction PredictPoint(const Mat3& K, const Rigid3& T_W_C, const Rigid3& T_W_F,
                             const Vec3& bearing_F, double rho);

// Blocks (camera body pose[7], anchor body pose[7], ρ[1]); ambient Jacobians (positions Euclidean,
// quaternions through LeftRotationJacobianWrtQuat), so they compose with any manifold.
class PointFactor final : public ceres::SizedCostFunction<2, 7, 7, 1> {
 public:
  // bearing_F: (x, y, 1) of the anchor view, normalised coordinates.
  PointFactor(const Vec2& uv_px, const Vec3& bearing_F, const Mat3& K, const Rigid3& T_B_C,
              const FspFactorOptions& options);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vec2 obs_;
  Vec3 a_;
  Mat3 K_;
  Rigid3 T_B_C_;
  FspFactorOptions options_;
};

}  // namespace fsp::backend
