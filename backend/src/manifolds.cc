#include "fsp/backend/manifolds.h"

#include <Eigen/Dense>

#include "fsp/common/error.h"

namespace fsp::backend {

std::unique_ptr<ceres::Manifold> MakePoseManifold() {
  return std::make_unique<PoseManifold>();
}

void PosePlus(const double* x, const double* delta, double* x_plus_delta) {
  Eigen::Map<Vec3> p_out(x_plus_delta);
  Eigen::Map<Quat> q_out(x_plus_delta + 3);  // Eigen maps quaternions in (x, y, z, w) storage order
  const Eigen::Map<const Quat> q(x + 3);
  p_out = Eigen::Map<const Vec3>(x) + Eigen::Map<const Vec3>(delta);
  q_out = (ExpQuat(2.0 * Eigen::Map<const Vec3>(delta + 3)) * q).normalized();
}

Vec6 PoseMinus(const double* y, const double* x) {
  Vec6 d;
  d.head<3>() = Eigen::Map<const Vec3>(y) - Eigen::Map<const Vec3>(x);
  const Eigen::Map<const Quat> qx(x + 3), qy(y + 3);
  d.tail<3>() = 0.5 * LogQuat(qy * qx.conjugate());
  return d;
}

// (δ, 1) ⊗ q in (x, y, z, w) storage: vector part w δ + δ × v = (w I − [v]×) δ, scalar part −v·δ.
Mat76 PosePlusJacobian(const double* pose) {
  const Vec3 v(pose[3], pose[4], pose[5]);
  const double w = pose[6];
  Mat76 P = Mat76::Zero();
  P.topLeftCorner<3, 3>().setIdentity();
  P.block<3, 3>(3, 3) = w * Mat3::Identity() - Skew(v);
  P.block<1, 3>(6, 3) = -v.transpose();
  return P;
}

// q ⊗ (δ/2, 1) in (x, y, z, w) storage: vector part (w I + [v]×) δ/2, scalar part −v·δ/2.
Mat43 QuaternionRightPlusJacobian(const double* q) {
  const Vec3 v(q[0], q[1], q[2]);
  const double w = q[3];
  Mat43 P;
  P.topRows<3>() = 0.5 * (w * Mat3::Identity() + Skew(v));
  P.bottomRows<1>() = -0.5 * v.transpose();
  return P;
}

// P_rᵀP_r = ¼[(wI − [v]×)(wI + [v]×) + v vᵀ] = ¼(w² + |v|²) I = I/4 for a unit quaternion.
Mat34 QuaternionRightLift(const double* q) {
  return 4.0 * QuaternionRightPlusJacobian(q).transpose();
}

Mat67 PoseRightLift(const double* pose) {
  Mat67 L = Mat67::Zero();
  L.topLeftCorner<3, 3>().setIdentity();
  L.bottomRightCorner<3, 4>() = QuaternionRightLift(pose + 3);
  return L;
}

Eigen::MatrixXd LiftJacobian(const ceres::Manifold* manifold, const double* x, int ambient_size) {
  if (manifold == nullptr) return Eigen::MatrixXd::Identity(ambient_size, ambient_size);
  FSP_CHECK(manifold->AmbientSize() == ambient_size);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> P(ambient_size,
                                                                           manifold->TangentSize());
  FSP_CHECK(manifold->PlusJacobian(x, P.data()));
  // (PᵀP)⁻¹Pᵀ; P has full column rank for a valid manifold.
  const Eigen::MatrixXd Pd = P;
  return (Pd.transpose() * Pd).ldlt().solve(Pd.transpose());
}

Eigen::MatrixXd MinusTangentJacobian(const ceres::Manifold* manifold, const double* x,
                                     const double* x0, int ambient_size) {
  if (manifold == nullptr) return Eigen::MatrixXd::Identity(ambient_size, ambient_size);
  const int n = manifold->TangentSize();
  // ½ Log(Exp(2δ) Exp(φ)) ≈ ½ φ + Jl⁻¹(φ) δ with φ = Log(q ⊗ q0⁻¹) and Jl⁻¹(φ) = Jr⁻¹(−φ)
  // (left Jacobian of SO(3); Forster et al. 2017 eq. 9 for the right one).
  auto rotation_part = [](const double* q, const double* q0) {
    const Eigen::Map<const Quat> qm(q), q0m(q0);
    return RightJacobianInvSO3(-LogQuat(qm * q0m.conjugate()));
  };
  if (dynamic_cast<const PoseManifold*>(manifold)) {
    Eigen::MatrixXd J = Eigen::MatrixXd::Identity(6, 6);
    J.bottomRightCorner<3, 3>() = rotation_part(x + 3, x0 + 3);
    return J;
  }
  if (dynamic_cast<const ceres::EigenQuaternionManifold*>(manifold)) return rotation_part(x, x0);
  // Generic: central differences of (x ⊞ δ) ⊟ x0.
  Eigen::MatrixXd J(n, n);
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(n), xp(ambient_size), mp(n), mm(n);
  const double h = 1e-6;
  for (int k = 0; k < n; ++k) {
    delta.setZero();
    delta[k] = h;
    FSP_CHECK(manifold->Plus(x, delta.data(), xp.data()));
    FSP_CHECK(manifold->Minus(xp.data(), x0, mp.data()));
    delta[k] = -h;
    FSP_CHECK(manifold->Plus(x, delta.data(), xp.data()));
    FSP_CHECK(manifold->Minus(xp.data(), x0, mm.data()));
    J.col(k) = (mp - mm) / (2.0 * h);
  }
  return J;
}

}  // namespace fsp::backend
