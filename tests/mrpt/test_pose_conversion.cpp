// The one tangent → MRPT [x y z yaw pitch roll] covariance conversion, against Monte Carlo:
// sample ξ ~ N(0, Σ), perturb T_wc·Exp(ξ), read MRPT's own yaw/pitch/roll of the result.
#include <random>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <gtest/gtest.h>
#include <mrpt/math/wrap2pi.h>

#include "dbacov/mrpt/pose_conversion.h"

namespace dbacov {
namespace {

Matrix6d sampleCovariance(const Eigen::Isometry3d& T, const Matrix6d& Sigma, int n,
                          std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01;
  const Matrix6d L = Sigma.llt().matrixL();
  const mrpt::poses::CPose3D mean = mrpt_bridge::toCPose3D(T);
  const Vector6d m(mean.x(), mean.y(), mean.z(), mean.yaw(), mean.pitch(), mean.roll());
  Matrix6d C = Matrix6d::Zero();
  for (int s = 0; s < n; ++s) {
    Vector6d w;
    for (int i = 0; i < 6; ++i) w[i] = n01(rng);
    const mrpt::poses::CPose3D p = mrpt_bridge::toCPose3D(T * expSE3(L * w));
    Vector6d d = Vector6d(p.x(), p.y(), p.z(), p.yaw(), p.pitch(), p.roll()) - m;
    for (int i = 3; i < 6; ++i) d[i] = mrpt::math::wrapToPi(d[i]);
    C += d * d.transpose();
  }
  return C / n;
}

TEST(PoseConversion, TangentToYawPitchRollMatchesMonteCarlo) {
  Eigen::Matrix<double, 6, 6> A;
  A << 3, 1, 0, 0.2, 0, 0.1,  //
      0, 2, 1, 0, 0.3, 0,     //
      0, 0, 4, 0.1, 0, 0.2,   //
      0, 0, 0, 1, 0.3, 0,     //
      0, 0, 0, 0, 2, 0.5,     //
      0, 0, 0, 0, 0, 1.5;
  Matrix6d Sigma = A * A.transpose();
  Sigma.topLeftCorner<3, 3>() *= 1e-4;      // ~1 cm
  Sigma.bottomRightCorner<3, 3>() *= 4e-6;  // ~2–4 mrad: small enough to stay linear at 80°
  Sigma.topRightCorner<3, 3>() *= 2e-5;
  Sigma.bottomLeftCorner<3, 3>() = Sigma.topRightCorner<3, 3>().transpose();
  ASSERT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(Sigma).eigenvalues().minCoeff(), 0);

  const double deg = M_PI / 180;
  for (const auto& ypr : std::vector<Eigen::Vector3d>{{0.3, 0.2, -0.5},
                                                      {2.5, -1.2, 1.0},
                                                      {0.1, 80 * deg, 0.4},
                                                      {-1.0, -80 * deg, 2.5},
                                                      {3.0, 0.0, -3.0}}) {
    const mrpt::poses::CPose3D p(1.0, -2.0, 0.5, ypr[0], ypr[1], ypr[2]);
    const Eigen::Isometry3d T = mrpt_bridge::fromCPose3D(p);
    const mrpt::poses::CPose3DPDFGaussian g = mrpt_bridge::toPoseGaussian(T, Sigma);
    Matrix6d predicted;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) predicted(r, c) = g.cov(r, c);
    const Matrix6d mc = sampleCovariance(T, Sigma, 200000, 7);
    // Compare in correlation-normalized form so that every entry counts the same.
    const Vector6d s = predicted.diagonal().cwiseSqrt();
    const Matrix6d diff =
        s.cwiseInverse().asDiagonal() * (mc - predicted) * s.cwiseInverse().asDiagonal();
    EXPECT_LT(diff.cwiseAbs().maxCoeff(), 0.03) << "ypr " << ypr.transpose() << "\nMC\n"
                                                << mc << "\npredicted\n"
                                                << predicted;
    EXPECT_NEAR(g.mean.pitch(), ypr[1], 1e-12);
  }
}

TEST(PoseConversion, IgnoringTheJacobianWouldBeDetected) {
  // At 80° pitch, yaw and roll variances are inflated by 1/cos²(pitch) ≈ 33: a conversion that
  // copied the tangent blocks would be off by far more than the test tolerance.
  const mrpt::poses::CPose3D p(0, 0, 0, 0.1, 80 * M_PI / 180, 0.4);
  Matrix6d Sigma = Matrix6d::Identity() * 1e-6;
  const auto g = mrpt_bridge::toPoseGaussian(mrpt_bridge::fromCPose3D(p), Sigma);
  EXPECT_GT(g.cov(3, 3), 10 * 1e-6);
}

TEST(PoseConversion, GimbalLockIsRefused) {
  const mrpt::poses::CPose3D p(0, 0, 0, 0.1, M_PI / 2, 0.4);
  EXPECT_THROW(mrpt_bridge::toPoseGaussian(mrpt_bridge::fromCPose3D(p), Matrix6d::Identity()),
               std::domain_error);
}

}  // namespace
}  // namespace dbacov
