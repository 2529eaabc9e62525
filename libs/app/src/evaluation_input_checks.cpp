// Checks of dba-evaluate's input values. See evaluation_input_checks.h.
#include "evaluation_input_checks.h"

#include <cmath>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "dbacov/core/errors.h"

namespace dbacov::app::detail {
namespace {

std::string num(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

std::string entry(int r, int c) {
  return "cov_" + std::to_string(std::min(r, c)) + std::to_string(std::max(r, c));
}

}  // namespace

void checkCovarianceValues(const Matrix6d& S, const std::string& where) {
  for (int i = 0; i < 6; ++i)
    if (S(i, i) < 0)
      throw InputError(where + ": " + entry(i, i) + " = " + num(S(i, i)) +
                       " is a negative variance: expected a positive semidefinite covariance");
  for (int r = 0; r < 6; ++r)
    for (int c = r; c < 6; ++c)
      if (std::abs(S(r, c)) > kMaxCovarianceEntry)
        throw InputError(where + ": " + entry(r, c) + " = " + num(S(r, c)) +
                         " is beyond any pose covariance (|entry| <= 1e100): the file is "
                         "damaged or not a covariance table");
  const Vector6d lambda =
      Eigen::SelfAdjointEigenSolver<Matrix6d>(S, Eigen::EigenvaluesOnly).eigenvalues();
  if (lambda[0] < -1e-9 * std::max(lambda[5], 0.0) && lambda[0] < 0)
    throw InputError(where + ": the covariance is not positive semidefinite (smallest eigenvalue " +
                     num(lambda[0]) + ", largest " + num(lambda[5]) + ")");
}

void checkGroundTruthTimes(const std::string& path,
                           const std::vector<std::pair<double, Eigen::Isometry3d>>& rows) {
  for (std::size_t i = 1; i < rows.size(); ++i)
    if (rows[i].first == rows[i - 1].first &&
        !(rows[i].second.matrix() - rows[i - 1].second.matrix()).isZero(1e-9))
      throw InputError(path + ": two different poses at time " + num(rows[i].first) +
                       " s: expected one ground-truth pose per timestamp (remove or fix the "
                       "duplicate)");
}

}  // namespace dbacov::app::detail
