// Marginalisation prior: exactness on a linear-Gaussian problem (also with a rank-deficient H_mm),
// the prior factor's Jacobians, and the 4-D gauge nullspace (x, y, z, yaw) of a VIO window (IMU
// factors + bearing factors to points) before and after marginalising the oldest keyframe.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <random>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "backend/imu_test_util.h"
#include "backend/jacobian_check.h"
#include "fsp/backend/fsp_factor.h"
#include "fsp/backend/fsp_landmark.h"
#include "fsp/backend/imu_factor.h"
#include "fsp/backend/manifolds.h"
#include "fsp/backend/marginalization.h"

namespace fsp::backend {
namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// r = A [x_1; ...; x_k] − b over Euclidean blocks.
class LinearCost : public ceres::CostFunction {
 public:
  LinearCost(Eigen::MatrixXd A, Eigen::VectorXd b, const std::vector<int>& sizes)
      : A_(std::move(A)), b_(std::move(b)) {
    set_num_residuals(static_cast<int>(b_.size()));
    for (int s : sizes) mutable_parameter_block_sizes()->push_back(s);
  }
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    Eigen::Map<Eigen::VectorXd> res(r, b_.size());
    res = -b_;
    int off = 0;
    for (size_t k = 0; k < parameter_block_sizes().size(); ++k) {
      const int s = parameter_block_sizes()[k];
      res += A_.middleCols(off, s) * Eigen::Map<const Eigen::VectorXd>(p[k], s);
      if (J && J[k]) {
        Eigen::Map<RowMajorMatrix> Jk(J[k], b_.size(), s);
        Jk = A_.middleCols(off, s);
      }
      off += s;
    }
    return true;
  }

 private:
  Eigen::MatrixXd A_;
  Eigen::VectorXd b_;
};

Eigen::MatrixXd RandomMatrix(std::mt19937& rng, int r, int c) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd M(r, c);
  for (int i = 0; i < r; ++i)
    for (int j = 0; j < c; ++j) M(i, j) = n(rng);
  return M;
}

void SolveQuietly(ceres::Problem* problem) {
  ceres::Solver::Options o;
  o.max_num_iterations = 50;
  o.function_tolerance = 1e-16;
  o.gradient_tolerance = 1e-16;
  o.parameter_tolerance = 1e-16;
  ceres::Solver::Summary s;
  ceres::Solve(o, problem, &s);
}

// Marginalising x1 (linearised anywhere) and solving the rest with the prior gives the same kept
// estimate as the full problem: exact for a linear-Gaussian problem. `deficient` zeroes x1's last
// column so H_mm is singular (the pseudo-inverse must cope).
void LinearEquivalence(bool deficient) {
  std::mt19937 rng(deficient ? 9 : 8);
  double x1[3] = {0.3, -0.2, 1.0}, x2[2] = {1, 2}, x3[4] = {0, 0, 0, 0};
  Eigen::MatrixXd A1 = RandomMatrix(rng, 5, 5), A2 = RandomMatrix(rng, 4, 7),
                  A3 = RandomMatrix(rng, 6, 6);
  if (deficient) {  // x1[2] enters no residual: H_mm is singular
    A1.col(2).setZero();
    A2.col(2).setZero();
  }
  LinearCost c1(A1, RandomMatrix(rng, 5, 1), {3, 2});  // x1, x2
  LinearCost c2(A2, RandomMatrix(rng, 4, 1), {3, 4});  // x1, x3
  LinearCost c3(A3, RandomMatrix(rng, 6, 1), {2, 4});  // x2, x3
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem full(po);
  full.AddResidualBlock(&c1, nullptr, x1, x2);
  full.AddResidualBlock(&c2, nullptr, x1, x3);
  full.AddResidualBlock(&c3, nullptr, x2, x3);
  double f1[3], f2[2], f3[4];
  std::copy(x1, x1 + 3, f1);
  std::copy(x2, x2 + 2, f2);
  std::copy(x3, x3 + 4, f3);
  SolveQuietly(&full);

  // Marginalise from the ORIGINAL values (std::copy'd before the solve).
  std::swap_ranges(x1, x1 + 3, f1);
  std::swap_ranges(x2, x2 + 2, f2);
  std::swap_ranges(x3, x3 + 4, f3);  // now x* holds the initial values, f* the full solution
  const MarginalizationSummary ms =
      Marginalize({{&c1, nullptr, {x1, x2}}, {&c2, nullptr, {x1, x3}}}, {x1}, {});
  ASSERT_TRUE(ms.success) << ms.reason;
  EXPECT_EQ(ms.marginalized_dim, 3);
  EXPECT_EQ(ms.kept_dim, 6);
  EXPECT_EQ(ms.rank_marginalized, deficient ? 2 : 3);
  ceres::Problem reduced(po);
  MarginalizationPriorFactor prior(ms.prior);
  reduced.AddResidualBlock(&prior, nullptr, ms.prior->blocks);
  reduced.AddResidualBlock(&c3, nullptr, x2, x3);
  SolveQuietly(&reduced);
  double err = 0.0;
  for (int i = 0; i < 2; ++i) err = std::max(err, std::abs(x2[i] - f2[i]));
  for (int i = 0; i < 4; ++i) err = std::max(err, std::abs(x3[i] - f3[i]));
  std::printf(
      "[marginalization] linear problem%s: kept estimate vs full solve max |diff| %.2e (rank H* "
      "%d)\n",
      deficient ? " (H_mm rank-deficient)" : "", err, ms.rank);
  EXPECT_LT(err, 1e-9);
}

