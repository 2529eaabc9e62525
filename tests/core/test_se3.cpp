#include <random>

#include <gtest/gtest.h>

#include "dbacov/core/se3.h"
#include "fixtures.h"

namespace dbacov {
namespace {

using testing::randomTangent;

TEST(Se3, ExpLogRoundTrip) {
  std::mt19937 rng(7);
  for (int t = 0; t < 200; ++t) {
    const Vector6d xi = randomTangent(rng, t < 100 ? 0.8 : 1e-6);
    EXPECT_LT((logSE3(expSE3(xi)) - xi).norm(), 1e-10 * std::max(1.0, xi.norm())) << xi.transpose();
  }
}

TEST(Se3, ExpMatchesMatrixExponentialSeries) {
  // Independent reference: the exponential of the 4×4 twist matrix by its power series.
  std::mt19937 rng(3);
  for (int t = 0; t < 20; ++t) {
    const Vector6d xi = randomTangent(rng, 0.7);
    Eigen::Matrix4d X = Eigen::Matrix4d::Zero();
    X.topLeftCorner<3, 3>() = hat(xi.tail<3>());
    X.topRightCorner<3, 1>() = xi.head<3>();
    Eigen::Matrix4d E = Eigen::Matrix4d::Identity(), term = Eigen::Matrix4d::Identity();
    for (int k = 1; k < 40; ++k) {
      term = term * X / k;
      E += term;
    }
    EXPECT_LT((expSE3(xi).matrix() - E).norm(), 1e-12);
  }
}

TEST(Se3, AdjointIdentity) {
  std::mt19937 rng(5);
  for (int t = 0; t < 50; ++t) {
    const Eigen::Isometry3d T = expSE3(randomTangent(rng, 1.0));
    const Vector6d xi = randomTangent(rng, 0.5);
    const Eigen::Isometry3d lhs = T * expSE3(xi) * T.inverse();
    const Eigen::Isometry3d rhs = expSE3(adjoint(T) * xi);
    EXPECT_LT((lhs.matrix() - rhs.matrix()).norm(), 1e-12);
  }
}

TEST(Se3, LeftJacobianInverse) {
  std::mt19937 rng(11);
  for (int t = 0; t < 50; ++t) {
    const Eigen::Vector3d phi = randomTangent(rng, t < 25 ? 1.0 : 1e-7).tail<3>();
    EXPECT_LT((leftJacobianSO3(phi) * leftJacobianInvSO3(phi) - Eigen::Matrix3d::Identity()).norm(),
              1e-12);
  }
}

TEST(Se3, TQRoundTripAndOrder) {
  const double v[7] = {1, 2, 3, 0.0, 0.0, std::sin(0.25), std::cos(0.25)};  // yaw 0.5 about z
  const Eigen::Isometry3d T = poseFromTQ(v);
  EXPECT_NEAR(T.linear()(1, 0), std::sin(0.5), 1e-12);  // x axis rotated towards +y
  EXPECT_EQ(T.translation(), Eigen::Vector3d(1, 2, 3));
  const auto back = poseToTQ(T);
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(back[i], v[i], 1e-12);
}

TEST(Se3, RelativeCovarianceMatchesMonteCarlo) {
  // Sample correlated (ξ_a, ξ_b), perturb both poses, take Log of the relative-pose error.
  std::mt19937 rng(17);
  const Eigen::Isometry3d Ta = expSE3((Vector6d() << 0.3, -0.2, 1.0, 0.2, -0.4, 0.9).finished());
  const Eigen::Isometry3d Tb = expSE3((Vector6d() << 1.1, 0.4, 0.5, -0.3, 0.5, 1.3).finished());
  Eigen::Matrix<double, 12, 12> A = Eigen::Matrix<double, 12, 12>::Random() * 0.01;
  const Matrix12d joint = A * A.transpose() + 1e-6 * Matrix12d::Identity();
  const Eigen::Matrix<double, 12, 12> L = joint.llt().matrixL();
  const Eigen::Isometry3d Z = Ta.inverse() * Tb;
  const int n = 100000;
  Matrix6d C = Matrix6d::Zero();
  std::normal_distribution<double> n01;
  for (int s = 0; s < n; ++s) {
    Eigen::Matrix<double, 12, 1> w;
    for (int i = 0; i < 12; ++i) w[i] = n01(rng);
    const Eigen::Matrix<double, 12, 1> x = L * w;
    const Eigen::Isometry3d Zs = (Ta * expSE3(x.head<6>())).inverse() * (Tb * expSE3(x.tail<6>()));
    const Vector6d e = logSE3(Z.inverse() * Zs);
    C += e * e.transpose();
  }
  C /= n;
  const Matrix6d P = relativeCovariance(Ta, Tb, joint);
  // Sampling error of a covariance entry ~ sqrt(2/n) relative; 4% of the scale is ~10 sigma.
  EXPECT_LT((C - P).norm(), 0.04 * P.norm()) << "MC\n" << C << "\npredicted\n" << P;
}

}  // namespace
}  // namespace dbacov
