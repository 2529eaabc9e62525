// The sparse solver (CHOLMOD + selected inversion) against dense references: the solver alone on
// random sparse SPD matrices, then through DbaCovariance (joint blocks, depth variances, relative
// poses, orderings).
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "dbacov/core/covariance.h"
#include "dbacov/core/marginal_solver.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "dense_reference.h"
#include "fixtures.h"

namespace dbacov {
namespace {

/// A random sparse SPD matrix with a banded-plus-random pattern (like a pose graph with loops).
Eigen::SparseMatrix<double> randomSpd(int n, double density, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1), p(0, 1);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < i; ++j)
      if (i - j <= 2 || p(rng) < density) A(i, j) = A(j, i) = u(rng);
  // Diagonal dominance makes it SPD.
  for (int i = 0; i < n; ++i) A(i, i) = A.row(i).cwiseAbs().sum() + 0.5 + p(rng);
  Eigen::SparseMatrix<double> S = A.sparseView();
  return S.triangularView<Eigen::Upper>();
}

TEST(SparseSolver, EveryEntryMatchesDenseInverse) {
  std::mt19937 rng(123);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 5 + trial * 7;
    const Eigen::SparseMatrix<double> S = randomSpd(n, 0.05, rng);
    const Eigen::MatrixXd U = Eigen::MatrixXd(S);
    const Eigen::MatrixXd full = Eigen::MatrixXd(U.selfadjointView<Eigen::Upper>());
    const Eigen::MatrixXd inv = full.inverse();
    for (Ordering o :
         {Ordering::Auto, Ordering::Amd, Ordering::Metis, Ordering::Nesdis, Ordering::Natural}) {
      auto solver = makeCholmodMarginalSolver(o);
      solver->factorize(S);
      std::vector<int> all(n);
      for (int i = 0; i < n; ++i) all[i] = i;
      // Entries on and off the factor's pattern (the latter through solves).
      const Eigen::MatrixXd got = solver->covariance(all, all);
      EXPECT_LT((got - inv).norm(), 1e-11 * inv.norm()) << "n=" << n << " ordering " << int(o);
    }
  }
}

TEST(SparseSolver, NotPositiveDefiniteNamesTheColumn) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Identity(6, 6);
  A(3, 3) = -1.0;
  Eigen::SparseMatrix<double> S = A.sparseView();
  auto solver = makeCholmodMarginalSolver(Ordering::Natural);
  try {
    solver->factorize(S);
    FAIL();
  } catch (const FactorizationError& e) {
    EXPECT_EQ(e.column(), 3);
  }
  // Numerically singular: a column that is a combination of others up to round-off.
  Eigen::MatrixXd B = Eigen::MatrixXd::Identity(3, 3);
  B << 1, 1, 0, 1, 1 + 1e-15, 0, 0, 0, 1;
  auto solver2 = makeCholmodMarginalSolver(Ordering::Natural);
  EXPECT_THROW(solver2->factorize(
                   Eigen::SparseMatrix<double>(B.sparseView()).triangularView<Eigen::Upper>()),
               FactorizationError);
  auto dense = makeDenseMarginalSolver();
  EXPECT_THROW(
      dense->factorize(Eigen::SparseMatrix<double>(B.sparseView()).triangularView<Eigen::Upper>()),
      FactorizationError);
}

sim::SyntheticSnapshotConfig graphConfig(std::uint64_t seed, int n) {
  sim::SyntheticSnapshotConfig c = testing::gridConfig(seed, n, 6, 8);
  c.covisibility.edge_radius = 3;
  return c;
}

TEST(SparseSolver, JointBlocksAndOrderingsOnDbaGraphs) {
  for (std::uint64_t seed : {21, 22, 23}) {
    const auto syn = sim::generateSyntheticSnapshot(graphConfig(seed, 7));
    DbaOptions o;
    o.weight_scale = 4;
    CovarianceOptions dense_opt;
    dense_opt.kind = SolverKind::Dense;
    const DbaCovariance ref(syn.snapshot, o, dense_opt);
    for (Ordering ord : {Ordering::Auto, Ordering::Amd, Ordering::Natural, Ordering::Metis}) {
      CovarianceOptions so;
      so.ordering = ord;
      const DbaCovariance cov(syn.snapshot, o, so);
      for (int a : cov.keyframes())
        for (int b : cov.keyframes()) {
          const Matrix12d J = cov.joint(a, b), R = ref.joint(a, b);
          EXPECT_LE((J - R).norm(), 1e-9 * R.norm() + 1e-300) << a << "," << b;
          if (a != b && R.norm() > 0) {
            const Matrix6d rel = cov.relative(a, b), relRef = ref.relative(a, b);
            EXPECT_LE((rel - relRef).norm(), 1e-9 * relRef.norm()) << a << "," << b;
          }
        }
    }
  }
}

TEST(SparseSolver, DepthSigmaMatchesDenseFullInverse) {
  const auto syn = sim::generateSyntheticSnapshot(graphConfig(31, 5));
  for (auto type : {GaugeOptions::Type::TwoPose, GaugeOptions::Type::Minimal}) {
    DbaOptions o;
    o.weight_scale = 4;
    o.gauge.type = type;
    CovarianceOptions so;
    so.depth_variances = true;
    const DbaCovariance cov(syn.snapshot, o, so);
    const testing::DenseReference ref = testing::denseReference(syn.snapshot, o);
    const int np = ref.numPoseDims();
    std::size_t compared = 0;
    for (int k : cov.sourceKeyframes()) {
      const std::vector<float> sigma = cov.inverseDepthSigma(k);
      for (std::size_t v = 0; v < ref.depth_vars.size(); ++v) {
        if (ref.depth_vars[v].first != k) continue;
        const double expected = std::sqrt(ref.Sigma_full(np + v, np + v));
        EXPECT_NEAR(sigma[ref.depth_vars[v].second], expected, 1e-6 * expected);  // float output
        ++compared;
      }
      // Pixels without a depth variable are NaN, the others finite.
      std::size_t finite = 0;
      for (float x : sigma) finite += std::isfinite(x);
      std::size_t vars = 0;
      for (const auto& dv : ref.depth_vars) vars += dv.first == k;
      EXPECT_EQ(finite, vars) << "keyframe " << k;
    }
    EXPECT_GT(compared, 100u);
  }
}

TEST(SparseSolver, DepthSigmaNeedsToBeRequested) {
  const auto syn = sim::generateSyntheticSnapshot(graphConfig(32, 4));
  DbaOptions o;
  o.weight_scale = 4;
  const DbaCovariance cov(syn.snapshot, o);
  EXPECT_THROW(cov.inverseDepthSigma(1), std::logic_error);
}

}  // namespace
}  // namespace dbacov
