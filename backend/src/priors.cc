#include "fsp/backend/priors.h"

#include <cmath>

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "fsp/backend/fsp_landmark.h"
#include "fsp/common/error.h"

namespace fsp::backend {

PosePrior::PosePrior(const Rigid3& T_W_B0, double sigma_p, double sigma_roll_pitch,
                     double sigma_yaw)
    : T0_(T_W_B0),
      inv_sigma_p_(Vec3::Constant(1.0 / sigma_p)),
      inv_sigma_rot_(1.0 / sigma_roll_pitch, 1.0 / sigma_roll_pitch, 1.0 / sigma_yaw) {}

bool PosePrior::Evaluate(double const* const* parameters, double* residuals,
                         double** jacobians) const {
  const Rigid3 T = PoseFromBlock(parameters[0]);
  Eigen::Map<Eigen::Matrix<double, 6, 1>> r(residuals);
  // Rotation error in the world frame: φ = Log(R R0ᵀ).
  const Vec3 phi = LogQuat(T.rotation() * T0_.rotation().conjugate());
  r.head<3>() = inv_sigma_p_.cwiseProduct(T.translation() - T0_.translation());
  r.tail<3>() = inv_sigma_rot_.cwiseProduct(phi);
  if (jacobians && jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobians[0]);
    J.setZero();
    J.block<3, 3>(0, 0) = inv_sigma_p_.asDiagonal();
    // R -> Exp(δ) R changes φ by Jl⁻¹(φ) δ = Jr⁻¹(−φ) δ; δ = LeftRotationJacobianWrtQuat(q) dq.
    const Mat3 d_phi_d_delta = RightJacobianInvSO3(-phi);
    J.block<3, 4>(3, 3) =
        inv_sigma_rot_.asDiagonal() * d_phi_d_delta * LeftRotationJacobianWrtQuat(T.rotation());
  }
  return true;
}

SpeedBiasPrior::SpeedBiasPrior(const Eigen::Matrix<double, 9, 1>& sb0,
                               const Eigen::Matrix<double, 9, 1>& sigma)
    : sb0_(sb0), inv_sigma_(sigma.cwiseInverse()) {}

bool SpeedBiasPrior::Evaluate(double const* const* parameters, double* residuals,
                              double** jacobians) const {
  Eigen::Map<const Eigen::Matrix<double, 9, 1>> sb(parameters[0]);
  Eigen::Map<Eigen::Matrix<double, 9, 1>> r(residuals);
  r = inv_sigma_.cwiseProduct(sb - sb0_);
  if (jacobians && jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 9, 9, Eigen::RowMajor>> J(jacobians[0]);
    J = inv_sigma_.asDiagonal();
  }
  return true;
}

LogWidthPrior::LogWidthPrior(double width_prior_m, double sigma_log)
    : log_w0_(std::log(width_prior_m)), inv_sigma_(1.0 / sigma_log) {}

bool LogWidthPrior::Evaluate(double const* const* parameters, double* residuals,
                             double** jacobians) const {
  const double* x = parameters[0];
  residuals[0] = inv_sigma_ * (x[kFspLogWbar] - x[kFspLogOmega] - log_w0_);
  if (jacobians && jacobians[0]) {
    for (int i = 0; i < 5; ++i) jacobians[0][i] = 0.0;
    jacobians[0][kFspLogWbar] = inv_sigma_;
    jacobians[0][kFspLogOmega] = -inv_sigma_;
  }
  return true;
}

namespace {

struct ImuGapResidual {
  double dt, inv_rot, inv_v, inv_p, inv_bg, inv_ba;

  template <typename T>
  bool operator()(const T* pose_i, const T* sb_i, const T* pose_j, const T* sb_j, T* r) const {
    // Quaternions are stored (x, y, z, w); ceres/rotation.h wants (w, x, y, z).
    const T qi_conj[4] = {pose_i[6], -pose_i[3], -pose_i[4], -pose_i[5]};
    const T qj[4] = {pose_j[6], pose_j[3], pose_j[4], pose_j[5]};
    T dq[4];
    ceres::QuaternionProduct(qi_conj, qj, dq);
    if (dq[0] < T(0.0))
      for (T& c : dq) c = -c;  // the shorter of the two rotations
    T phi[3];
    ceres::QuaternionToAngleAxis(dq, phi);
    const T half_dt = T(0.5 * dt);
    for (int k = 0; k < 3; ++k) {
      r[k] = phi[k] * T(inv_rot);
      r[3 + k] = (sb_j[k] - sb_i[k]) * T(inv_v);
      r[6 + k] = (pose_j[k] - pose_i[k] - (sb_i[k] + sb_j[k]) * half_dt) * T(inv_p);
      r[9 + k] = (sb_j[3 + k] - sb_i[3 + k]) * T(inv_bg);
      r[12 + k] = (sb_j[6 + k] - sb_i[6 + k]) * T(inv_ba);
    }
    return true;
  }
};

struct FhpLogWidthResidual {
  double log_w0, inv_sigma;

