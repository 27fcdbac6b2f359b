// Pins the geometry conventions of docs/conventions.md and checks exp/log, Jacobians and
// Plus/Minus.
#include <random>

#include <gtest/gtest.h>

#include "fsp/common/geometry.h"

namespace fsp {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 RandomVec(std::mt19937& rng, double scale) {
  std::normal_distribution<double> n(0.0, scale);
  return Vec3(n(rng), n(rng), n(rng));
}

TEST(Conventions, YawOf90DegreesMapsXToY) {
  const Rigid3 T_W_B(RotZ(kPi / 2), Vec3::Zero());
  EXPECT_TRUE((T_W_B * Vec3::UnitX()).isApprox(Vec3::UnitY(), 1e-12));
  EXPECT_TRUE(RotFromRpy(0, 0, kPi / 2).isApprox(RotZ(kPi / 2), 1e-12));
}

TEST(Conventions, EigenQuaternionStorageIsXyzw) {
  const Quat q = ExpQuat(Vec3(0, 0, kPi / 2));        // 90 deg about z
  EXPECT_NEAR(q.coeffs()[0], 0.0, 1e-12);             // x
  EXPECT_NEAR(q.coeffs()[2], std::sqrt(0.5), 1e-12);  // z
  EXPECT_NEAR(q.coeffs()[3], std::sqrt(0.5), 1e-12);  // w last
  EXPECT_NEAR(q.w(), std::sqrt(0.5), 1e-12);
}

TEST(Conventions, TransformComposition) {
  // p_A = T_A_B p_B; T_A_C = T_A_B T_B_C.
  const Rigid3 T_A_B(RotZ(0.3), Vec3(1, 2, 3));
  const Rigid3 T_B_C(RotX(-0.7), Vec3(-1, 0.5, 0));
  const Vec3 p_C(0.1, 0.2, 0.3);
  EXPECT_TRUE(((T_A_B * T_B_C) * p_C).isApprox(T_A_B * (T_B_C * p_C), 1e-12));
  EXPECT_TRUE((T_A_B.Inverse() * (T_A_B * p_C)).isApprox(p_C, 1e-12));
  EXPECT_TRUE((T_A_B * T_A_B.Inverse()).Matrix().isApprox(Mat4::Identity(), 1e-12));
}

TEST(Conventions, RpyOrderIsZyx) {
  const double r = 0.1, p = -0.4, y = 1.2;
  const Mat3 expected = Eigen::AngleAxisd(y, Vec3::UnitZ()).toRotationMatrix() *
                        Eigen::AngleAxisd(p, Vec3::UnitY()).toRotationMatrix() *
                        Eigen::AngleAxisd(r, Vec3::UnitX()).toRotationMatrix();
  EXPECT_TRUE(RotFromRpy(r, p, y).isApprox(expected, 1e-12));
  // The scene file's convention: a door on a wall facing -y, upright, is rpy_deg [90, 0, 0]: x
  // along the width
  // (+x), y (height) up, z = x × y pointing out of the face towards -y.
  const Mat3 R_W_O = RotFromRpy(kPi / 2, 0, 0);
  EXPECT_TRUE((R_W_O * Vec3::UnitY()).isApprox(Vec3::UnitZ(), 1e-12));
  EXPECT_TRUE((R_W_O * Vec3::UnitZ()).isApprox(-Vec3::UnitY(), 1e-12));
}

TEST(SO3, ExpLogRoundTrip) {
  std::mt19937 rng(1);
  for (int i = 0; i < 200; ++i) {
    Vec3 phi = RandomVec(rng, 1.0);
    if (phi.norm() > 3.0) phi *= 3.0 / phi.norm();
    EXPECT_TRUE(LogSO3(ExpSO3(phi)).isApprox(phi, 1e-10)) << phi.transpose();
  }
  // Tiny and near-pi angles.
  const Vec3 tiny(1e-12, -2e-12, 3e-13);
  EXPECT_TRUE(LogSO3(ExpSO3(tiny)).isApprox(tiny, 1e-6));
  const Vec3 near_pi = Vec3(1, 2, 3).normalized() * (kPi - 1e-7);
  EXPECT_NEAR(LogSO3(ExpSO3(near_pi)).norm(), kPi - 1e-7, 1e-6);
  EXPECT_TRUE(ExpSO3(Vec3::Zero()).isApprox(Mat3::Identity(), 0));
}

TEST(SO3, RightJacobianMatchesNumeric) {
  std::mt19937 rng(2);
  for (double scale : {1e-7, 0.1, 1.0}) {
    const Vec3 phi = RandomVec(rng, scale);
    Mat3 numeric;
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      // Exp(phi + h e_k) = Exp(phi) Exp(Jr e_k h)  =>  column k = Log(Exp(phi)^T Exp(phi + h e_k))
      // / h
      const Vec3 e = Vec3::Unit(k) * h;
      numeric.col(k) = (LogSO3(ExpSO3(phi).transpose() * ExpSO3(phi + e)) -
                        LogSO3(ExpSO3(phi).transpose() * ExpSO3(phi - e))) /
                       (2 * h);
    }
    EXPECT_TRUE(RightJacobianSO3(phi).isApprox(numeric, 1e-7)) << RightJacobianSO3(phi) << "\n"
                                                               << numeric;
    EXPECT_TRUE(
        (RightJacobianSO3(phi) * RightJacobianInvSO3(phi)).isApprox(Mat3::Identity(), 1e-10));
  }
}

TEST(Rigid3, PlusMinusRoundTripAndTransformJacobian) {
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    const Rigid3 T(ExpQuat(RandomVec(rng, 1.0)), RandomVec(rng, 2.0));
    Eigen::Matrix<double, 6, 1> d;
    d << RandomVec(rng, 0.3), RandomVec(rng, 0.3);
    EXPECT_TRUE(T.Minus(T.Plus(d)).isApprox(d, 1e-10));
    const Vec3 p = RandomVec(rng, 1.0);
    Mat36 J;
    Mat3 Jp;
    T.Transform(p, &J, &Jp);
    Mat36 numeric;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> e = Eigen::Matrix<double, 6, 1>::Zero();
      e[k] = h;
      numeric.col(k) = (T.Plus(e) * p - T.Plus(-e) * p) / (2 * h);
    }
    EXPECT_TRUE(J.isApprox(numeric, 1e-7));
    EXPECT_TRUE(Jp.isApprox(T.R(), 1e-15));
  }
}

TEST(Rigid3, FromMatrixRejectsNonRotation) {
  Mat4 M = Mat4::Identity();
  M(0, 0) = 2.0;
  EXPECT_THROW(Rigid3::FromMatrix(M), std::invalid_argument);
  M = Mat4::Identity();
  M(0, 1) = 1e-9;  // calibration rounding is accepted and cleaned up
  EXPECT_NO_THROW(Rigid3::FromMatrix(M));
}

TEST(SO3, OrthonormalizeGivesRotation) {
  Mat3 M = RotFromRpy(0.2, 0.3, 0.4);
  M(0, 1) += 0.01;
  const Mat3 R = Orthonormalize(M);
  EXPECT_TRUE((R.transpose() * R).isApprox(Mat3::Identity(), 1e-12));
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
}

}  // namespace
}  // namespace fsp
