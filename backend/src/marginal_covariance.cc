// See marginal_covariance.h.
#include "marginal_covariance.h"

#include <algorithm>
#include <set>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

namespace fsp::backend::internal {

bool MarginalCovariance::Compute(ceres::Problem* problem,
                                 const std::vector<const double*>& wanted) {
  rows_.clear();
  cols_.clear();
  constant_.clear();
  inverse_.resize(0, 0);
  ok_ = false;
  // The blocks in the order the residual blocks were added and name them (GetParameterBlocks
  // lists them by address), the variable ones with their offsets in the tangent space the
  // Jacobian is expressed in. A block no residual names is left out (asking for it fails).
  std::vector<double*> all, variable;
  std::set<const double*> listed;
  std::vector<ceres::ResidualBlockId> residuals;
  problem->GetResidualBlocks(&residuals);
  for (ceres::ResidualBlockId r : residuals) {
    std::vector<double*> blocks;
    problem->GetParameterBlocksForResidualBlock(r, &blocks);
    for (double* b : blocks)
      if (listed.insert(b).second) all.push_back(b);
  }
  int n = 0;
  for (double* b : all) {
    const int size = problem->ParameterBlockTangentSize(b);
    if (problem->IsParameterBlockConstant(b)) {
      if (size == problem->ParameterBlockSize(b)) constant_[b] = size;
      continue;
    }
    variable.push_back(b);
    if (size == problem->ParameterBlockSize(b)) rows_[b] = {n, size};
    n += size;
  }
  int m = 0;
  for (const double* b : wanted) {
    if (constant_.count(b)) continue;
    const auto it = rows_.find(b);
    if (it == rows_.end()) return false;
    if (cols_.count(b)) continue;
    cols_[b] = {m, it->second.size};
    m += it->second.size;
  }
  if (m == 0) return ok_ = true;  // nothing variable wanted: all asked for has zero covariance

  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = variable;
  eo.num_threads = 1;
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(eo, nullptr, nullptr, nullptr, &crs)) return false;
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(crs.values.size());
  for (int r = 0; r < crs.num_rows; ++r)
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k)
      triplets.emplace_back(r, crs.cols[k], crs.values[k]);
  Eigen::SparseMatrix<double> J(crs.num_rows, crs.num_cols);
  J.setFromTriplets(triplets.begin(), triplets.end());
  const Eigen::SparseMatrix<double> H = J.transpose() * J;
  const Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(H);
  if (llt.info() != Eigen::Success) return false;

  Eigen::MatrixXd E = Eigen::MatrixXd::Zero(n, m);
  for (const auto& [b, col] : cols_)
    for (int k = 0; k < col.size; ++k) E(rows_.at(b).offset + k, col.offset + k) = 1.0;
  inverse_ = llt.solve(E);
  ok_ = llt.info() == Eigen::Success && inverse_.allFinite();
  return ok_;
}

bool MarginalCovariance::Block(const double* a, const double* b, double* out) const {
  if (!ok_) return false;
  const auto ka = constant_.find(a), kb = constant_.find(b);
  if (ka != constant_.end() || kb != constant_.end()) {
    const auto size = [&](const double* p, auto k) {
      if (k != constant_.end()) return k->second;
      const auto r = rows_.find(p);
      return r == rows_.end() ? -1 : r->second.size;
    };
    const int sa = size(a, ka), sb = size(b, kb);
    if (sa < 0 || sb < 0) return false;
    std::fill(out, out + sa * sb, 0.0);
    return true;
  }
  const auto ra = rows_.find(a);
  const auto cb = cols_.find(b);
  if (ra == rows_.end() || cb == cols_.end()) return false;
  for (int i = 0; i < ra->second.size; ++i)
    for (int j = 0; j < cb->second.size; ++j)
      out[i * cb->second.size + j] = inverse_(ra->second.offset + i, cb->second.offset + j);
  return true;
}

}  // namespace fsp::backend::internal
