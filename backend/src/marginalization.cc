#include "fsp/backend/marginalization.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "fsp/backend/manifolds.h"
#include "fsp/common/error.h"

namespace fsp::backend {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

bool MarginalizationOptions::Check(std::string* why) const {
  if (!(relative_eigenvalue_threshold > 0.0 && relative_eigenvalue_threshold < 1.0)) {
    if (why) *why = "relative_eigenvalue_threshold must be in (0, 1)";
    return false;
  }
  return true;
}

int LinearPrior::tangent_dim() const {
  int n = 0;
  for (int t : tangent_sizes) n += t;
  return n;
}

namespace {

// Eigen-decomposition of the Jacobi-scaled symmetric PSD matrix A: A = D^½ V S Vᵀ D^½ with only the
// eigenvalues above threshold·max kept. Returns the scale d = diag(D)^-½ (1 for zero diagonals).
struct ScaledEigen {
  Eigen::VectorXd inv_sqrt_d;  // D^-½
  Eigen::VectorXd s;           // kept eigenvalues
  Eigen::MatrixXd V;           // their eigenvectors (columns)
};

ScaledEigen Decompose(const Eigen::MatrixXd& A, double threshold) {
  ScaledEigen e;
  const int n = static_cast<int>(A.rows());
  e.inv_sqrt_d.resize(n);
  for (int i = 0; i < n; ++i) e.inv_sqrt_d[i] = A(i, i) > 0.0 ? 1.0 / std::sqrt(A(i, i)) : 1.0;
  Eigen::MatrixXd As = e.inv_sqrt_d.asDiagonal() * A * e.inv_sqrt_d.asDiagonal();
  As = 0.5 * (As + As.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(As);
  const double max_ev = std::max(es.eigenvalues().maxCoeff(), 0.0);
  std::vector<int> keep;
  for (int i = 0; i < n; ++i) {
    if (es.eigenvalues()[i] > threshold * max_ev && es.eigenvalues()[i] > 0.0) keep.push_back(i);
  }
  e.s.resize(static_cast<int>(keep.size()));
  e.V.resize(n, static_cast<int>(keep.size()));
  for (size_t k = 0; k < keep.size(); ++k) {
    e.s[static_cast<int>(k)] = es.eigenvalues()[keep[k]];
    e.V.col(static_cast<int>(k)) = es.eigenvectors().col(keep[k]);
  }
  return e;
}

// Block minus x ⊟ x0 consistent with MinusTangentJacobian.
Eigen::VectorXd BlockMinus(const ceres::Manifold* m, const double* x, const double* x0,
                           int ambient) {
  if (m == nullptr)
    return Eigen::Map<const Eigen::VectorXd>(x, ambient) -
           Eigen::Map<const Eigen::VectorXd>(x0, ambient);
  if (dynamic_cast<const PoseManifold*>(m)) return PoseMinus(x, x0);
  if (dynamic_cast<const ceres::EigenQuaternionManifold*>(m)) {
    const Eigen::Map<const Quat> q(x), q_0(x0);
    return 0.5 * LogQuat(q * q_0.conjugate());
  }
  Eigen::VectorXd d(m->TangentSize());
  FSP_CHECK(m->Minus(x, x0, d.data()));
  return d;
}

}  // namespace

MarginalizationSummary Marginalize(
    const std::vector<ResidualBlockInput>& residual_blocks,
    const std::unordered_set<const double*>& to_marginalize,
    const std::unordered_map<const double*, const ceres::Manifold*>& manifolds,
    const MarginalizationOptions& options) {
  std::string why;
  FSP_CHECK(options.Check(&why));
  MarginalizationSummary summary;
  summary.num_residual_blocks = static_cast<int>(residual_blocks.size());

  // Parameter blocks in order: dropped first, then kept (each in order of first appearance).
  struct BlockInfo {
    double* ptr;
    int ambient, tangent, offset;
    const ceres::Manifold* manifold;
  };
  std::vector<BlockInfo> dropped, kept;
  std::unordered_map<const double*, std::pair<bool, int>> where;  // ptr -> (dropped?, index)
  for (const ResidualBlockInput& rb : residual_blocks) {
    FSP_CHECK(rb.cost != nullptr);
    FSP_CHECK(rb.parameter_blocks.size() == rb.cost->parameter_block_sizes().size());
    for (size_t k = 0; k < rb.parameter_blocks.size(); ++k) {
      double* p = rb.parameter_blocks[k];
      if (where.count(p)) continue;
      const auto it = manifolds.find(p);
      const ceres::Manifold* m = it == manifolds.end() ? nullptr : it->second;
      const int amb = rb.cost->parameter_block_sizes()[k];
      BlockInfo info{p, amb, m ? m->TangentSize() : amb, 0, m};
      const bool drop = to_marginalize.count(p) > 0;
      auto& list = drop ? dropped : kept;
      where[p] = {drop, static_cast<int>(list.size())};
      list.push_back(info);
    }
  }
  int m_dim = 0, n_dim = 0;
  for (BlockInfo& b : dropped) {
    b.offset = m_dim;
    m_dim += b.tangent;
  }
  for (BlockInfo& b : kept) {
    b.offset = m_dim + n_dim;
    n_dim += b.tangent;
  }
  summary.marginalized_dim = m_dim;
  summary.kept_dim = n_dim;
  if (m_dim == 0) {
    summary.reason = "no residual block touches the blocks to marginalise";
    return summary;
  }
  if (n_dim == 0) {
    summary.reason = "nothing is kept: the residual blocks touch only marginalised blocks";
    return summary;
  }

  // Linearise every residual block in the tangent space and accumulate H, g.
  const int N = m_dim + n_dim;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(N, N);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(N);
  for (const ResidualBlockInput& rb : residual_blocks) {
    const int nr = rb.cost->num_residuals();
    const size_t nb = rb.parameter_blocks.size();
    std::vector<RowMajorMatrix> Ja(nb);
    std::vector<double*> jp(nb);
    for (size_t k = 0; k < nb; ++k) {
      Ja[k].resize(nr, rb.cost->parameter_block_sizes()[k]);
      jp[k] = Ja[k].data();
    }
    Eigen::VectorXd r(nr);
    if (!rb.cost->Evaluate(rb.parameter_blocks.data(), r.data(), jp.data())) {
      summary.reason = "a residual block failed to evaluate at the linearisation point";
      return summary;
    }
    std::vector<Eigen::MatrixXd> Jt(nb);
    std::vector<int> offsets(nb);
    for (size_t k = 0; k < nb; ++k) {
      const auto [drop, idx] = where.at(rb.parameter_blocks[k]);
      const BlockInfo& b = drop ? dropped[idx] : kept[idx];
      offsets[k] = b.offset;
      if (b.manifold) {
        RowMajorMatrix P(b.ambient, b.tangent);
        FSP_CHECK(b.manifold->PlusJacobian(b.ptr, P.data()));
        Jt[k] = Ja[k] * P;
      } else {
        Jt[k] = Ja[k];
      }
    }
    // Robust loss: Ceres' corrector (Triggs et al., "Bundle adjustment — a modern synthesis",
    // §4.3): J ← √ρ' (I − α/|r|² r rᵀ) J, r ← √ρ'/(1 − α) r, α = 1 − √(1 + 2|r|²ρ''/ρ').
    if (rb.loss) {
      const double sq = r.squaredNorm();
      double rho[3];
      rb.loss->Evaluate(sq, rho);
      const double sqrt_rho1 = std::sqrt(std::max(rho[1], 0.0));
      double residual_scaling = sqrt_rho1, alpha_sq_norm = 0.0;
      if (sq > 0.0 && rho[2] > 0.0) {
        const double D = 1.0 + 2.0 * sq * rho[2] / rho[1];
        const double alpha = 1.0 - std::sqrt(D);
        residual_scaling = sqrt_rho1 / (1.0 - alpha);
        alpha_sq_norm = alpha / sq;
      }
      for (size_t k = 0; k < nb; ++k) {
        Jt[k] = sqrt_rho1 * (Jt[k] - alpha_sq_norm * r * (r.transpose() * Jt[k]));
      }
      r *= residual_scaling;
    }
    for (size_t a = 0; a < nb; ++a) {
      const int ta = static_cast<int>(Jt[a].cols());
      g.segment(offsets[a], ta) += Jt[a].transpose() * r;
      for (size_t b = 0; b < nb; ++b) {
        H.block(offsets[a], offsets[b], ta, Jt[b].cols()) += Jt[a].transpose() * Jt[b];
      }
    }
  }

  // Schur complement with the thresholded (generalised) inverse of H_mm.
  const Eigen::MatrixXd Hmm = H.topLeftCorner(m_dim, m_dim);
  const ScaledEigen em = Decompose(Hmm, options.relative_eigenvalue_threshold);
  summary.rank_marginalized = static_cast<int>(em.s.size());
  // H_mm⁺ = D^-½ V S⁻¹ Vᵀ D^-½
  const Eigen::MatrixXd W = em.inv_sqrt_d.asDiagonal() * em.V;  // m x rank
  const Eigen::MatrixXd Hmm_inv = W * em.s.cwiseInverse().asDiagonal() * W.transpose();
  const Eigen::MatrixXd Hnm = H.bottomLeftCorner(n_dim, m_dim);
  Eigen::MatrixXd Hs = H.bottomRightCorner(n_dim, n_dim) - Hnm * Hmm_inv * Hnm.transpose();
  Hs = 0.5 * (Hs + Hs.transpose());
  const Eigen::VectorXd gm = g.head(m_dim);
  const Eigen::VectorXd Hmm_inv_gm = Hmm_inv * gm;
  const Eigen::VectorXd gs = g.tail(n_dim) - Hnm * Hmm_inv_gm;

  // H* = D^½ V S Vᵀ D^½  =>  J_p = S^½ Vᵀ D^½,  r0 = S^-½ Vᵀ D^-½ g*.
  const ScaledEigen ek = Decompose(Hs, options.relative_eigenvalue_threshold);
  summary.rank = static_cast<int>(ek.s.size());
  if (summary.rank == 0) {
    summary.reason = "the marginalised information on the kept blocks is zero";
    return summary;
  }
  auto prior = std::make_shared<LinearPrior>();
  const Eigen::VectorXd sqrt_d = ek.inv_sqrt_d.cwiseInverse();
  prior->J = ek.s.cwiseSqrt().asDiagonal() * ek.V.transpose() * sqrt_d.asDiagonal();
  prior->r0 = ek.s.cwiseSqrt().cwiseInverse().asDiagonal() * ek.V.transpose() *
              (ek.inv_sqrt_d.cwiseProduct(gs));
  for (const BlockInfo& b : kept) {
    prior->blocks.push_back(b.ptr);
    prior->ambient_sizes.push_back(b.ambient);
    prior->tangent_sizes.push_back(b.tangent);
    prior->manifolds.push_back(b.manifold);
    prior->x0.push_back(Eigen::Map<const Eigen::VectorXd>(b.ptr, b.ambient));
  }
  summary.prior = prior;
  summary.success = true;
  return summary;
}

void CollectResidualBlocks(const ceres::Problem& problem, const std::vector<double*>& blocks,
                           std::vector<ResidualBlockInput>* residual_blocks,
                           std::unordered_map<const double*, const ceres::Manifold*>* manifolds) {
  std::unordered_set<ceres::ResidualBlockId> seen;
  for (double* p : blocks) {
    std::vector<ceres::ResidualBlockId> ids;
    problem.GetResidualBlocksForParameterBlock(p, &ids);
    for (ceres::ResidualBlockId id : ids) {
      if (!seen.insert(id).second) continue;
      ResidualBlockInput rb;
      rb.cost = problem.GetCostFunctionForResidualBlock(id);
      rb.loss = problem.GetLossFunctionForResidualBlock(id);
      problem.GetParameterBlocksForResidualBlock(id, &rb.parameter_blocks);
      for (double* q : rb.parameter_blocks) (*manifolds)[q] = problem.GetManifold(q);
      residual_blocks->push_back(std::move(rb));
    }
  }
}

std::shared_ptr<const LinearPrior> Recentered(const LinearPrior& prior) {
  auto out = std::make_shared<LinearPrior>(prior);
  for (size_t b = 0; b < out->blocks.size(); ++b)
    out->x0[b] = Eigen::Map<const Eigen::VectorXd>(out->blocks[b], out->ambient_sizes[b]);
  out->r0.setZero();
  return out;
}

MarginalizationPriorFactor::MarginalizationPriorFactor(std::shared_ptr<const LinearPrior> prior)
    : prior_(std::move(prior)) {
  FSP_CHECK(prior_ != nullptr);
  set_num_residuals(static_cast<int>(prior_->r0.size()));
  for (int s : prior_->ambient_sizes) mutable_parameter_block_sizes()->push_back(s);
}

bool MarginalizationPriorFactor::Evaluate(double const* const* parameters, double* residuals,
                                          double** jacobians) const {
  const LinearPrior& p = *prior_;
  const int nr = static_cast<int>(p.r0.size());
  Eigen::VectorXd dx(p.tangent_dim());
  int off = 0;
  for (size_t b = 0; b < p.blocks.size(); ++b) {
    dx.segment(off, p.tangent_sizes[b]) =
        BlockMinus(p.manifolds[b], parameters[b], p.x0[b].data(), p.ambient_sizes[b]);
    off += p.tangent_sizes[b];
  }
  Eigen::Map<Eigen::VectorXd> r(residuals, nr);
  r = p.r0 + p.J * dx;
  if (jacobians == nullptr) return true;
  off = 0;
  for (size_t b = 0; b < p.blocks.size(); ++b) {
    const int t = p.tangent_sizes[b], a = p.ambient_sizes[b];
    if (jacobians[b]) {
      // ∂r/∂x_b = J_b · ∂(x ⊟ x0)/∂δ · lift  (tangent Jacobian of the minus, lifted to ambient).
      const Eigen::MatrixXd Jt =
          p.J.middleCols(off, t) *
          MinusTangentJacobian(p.manifolds[b], parameters[b], p.x0[b].data(), a);
      Eigen::Map<RowMajorMatrix> Ja(jacobians[b], nr, a);
      Ja = Jt * LiftJacobian(p.manifolds[b], parameters[b], a);
    }
    off += t;
  }
  return true;
}

}  // namespace fsp::backend
