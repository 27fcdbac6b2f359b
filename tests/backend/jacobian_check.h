// Shared Jacobian test helper for every Ceres factor of fsp_backend.
//
// CheckJacobians compares a cost function's analytic Jacobians with central differences taken in
// the TANGENT space of each parameter block's manifold:
//   numeric  J_t(:, k) = [r(x ⊞ h e_k) − r(x ⊞ −h e_k)] / 2h
//   analytic J_t       = J_ambient · PlusJacobian(x)          (what Ceres itself uses)
// and reports the worst entry. The error of an entry is |a − n| / max(|n|, 1e-3·max|J_block|,
// 1e-9), so tiny entries of a block with large ones are judged against the block's scale.
// ExpectJacobiansOk additionally runs ceres::GradientChecker with the same manifolds.
//
// Usage:
//   std::vector<double*> params = {pose_i, sb_i, pose_j, sb_j};
//   std::vector<const ceres::Manifold*> manifolds = {&pose_manifold, nullptr, &pose_manifold,
//   nullptr}; EXPECT_TRUE(fsp::test::ExpectJacobiansOk(cost, params, manifolds, 1e-6));
#pragma once

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <gtest/gtest.h>
#include <Eigen/Core>

namespace fsp::test {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct JacobianCheckResult {
  bool evaluated = false;    // the cost function returned true at x and at every probe
  double worst_error = 0.0;  // worst relative entry error (definition above)
  int worst_block = -1, worst_row = -1, worst_col = -1;
  double worst_analytic = 0.0, worst_numeric = 0.0;
  std::vector<Eigen::MatrixXd> analytic_tangent;  // per block, residuals x tangent size
  std::vector<Eigen::MatrixXd> numeric_tangent;
  std::string Describe() const {
    std::ostringstream os;
    os << "worst Jacobian entry: block " << worst_block << " (" << worst_row << ", " << worst_col
       << ") analytic " << worst_analytic << " numeric " << worst_numeric << " rel.err "
       << worst_error;
    return os.str();
  }
};

inline Eigen::VectorXd EvaluateResiduals(const ceres::CostFunction& cost,
                                         const std::vector<double*>& params, bool* ok) {
  Eigen::VectorXd r(cost.num_residuals());
  *ok = cost.Evaluate(params.data(), r.data(), nullptr) && *ok;
  return r;
}

// manifolds[i] == nullptr means Euclidean. `step` is the tangent step h.
inline JacobianCheckResult CheckJacobians(const ceres::CostFunction& cost,
                                          const std::vector<double*>& params,
                                          const std::vector<const ceres::Manifold*>& manifolds,
                                          double step = 1e-6) {
  JacobianCheckResult res;
  const auto& sizes = cost.parameter_block_sizes();
  const int m = cost.num_residuals();
  const size_t nb = sizes.size();
  if (params.size() != nb || manifolds.size() != nb) return res;

  std::vector<RowMajorMatrix> J_ambient(nb);
  std::vector<double*> jac_ptrs(nb);
  for (size_t b = 0; b < nb; ++b) {
    J_ambient[b].resize(m, sizes[b]);
    jac_ptrs[b] = J_ambient[b].data();
  }
  Eigen::VectorXd r0(m);
  bool ok = cost.Evaluate(params.data(), r0.data(), jac_ptrs.data());

  for (size_t b = 0; b < nb; ++b) {
    const int amb = sizes[b];
    const ceres::Manifold* man = manifolds[b];
    const int tan = man ? man->TangentSize() : amb;
    RowMajorMatrix P = RowMajorMatrix::Identity(amb, tan);
    if (man) ok = man->PlusJacobian(params[b], P.data()) && ok;
    res.analytic_tangent.push_back(J_ambient[b] * P);

    Eigen::MatrixXd Jn(m, tan);
    const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(params[b], amb);
    Eigen::VectorXd delta(tan), xp(amb);
    for (int k = 0; k < tan; ++k) {
      Eigen::VectorXd rp, rm;
      for (int sign : {1, -1}) {
        delta.setZero();
        delta[k] = sign * step;
        if (man) {
          ok = man->Plus(x0.data(), delta.data(), xp.data()) && ok;
        } else {
          xp = x0 + delta;
        }
        Eigen::Map<Eigen::VectorXd>(params[b], amb) = xp;
        (sign > 0 ? rp : rm) = EvaluateResiduals(cost, params, &ok);
      }
      Eigen::Map<Eigen::VectorXd>(params[b], amb) = x0;
      Jn.col(k) = (rp - rm) / (2.0 * step);
    }
    res.numeric_tangent.push_back(Jn);

    const Eigen::MatrixXd& Ja = res.analytic_tangent.back();
    const double scale = std::max(Ja.cwiseAbs().maxCoeff(), Jn.cwiseAbs().maxCoeff());
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < tan; ++j) {
        const double den = std::max({std::abs(Jn(i, j)), 1e-3 * scale, 1e-9});
        const double err = std::abs(Ja(i, j) - Jn(i, j)) / den;
        if (err > res.worst_error || res.worst_block < 0) {
          res.worst_error = err;
          res.worst_block = static_cast<int>(b);
          res.worst_row = i;
          res.worst_col = j;
          res.worst_analytic = Ja(i, j);
          res.worst_numeric = Jn(i, j);
        }
      }
    }
  }
  res.evaluated = ok;
  return res;
}

// Both checks; prints the worst entry of each. `tolerance` is the relative tolerance of
// CheckJacobians; GradientChecker gets `gradient_checker_precision` (its own relative measure).
inline ::testing::AssertionResult ExpectJacobiansOk(
    const ceres::CostFunction& cost, const std::vector<double*>& params,
    const std::vector<const ceres::Manifold*>& manifolds, double tolerance = 1e-6,
    double step = 1e-6, double gradient_checker_precision = 1e-5) {
  const JacobianCheckResult res = CheckJacobians(cost, params, manifolds, step);
  std::cout << "[jacobian_check] " << res.Describe() << "\n";
  if (!res.evaluated) return ::testing::AssertionFailure() << "cost function failed to evaluate";
  if (!(res.worst_error <= tolerance)) {
    return ::testing::AssertionFailure() << res.Describe() << " > tolerance " << tolerance;
  }
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = 1e-7;
  // GradientChecker uses Ridders' method, which ignores relative_step_size and starts at
  // ridders_relative_initial_step_size (1e-2 by default: too coarse on quaternion blocks).
  nd.ridders_relative_initial_step_size = 1e-5;
  ceres::GradientChecker checker(&cost, &manifolds, nd);
  ceres::GradientChecker::ProbeResults probe;
  const bool gc_ok = checker.Probe(params.data(), gradient_checker_precision, &probe);
  std::cout << "[jacobian_check] ceres::GradientChecker max relative error "
            << probe.maximum_relative_error << "\n";
  if (!gc_ok) {
    return ::testing::AssertionFailure() << "ceres::GradientChecker: " << probe.error_log;
  }
  return ::testing::AssertionSuccess() << res.Describe();
}

}  // namespace fsp::test