TEST(Marginalization, LinearProblemMatchesFullSolve) {
  LinearEquivalence(false);
}
TEST(Marginalization, RankDeficientMarginalBlock) {
  LinearEquivalence(true);
}

// Bearing of a world point seen from the body: r = (R_W_Bᵀ(l − p)/|l − p| − b) / σ.
struct BearingResidual {
  Vec3 b;
  double sigma = 0.01;
  template <typename T>
  bool operator()(const T* pose, const T* l, T* r) const {
    const T qinv[4] = {pose[6], -pose[3], -pose[4], -pose[5]};
    const T d[3] = {l[0] - pose[0], l[1] - pose[1], l[2] - pose[2]};
    T d_b[3];
    ceres::QuaternionRotatePoint(qinv, d, d_b);
    const T n = ceres::sqrt(d_b[0] * d_b[0] + d_b[1] * d_b[1] + d_b[2] * d_b[2]);
    for (int i = 0; i < 3; ++i) r[i] = (d_b[i] / n - T(b[i])) / T(sigma);
    return true;
  }
};

struct Window {
  test::AnalyticTrajectory traj;
  PreintegrationOptions opt;
  std::vector<KeyframeState> kf;
  std::vector<Vec3> points;
  std::vector<std::shared_ptr<ImuPreintegration>> pre;
  std::unique_ptr<ceres::Problem> problem;
  PoseManifold pose_manifold;

