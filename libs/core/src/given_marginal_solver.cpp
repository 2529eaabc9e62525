#include "given_marginal_solver.h"

#include <stdexcept>
#include <string>

namespace dbacov {
namespace {

class GivenMarginalSolver : public MarginalSolver {
 public:
  explicit GivenMarginalSolver(const Eigen::MatrixXd& Sigma) : Sigma_(Sigma) {}
  void factorize(const Eigen::SparseMatrix<double>&) override {}
  Eigen::MatrixXd covariance(const std::vector<int>& rows, const std::vector<int>& cols) override {
    Eigen::MatrixXd out(rows.size(), cols.size());
    for (std::size_t r = 0; r < rows.size(); ++r)
      for (std::size_t c = 0; c < cols.size(); ++c) out(r, c) = Sigma_(rows[r], cols[c]);
    return out;
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& x) override { return Sigma_ * x; }
  std::size_t factorEntries() const override { return Sigma_.size(); }
  std::string name() const override { return "given"; }

 private:
  Eigen::MatrixXd Sigma_;
};

}  // namespace

std::unique_ptr<MarginalSolver> makeGivenMarginalSolver(const Eigen::MatrixXd& Sigma, int dim) {
  if (Sigma.rows() != dim || Sigma.cols() != dim)
    throw std::invalid_argument("given reduced covariance is " + std::to_string(Sigma.rows()) +
                                "x" + std::to_string(Sigma.cols()) + ", the gauge has " +
                                std::to_string(dim) + " free DoF");
  if (!Sigma.allFinite()) throw std::invalid_argument("given reduced covariance is not finite");
  return std::make_unique<GivenMarginalSolver>(Sigma);
}

}  // namespace dbacov
