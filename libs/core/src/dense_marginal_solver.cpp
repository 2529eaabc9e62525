#include <cmath>

#include <Eigen/Cholesky>

#include "dbacov/core/marginal_solver.h"

namespace dbacov {
namespace {

class DenseMarginalSolver final : public MarginalSolver {
 public:
  void factorize(const Eigen::SparseMatrix<double>& S_upper) override {
    const Eigen::MatrixXd U = Eigen::MatrixXd(S_upper).triangularView<Eigen::Upper>();
    const Eigen::MatrixXd S = U + U.transpose() - Eigen::MatrixXd(U.diagonal().asDiagonal());
    llt_.compute(S);
    bool ok = llt_.info() == Eigen::Success;
    for (int j = 0; ok && j < S.rows(); ++j)
      ok = llt_.matrixLLT()(j, j) * llt_.matrixLLT()(j, j) > kMinRelativePivot * S(j, j);
    // Eigen's LLT says that it failed, not where: redo the factorization column by column.
    if (!ok) throw FactorizationError("S is not positive definite", firstBadPivot(S));
    Sigma_ = llt_.solve(Eigen::MatrixXd::Identity(S.rows(), S.cols()));
  }

  Eigen::MatrixXd covariance(const std::vector<int>& rows, const std::vector<int>& cols) override {
    Eigen::MatrixXd out(rows.size(), cols.size());
    for (std::size_t c = 0; c < cols.size(); ++c)
      for (std::size_t r = 0; r < rows.size(); ++r) out(r, c) = Sigma_(rows[r], cols[c]);
    return out;
  }

  Eigen::VectorXd solve(const Eigen::VectorXd& x) override { return llt_.solve(x); }

  std::size_t factorEntries() const override {
    return static_cast<std::size_t>(Sigma_.rows()) * Sigma_.rows();
  }

  std::string name() const override { return "dense"; }

 private:
  Eigen::LLT<Eigen::MatrixXd> llt_;
  Eigen::MatrixXd Sigma_;
};

}  // namespace

int firstBadPivot(const Eigen::MatrixXd& S) {
  const int n = static_cast<int>(S.rows());
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n, n);
  for (int j = 0; j < n; ++j) {
    const double pivot = S(j, j) - L.row(j).head(j).squaredNorm();
    if (!(pivot > kMinRelativePivot * S(j, j))) return j;
    L(j, j) = std::sqrt(pivot);
    for (int i = j + 1; i < n; ++i)
      L(i, j) = (S(i, j) - L.row(i).head(j).dot(L.row(j).head(j))) / L(j, j);
  }
  return -1;
}

std::unique_ptr<MarginalSolver> makeDenseMarginalSolver() {
  return std::make_unique<DenseMarginalSolver>();
}

}  // namespace dbacov