  // FSP rectangles instead of points: anchored at keyframes 1 and 2, observed by every keyframe
  // through the landmark helper's FspFactor (FspAnchorFactor in the anchor).
  std::vector<FspLandmark> objects;
  std::vector<int> anchor_of;
  ceres::EigenQuaternionManifold quat_manifold;
  Rigid3 T_B_C{Mat3((Mat3() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished().transpose()),
               Vec3(0.05, 0.0, 0.02)};
  Mat3 K = (Mat3() << 450, 0, 370, 0, 450, 250, 0, 0, 1).finished();

  explicit Window(int n_kf, bool fsp = false, double spacing = 0.4) {
    kf.reserve(n_kf);
    points.reserve(12);
    const Vec3 bg(0.003, -0.002, 0.001), ba(0.05, -0.02, 0.03);
    test::ImuSamplingOptions so;
    so.bg = bg;
    so.ba = ba;
    const auto imu = test::SampleImu(traj, 0.5, 1.0 + spacing * n_kf + 0.5, so);
    for (int k = 0; k < n_kf; ++k) kf.push_back(traj.State(1.0 + spacing * k, bg, ba));
    for (int i = 0; i < 12; ++i) {
      const double a = 0.5 * i;
      points.emplace_back(4.0 * std::cos(a), 0.5 + 4.0 * std::sin(a), 1.5 * std::sin(1.7 * a));
    }
    ceres::Problem::Options po;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem = std::make_unique<ceres::Problem>(po);
    for (int k = 0; k + 1 < n_kf; ++k) {
      pre.push_back(
          std::make_shared<ImuPreintegration>(opt, imu, kf[k].t_ns, kf[k + 1].t_ns, bg, ba));
      problem->AddResidualBlock(new ImuFactor(pre.back()), nullptr, kf[k].pose, kf[k].speed_bias,
                                kf[k + 1].pose, kf[k + 1].speed_bias);
    }
    for (int k = 0; k < n_kf; ++k) problem->SetManifold(kf[k].pose, &pose_manifold);
    if (fsp) {
      objects.reserve(6);
      for (int o = 0; o < 6; ++o) {
        const int a = 1 + o % 2;
        // In the anchor camera: 3..5 m ahead, spread sideways, tilted, 0.6..1.1 m wide.
        const Rigid3 T_F_O(RotY(0.3 * (o - 2.5) / 2.5) * RotX(0.2 * (o % 3 - 1)),
                           Vec3(-1.2 + 0.5 * o, 0.4 * (o % 3) - 0.6, 3.0 + 0.4 * o));
        objects.push_back(FspLandmark::FromObject(T_F_O, 0.6 + 0.1 * o, 0.5 + 0.08 * o));
        anchor_of.push_back(a);
      }
      for (size_t o = 0; o < objects.size(); ++o) {
        FspLandmark& L = objects[o];
        problem->AddParameterBlock(L.q_F_O, 4, &quat_manifold);
        const int a = anchor_of[o];
        const Rigid3 T_W_F = kf[a].T_W_B() * T_B_C;
        for (int k = 0; k < n_kf; ++k) {
          const CornerPrediction pred = PredictFspCorners(K, kf[k].T_W_B() * T_B_C, T_W_F, L);
          EXPECT_TRUE(pred.in_front) << "object " << o << " keyframe " << k;
          if (k == a) {
            problem->AddResidualBlock(new FspAnchorFactor(pred.uv, K, FspFactorOptions{}), nullptr,
                                      L.q_F_O, L.x);
          } else {
            problem->AddResidualBlock(new FspFactor(pred.uv, K, T_B_C, FspFactorOptions{}), nullptr,
                                      kf[k].pose, kf[a].pose, L.q_F_O, L.x);
          }
        }
      }
      return;
    }
    for (int k = 0; k < n_kf; ++k) {
      for (Vec3& l : points) {
        const Rigid3 T = kf[k].T_W_B();
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<BearingResidual, 3, 7, 3>(
                new BearingResidual{(T.R().transpose() * (l - T.translation())).normalized()}),
            nullptr, kf[k].pose, l.data());
      }
    }
  }
};

// Tangent-space Hessian of a set of residual blocks over `order` (all their parameter blocks).
Eigen::MatrixXd TangentHessian(
    const std::vector<ResidualBlockInput>& blocks, const std::vector<double*>& order,
    const std::unordered_map<const double*, const ceres::Manifold*>& manifolds,
    const std::unordered_map<const double*, int>& ambient) {
  std::unordered_map<const double*, int> offset;
  int n = 0;
  for (double* p : order) {
    offset[p] = n;
    const auto it = manifolds.find(p);
    n += (it != manifolds.end() && it->second) ? it->second->TangentSize() : ambient.at(p);
  }
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  for (const ResidualBlockInput& rb : blocks) {
    const int nr = rb.cost->num_residuals();
    std::vector<RowMajorMatrix> Ja(rb.parameter_blocks.size());
    std::vector<double*> jp;
    for (size_t k = 0; k < Ja.size(); ++k) {
      Ja[k].resize(nr, rb.cost->parameter_block_sizes()[k]);
      jp.push_back(Ja[k].data());
    }
    Eigen::VectorXd r(nr);
    EXPECT_TRUE(rb.cost->Evaluate(rb.parameter_blocks.data(), r.data(), jp.data()));
    std::vector<Eigen::MatrixXd> Jt;
    for (size_t k = 0; k < Ja.size(); ++k) {
      const auto it = manifolds.find(rb.parameter_blocks[k]);
      const ceres::Manifold* m = it == manifolds.end() ? nullptr : it->second;
      if (m) {
        RowMajorMatrix P(m->AmbientSize(), m->TangentSize());
        m->PlusJacobian(rb.parameter_blocks[k], P.data());
        Jt.push_back(Ja[k] * P);
      } else {
        Jt.push_back(Ja[k]);
      }
    }
    for (size_t a = 0; a < Jt.size(); ++a)
      for (size_t b = 0; b < Jt.size(); ++b)
        H.block(offset[rb.parameter_blocks[a]], offset[rb.parameter_blocks[b]], Jt[a].cols(),
                Jt[b].cols()) += Jt[a].transpose() * Jt[b];
  }
  return H;
}

// Eigenvalues of the Jacobi-scaled H (same inertia as H), ascending.
Eigen::VectorXd ScaledEigenvalues(const Eigen::MatrixXd& H) {
  const Eigen::VectorXd d = H.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd Hs = d.asDiagonal() * H * d.asDiagonal();
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * (Hs + Hs.transpose())).eigenvalues();
}

