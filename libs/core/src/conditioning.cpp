// Condition number of a marginal covariance over its free subspace. See conditioning.h.
#include "dbacov/core/conditioning.h"

#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

namespace dbacov {

double freeConditionNumber(const Matrix6d& Sigma, int free_dof) {
  if (free_dof <= 0) return 1.0;
  if (!Sigma.allFinite()) return std::numeric_limits<double>::infinity();
  const Vector6d lambda =
      Eigen::SelfAdjointEigenSolver<Matrix6d>(Sigma, Eigen::EigenvaluesOnly).eigenvalues();
  const double lo = lambda[6 - std::min(free_dof, 6)], hi = lambda[5];  // ascending
  if (!(lo > 0) || !std::isfinite(hi)) return std::numeric_limits<double>::infinity();
  return hi / lo;
}

}  // namespace dbacov
