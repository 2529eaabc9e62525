// Analytic Jacobians of the DBA pixel factor vs central finite differences of an independent
// residual implementation (4×4 homogeneous matrices), with right perturbations T Exp(ξ).
#include <random>

#include <gtest/gtest.h>

#include "dbacov/core/dba_factor.h"

namespace dbacov {
namespace {

struct Case {
  Eigen::Isometry3d T_wc_i, T_wc_j;
  double x, y, d, tx, ty;
};

Case randomCase(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Vector6d a, b;
  for (int k = 0; k < 6; ++k) {
    a[k] = 0.4 * u(rng);
    b[k] = 0.4 * u(rng);
  }
  return {expSE3(a),          expSE3(b),        30 + 20 * u(rng), 20 + 15 * u(rng),
          0.6 + 0.5 * u(rng), 30 + 10 * u(rng), 25 + 10 * u(rng)};
}

TEST(DbaFactor, JacobiansMatchCentralDifferences) {
  const PinholeIntrinsics K{78.3, 78.4, 31.5, 26.2};
  std::mt19937 rng(42);
  const double h = 1e-6;
  for (int t = 0; t < 100; ++t) {
    const Case c = randomCase(rng);
    const Eigen::Isometry3d T_ji = c.T_wc_j.inverse() * c.T_wc_i;
    if (transferPoint(T_ji.linear(), T_ji.translation(), K, c.x, c.y, c.d).z() < 0.2) continue;
    PixelFactorLinearization f;
    linearizePixelFactor(T_ji.linear(), T_ji.translation(), K, c.x, c.y, c.d, c.tx, c.ty, &f);
    const Eigen::Vector2d r0 =
        pixelFactorResidual(c.T_wc_i, c.T_wc_j, K, c.x, c.y, c.d, c.tx, c.ty);
    EXPECT_LT((f.r - r0).norm(), 1e-9);

    Eigen::Matrix<double, 2, 6> Ji, Jj;
    for (int k = 0; k < 6; ++k) {
      Vector6d dx = Vector6d::Zero();
      dx[k] = h;
      auto res = [&](const Eigen::Isometry3d& Ti, const Eigen::Isometry3d& Tj) {
        return pixelFactorResidual(Ti, Tj, K, c.x, c.y, c.d, c.tx, c.ty);
      };
      Ji.col(k) =
          (res(c.T_wc_i * expSE3(dx), c.T_wc_j) - res(c.T_wc_i * expSE3(-dx), c.T_wc_j)) / (2 * h);
      Jj.col(k) =
          (res(c.T_wc_i, c.T_wc_j * expSE3(dx)) - res(c.T_wc_i, c.T_wc_j * expSE3(-dx))) / (2 * h);
    }
    const Eigen::Vector2d Jd =
        (pixelFactorResidual(c.T_wc_i, c.T_wc_j, K, c.x, c.y, c.d + h, c.tx, c.ty) -
         pixelFactorResidual(c.T_wc_i, c.T_wc_j, K, c.x, c.y, c.d - h, c.tx, c.ty)) /
        (2 * h);
    const double tol = 1e-6 * std::max(1.0, f.J_i.norm() + f.J_j.norm());
    EXPECT_LT((f.J_i - Ji).norm(), tol) << "analytic\n" << f.J_i << "\nnumeric\n" << Ji;
    EXPECT_LT((f.J_j - Jj).norm(), tol) << "analytic\n" << f.J_j << "\nnumeric\n" << Jj;
    EXPECT_LT((f.J_d - Jd).norm(), tol)
        << "analytic " << f.J_d.transpose() << " numeric " << Jd.transpose();
  }
}

TEST(DbaFactor, WrongConventionWouldBeDetected) {
  // The check above must be able to fail: a left perturbation gives different derivatives.
  const PinholeIntrinsics K{78.3, 78.4, 31.5, 26.2};
  std::mt19937 rng(1);
  const Case c = randomCase(rng);
  const Eigen::Isometry3d T_ji = c.T_wc_j.inverse() * c.T_wc_i;
  PixelFactorLinearization f;
  linearizePixelFactor(T_ji.linear(), T_ji.translation(), K, c.x, c.y, c.d, c.tx, c.ty, &f);
  Eigen::Matrix<double, 2, 6> Jleft;
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    Vector6d dx = Vector6d::Zero();
    dx[k] = h;
    Jleft.col(k) =
        (pixelFactorResidual(expSE3(dx) * c.T_wc_i, c.T_wc_j, K, c.x, c.y, c.d, c.tx, c.ty) -
         pixelFactorResidual(expSE3(-dx) * c.T_wc_i, c.T_wc_j, K, c.x, c.y, c.d, c.tx, c.ty)) /
        (2 * h);
  }
  EXPECT_GT((f.J_i - Jleft).norm(), 1e-2);
}

}  // namespace
}  // namespace dbacov