// The 4 gauge directions in the Ceres tangent coordinates: translation (δp = δl = e_k) and yaw
// (Exp(2δθ) R = Rz(ε) R  =>  δθ = ε/2 e_z;  δp = ε e_z × p, δv = ε e_z × v, δl = ε e_z × l).
Eigen::MatrixXd GaugeDirections(const std::vector<double*>& order,
                                const std::unordered_map<const double*, int>& kind, int n) {
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, 4);
  int off = 0;
  for (double* p : order) {
    const int k = kind.at(p);  // 0 pose, 1 speed_bias, 2 point, 3 q_F_O, 4 FSP x (anchor-relative)
    if (k == 3 ||
        k == 4) {  // FSP parameters are relative to their anchor: the gauge leaves them alone
      off += k == 3 ? 3 : 5;
      continue;
    }
    const Vec3 x(p[0], p[1], p[2]);
    const Vec3 yaw = Vec3::UnitZ().cross(x);
    if (k == 0) {
      G.block<3, 3>(off, 0).setIdentity();
      G.block<3, 1>(off, 3) = yaw;
      G(off + 5, 3) = 0.5;
      off += 6;
    } else if (k == 1) {
      G.block<3, 1>(off, 3) = yaw;
      off += 9;
    } else {
      G.block<3, 3>(off, 0).setIdentity();
      G.block<3, 1>(off, 3) = yaw;
      off += 3;
    }
  }
  return G;
}

TEST(Marginalization, WindowHessianHasExactlyFourDimensionalNullspace) {
  Window w(6);
  // All residual blocks of the window, and the parameter order.
  std::vector<double*> all_blocks;
  std::unordered_map<const double*, int> kind, ambient;
  for (KeyframeState& k : w.kf) {
    all_blocks.push_back(k.pose);
    all_blocks.push_back(k.speed_bias);
    kind[k.pose] = 0;
    kind[k.speed_bias] = 1;
    ambient[k.pose] = 7;
    ambient[k.speed_bias] = 9;
  }
  for (Vec3& l : w.points) {
    all_blocks.push_back(l.data());
    kind[l.data()] = 2;
    ambient[l.data()] = 3;
  }
  std::vector<ResidualBlockInput> blocks;
  std::unordered_map<const double*, const ceres::Manifold*> manifolds;
  CollectResidualBlocks(*w.problem, all_blocks, &blocks, &manifolds);

  auto report = [&](const char* what, const Eigen::MatrixXd& H, const std::vector<double*>& order) {
    const Eigen::VectorXd ev = ScaledEigenvalues(H);
    const double max_ev = ev.maxCoeff();
    std::printf("[marginalization] %s: dim %d, smallest scaled eigenvalues / max:", what,
                static_cast<int>(H.rows()));
    for (int i = 0; i < 6; ++i) std::printf(" %.1e", ev[i] / max_ev);
    std::printf("\n");
    int null_dim = 0;
    for (int i = 0; i < ev.size(); ++i) null_dim += ev[i] < 1e-11 * max_ev ? 1 : 0;
    EXPECT_EQ(null_dim, 4) << what;
    EXPECT_GT(ev[4] / max_ev, 1e-8) << what;  // a clear gap above the gauge
    // ...and the nullspace is exactly the gauge (x, y, z, yaw).
    const Eigen::MatrixXd G = GaugeDirections(order, kind, static_cast<int>(H.rows()));
    const double rel = (H * G).norm() / (H.norm() * G.norm());
    std::printf("[marginalization] %s: |H G| / (|H||G|) = %.1e for the 4 gauge directions\n", what,
                rel);
    EXPECT_LT(rel, 1e-12) << what;
  };
  report("window of 6 keyframes", TangentHessian(blocks, all_blocks, manifolds, ambient),
         all_blocks);

  // Marginalise the oldest keyframe (pose + speed_bias) at the (true) estimate.
  std::vector<ResidualBlockInput> touching;
  std::unordered_map<const double*, const ceres::Manifold*> touching_manifolds;
  CollectResidualBlocks(*w.problem, {w.kf[0].pose, w.kf[0].speed_bias}, &touching,
                        &touching_manifolds);
  const MarginalizationSummary ms =
      Marginalize(touching, {w.kf[0].pose, w.kf[0].speed_bias}, touching_manifolds);
  ASSERT_TRUE(ms.success) << ms.reason;
  std::printf(
      "[marginalization] oldest keyframe: %d residual blocks, dropped dim %d, kept dim %d, rank "
      "%d\n",
      ms.num_residual_blocks, ms.marginalized_dim, ms.kept_dim, ms.rank);
  EXPECT_EQ(ms.marginalized_dim, 15);
  EXPECT_EQ(ms.rank_marginalized, 15);
  // Kept: pose_1, speed_bias_1 and the 12 points. The information the prior carries has rank
  // 12 bearings x 2 + 15 IMU residuals − 15 dropped dimensions = 24.
  EXPECT_EQ(ms.kept_dim, 15 + 36);
  EXPECT_EQ(ms.rank, 24);
  MarginalizationPriorFactor prior(ms.prior);
  std::vector<ResidualBlockInput> after = {{&prior, nullptr, ms.prior->blocks}};
  for (const ResidualBlockInput& rb : blocks) {
    const auto& pb = rb.parameter_blocks;
    if (std::find(pb.begin(), pb.end(), w.kf[0].pose) == pb.end() &&
        std::find(pb.begin(), pb.end(), w.kf[0].speed_bias) == pb.end()) {
      after.push_back(rb);
    }
  }
  const std::vector<double*> kept_order(all_blocks.begin() + 2, all_blocks.end());
  report("after marginalising the oldest keyframe",
         TangentHessian(after, kept_order, manifolds, ambient), kept_order);
  // Noise-free window at the truth: the prior's residual is at the level of the whitened IMU
  // discretisation error (|r0| ~ 1e-5), not zero.
  EXPECT_LT(prior.prior().r0.norm(), 1e-3);
}

