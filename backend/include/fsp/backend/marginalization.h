// Marginalisation into a linear prior by Schur complement (sliding-window estimators: Leutenegger
// et al., OKVIS, IJRR 2015 §IV-D; Qin et al., VINS-Mono, T-RO 2018 §VI-D).
//
// Input: the residual blocks that touch the parameter blocks to drop (cost function + loss +
// parameter pointers, e.g. from a ceres::Problem with CollectResidualBlocks) and which blocks to
// drop. At the current values x̄ every block is linearised in the TANGENT space of its parameter
// blocks' manifolds (J_t = J_ambient · PlusJacobian), robustified like Ceres does (Triggs
// correction with ρ', ρ''), and accumulated into H = Σ JᵀJ, g = Σ Jᵀr, ordered [dropped m | kept
// n]. Then
//     H* = H_nn − H_nm H_mm⁺ H_mn,      g* = g_n − H_nm H_mm⁺ g_m
// (H_mm⁺: pseudo-inverse by eigen-decomposition). H* = V S Vᵀ is factorised the same way and the
// prior is the linear residual over the kept blocks
//     r(x) = r0 + J_p (x ⊟ x̄),   J_p = S^½ Vᵀ,   r0 = S^-½ Vᵀ g*
// so that ½|r|² = ½ δᵀH*δ + g*ᵀδ + const. Rank deficiency (the 4-DoF gauge of a VIO window, blocks
// without information) is handled like OKVIS / VINS-Mono: eigenvalues below a threshold are dropped
// (both in H_mm⁺ and in S), so J_p has one row per kept eigenvalue. Both decompositions are done on
// the Jacobi-scaled matrix D^-½ H D^-½ (D = diag H) so that the threshold is unit-free (rad, m, m/s
// and biases mix in one H); the scaling is undone exactly. ⊟ is the manifold minus of each kept
// block (closed form, shortest rotation, for PoseManifold and EigenQuaternionManifold;
// Manifold::Minus otherwise); its Jacobian is MinusTangentJacobian lifted to ambient with
// LiftJacobian (manifolds.h).
#pragma once

#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <Eigen/Core>

namespace fsp::backend {

struct ResidualBlockInput {
  const ceres::CostFunction* cost = nullptr;  // not owned
  const ceres::LossFunction* loss = nullptr;  // not owned; nullptr = squared loss
  std::vector<double*> parameter_blocks;
};

struct MarginalizationOptions {
  // Eigenvalues of the Jacobi-scaled matrices below this (relative to the largest) are treated as
  // zero. Larger: more robust against near-singular directions, loses weak information.
  double relative_eigenvalue_threshold = 1e-10;
  bool Check(std::string* why) const;
};

// The linearised prior: kept blocks, their linearisation point and (J_p, r0).
struct LinearPrior {
  std::vector<double*> blocks;  // kept parameter blocks (addresses in the problem)
  std::vector<int> ambient_sizes, tangent_sizes;  // per block
  std::vector<const ceres::Manifold*> manifolds;  // per block, nullptr = Euclidean; not owned
  std::vector<Eigen::VectorXd> x0;                // linearisation point per block (ambient)
  Eigen::MatrixXd J;                              // rank x Σ tangent_sizes
  Eigen::VectorXd r0;                             // rank
  int tangent_dim() const;
  // The prior's information at x0 (= J_pᵀ J_p, the Schur complement up to the dropped eigenvalues).
  Eigen::MatrixXd Hessian() const { return J.transpose() * J; }
};

// The same information re-centred at the blocks' current values: x0 = the values now in
// prior.blocks, r0 = 0, so the prior's minimum is where the blocks are. For a window whose states
// were moved by a solve that held every measurement (a global bundle adjustment, a loop
// correction): without it the prior would pull the window back to where it was linearised.
std::shared_ptr<const LinearPrior> Recentered(const LinearPrior& prior);

struct MarginalizationSummary {
  bool success = false;
  std::string reason;         // when !success
  int marginalized_dim = 0;   // tangent dimension dropped
  int kept_dim = 0;           // tangent dimension of the kept blocks
  int rank_marginalized = 0;  // numerical rank of H_mm
  int rank = 0;               // numerical rank of H* = rows of J_p
  int num_residual_blocks = 0;
  std::shared_ptr<const LinearPrior> prior;
};

// manifolds: manifold of every parameter block that has one (missing = Euclidean); they must
// outlive the prior. Blocks in `to_marginalize` that no residual touches are ignored.
MarginalizationSummary Marginalize(
    const std::vector<ResidualBlockInput>& residual_blocks,
    const std::unordered_set<const double*>& to_marginalize,
    const std::unordered_map<const double*, const ceres::Manifold*>& manifolds,
    const MarginalizationOptions& options = MarginalizationOptions());

// Every residual block of `problem` that touches one of `blocks`, and the manifolds of all
// parameter blocks they touch (as the problem knows them), ready for Marginalize.
void CollectResidualBlocks(const ceres::Problem& problem, const std::vector<double*>& blocks,
                           std::vector<ResidualBlockInput>* residual_blocks,
                           std::unordered_map<const double*, const ceres::Manifold*>* manifolds);

// r = r0 + J_p (x ⊟ x0) over the kept blocks (parameter blocks in LinearPrior::blocks order).
class MarginalizationPriorFactor : public ceres::CostFunction {
 public:
  explicit MarginalizationPriorFactor(std::shared_ptr<const LinearPrior> prior);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;
  const LinearPrior& prior() const { return *prior_; }

 private:
  std::shared_ptr<const LinearPrior> prior_;
};

}  // namespace fsp::backend
