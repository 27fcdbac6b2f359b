#include "fsp/backend/fsp_factor.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "fsp/common/error.h"

namespace fsp::backend {

bool FspFactorOptions::Check(std::string* why) const {
  if (!(sigma_px > 0.0) || !std::isfinite(sigma_px)) {
    if (why) *why = "sigma_px must be positive and finite";
    return false;
  }
  if (!(min_h_z >= 0.0) || !std::isfinite(min_h_z)) {
    if (why) *why = "min_h_z must be >= 0 and finite";
    return false;
  }
  return true;
}

bool RobustLossOptions::Check(std::string* why) const {
  if (type != Type::kNone && (!(k_sigma > 0.0) || !std::isfinite(k_sigma))) {
    if (why) *why = "k_sigma must be positive and finite";
    return false;
  }
  return true;
}

std::unique_ptr<ceres::LossFunction> MakeRobustLoss(const RobustLossOptions& options,
                                                    int residual_dim) {
  std::string why;
  FSP_CHECK(options.Check(&why));
  FSP_CHECK(residual_dim > 0);
  // Ceres' Huber(a) and Cauchy(a) act on s = |e|²; the knee is at s = a², here a² = k² d.
  const double a = options.k_sigma * std::sqrt(static_cast<double>(residual_dim));
  switch (options.type) {
    case RobustLossOptions::Type::kHuber:
      return std::make_unique<ceres::HuberLoss>(a);
    case RobustLossOptions::Type::kCauchy:
      return std::make_unique<ceres::CauchyLoss>(a);
    case RobustLossOptions::Type::kNone:
      break;
  }
  return nullptr;
}

AnchoredFrames::AnchoredFrames(const Rigid3& T_W_Bcam, const Rigid3& T_W_Banchor,
                               const Rigid3& T_B_C) {
  const Mat3 R_B_C = T_B_C.R();
  const Vec3& p_B_C = T_B_C.translation();
  const Mat3 R_W_Bc = T_W_Bcam.R();
  const Mat3 R_W_Ba = T_W_Banchor.R();
  // Lever arms of the camera in W: b = R_W_B p_B_C.
  b_cam = R_W_Bc * p_B_C;
  b_anc = R_W_Ba * p_B_C;
  R_C_W = (R_W_Bc * R_B_C).transpose();
  R_W_F = R_W_Ba * R_B_C;
  const Vec3 p_W_C = T_W_Bcam.translation() + b_cam;
  const Vec3 p_W_F = T_W_Banchor.translation() + b_anc;
  d_FC = p_W_F - p_W_C;
}

Vec3 AnchoredHomogeneousPoint(const AnchoredFrames& f, const Vec3& a, double omega,
                              AnchoredPointJacobians* J) {
  const Vec3 Ra = f.R_W_F * a;
  // g = ω (p_W_F − p_W_C) + R_W_F a (in W), h = R_C_W g.
  const Vec3 g = omega * f.d_FC + Ra;
  if (J != nullptr) {
    J->d_p_cam = -omega * f.R_C_W;
    J->d_phi_cam = f.R_C_W * (Skew(g) + omega * Skew(f.b_cam));
    J->d_p_anchor = omega * f.R_C_W;
    J->d_phi_anchor = -f.R_C_W * (omega * Skew(f.b_anc) + Skew(Ra));
    J->d_a = f.R_C_W * f.R_W_F;
    J->d_omega = f.R_C_W * f.d_FC;
  }
  return f.R_C_W * g;
}

Vec3 AnchoredHomogeneousPoint(const Rigid3& T_W_Bcam, const Rigid3& T_W_Banchor,
                              const Rigid3& T_B_C, const Vec3& a, double omega,
                              AnchoredPointJacobians* J) {
  return AnchoredHomogeneousPoint(AnchoredFrames(T_W_Bcam, T_W_Banchor, T_B_C), a, omega, J);
}

Vec2 ProjectHomogeneous(const Mat3& K, const Vec3& h, Mat23* d_z_d_h) {
  const Vec3 p = K * h;
  const double inv_z = 1.0 / p.z();
  if (d_z_d_h != nullptr) {
    Mat23 D;
    D << inv_z, 0.0, -p.x() * inv_z * inv_z, 0.0, inv_z, -p.y() * inv_z * inv_z;
    *d_z_d_h = D * K;
  }
  return Vec2(p.x() * inv_z, p.y() * inv_z);
}

bool AnchoredReprojection(const Rigid3& T_W_Bcam, const Rigid3& T_W_Banchor, const Rigid3& T_B_C,
                          const Mat3& K, const Vec3& a, double omega, const Vec2& obs,
                          double sigma_px, double min_h_z, double* residuals, double** jacobians,
                          Mat23* D, AnchoredPointJacobians* Jh) {
  using Mat27R = Eigen::Matrix<double, 2, 7, Eigen::RowMajor>;
  const bool want = jacobians != nullptr;
  const Vec3 h =
      AnchoredHomogeneousPoint(T_W_Bcam, T_W_Banchor, T_B_C, a, omega, want ? Jh : nullptr);
  if (!(h.z() > min_h_z)) return false;
  const Vec2 z = ProjectHomogeneous(K, h, want ? D : nullptr);
  const double inv_sigma = 1.0 / sigma_px;
  residuals[0] = (z.x() - obs.x()) * inv_sigma;
  residuals[1] = (z.y() - obs.y()) * inv_sigma;
  if (!want) return true;
  *D *= inv_sigma;
  if (jacobians[0] != nullptr) {
    Eigen::Map<Mat27R> J(jacobians[0]);
    J.leftCols<3>() = *D * Jh->d_p_cam;
    J.rightCols<4>() = *D * Jh->d_phi_cam * LeftRotationJacobianWrtQuat(T_W_Bcam.rotation());
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Mat27R> J(jacobians[1]);
    J.leftCols<3>() = *D * Jh->d_p_anchor;
    J.rightCols<4>() = *D * Jh->d_phi_anchor * LeftRotationJacobianWrtQuat(T_W_Banchor.rotation());
  }
  return true;
}

CornerPrediction PredictFspCorners(const Mat3& K, const Rigid3& T_W_C, const Rigid3& T_W_F,
                                   const FspLandmark& landmark) {
  // With T_B_C = identity the "body" poses are the camera poses.
  CornerPrediction out;
  out.in_front = true;
  const double omega = landmark.Omega();
  for (int j = 0; j < 4; ++j) {
    const Vec3 h =
        AnchoredHomogeneousPoint(T_W_C, T_W_F, Rigid3::Identity(), landmark.CornerDirF(j), omega);
    out.h_z[j] = h.z();
    out.in_front = out.in_front && h.z() > 0.0;
    out.uv[j] = ProjectHomogeneous(K, h);
  }
  return out;
}

namespace {

using Mat85R = Eigen::Matrix<double, 8, 5, Eigen::RowMajor>;
using Mat84R = Eigen::Matrix<double, 8, 4, Eigen::RowMajor>;
using Mat87R = Eigen::Matrix<double, 8, 7, Eigen::RowMajor>;
using Mat35 = Eigen::Matrix<double, 3, 5>;

// Corner j not seen: its residuals (2j, 2j + 1) and those rows of every row-major 8 x n Jacobian
// block are 0.
void ZeroCornerRows(int j, const std::vector<int32_t>& block_sizes, double* residuals,
                    double** jacobians) {
  residuals[2 * j] = residuals[2 * j + 1] = 0.0;
  if (jacobians == nullptr) return;
  for (size_t b = 0; b < block_sizes.size(); ++b) {
    if (jacobians[b] != nullptr)
      std::fill_n(jacobians[b] + 2 * j * block_sizes[b], 2 * block_sizes[b], 0.0);
  }
}

FspLandmark LandmarkFromBlocks(const double* q_F_O, const double* x) {
  FspLandmark l;
  for (int i = 0; i < 4; ++i) l.q_F_O[i] = q_F_O[i];
  for (int i = 0; i < 5; ++i) l.x[i] = x[i];
  return l;
}

// Jacobians of a_j = r + R_F_O s̄_j (Rs = R_F_O s̄_j) w.r.t. the left perturbation of R_F_O (3) and x
// (5):
//   da/dφ = −[R_F_O s̄_j]×,  da/du = e_x, da/dv = e_y, da/dlog ω = 0,
//   da/dlog w̄ = R_F_O s̄_j (s̄ ∝ w̄),  da/dlog f = R_F_O (0, −s̄_j,y, 0) (s̄_y ∝ 1/f).
void CornerDirJacobians(const Mat3& R_F_O, const Vec3& sbar, const Vec3& Rs, Mat3* d_a_d_phi,
                        Mat35* d_a_d_x) {
  *d_a_d_phi = -Skew(Rs);
  d_a_d_x->setZero();
  d_a_d_x->col(kFspU) = Vec3::UnitX();
  d_a_d_x->col(kFspV) = Vec3::UnitY();
  d_a_d_x->col(kFspLogWbar) = Rs;
  d_a_d_x->col(kFspLogForm) = R_F_O * Vec3(0.0, -sbar.y(), 0.0);
}

}  // namespace

FspFactor::FspFactor(const Corners& corners_px, const Mat3& K, const Rigid3& T_B_C,
                     const FspFactorOptions& options, const CornerMask& seen)
    : obs_(corners_px), seen_(seen), K_(K), T_B_C_(T_B_C), options_(options) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
  FSP_CHECK(K_.row(2).isApprox(Eigen::RowVector3d(0.0, 0.0, 1.0)));
}