TEST(Marginalization, WindowWithFspRectanglesHasExactlyFourDimensionalNullspace) {
  Window w(5, /*fsp=*/true, /*spacing=*/0.25);
  std::vector<double*> order;
  std::unordered_map<const double*, int> kind, ambient;
  for (KeyframeState& k : w.kf) {
    order.push_back(k.pose);
    order.push_back(k.speed_bias);
    kind[k.pose] = 0;
    kind[k.speed_bias] = 1;
    ambient[k.pose] = 7;
    ambient[k.speed_bias] = 9;
  }
  for (FspLandmark& L : w.objects) {
    order.push_back(L.q_F_O);
    order.push_back(L.x);
    kind[L.q_F_O] = 3;
    kind[L.x] = 4;
    ambient[L.q_F_O] = 4;
    ambient[L.x] = 5;
  }
  std::vector<ResidualBlockInput> blocks;
  std::unordered_map<const double*, const ceres::Manifold*> manifolds;
  CollectResidualBlocks(*w.problem, order, &blocks, &manifolds);
  auto check = [&](const char* what, const Eigen::MatrixXd& H, const std::vector<double*>& ord) {
    const Eigen::VectorXd ev = ScaledEigenvalues(H);
    const double max_ev = ev.maxCoeff();
    std::printf("[marginalization] FSP %s: dim %d, smallest scaled eigenvalues / max:", what,
                static_cast<int>(H.rows()));
    for (int i = 0; i < 6; ++i) std::printf(" %.1e", ev[i] / max_ev);
    std::printf("\n");
    int null_dim = 0;
    for (int i = 0; i < ev.size(); ++i) null_dim += ev[i] < 1e-11 * max_ev ? 1 : 0;
    EXPECT_EQ(null_dim, 4) << what;
    const Eigen::MatrixXd G = GaugeDirections(ord, kind, static_cast<int>(H.rows()));
    EXPECT_LT((H * G).norm() / (H.norm() * G.norm()), 1e-12) << what;
  };
  check("window of 5 keyframes, 6 rectangles", TangentHessian(blocks, order, manifolds, ambient),
        order);
  std::vector<ResidualBlockInput> touching;
  std::unordered_map<const double*, const ceres::Manifold*> tm;
  CollectResidualBlocks(*w.problem, {w.kf[0].pose, w.kf[0].speed_bias}, &touching, &tm);
  const MarginalizationSummary ms = Marginalize(touching, {w.kf[0].pose, w.kf[0].speed_bias}, tm);
  ASSERT_TRUE(ms.success) << ms.reason;
  MarginalizationPriorFactor prior(ms.prior);
  std::vector<ResidualBlockInput> after = {{&prior, nullptr, ms.prior->blocks}};
  for (const ResidualBlockInput& rb : blocks) {
    const auto& pb = rb.parameter_blocks;
    if (std::find(pb.begin(), pb.end(), w.kf[0].pose) == pb.end() &&
        std::find(pb.begin(), pb.end(), w.kf[0].speed_bias) == pb.end()) {
      after.push_back(rb);
    }
  }
  const std::vector<double*> kept(order.begin() + 2, order.end());
  check("after marginalising the oldest keyframe", TangentHessian(after, kept, manifolds, ambient),
        kept);
}

