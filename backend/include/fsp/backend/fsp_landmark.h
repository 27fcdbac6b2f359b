// Rectangle landmarks for the back end: Framed Structural Points (FSP, the paper's representation,
// 8 DoF) and Framed Homogeneous Points (FHP, the paper's baseline, 12 DoF). backend/README.md,
// "Landmark models".
//
// Frames: W world, F anchor = the CAMERA frame of the keyframe where the object was initialised
// (T_W_F = T_W_B(anchor) * T_B_C), O object (x along the width, y along the height, z = x × y).
// Corners s1..s4 = (0,0,0), (w,0,0), (w,h,0), (0,h,0) in O.
//
// FSP parameters (two Ceres parameter blocks; the anchor pose is a keyframe's block, shared, not
// owned):
//   q_F_O[4]  R_F_O as an Eigen quaternion (x, y, z, w), manifold ceres::EigenQuaternionManifold.
//   x[5]      (u, v, log ω, log w̄, log f):
//               r = (u, v, 1)  normalised ray of s1 in F,
//               ω  > 0         inverse depth of s1 (s1 lies at depth 1/ω along F's optical axis)
//               [1/m], w̄ = w ω > 0    width at unit depth [-], f = w / h > 0  form factor [-].
//             Log-parameters keep ω, w̄, f positive without bounds (Ceres' bounds would stall the
//             trust region at the boundary). Effect on the Jacobians: d/d(log a) = a · d/da, so the
//             factor's Jacobian columns for these three entries are the physical ones times the
//             value. The Euclidean manifold is used for x; the tangent step in log ω is a relative
//             step in ω.
//   With s̄1 = 0, s̄2 = (w̄,0,0), s̄3 = (w̄, w̄/f, 0), s̄4 = (0, w̄/f, 0) (corners at unit depth scale):
//     p_F(s_j) = (r + R_F_O s̄_j) / ω,      p_W(s_j) = p_W_F + R_W_F p_F(s_j),
//     w = w̄ / ω,  h = w̄ / (f ω).
//
// FHP parameters: per corner j one block fhp[3] = (u_j, v_j, log ω_j), p_F(s_j) = (u_j, v_j, 1) /
// ω_j. A rectangle is four independent points (12 DoF); width and height follow from corner
// distances.
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>

#include "fsp/backend/state.h"  // pose block layout: PoseFromBlock / PoseToBlock
#include "fsp/common/geometry.h"

namespace fsp::backend {

using Vec5 = Eigen::Matrix<double, 5, 1>;
using Mat34 = Eigen::Matrix<double, 3, 4>;  // same alias as manifolds.h

// Ambient Jacobian of a rotation w.r.t. its Eigen quaternion coefficients (x, y, z, w).
// For a unit q and an ambient step dq, R(q + dq) = Exp(φ) R(q) to first order with φ = J dq, where
//   J = 2 [q_w I + [q_v]×, −q_v]   (3×4; the radial direction q gives φ = 0: R(q/|q|) is
//   differentiated).
// A residual's ambient Jacobian is therefore (d res / dφ)_left · J. It is independent of the
// manifold; with ceres::EigenQuaternionManifold (Plus(q, δ) = [sin|δ| δ/|δ|, cos|δ|] ⊗ q, i.e.
// Exp(2δ) on the left) J · PlusJacobian(q) = 2 I.
Mat34 LeftRotationJacobianWrtQuat(const Quat& q);

// Index of the entries in FspLandmark::x.
enum FspParam : int { kFspU = 0, kFspV = 1, kFspLogOmega = 2, kFspLogWbar = 3, kFspLogForm = 4 };

// s̄_j / w̄ = (ξ_j, η_j / f, 0): the unit-square coordinates (ξ, η) of corner j = 0..3 (s1..s4).
inline constexpr double kCornerXi[4] = {0.0, 1.0, 1.0, 0.0};
inline constexpr double kCornerEta[4] = {0.0, 0.0, 1.0, 1.0};

struct FspLandmark {
  // Ceres parameter blocks. Ceres keeps their addresses: do not move the object while a problem
  // uses it.
  double q_F_O[4] = {0.0, 0.0, 0.0, 1.0};
  double x[5] = {0.0, 0.0, 0.0, 0.0, 0.0};