// The paper's FSP observation model in homogeneous form (backend/README.md, "Landmark models";
// formula and frames in fsp_factor.h).
bool FspFactor::Evaluate(double const* const* parameters, double* residuals,
                         double** jacobians) const {
  const Rigid3 T_W_Bc = PoseFromBlock(parameters[0]);
  const Rigid3 T_W_Ba = PoseFromBlock(parameters[1]);
  const FspLandmark l = LandmarkFromBlocks(parameters[2], parameters[3]);
  const Mat3 R_F_O = l.R_F_O();
  const double omega = l.Omega();
  const double inv_sigma = 1.0 / options_.sigma_px;
  const bool want = jacobians != nullptr;
  // What the four corners share, computed once (the same bits as per corner).
  const AnchoredFrames frames(T_W_Bc, T_W_Ba, T_B_C_);
  const Vec3 ray = l.Ray();

  Mat34 dphi_dq_cam, dphi_dq_anc, dphi_dq_FO;
  if (want) {
    dphi_dq_cam = LeftRotationJacobianWrtQuat(T_W_Bc.rotation());
    dphi_dq_anc = LeftRotationJacobianWrtQuat(T_W_Ba.rotation());
    dphi_dq_FO = LeftRotationJacobianWrtQuat(l.QuatFO());
  }
  for (int j = 0; j < 4; ++j) {
    if (!seen_[j]) {
      ZeroCornerRows(j, parameter_block_sizes(), residuals, jacobians);
      continue;
    }
    const Vec3 sbar = l.SBar(j);
    const Vec3 Rs = R_F_O * sbar;
    const Vec3 a = ray + Rs;  // l.CornerDirF(j)
    AnchoredPointJacobians Jh;
    const Vec3 h = AnchoredHomogeneousPoint(frames, a, omega, want ? &Jh : nullptr);
    if (!(h.z() > options_.min_h_z)) return false;  // cheirality (see header)
    Mat23 D;
    const Vec2 z = ProjectHomogeneous(K_, h, want ? &D : nullptr);
    residuals[2 * j] = (z.x() - obs_[j].x()) * inv_sigma;
    residuals[2 * j + 1] = (z.y() - obs_[j].y()) * inv_sigma;
    if (!want) continue;
    D *= inv_sigma;
    if (jacobians[0] != nullptr) {
      Eigen::Map<Mat87R> J(jacobians[0]);
      J.block<2, 3>(2 * j, 0) = D * Jh.d_p_cam;
      J.block<2, 4>(2 * j, 3) = D * Jh.d_phi_cam * dphi_dq_cam;
    }
    if (jacobians[1] != nullptr) {
      Eigen::Map<Mat87R> J(jacobians[1]);
      J.block<2, 3>(2 * j, 0) = D * Jh.d_p_anchor;
      J.block<2, 4>(2 * j, 3) = D * Jh.d_phi_anchor * dphi_dq_anc;
    }
    if (jacobians[2] != nullptr || jacobians[3] != nullptr) {
      Mat3 d_a_d_phi;
      Mat35 d_a_d_x;
      CornerDirJacobians(R_F_O, sbar, Rs, &d_a_d_phi, &d_a_d_x);
      const Mat23 Da = D * Jh.d_a;
      if (jacobians[2] != nullptr) {
        Eigen::Map<Mat84R> J(jacobians[2]);
        J.block<2, 4>(2 * j, 0) = Da * d_a_d_phi * dphi_dq_FO;
      }
      if (jacobians[3] != nullptr) {
        Eigen::Map<Mat85R> J(jacobians[3]);
        J.block<2, 5>(2 * j, 0) = Da * d_a_d_x;
        // dh/dlog ω = ω dh/dω.
        J.block<2, 1>(2 * j, kFspLogOmega) = omega * (D * Jh.d_omega);
      }
    }
  }
  return true;
}

