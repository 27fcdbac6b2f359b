// Ceres reprojection factor of a Framed-Structural-Points rectangle (backend/README.md, "Landmark
// models"; the paper's FSP observation model), one factor per object observation: 4 corners -> 8
// residuals.
//
//   a_j = r + R_F_O s̄_j                                   (corner j in F, scale 1/ω;
//   fsp_landmark.h) h_j = R_C_W ( ω (p_W_F − p_W_C) + R_W_F a_j )          (homogeneous: = ω
//   p_C(s_j), no 1/ω) z_j = π(K h_j),   π(x, y, z) = (x/z, y/z)                (UNDISTORTED pixels,
//   ideal pinhole K) e_j = (z_j − z_j^obs) / σ_px                            (whitened, 2 residuals
//   per corner)
//
// Poses come from body pose blocks: T_W_C = T_W_B(camera kf) T_B_C, T_W_F = T_W_B(anchor kf) T_B_C
// with the calibration T_B_C held by the factor. When C = F, h_j = a_j: the prediction depends only
// on the shape and the bearing, not on ω (nor on the pose); parallax in other views fixes ω. The
// authors' first-view residual compared pixels with normalised coordinates (no K); ours is the
// general model at C = F, K included.
//
// Cheirality: a corner with homogeneous depth h_z ≤ Options::min_h_z makes Evaluate return false.
// Ceres treats false as "cost not computable here": inside a solve the step is rejected and the
// trust region shrinks, but at the initial point the solve ends with FAILURE. Callers therefore
// check the prediction (PredictFspCorners(...).in_front) before adding a factor and drop
// observations behind the camera.
#pragma once

#include <memory>
#include <string>

#include <ceres/loss_function.h>
#include <ceres/sized_cost_function.h>

#include "fsp/backend/fsp_landmark.h"
#include "fsp/common/geometry.h"
#include "fsp/common/types.h"

