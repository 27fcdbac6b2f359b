// Marginal covariances of a solved problem's parameter blocks, computed in the order the blocks
// were added to the problem. ceres::Covariance orders its columns by block address, so the last
// bits of its results depend on the heap layout (two runs of the same input in different thread
// schedules gave σ that differed in the 10th digit); here the same problem built the same way
// gives the same bits. Internal: included by the estimator's files only.
#pragma once

#include <map>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Core>

namespace fsp::backend::internal {

class MarginalCovariance {
 public:
  // Factorises JᵀJ of PROBLEM's variable blocks (loss functions applied, at their current values)
  // and keeps the columns of its inverse for the WANTED blocks, which must be Euclidean blocks of
  // the problem (a constant one has zero covariance). False when the information matrix is not
  // positive definite (an unobservable direction) or a wanted block is not of that kind.
  bool Compute(ceres::Problem* problem, const std::vector<const double*>& wanted);
  // Cov(A, B), row-major size(A) x size(B). A is any Euclidean block of the problem, B one of the
  // wanted blocks; false otherwise (or before a successful Compute).
  bool Block(const double* a, const double* b, double* out) const;

 private:
  struct Span {
    int offset = 0, size = 0;
  };
  std::map<const double*, Span> rows_;     // every variable Euclidean block: its rows of inverse_
  std::map<const double*, Span> cols_;     // the wanted blocks: their columns of inverse_
  std::map<const double*, int> constant_;  // constant Euclidean blocks: their sizes
  Eigen::MatrixXd inverse_;                // (JᵀJ)⁻¹ restricted to the wanted blocks' columns
  bool ok_ = false;                        // the last Compute succeeded
};

}  // namespace fsp::backend::internal