// Marginalises the oldest keyframe of W (every factor touching it); `manifolds` gets the
// manifolds of the blocks those factors touch.
MarginalizationSummary MarginalizeOldest(
    Window& w, std::unordered_map<const double*, const ceres::Manifold*>* manifolds) {
  std::vector<ResidualBlockInput> touching;
  CollectResidualBlocks(*w.problem, {w.kf[0].pose, w.kf[0].speed_bias}, &touching, manifolds);
  return Marginalize(touching, {w.kf[0].pose, w.kf[0].speed_bias}, *manifolds);
}

TEST(Marginalization, PriorFactorJacobians) {
  Window w(3);
  std::unordered_map<const double*, const ceres::Manifold*> manifolds;
  const MarginalizationSummary ms = MarginalizeOldest(w, &manifolds);
  ASSERT_TRUE(ms.success) << ms.reason;
  MarginalizationPriorFactor prior(ms.prior);
  // Move every kept block away from the linearisation point (rotations by up to ~0.6 rad).
  std::mt19937 rng(4);
  std::normal_distribution<double> n(0.0, 0.3);
  std::vector<const ceres::Manifold*> ms_list;
  std::vector<double*> params;
  for (size_t b = 0; b < ms.prior->blocks.size(); ++b) {
    double* p = ms.prior->blocks[b];
    const ceres::Manifold* m = manifolds.count(p) ? manifolds.at(p) : nullptr;
    ms_list.push_back(m);
    params.push_back(p);
    if (m) {
      double d[6], y[7];
      for (double& v : d) v = n(rng);
      PosePlus(p, d, y);
      std::copy(y, y + 7, p);
    } else {
      const int a = static_cast<int>(ms.prior->x0[b].size());
      for (int i = 0; i < a; ++i) p[i] += n(rng);
    }
  }
  EXPECT_TRUE(test::ExpectJacobiansOk(prior, params, ms_list, 1e-6));
  // At the linearisation point the residual is r0.
  for (size_t b = 0; b < params.size(); ++b)
    std::copy(ms.prior->x0[b].data(), ms.prior->x0[b].data() + ms.prior->x0[b].size(), params[b]);
  Eigen::VectorXd r(ms.prior->r0.size());
  ASSERT_TRUE(prior.Evaluate(params.data(), r.data(), nullptr));
  EXPECT_LT((r - ms.prior->r0).norm(), 1e-15);
}

// A re-centred prior (after a global solve moved the window): zero residual at the blocks' new
// values, the same information (J_p) and so the same curvature around them; the original prior
// still pulls towards where it was linearised.
TEST(Marginalization, RecenteredPriorIsZeroAtTheNewValuesWithTheSameInformation) {
  Window w(3);
  std::unordered_map<const double*, const ceres::Manifold*> manifolds;
  const MarginalizationSummary ms = MarginalizeOldest(w, &manifolds);
  ASSERT_TRUE(ms.success) << ms.reason;
  // Move the kept blocks (a translation of every pose, a velocity change).
  for (double* p : ms.prior->blocks) {
    const bool pose = manifolds.count(p) && manifolds.at(p);
    if (pose) {
      p[0] += 0.4;
      p[2] -= 0.2;
    } else {
      p[0] += 0.1;
    }
  }
  const std::shared_ptr<const LinearPrior> re = Recentered(*ms.prior);
  ASSERT_EQ(re->blocks, ms.prior->blocks);
  EXPECT_EQ((re->J - ms.prior->J).norm(), 0.0);
  Eigen::VectorXd r_old(ms.prior->r0.size()), r_new(re->r0.size());
  ASSERT_TRUE(MarginalizationPriorFactor(ms.prior).Evaluate(ms.prior->blocks.data(), r_old.data(),
                                                            nullptr));
  ASSERT_TRUE(MarginalizationPriorFactor(re).Evaluate(re->blocks.data(), r_new.data(), nullptr));
  EXPECT_LT(r_new.norm(), 1e-12);
  EXPECT_GT(r_old.norm(), 1.0);  // the old prior pulls back
}

}  // namespace
}  // namespace fsp::backend
