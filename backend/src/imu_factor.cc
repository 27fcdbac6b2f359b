#include "fsp/backend/imu_factor.h"

#include "fsp/backend/manifolds.h"
#include "fsp/backend/state.h"
#include "fsp/common/error.h"

namespace fsp::backend {

namespace {

using RowMat15x7 = Eigen::Matrix<double, 15, 7, Eigen::RowMajor>;
using RowMat15x9 = Eigen::Matrix<double, 15, 9, Eigen::RowMajor>;
using Mat15x6 = Eigen::Matrix<double, 15, 6>;
using Mat15x9 = Eigen::Matrix<double, 15, 9>;

struct Terms {
  Vec15 r;
  Mat3 Ri, Rj;
  Vec3 dv_term, dp_term;  // R_iᵀ(v_j − v_i − gΔt), R_iᵀ(p_j − p_i − v_iΔt − ½gΔt²)
  Vec3 dbg;
};

Terms Compute(const ImuPreintegration& pre, const double* pose_i, const double* sb_i,
              const double* pose_j, const double* sb_j) {
  Terms t;
  const Eigen::Map<const Vec3> p_i(pose_i), p_j(pose_j);
  const Eigen::Map<const Quat> q_i(pose_i + 3), q_j(pose_j + 3);
  const Vec3 v_i = VelocityOf(sb_i), v_j = VelocityOf(sb_j);
  const Vec3 bg_i = GyroBiasOf(sb_i), ba_i = AccBiasOf(sb_i);
  const PreintegratedDelta d = pre.Corrected(bg_i, ba_i);
  const Vec3 g = GravityW(pre.options().gravity);
  const double dt = pre.dt();
  t.Ri = q_i.toRotationMatrix();
  t.Rj = q_j.toRotationMatrix();
  t.dbg = bg_i - pre.bg_lin();
  t.dv_term = t.Ri.transpose() * (v_j - v_i - g * dt);
  t.dp_term = t.Ri.transpose() * (p_j - p_i - v_i * dt - 0.5 * g * dt * dt);
  t.r.segment<3>(0) = LogQuat(d.dR.conjugate() * q_i.conjugate() * q_j);
  t.r.segment<3>(3) = t.dv_term - d.dv;
  t.r.segment<3>(6) = t.dp_term - d.dp;
  t.r.segment<3>(9) = GyroBiasOf(sb_j) - bg_i;
  t.r.segment<3>(12) = AccBiasOf(sb_j) - ba_i;
  return t;
}

}  // namespace

ImuFactor::ImuFactor(std::shared_ptr<const ImuPreintegration> preintegration)
    : pre_(std::move(preintegration)) {
  FSP_CHECK(pre_ != nullptr);
}

Vec15 ImuFactor::UnwhitenedResidual(const double* pose_i, const double* speed_bias_i,
                                    const double* pose_j, const double* speed_bias_j) const {
  return Compute(*pre_, pose_i, speed_bias_i, pose_j, speed_bias_j).r;
}

bool ImuFactor::Evaluate(double const* const* parameters, double* residuals,
                         double** jacobians) const {
  const ImuPreintegration& pre = *pre_;
  const Terms t = Compute(pre, parameters[0], parameters[1], parameters[2], parameters[3]);
  const Mat15& S = pre.sqrt_information();
  Eigen::Map<Vec15> r_w(residuals);
  r_w = S * t.r;
  if (jacobians == nullptr) return true;

  const double dt = pre.dt();
  const Vec3 r_phi = t.r.segment<3>(0);
  const Mat3 Jr_inv = RightJacobianInvSO3(r_phi);
  const Mat3 RiT = t.Ri.transpose();
  const Mat3 I3 = Mat3::Identity();

  if (jacobians[0]) {  // pose_i, tangent (δp_W, δθ right)
    Mat15x6 J = Mat15x6::Zero();
    J.block<3, 3>(0, 3) = -Jr_inv * t.Rj.transpose() * t.Ri;
    J.block<3, 3>(3, 3) = Skew(t.dv_term);  // d (R Exp(δθ))ᵀ w / dδθ = [Rᵀ w]×
    J.block<3, 3>(6, 0) = -RiT;
    J.block<3, 3>(6, 3) = Skew(t.dp_term);
    Eigen::Map<RowMat15x7> Ja(jacobians[0]);
    Ja = (S * J) * PoseRightLift(parameters[0]);
  }
  if (jacobians[1]) {  // speed_bias_i = (v, b_g, b_a)
    Mat15x9 J = Mat15x9::Zero();
    const Vec3 corr = pre.dR_dbg() * t.dbg;
    J.block<3, 3>(0, 3) =
        -Jr_inv * ExpSO3(r_phi).transpose() * RightJacobianSO3(corr) * pre.dR_dbg();
    J.block<3, 3>(3, 0) = -RiT;
    J.block<3, 3>(3, 3) = -pre.dv_dbg();
    J.block<3, 3>(3, 6) = -pre.dv_dba();
    J.block<3, 3>(6, 0) = -RiT * dt;
    J.block<3, 3>(6, 3) = -pre.dp_dbg();
    J.block<3, 3>(6, 6) = -pre.dp_dba();
    J.block<3, 3>(9, 3) = -I3;
    J.block<3, 3>(12, 6) = -I3;
    Eigen::Map<RowMat15x9> Ja(jacobians[1]);
    Ja = S * J;
  }
  if (jacobians[2]) {  // pose_j
    Mat15x6 J = Mat15x6::Zero();
    J.block<3, 3>(0, 3) = Jr_inv;
    J.block<3, 3>(6, 0) = RiT;
    Eigen::Map<RowMat15x7> Ja(jacobians[2]);
    Ja = (S * J) * PoseRightLift(parameters[2]);
  }
  if (jacobians[3]) {  // speed_bias_j
    Mat15x9 J = Mat15x9::Zero();
    J.block<3, 3>(3, 0) = RiT;
    J.block<3, 3>(9, 3) = I3;
    J.block<3, 3>(12, 6) = I3;
    Eigen::Map<RowMat15x9> Ja(jacobians[3]);
    Ja = S * J;
  }
  return true;
}

}  // namespace fsp::backend
