// Manifolds of the back end's parameter blocks (Ceres 2.1 Manifold API) and the closed-form
// Jacobians the factors need to hand Ceres AMBIENT Jacobians that are consistent with the
// manifolds.
//
// CAUTION, Ceres' quaternion convention (ceres/manifold.h, checked by
// tests/backend/test_manifolds.cc):
//   EigenQuaternionManifold::Plus(q, δ) = [sin|δ| δ/|δ|, cos|δ|] ⊗ q = Exp(2δ) ⊗ q
// i.e. a LEFT (world-frame) perturbation whose tangent coordinate is HALF the rotation vector, and
// Minus(y, x) = ½ Log(y ⊗ x⁻¹). It is NOT q ⊗ Exp(δ). Nothing in fsp_backend depends on that
// choice:
//
// How factors produce Jacobians. Ceres multiplies a cost function's ambient Jacobian J_a
// (residual x ambient) by the manifold's PlusJacobian P(x) = d(x ⊞ δ)/dδ|₀. Our factors derive
// their Jacobians J_t in the convenient RIGHT tangent (δp in world, δθ on the right: R Exp(δθ),
// full angle), whose own plus-Jacobian at q is P_r = d(q ⊗ Exp(δθ))/dδθ|₀ = ½ [w I + [v]×; −vᵀ].
// They return J_a = J_t P_r⁺ with the left pseudo-inverse P_r⁺ = 4 P_rᵀ (P_rᵀP_r = I/4 for a unit
// q). J_a is then the true derivative along the unit sphere (and zero along the quaternion's norm),
// so for ANY quaternion manifold whose tangent at q spans the sphere's tangent space, J_a P is
// exactly the derivative w.r.t. that manifold's δ. The tests check J_a P_ceres against central
// differences through Ceres' own Plus.
#pragma once

#include <memory>

#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <Eigen/Core>

#include "fsp/backend/state.h"
#include "fsp/common/geometry.h"

namespace fsp::backend {

// pose[7] = (p_W_B, q_W_B xyzw);  pose ⊞ (δp, δθ) = (p + δp, Exp(2δθ) ⊗ q)  (Ceres' convention).
using PoseManifold =
    ceres::ProductManifold<ceres::EuclideanManifold<3>, ceres::EigenQuaternionManifold>;

using Mat76 = Eigen::Matrix<double, 7, 6>;
using Mat67 = Eigen::Matrix<double, 6, 7>;
using Mat43 = Eigen::Matrix<double, 4, 3>;
using Mat34 = Eigen::Matrix<double, 3, 4>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

// A new PoseManifold (hand it to ceres::Problem::SetManifold, which takes ownership by default).
std::unique_ptr<ceres::Manifold> MakePoseManifold();

// Closed forms of PoseManifold's Plus / Minus (same results as Ceres, no virtual calls):
//   x ⊞ δ = (p + δp, Exp(2δθ) ⊗ q),   y ⊟ x = (p_y − p_x, ½ Log(q_y ⊗ q_x⁻¹)),   x ⊞ (y ⊟ x) = y.
void PosePlus(const double* x, const double* delta, double* x_plus_delta);
Vec6 PoseMinus(const double* y, const double* x);
// PoseManifold's PlusJacobian (7x6): blockdiag(I3, [w I − [v]×; −vᵀ]).
Mat76 PosePlusJacobian(const double* pose);

// Right-tangent lifts (see above): J_ambient = J_right_tangent * lift.
// d(q ⊗ Exp(δθ))/dδθ at 0 for q stored (x, y, z, w): ½ [w I + [v]×; −vᵀ].
Mat43 QuaternionRightPlusJacobian(const double* q);
// Its left pseudo-inverse 4 P_rᵀ (q unit).
Mat34 QuaternionRightLift(const double* q);
// Pose block with tangent (δp world, δθ right): blockdiag(I3, QuaternionRightLift).
Mat67 PoseRightLift(const double* pose);

// Pseudo-inverse of any manifold's PlusJacobian (nullptr = Euclidean of `ambient_size`): lifts a
// Jacobian w.r.t. THAT manifold's tangent to an ambient one. Used by the marginalisation prior.
Eigen::MatrixXd LiftJacobian(const ceres::Manifold* manifold, const double* x, int ambient_size);

// Tangent Jacobian of m(δ) = (x ⊞ δ) ⊟ x0 w.r.t. δ at δ = 0 (tangent x tangent) for the manifold's
// own Plus/Minus. Closed form for Euclidean (I), EigenQuaternionManifold and PoseManifold (Jl⁻¹(φ)
// = Jr⁻¹(−φ), φ = Log(q ⊗ q0⁻¹), for the rotation); central differences otherwise.
Eigen::MatrixXd MinusTangentJacobian(const ceres::Manifold* manifold, const double* x,
                                     const double* x0, int ambient_size);

}  // namespace fsp::backend
