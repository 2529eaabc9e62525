// A MarginalSolver that answers from a given covariance matrix (internal; covariance.cpp).
#pragma once

#include <memory>

#include <Eigen/Core>

#include "dbacov/core/marginal_solver.h"

namespace dbacov {

/// Answers covariance() and solve() from Σ (dim×dim); factorize() is a no-op. Throws
/// std::invalid_argument when Σ is not dim×dim or not finite.
std::unique_ptr<MarginalSolver> makeGivenMarginalSolver(const Eigen::MatrixXd& Sigma, int dim);

}  // namespace dbacov