namespace fsp::backend {

using Mat26 = Eigen::Matrix<double, 2, 6>;

struct FspFactorOptions {
  // Corner noise standard deviation [px]; residuals are divided by it (whitening).
  double sigma_px = 1.0;
  // Smallest accepted homogeneous depth h_z = ω z_C [-] (z_C = corner depth in the camera). Below
  // it the factor reports failure (see cheirality above). Small: only points behind or on the
  // camera plane.
  double min_h_z = 1e-9;
  bool Check(std::string* why) const;
};

// Robust loss on a whitened residual block of dimension d. The loss threshold is set on the block's
// RMS per coordinate: a block is an inlier while |e|² ≤ (k² d), i.e. Huber/Cauchy scale a = k √d.
// k = 2..3 (σ units): smaller rejects outliers harder but biases against inliers' tails. Cauchy
// by default: a view whose outline the front end took from a wrong edge (6-30 px off for a few
// frames) keeps a bounded pull under Huber, a vanishing one under Cauchy. Default room from pixels,
// render seeds 1/2/3 (keyframes 0.1 s, returns at the border not resumed): ATE 0.38/0.35/0.57 ->
// 0.35/0.31/0.49 cm, causal 2.5/2.8/3.1 -> 2.0/2.4/2.5 cm; gt-corners (Gaussian 1 px) the same
// within 0.02 cm, FHP too.
struct RobustLossOptions {
  enum class Type { kNone, kHuber, kCauchy };
  Type type = Type::kCauchy;
  double k_sigma = 2.5;  // threshold per coordinate in σ units (whitened) [-]
  bool Check(std::string* why) const;
};
// nullptr for kNone (Ceres' squared loss). The caller hands .release() to
// Problem::AddResidualBlock, which takes ownership.
std::unique_ptr<ceres::LossFunction> MakeRobustLoss(const RobustLossOptions& options,
                                                    int residual_dim);

// Jacobians of h = R_C_W (ω (p_W_F − p_W_C) + R_W_F a) w.r.t. the body poses' LOCAL perturbations
// (position additive in W; rotation on the left, R_W_B -> Exp(φ) R_W_B), the anchored direction a
// and ω.
struct AnchoredPointJacobians {
  Mat3 d_p_cam, d_phi_cam;        // camera keyframe body pose
  Mat3 d_p_anchor, d_phi_anchor;  // anchor keyframe body pose
  Mat3 d_a;                       // = R_C_F
  Vec3 d_omega;                   // = R_C_W (p_W_F − p_W_C)
};
// The homogeneous point h in C. Derivation (left perturbations, R_W_C = R_W_Bc R_B_C,
// p_W_C = p_W_Bc + R_W_Bc p_B_C, same for F):
//   dh/dp_cam = −ω R_C_W,  dh/dφ_cam = R_C_W([g]× + ω[R_W_Bc p_B_C]×),  g = ω(p_W_F − p_W_C) +
//   R_W_F a, dh/dp_anc = ω R_C_W,   dh/dφ_anc = −R_C_W(ω[R_W_Ba p_B_C]× + [R_W_F a]×).
Vec3 AnchoredHomogeneousPoint(const Rigid3& T_W_Bcam, const Rigid3& T_W_Banchor,
                              const Rigid3& T_B_C, const Vec3& a, double omega,
                              AnchoredPointJacobians* J = nullptr);
// What h depends on besides a and ω (one camera pose, one anchor pose): computed once for the four
// corners of a rectangle. The overload below gives the same bits as the one above.
struct AnchoredFrames {
  AnchoredFrames(const Rigid3& T_W_Bcam, const Rigid3& T_W_Banchor, const Rigid3& T_B_C);
  Vec3 b_cam, b_anc;  // lever arms R_W_B p_B_C of camera and anchor, in W
  Mat3 R_C_W, R_W_F;
  Vec3 d_FC;  // p_W_F − p_W_C
};
Vec3 AnchoredHomogeneousPoint(const AnchoredFrames& f, const Vec3& a, double omega,
                              AnchoredPointJacobians* J = nullptr);

// z = π(K h) with optional Jacobian dz/dh = [[1/h_z, 0, −p_x/h_z²], [0, 1/h_z, −p_y/h_z²]] K, p = K
// h. K must have last row (0, 0, 1) (zero skew allowed or not).
Vec2 ProjectHomogeneous(const Mat3& K, const Vec3& h, Mat23* d_z_d_h = nullptr);

// The whitened reprojection residual (π(K h) − OBS) / SIGMA_PX of an anchored point (h as above,
// body poses T_W_Bcam and T_W_Banchor as stored in their 7-number blocks), with the two pose
// blocks' 2x7 row-major Jacobians written into JACOBIANS[0] and [1] where requested. False when h
// is not in front (h_z <= MIN_H_Z). When JACOBIANS is given, *D (whitened dz/dh) and *JH are set
// for the caller's own landmark block. Shared by the FHP corner and the point factors.
bool AnchoredReprojection(const Rigid3& T_W_Bcam, const Rigid3& T_W_Banchor, const Rigid3& T_B_C,
                          const Mat3& K, const Vec3& a, double omega, const Vec2& obs,
                          double sigma_px, double min_h_z, double* residuals, double** jacobians,
                          Mat23* D, AnchoredPointJacobians* Jh);

// Predicted corners of an FSP landmark in a camera (poses of the CAMERAS here, not bodies).
struct CornerPrediction {
  Corners uv;                   // undistorted pixels
  std::array<double, 4> h_z{};  // homogeneous depths ω z_C
  bool in_front = false;        // all h_z > 0
};
CornerPrediction PredictFspCorners(const Mat3& K, const Rigid3& T_W_C, const Rigid3& T_W_F,
                                   const FspLandmark& landmark);

// General observation: blocks (camera body pose[7], anchor body pose[7], q_F_O[4], x[5]).
// Ambient Jacobians (positions Euclidean; quaternions through LeftRotationJacobianWrtQuat), so they
// compose with any manifold on those blocks. A corner not in `seen` (an object partly out of view)
// has residual and Jacobian rows 0, and its cheirality is not checked.
class FspFactor final : public ceres::SizedCostFunction<8, 7, 7, 4, 5> {
 public:
  FspFactor(const Corners& corners_px, const Mat3& K, const Rigid3& T_B_C,
            const FspFactorOptions& options, const CornerMask& seen = kAllCorners);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Corners obs_;
  CornerMask seen_;
  Mat3 K_;
  Rigid3 T_B_C_;
  FspFactorOptions options_;
};

// Observation in the anchor keyframe itself (C = F): z_j = π(K a_j). Blocks (q_F_O[4], x[5]); the
// pose block is omitted (Ceres forbids a block twice in one residual, and h does not depend on it).
// The Jacobian column of log ω is identically zero. `seen` as in FspFactor.
class FspAnchorFactor final : public ceres::SizedCostFunction<8, 4, 5> {
 public:
  FspAnchorFactor(const Corners& corners_px, const Mat3& K, const FspFactorOptions& options,
                  const CornerMask& seen = kAllCorners);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Corners obs_;
  CornerMask seen_;
  Mat3 K_;
  FspFactorOptions options_;
};

}  // namespace fsp::backend
