#include "dbacov/core/criteria.h"

#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

namespace dbacov {
namespace {

/// Σ log10 λ over the eigenvalues of a symmetric PSD matrix, −inf when it is singular.
template <int N>
double log10Det(const Eigen::Matrix<double, N, N>& A) {
  const Eigen::Matrix<double, N, 1> lambda =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>>(A, Eigen::EigenvaluesOnly)
          .eigenvalues();
  const double tol = 1e-14 * lambda.maxCoeff();
  double s = 0;
  for (int i = 0; i < N; ++i) {
    if (!(lambda[i] > tol) || !(lambda[i] > 0)) return -std::numeric_limits<double>::infinity();
    s += std::log10(lambda[i]);
  }
  return s;
}

}  // namespace

UncertaintyCriteria computeCriteria(const Matrix6d& Sigma) {
  UncertaintyCriteria c;
  c.log10_det = log10Det<6>(Sigma);
  c.d_opt = std::isinf(c.log10_det) ? 0.0 : std::pow(10.0, c.log10_det / 6.0);
  c.a_opt = Sigma.trace() / 6.0;
  c.e_opt = Eigen::SelfAdjointEigenSolver<Matrix6d>(Sigma, Eigen::EigenvaluesOnly).eigenvalues()(5);
  c.log10_det_rot = log10Det<3>(Eigen::Matrix3d(Sigma.bottomRightCorner<3, 3>()));
  c.log10_det_trans = log10Det<3>(Eigen::Matrix3d(Sigma.topLeftCorner<3, 3>()));
  return c;
}

}  // namespace dbacov
