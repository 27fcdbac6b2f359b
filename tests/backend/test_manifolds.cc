// PoseManifold conventions, closed-form Plus/Minus/Jacobians against Ceres and central differences,
// and the shared Jacobian checker itself (it must accept a right Jacobian and reject a wrong one).
#include <random>

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>
#include <gtest/gtest.h>

#include "backend/jacobian_check.h"
#include "fsp/backend/manifolds.h"

namespace fsp::backend {
namespace {

Vec3 RandomVec(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return Vec3(n(rng), n(rng), n(rng));
}

void RandomPose(std::mt19937& rng, double* pose) {
  PoseToBlock(Rigid3(ExpQuat(RandomVec(rng, 1.5)), RandomVec(rng, 3.0)), pose);
}

TEST(PoseManifold, ConventionWorldTranslationLeftHalfAngleRotation) {
  // Pins Ceres' convention (ceres/manifold.h): a tangent step (δp = x̂, 0) moves the position along
  // WORLD x; (0, δθ) rotates by Exp(2δθ) on the LEFT (about the WORLD axis, twice the tangent
  // norm).
  double x[7];
  PoseToBlock(Rigid3(RotZ(M_PI / 2), Vec3(1, 2, 3)), x);
  PoseManifold m;
  double d1[6] = {1, 0, 0, 0, 0, 0}, y[7];
  ASSERT_TRUE(m.Plus(x, d1, y));
  EXPECT_NEAR(y[0], 2.0, 1e-15);
  EXPECT_NEAR(y[1], 2.0, 1e-15);
  double d2[6] = {0, 0, 0, 0.15, 0, 0};
  ASSERT_TRUE(m.Plus(x, d2, y));
  const Mat3 R = PoseFromBlock(y).R();
  EXPECT_LT((R - RotX(0.3) * RotZ(M_PI / 2)).norm(), 1e-14);
  EXPECT_GT((R - RotZ(M_PI / 2) * RotX(0.3)).norm(), 0.1);  // not the right perturbation
}

TEST(PoseManifold, ClosedFormsMatchCeresAndRoundTrip) {
  std::mt19937 rng(7);
  PoseManifold m;
  for (int trial = 0; trial < 50; ++trial) {
    double x[7], y[7], yc[7], delta[6];
    RandomPose(rng, x);
    Eigen::Map<Vec6>(delta) << RandomVec(rng, 2.0), RandomVec(rng, 0.4);
    ASSERT_TRUE(m.Plus(x, delta, yc));
    PosePlus(x, delta, y);
    for (int i = 0; i < 7; ++i) EXPECT_NEAR(y[i], yc[i], 1e-12) << i;
    // Minus(Plus(x, δ), x) == δ for |2δθ| < π, ours and Ceres'.
    const Vec6 d = PoseMinus(y, x);
    double dc[6];
    ASSERT_TRUE(m.Minus(y, x, dc));
    for (int i = 0; i < 6; ++i) {
      EXPECT_NEAR(d[i], delta[i], 1e-10);
      EXPECT_NEAR(dc[i], delta[i], 1e-10);
    }
    // Plus(x, Minus(z, x)) == z for arbitrary z.
    double z[7], zz[7];
    RandomPose(rng, z);
    const Vec6 dz = PoseMinus(z, x);
    PosePlus(x, dz.data(), zz);
    EXPECT_LT(PoseMinus(zz, z).norm(), 1e-12);
  }
}

TEST(PoseManifold, PlusJacobianLiftsAndMinusJacobianNumeric) {
  std::mt19937 rng(11);
  PoseManifold m;
  const double h = 1e-6;
  for (int trial = 0; trial < 20; ++trial) {
    double x[7], x0[7];
    RandomPose(rng, x);
    RandomPose(rng, x0);
    // PlusJacobian: ours == Ceres' == central differences of Plus.
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> Pc;
    ASSERT_TRUE(m.PlusJacobian(x, Pc.data()));
    const Mat76 P = PosePlusJacobian(x);
    EXPECT_LT((P - Pc).cwiseAbs().maxCoeff(), 1e-15);
    Mat76 Pn;
    for (int k = 0; k < 6; ++k) {
      double dp[6] = {0}, dm[6] = {0}, yp[7], ym[7];
      dp[k] = h;
      dm[k] = -h;
      PosePlus(x, dp, yp);
      PosePlus(x, dm, ym);
      for (int i = 0; i < 7; ++i) Pn(i, k) = (yp[i] - ym[i]) / (2 * h);
    }
    EXPECT_LT((P - Pn).cwiseAbs().maxCoeff(), 1e-9);
    // Generic lift is a left inverse of Ceres' P.
    EXPECT_LT((LiftJacobian(&m, x, 7) * P - Eigen::MatrixXd::Identity(6, 6)).norm(), 1e-12);
    // Right lift is a left inverse of the right plus-Jacobian, and maps right-tangent Jacobians to
    // Ceres-tangent ones: (L_r P)(δp, δθ) = (δp, 2 q⁻¹-rotated δθ), i.e. R Exp(ψ) = Exp(2δθ) R with
    // ψ = 2 Rᵀ δθ.
    Mat76 Pr = Mat76::Zero();
    Pr.topLeftCorner<3, 3>().setIdentity();
    Pr.bottomRightCorner<4, 3>() = QuaternionRightPlusJacobian(x + 3);
    EXPECT_LT((PoseRightLift(x) * Pr - Eigen::Matrix<double, 6, 6>::Identity()).norm(), 1e-14);
    Eigen::Matrix<double, 6, 6> M = Eigen::Matrix<double, 6, 6>::Identity();
    M.bottomRightCorner<3, 3>() = 2.0 * PoseFromBlock(x).R().transpose();
    EXPECT_LT((PoseRightLift(x) * P - M).norm(), 1e-12);
    // d((x ⊞ δ) ⊟ x0)/dδ: closed form vs central differences.
    const Eigen::MatrixXd J = MinusTangentJacobian(&m, x, x0, 7);
    Eigen::Matrix<double, 6, 6> Jn;
    for (int k = 0; k < 6; ++k) {
      double dp[6] = {0}, dm[6] = {0}, yp[7], ym[7];
      dp[k] = h;
      dm[k] = -h;
      PosePlus(x, dp, yp);
      PosePlus(x, dm, ym);
      Jn.col(k) = (PoseMinus(yp, x0) - PoseMinus(ym, x0)) / (2 * h);
    }
    EXPECT_LT((J - Jn).cwiseAbs().maxCoeff(), 1e-8) << "trial " << trial;
  }
}

TEST(QuaternionManifold, MinusJacobianAndGenericPath) {
  std::mt19937 rng(3);
  ceres::EigenQuaternionManifold m;
  // A manifold the closed forms do not know (so the generic numeric path runs): Ceres' own
  // Product<Euclidean<1>, EigenQuaternion>.
  ceres::ProductManifold<ceres::EuclideanManifold<1>, ceres::EigenQuaternionManifold> other;
  for (int trial = 0; trial < 10; ++trial) {
    // q0 near q: Ceres' Minus is atan2-based and leaves the principal branch when the relative
    // rotation exceeds π (q ⊗ q0⁻¹ with w < 0); ours always takes the short way (the two agree
    // here).
    const Quat q = ExpQuat(RandomVec(rng, 1.0)), q0 = ExpQuat(RandomVec(rng, 0.5)) * q;
    const Eigen::MatrixXd J = MinusTangentJacobian(&m, q.coeffs().data(), q0.coeffs().data(), 4);
    Mat3 Jn;
    for (int k = 0; k < 3; ++k) {
      double dp[3] = {0}, dm[3] = {0}, yp[4], ym[4], mp[3], mm[3];
      dp[k] = 1e-6;
      dm[k] = -1e-6;
      m.Plus(q.coeffs().data(), dp, yp);
      m.Plus(q.coeffs().data(), dm, ym);
      m.Minus(yp, q0.coeffs().data(), mp);
      m.Minus(ym, q0.coeffs().data(), mm);
      for (int i = 0; i < 3; ++i) Jn(i, k) = (mp[i] - mm[i]) / 2e-6;
    }
    EXPECT_LT((J - Jn).cwiseAbs().maxCoeff(), 1e-8);
    double x5[5] = {0.3, q.x(), q.y(), q.z(), q.w()},
           y5[5] = {-1.0, q0.x(), q0.y(), q0.z(), q0.w()};
    const Eigen::MatrixXd Jg = MinusTangentJacobian(&other, x5, y5, 5);
    EXPECT_NEAR(Jg(0, 0), 1.0, 1e-9);
    EXPECT_LT((Jg.bottomRightCorner<3, 3>() - J).cwiseAbs().maxCoeff(), 1e-8);
  }
}

// A small cost on a pose: the body-frame coordinates of a world point, r = R_W_Bᵀ (l − p) − z.
struct PointInBody {
  template <typename T>
  bool operator()(const T* pose, const T* l, T* r) const {
    const T qinv[4] = {pose[6], -pose[3], -pose[4], -pose[5]};  // ceres: w, x, y, z
    const T d[3] = {l[0] - pose[0], l[1] - pose[1], l[2] - pose[2]};
    ceres::QuaternionRotatePoint(qinv, d, r);
    for (int i = 0; i < 3; ++i) r[i] -= T(0.1 * (i + 1));
    return true;
  }
};

// The same residual with an analytic Jacobian in the right tangent, lifted with PoseRightLift;
// kWrong flips the sign of the rotation block (a bug the checker must catch).
template <bool kWrong>
class AnalyticPointInBody : public ceres::SizedCostFunction<3, 7, 3> {
 public:
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    const Rigid3 T = PoseFromBlock(p[0]);
    const Vec3 l(p[1][0], p[1][1], p[1][2]);
    const Mat3 Rt = T.R().transpose();
    Eigen::Map<Vec3> res(r);
    res = Rt * (l - T.translation()) - Vec3(0.1, 0.2, 0.3);
    if (J) {
      Eigen::Matrix<double, 3, 6> Jt;
      Jt.leftCols<3>() = -Rt;
      // d/dθ (R Exp(θ))ᵀ d = [Rᵀ d]×
      Jt.rightCols<3>() = (kWrong ? -1.0 : 1.0) * Skew(Rt * (l - T.translation()));
      if (J[0]) {
        Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> J0(J[0]);
        J0 = Jt * PoseRightLift(p[0]);
      }
      if (J[1]) {
        Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J1(J[1]);
        J1 = Rt;
      }
    }
    return true;
  }
};

TEST(JacobianCheck, AcceptsAutodiffAndRejectsWrongJacobian) {
  std::mt19937 rng(5);
  double pose[7], l[3];
  RandomPose(rng, pose);
  const Vec3 l_value = RandomVec(rng, 4.0);
  std::copy(l_value.data(), l_value.data() + 3, l);
  PoseManifold m;
  std::vector<double*> params = {pose, l};
  std::vector<const ceres::Manifold*> manifolds = {&m, nullptr};
  ceres::AutoDiffCostFunction<PointInBody, 3, 7, 3> good(new PointInBody);
  EXPECT_TRUE(test::ExpectJacobiansOk(good, params, manifolds, 1e-7));
  AnalyticPointInBody<false> analytic;
  EXPECT_TRUE(test::ExpectJacobiansOk(analytic, params, manifolds, 1e-7));
  AnalyticPointInBody<true> bad;
  const test::JacobianCheckResult res = test::CheckJacobians(bad, params, manifolds);
  EXPECT_GT(res.worst_error, 0.1) << res.Describe();
  EXPECT_EQ(res.worst_block, 0);
  EXPECT_FALSE(test::ExpectJacobiansOk(bad, params, manifolds, 1e-6));
}

}  // namespace
}  // namespace fsp::backend