  template <typename T>
  bool operator()(const T* c1, const T* c2, const T* c3, const T* c4, T* r) const {
    using std::exp;
    using std::log;
    using std::sqrt;
    // p_F(s_j) = (u_j, v_j, 1) / ω_j.
    const auto edge = [](const T* a, const T* b) {
      const T da = exp(-a[2]), db = exp(-b[2]);
      const T dx = b[0] * db - a[0] * da, dy = b[1] * db - a[1] * da, dz = db - da;
      return sqrt(dx * dx + dy * dy + dz * dz);
    };
    r[0] = (log(T(0.5) * (edge(c1, c2) + edge(c4, c3))) - T(log_w0)) * T(inv_sigma);
    return true;
  }
};

}  // namespace

ceres::CostFunction* MakeImuGapPrior(double dt_s, const ImuGapPriorOptions& o) {
  FSP_CHECK(dt_s > 0.0 && o.max_acc > 0.0 && o.max_rate > 0.0 && o.gyro_walk > 0.0 &&
            o.acc_walk > 0.0);
  const ImuGapResidual r{dt_s,
                         1.0 / (o.max_rate * dt_s),
                         1.0 / (o.max_acc * dt_s),
                         1.0 / (o.max_acc * dt_s * dt_s),
                         1.0 / (o.gyro_walk * std::sqrt(dt_s)),
                         1.0 / (o.acc_walk * std::sqrt(dt_s))};
  return new ceres::AutoDiffCostFunction<ImuGapResidual, 15, 7, 9, 7, 9>(new ImuGapResidual(r));
}

namespace {

struct RelativePoseResidual {
  Vec3 t_ij;
  Eigen::Vector4d q_ij_conj;  // (w, x, y, z)
  double inv_p, inv_rot;
  Vec3 along;  // unit vector along t_ij whose component is dropped, or zero

  template <typename T>
  bool operator()(const T* pose_i, const T* pose_j, T* r) const {
    // Quaternions are stored (x, y, z, w); ceres/rotation.h wants (w, x, y, z).
    const T qi_conj[4] = {pose_i[6], -pose_i[3], -pose_i[4], -pose_i[5]};
    const T qj[4] = {pose_j[6], pose_j[3], pose_j[4], pose_j[5]};
    const T dp[3] = {pose_j[0] - pose_i[0], pose_j[1] - pose_i[1], pose_j[2] - pose_i[2]};
    T p_i_j[3];
    ceres::UnitQuaternionRotatePoint(qi_conj, dp, p_i_j);
    T d[3];
    for (int k = 0; k < 3; ++k) d[k] = p_i_j[k] - t_ij[k];
    const T d_along = d[0] * along[0] + d[1] * along[1] + d[2] * along[2];
    for (int k = 0; k < 3; ++k) r[k] = inv_p * (d[k] - d_along * along[k]);
    T q_i_j[4], err[4];
    ceres::QuaternionProduct(qi_conj, qj, q_i_j);
    const T meas[4] = {T(q_ij_conj[0]), T(q_ij_conj[1]), T(q_ij_conj[2]), T(q_ij_conj[3])};
    ceres::QuaternionProduct(meas, q_i_j, err);
    const T sign = err[0] < T(0) ? T(-2) : T(2);
    for (int k = 0; k < 3; ++k) r[3 + k] = inv_rot * sign * err[1 + k];
    return true;
  }
};

}  // namespace

ceres::CostFunction* MakeRelativePosePrior(const Rigid3& T_i_j, double sigma_p, double sigma_rot,
                                           bool free_length) {
  FSP_CHECK(sigma_p > 0.0 && sigma_rot > 0.0);
  const Quat q = T_i_j.rotation();
  const double length = T_i_j.translation().norm();
  const Vec3 along =
      free_length && length > 0.0 ? Vec3(T_i_j.translation() / length) : Vec3::Zero();
  auto* r =
      new RelativePoseResidual{T_i_j.translation(), Eigen::Vector4d(q.w(), -q.x(), -q.y(), -q.z()),
                               1.0 / sigma_p, 1.0 / sigma_rot, along};
  return new ceres::AutoDiffCostFunction<RelativePoseResidual, 6, 7, 7>(r);
}

ceres::CostFunction* MakeFhpLogWidthPrior(double width_prior_m, double sigma_log) {
  FSP_CHECK(width_prior_m > 0.0 && sigma_log > 0.0);
  return new ceres::AutoDiffCostFunction<FhpLogWidthResidual, 1, 3, 3, 3, 3>(
      new FhpLogWidthResidual{std::log(width_prior_m), 1.0 / sigma_log});
}

}  // namespace fsp::backend