  // From physical values (omega, wbar, form > 0; checked).
  static FspLandmark Make(const Mat3& R_F_O, const Vec3& ray_s1, double omega, double wbar,
                          double form);
  // Exact conversion from an object pose in the anchor frame and its metric size. Requires s1 in
  // front of F (p_F(s1).z > 0), w > 0, h > 0 (checked).
  static FspLandmark FromObject(const Rigid3& T_F_O, double width, double height);

  Quat QuatFO() const;
  Mat3 R_F_O() const;
  Vec3 Ray() const { return Vec3(x[kFspU], x[kFspV], 1.0); }
  double Omega() const;
  double Wbar() const;
  double Form() const;
  double Width() const { return Wbar() / Omega(); }              // w = w̄ / ω [m]
  double Height() const { return Wbar() / (Form() * Omega()); }  // h = w̄ / (f ω) [m]
  // Jacobian of (w, h) w.r.t. x (for width/height σ from the covariance of x): with
  // w = exp(log w̄ − log ω), h = exp(log w̄ − log ω − log f):
  //   ∂w/∂x = w (0, 0, −1, 1, 0),   ∂h/∂x = h (0, 0, −1, 1, −1).
  Eigen::Matrix<double, 2, 5> SizeJacobian() const;
  // (σ_w, σ_h) [m] from a 5×5 covariance of x (first order).
  Eigen::Vector2d SizeSigma(const Eigen::Matrix<double, 5, 5>& cov_x) const;

  // s̄_j in O (unit-depth scale), j = 0..3.
  Vec3 SBar(int j) const;
  // a_j = r + R_F_O s̄_j: corner j in F up to the scale 1/ω (homogeneous point; p_F = a_j / ω).
  Vec3 CornerDirF(int j) const;
  // Metric corners in F and in W.
  std::array<Vec3, 4> CornersF() const;
  std::array<Vec3, 4> CornersW(const Rigid3& T_W_F) const;
  // Object pose: origin at s1, axes of O.
  Rigid3 T_F_O() const;
  Rigid3 T_W_O(const Rigid3& T_W_F) const;
};

struct FhpLandmark {
  // One Ceres block per corner: (u_j, v_j, log ω_j).
  double corner[4][3] = {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}};

  // From metric corners in F (each must have z > 0; checked).
  static FhpLandmark FromCornersF(const std::array<Vec3, 4>& p_F);
  // Same geometry as an FSP landmark with the same anchor (used to initialise the baseline).
  static FhpLandmark FromFsp(const FspLandmark& fsp);

  Vec3 Ray(int j) const { return Vec3(corner[j][0], corner[j][1], 1.0); }
  double Omega(int j) const;
  Vec3 CornerF(int j) const { return Ray(j) / Omega(j); }
  std::array<Vec3, 4> CornersF() const;
  std::array<Vec3, 4> CornersW(const Rigid3& T_W_F) const;
  // Mean of the two opposite edge lengths: w = (|s2−s1| + |s3−s4|)/2, h = (|s4−s1| + |s3−s2|)/2
  // [m].
  double Width() const;
  double Height() const;
  // Nearest rectangle frame: x̂ ∝ (s2−s1)+(s3−s4), ŷ ∝ (s4−s1)+(s3−s2), R = Orthonormalize([x̂ ŷ
  // x̂×ŷ]), origin placed so that the centre of the w×h rectangle is the corners' centroid.
  Rigid3 T_F_O() const;
  Rigid3 T_W_O(const Rigid3& T_W_F) const;
};

}  // namespace fsp::backend
