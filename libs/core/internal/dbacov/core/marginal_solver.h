// Selected entries of Σ = S⁻¹ for a sparse symmetric positive definite S (conventions §5).
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "dbacov/core/options.h"

namespace dbacov {

/// S is not (numerically) positive definite. `column` is the first column of S, in the caller's
/// numbering, at which the factorization broke down (−1 when unknown).
class FactorizationError : public std::runtime_error {
 public:
  FactorizationError(const std::string& what, int column)
      : std::runtime_error(what), column_(column) {}
  int column() const { return column_; }

 private:
  int column_;
};

/// A Cholesky pivot L_jj² smaller than this fraction of S_jj means column j is (numerically) a
/// combination of the previous ones: S is singular to working precision, and its "covariance"
/// would be round-off. Both solvers report it as a FactorizationError.
constexpr double kMinRelativePivot = 1e-12;

/// The first column of the dense symmetric S whose Cholesky pivot (unpivoted, left-looking) is
/// not above kMinRelativePivot · S_jj, or −1: where a factorization that failed broke down (Eigen's
/// LLT says that it failed, not where).
int firstBadPivot(const Eigen::MatrixXd& S);

class MarginalSolver {
 public:
  virtual ~MarginalSolver() = default;

  /// Factorizes S, given by its upper triangle (column-major; entries below the diagonal are
  /// ignored). Throws FactorizationError when S is not positive definite or a pivot falls
  /// below kMinRelativePivot.
  virtual void factorize(const Eigen::SparseMatrix<double>& S_upper) = 0;

  /// Σ[rows, cols] (Σ = S⁻¹), for index lists into S. Precondition: factorize() succeeded.
  virtual Eigen::MatrixXd covariance(const std::vector<int>& rows,
                                     const std::vector<int>& cols) = 0;

  /// Σ x for a vector x (one pair of triangular solves).
  virtual Eigen::VectorXd solve(const Eigen::VectorXd& x) = 0;

  /// Stored entries of the factor (nnz(L) for the sparse solver, n² for the dense one): the
  /// selected inverse needs as many again.
  virtual std::size_t factorEntries() const = 0;

  /// Short name for reports ("dense", "cholmod").
  virtual std::string name() const = 0;
};

/// Sparse supernodal Cholesky of S with CHOLMOD, then the sparse-inverse recursion
/// (Takahashi / Golub–Plemmons, block-wise per supernode) for every entry of Σ on the factor's
/// pattern, in about the time of the factorization and the memory of L. Requested entries off the
/// pattern are obtained by solves with the factor (one per column, cached).
std::unique_ptr<MarginalSolver> makeCholmodMarginalSolver(Ordering ordering = Ordering::Auto);

/// Dense Cholesky of S and its full inverse: O(n³) time and O(n²) memory. The reference for tests
/// and for small graphs.
std::unique_ptr<MarginalSolver> makeDenseMarginalSolver();

}  // namespace dbacov
