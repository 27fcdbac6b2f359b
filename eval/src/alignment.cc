#include "fsp/eval/alignment.h"

#include <Eigen/SVD>
#include <cmath>

#include "fsp/common/error.h"

namespace fsp::eval {

const char* ToString(AlignMode mode) {
  switch (mode) {
    case AlignMode::kSe3:
      return "se3";
    case AlignMode::kPosYaw:
      return "posyaw";
    case AlignMode::kSim3:
      return "sim3";
  }
  return "?";
}

bool ParseAlignMode(const std::string& text, AlignMode* mode) {
  if (text == "se3")
    *mode = AlignMode::kSe3;
  else if (text == "posyaw")
    *mode = AlignMode::kPosYaw;
  else if (text == "sim3")
    *mode = AlignMode::kSim3;
  else
    return false;
  return true;
}

AlignResult AlignPoints(const std::vector<Vec3>& ref, const std::vector<Vec3>& est,
                        AlignMode mode) {
  FSP_CHECK(ref.size() == est.size());
  AlignResult result;
  result.alignment.mode = mode;
  if (ref.size() < 3) {
    result.failure = "needs at least 3 point pairs, got " + std::to_string(ref.size());
    return result;
  }
  const double n = static_cast<double>(ref.size());
  Vec3 mu_ref = Vec3::Zero(), mu_est = Vec3::Zero();
  for (size_t i = 0; i < ref.size(); ++i) {
    mu_ref += ref[i];
    mu_est += est[i];
  }
  mu_ref /= n;
  mu_est /= n;

  if (mode == AlignMode::kPosYaw) {
    // 4-DoF: minimise Σ‖Rz(θ) x_i + t − y_i‖² with x_i, y_i the positions centred on their means
    // (t = μ_ref − Rz(θ) μ_est follows from ∂/∂t = 0). Then maximise Σ y_iᵀ Rz(θ) x_i =
    //   cosθ Σ (x_x y_x + x_y y_y) + sinθ Σ (x_x y_y − x_y y_x) + Σ x_z y_z  =  A cosθ + B sinθ +
    //   C,
    // whose maximum is at θ = atan2(B, A) (closed form; roll and pitch are left untouched).
    double A = 0.0, B = 0.0, norm = 0.0;
    for (size_t i = 0; i < ref.size(); ++i) {
      const Vec3 x = est[i] - mu_est, y = ref[i] - mu_ref;
      A += x.x() * y.x() + x.y() * y.y();
      B += x.x() * y.y() - x.y() * y.x();
      norm += x.head<2>().norm() * y.head<2>().norm();
    }
    if (!(std::hypot(A, B) > 1e-12 * norm) || norm <= 0.0) {
      result.failure = "degenerate: the horizontal motion does not determine the yaw";
      return result;
    }
    result.alignment.R = RotZ(std::atan2(B, A));
    result.alignment.t = mu_ref - result.alignment.R * mu_est;
    return result;
  }

  // Umeyama (1991), x = est, y = ref:
  //   Σxy = 1/n Σ (y_i − μy)(x_i − μx)ᵀ = U D Vᵀ,  S = diag(1, 1, det(U) det(V) < 0 ? −1 : 1),
  //   R = U S Vᵀ,  σx² = 1/n Σ ‖x_i − μx‖²,  s = tr(D S) / σx² (Sim3; 1 for SE3),  t = μy − s R μx.
  Mat3 sigma = Mat3::Zero();
  double var_est = 0.0;
  for (size_t i = 0; i < ref.size(); ++i) {
    const Vec3 x = est[i] - mu_est;
    sigma += (ref[i] - mu_ref) * x.transpose();
    var_est += x.squaredNorm();
  }
  sigma /= n;
  var_est /= n;
  Eigen::JacobiSVD<Mat3> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3 d = svd.singularValues();
  // Rank < 2 (all points on a line or one point): the rotation about that line is free (evo refuses
  // too).
  if (!(d(1) > 1e-12 * d(0)) || !(var_est > 0.0)) {
    result.failure =
        "degenerate: the positions are collinear or identical (rank of the cross-covariance < 2)";
    return result;
  }
  Mat3 S = Mat3::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2, 2) = -1.0;
  result.alignment.R = svd.matrixU() * S * svd.matrixV().transpose();
  if (mode == AlignMode::kSim3) result.alignment.scale = (d.asDiagonal() * S).trace() / var_est;
  result.alignment.t = mu_ref - result.alignment.scale * (result.alignment.R * mu_est);
  return result;
}

}  // namespace fsp::eval
