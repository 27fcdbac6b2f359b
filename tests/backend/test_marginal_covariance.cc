// MarginalCovariance (backend/src/marginal_covariance.h): the same covariance as ceres::Covariance,
// and the same bits wherever the parameter blocks live in memory (ceres::Covariance orders its
// columns by block address).
#include <array>
#include <memory>
#include <random>
#include <vector>

#include <ceres/ceres.h>
#include <ceres/normal_prior.h>
#include <gtest/gtest.h>
#include <Eigen/Core>

#include "marginal_covariance.h"

namespace fsp::backend::internal {
namespace {

// r = W (x_a - x_b - d): a relative measurement between two 3-vectors.
struct Difference {
  template <typename T>
  bool operator()(const T* a, const T* b, T* r) const {
    for (int k = 0; k < 3; ++k) r[k] = T(w[k]) * (a[k] - b[k] - T(d[k]));
    return true;
  }
  std::array<double, 3> d, w;
};

constexpr int kBlocks = 12;

struct Chain {
  std::vector<std::array<double, 3>> storage;  // the blocks, wherever they are
  std::vector<double*> x;                      // block i, in the order added to the problem
  std::unique_ptr<ceres::Problem> problem;
};

// A chain of kBlocks blocks with loop edges, block 0 held by a prior and block kBlocks-1 constant;
// the blocks are added in index order but stored forwards or backwards in memory.
Chain MakeChain(bool reversed_in_memory) {
  Chain c;
  c.storage.resize(kBlocks);
  for (int i = 0; i < kBlocks; ++i)
    c.x.push_back(c.storage[reversed_in_memory ? kBlocks - 1 - i : i].data());
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> w(0.5, 2.0);
  for (int i = 0; i < kBlocks; ++i)
    for (int k = 0; k < 3; ++k) c.x[i][k] = n(rng);
  c.problem = std::make_unique<ceres::Problem>();
  for (double* b : c.x) c.problem->AddParameterBlock(b, 3);
  const auto edge = [&](int a, int b) {
    Difference f;
    for (int k = 0; k < 3; ++k) {
      f.d[k] = n(rng);
      f.w[k] = w(rng);
    }
    c.problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<Difference, 3, 3, 3>(new Difference(f)),
        new ceres::HuberLoss(1.0), c.x[a], c.x[b]);
  };
  for (int i = 0; i + 1 < kBlocks; ++i) edge(i, i + 1);
  for (int i = 0; i + 4 < kBlocks; i += 3) edge(i, i + 4);
  c.problem->AddResidualBlock(
      new ceres::NormalPrior(Eigen::Matrix3d::Identity() * 3.0, Eigen::Vector3d::Zero()), nullptr,
      c.x[0]);
  c.problem->SetParameterBlockConstant(c.x[kBlocks - 1]);
  return c;
}

TEST(MarginalCovariance, EqualsCeresCovariance) {
  Chain c = MakeChain(false);
  std::vector<const double*> wanted = {c.x[2], c.x[7], c.x[kBlocks - 1]};
  MarginalCovariance mine;
  ASSERT_TRUE(mine.Compute(c.problem.get(), wanted));
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance ceres_cov(co);
  std::vector<std::pair<const double*, const double*>> blocks;
  for (int i = 0; i + 1 < kBlocks; ++i)
    for (const double* b : {c.x[2], c.x[7]}) blocks.emplace_back(c.x[i], b);
  ASSERT_TRUE(ceres_cov.Compute(blocks, c.problem.get()));
  for (int i = 0; i + 1 < kBlocks; ++i)
    for (const double* b : {c.x[2], c.x[7]}) {
      double expected[9], got[9];
      ASSERT_TRUE(ceres_cov.GetCovarianceBlock(c.x[i], b, expected));
      ASSERT_TRUE(mine.Block(c.x[i], b, got));
      for (int k = 0; k < 9; ++k) EXPECT_NEAR(got[k], expected[k], 1e-9) << i << " " << k;
    }
  // A constant block: zero covariance with anything; a block not wanted cannot be a column.
  double z[9] = {1.0};
  ASSERT_TRUE(mine.Block(c.x[3], c.x[kBlocks - 1], z));
  for (double v : z) EXPECT_EQ(v, 0.0);
  EXPECT_FALSE(mine.Block(c.x[2], c.x[3], z));
  double diag[9];
  ASSERT_TRUE(mine.Block(c.x[7], c.x[7], diag));
  EXPECT_GT(diag[0], 0.0);
}

TEST(MarginalCovariance, SameBitsWhereverTheBlocksLive) {
  Chain forward = MakeChain(false), backward = MakeChain(true);
  MarginalCovariance a, b;
  ASSERT_TRUE(a.Compute(forward.problem.get(), {forward.x[2], forward.x[7]}));
  ASSERT_TRUE(b.Compute(backward.problem.get(), {backward.x[2], backward.x[7]}));
  for (int i = 0; i + 1 < kBlocks; ++i)
    for (int j : {2, 7}) {
      double ca[9], cb[9];
      ASSERT_TRUE(a.Block(forward.x[i], forward.x[j], ca));
      ASSERT_TRUE(b.Block(backward.x[i], backward.x[j], cb));
      for (int k = 0; k < 9; ++k) EXPECT_EQ(ca[k], cb[k]) << i << " " << j << " " << k;
    }
}

TEST(MarginalCovariance, UnobservableDirectionIsRefused) {
  Chain c = MakeChain(false);
  c.problem->SetParameterBlockVariable(c.x[kBlocks - 1]);
  c.problem->RemoveResidualBlock([&] {
    std::vector<ceres::ResidualBlockId> r;
    c.problem->GetResidualBlocksForParameterBlock(c.x[0], &r);
    for (ceres::ResidualBlockId id : r)
      if (c.problem->GetCostFunctionForResidualBlock(id)->parameter_block_sizes().size() == 1)
        return id;
    return r.front();
  }());
  // Only differences remain: the chain can move as a whole.
  MarginalCovariance m;
  EXPECT_FALSE(m.Compute(c.problem.get(), {c.x[2]}));
  double out[9];
  EXPECT_FALSE(m.Block(c.x[2], c.x[2], out));
}

}  // namespace
}  // namespace fsp::backend::internal