FspAnchorFactor::FspAnchorFactor(const Corners& corners_px, const Mat3& K,
                                 const FspFactorOptions& options, const CornerMask& seen)
    : obs_(corners_px), seen_(seen), K_(K), options_(options) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
  FSP_CHECK(K_.row(2).isApprox(Eigen::RowVector3d(0.0, 0.0, 1.0)));
}

// C = F: h_j = a_j = r + R_F_O s̄_j, z_j = π(K a_j). No ω, no pose.
bool FspAnchorFactor::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  const FspLandmark l = LandmarkFromBlocks(parameters[0], parameters[1]);
  const Mat3 R_F_O = l.R_F_O();
  const double inv_sigma = 1.0 / options_.sigma_px;
  const bool want = jacobians != nullptr;
  Mat34 dphi_dq_FO;
  if (want) dphi_dq_FO = LeftRotationJacobianWrtQuat(l.QuatFO());
  const Vec3 ray = l.Ray();
  for (int j = 0; j < 4; ++j) {
    if (!seen_[j]) {
      ZeroCornerRows(j, parameter_block_sizes(), residuals, jacobians);
      continue;
    }
    const Vec3 sbar = l.SBar(j);
    const Vec3 Rs = R_F_O * sbar;
    const Vec3 h = ray + Rs;  // l.CornerDirF(j)
    if (!(h.z() > options_.min_h_z)) return false;
    Mat23 D;
    const Vec2 z = ProjectHomogeneous(K_, h, want ? &D : nullptr);
    residuals[2 * j] = (z.x() - obs_[j].x()) * inv_sigma;
    residuals[2 * j + 1] = (z.y() - obs_[j].y()) * inv_sigma;
    if (!want) continue;
    D *= inv_sigma;
    Mat3 d_a_d_phi;
    Mat35 d_a_d_x;
    CornerDirJacobians(R_F_O, sbar, Rs, &d_a_d_phi, &d_a_d_x);
    if (jacobians[0] != nullptr) {
      Eigen::Map<Mat84R> J(jacobians[0]);
      J.block<2, 4>(2 * j, 0) = D * d_a_d_phi * dphi_dq_FO;
    }
    if (jacobians[1] != nullptr) {
      Eigen::Map<Mat85R> J(jacobians[1]);
      J.block<2, 5>(2 * j, 0) = D * d_a_d_x;  // log ω column stays 0
    }
  }
  return true;
}

}  // namespace fsp::backend
