#include "fsp/backend/vi_alignment.h"

#include <cmath>

#include <Eigen/Dense>

namespace fsp::backend {

Alignment AlignVisualInertial(const std::vector<AlignmentView>& views,
                              const std::vector<std::unique_ptr<ImuPreintegration>>& pre,
                              const Vec3& p_B_C, const Vec3* g_dir, double g_mag,
                              const AlignmentOptions& options) {
  const int m = static_cast<int>(views.size());
  const int ng = g_dir ? 2 : 3;
  const bool with_ba = options.acc_bias_sigma > 0.0;
  const int n = 3 * m + ng + 1 + (with_ba ? 3 : 0);
  const int rows = 6 * (m - 1) + (with_ba ? 3 : 0);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(rows, n);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(rows);
  Eigen::Matrix<double, 3, Eigen::Dynamic> G(3, ng);  // g = g0 + G δ
  Vec3 g0 = Vec3::Zero();
  if (g_dir) {
    g0 = g_mag * *g_dir;
    Vec3 a = std::abs(g_dir->x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    const Vec3 b1 = (a - g_dir->dot(a) * *g_dir).normalized();
    G.col(0) = b1;
    G.col(1) = g_dir->cross(b1);
  } else {
    G = Mat3::Identity();
  }
  const int gi = 3 * m, si = 3 * m + ng, ai = si + 1;
  for (int k = 0; k + 1 < m; ++k) {
    const ImuPreintegration& p = *pre[k];
    const double dt = p.dt();
    const Mat3& Ri = views[k].R_S_B;
    const Mat3& Rj = views[k + 1].R_S_B;
    const int r = 6 * k;
    // s (ĉ_j − ĉ_i) − v_i dt − ½ g dt² = R_i Δp + (R_j − R_i) p_B_C
    A.block<3, 1>(r, si) = views[k + 1].c_hat - views[k].c_hat;
    A.block<3, 3>(r, 3 * k) = -dt * Mat3::Identity();
    A.block(r, gi, 3, ng) = -0.5 * dt * dt * G;
    b.segment<3>(r) = Ri * p.delta_p() + (Rj - Ri) * p_B_C + 0.5 * dt * dt * g0;
    // v_j − v_i − g dt = R_i Δv
    A.block<3, 3>(r + 3, 3 * (k + 1)) = Mat3::Identity();
    A.block<3, 3>(r + 3, 3 * k) = -Mat3::Identity();
    A.block(r + 3, gi, 3, ng) = -dt * G;
    b.segment<3>(r + 3) = Ri * p.delta_v() + dt * g0;
    if (with_ba) {  // Δ(b_a) = Δ + J (b_a − b̄_a), b̄_a the linearisation point
      A.block<3, 3>(r, ai) = -Ri * p.dp_dba();
      A.block<3, 3>(r + 3, ai) = -Ri * p.dv_dba();
      b.segment<3>(r) -= Ri * p.dp_dba() * p.ba_lin();
      b.segment<3>(r + 3) -= Ri * p.dv_dba() * p.ba_lin();
    }
  }
  if (with_ba) A.block<3, 3>(6 * (m - 1), ai) = Mat3::Identity() / options.acc_bias_sigma;
  const Eigen::VectorXd x = A.colPivHouseholderQr().solve(b);
  Alignment out;
  for (int k = 0; k < m; ++k) out.v.push_back(x.segment<3>(3 * k));
  out.g = g0 + G * x.segment(gi, ng);
  out.s = x[si];
  if (with_ba) out.acc_bias = x.segment<3>(ai);
  if (b.size() > 0) out.residual_rms = std::sqrt((A * x - b).squaredNorm() / b.size());
  return out;
}

Alignment AlignWithGravityMagnitude(const std::vector<AlignmentView>& views,
                                    const std::vector<std::unique_ptr<ImuPreintegration>>& pre,
                                    const Vec3& p_B_C, double g_mag, int iterations,
                                    double* gravity_error, const AlignmentOptions& options) {
  Alignment al = AlignVisualInertial(views, pre, p_B_C, nullptr, g_mag, options);
  if (gravity_error) *gravity_error = std::abs(al.g.norm() - g_mag);
  if (!(al.g.norm() > 0.0) || !std::isfinite(al.g.norm())) return al;
  for (int it = 0; it < iterations; ++it) {
    const Vec3 dir = al.g.normalized();
    al = AlignVisualInertial(views, pre, p_B_C, &dir, g_mag, options);
  }
  return al;
}

Vec3 EstimateGyroBias(const std::vector<AlignmentView>& views,
                      const std::vector<std::unique_ptr<ImuPreintegration>>& pre, int iterations,
                      double* rotation_rms) {
  Vec3 bg = pre.empty() ? Vec3::Zero() : pre.front()->bg_lin();
  const auto residual = [&](size_t k) {
    const Mat3 dR = pre[k]->delta_R().toRotationMatrix();
    return LogSO3(dR.transpose() * views[k].R_S_B.transpose() * views[k + 1].R_S_B);
  };
  for (int it = 0; it < iterations; ++it) {
    Mat3 H = Mat3::Zero();
    Vec3 g = Vec3::Zero();
    for (size_t k = 0; k < pre.size(); ++k) {
      const Mat3& J = pre[k]->dR_dbg();
      H += J.transpose() * J;
      g += J.transpose() * residual(k);
    }
    bg += H.ldlt().solve(g);
    for (const auto& p : pre) p->Reintegrate(bg, p->ba_lin());
  }
  if (rotation_rms) {
    double sum = 0.0;
    for (size_t k = 0; k < pre.size(); ++k) sum += residual(k).squaredNorm();
    *rotation_rms = pre.empty() ? 0.0 : std::sqrt(sum / pre.size());
  }
  return bg;
}

}  // namespace fsp::backend
