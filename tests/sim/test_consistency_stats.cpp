// The statistics of core/consistency.h against closed forms, tables and the numbers of conventions
// §7.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Cholesky>

#include "dbacov/sim/consistency.h"

namespace dbacov {
namespace {

TEST(ChiSquare, RegionsAreTheNumbersOfTheSpec) {
  // conventions §7: 6 DoF, N = 50: [5.08, 7.00]; N = 100: [5.34, 6.70]; 3 DoF, N = 100:
  // [2.54, 3.50].
  ChiSquareRegion r = aneesRegion(6, 50);
  EXPECT_NEAR(r.lower, 5.08, 0.005);
  EXPECT_NEAR(r.upper, 7.00, 0.005);
  r = aneesRegion(6, 100);
  EXPECT_NEAR(r.lower, 5.34, 0.005);
  EXPECT_NEAR(r.upper, 6.70, 0.005);
  r = aneesRegion(3, 100);
  EXPECT_NEAR(r.lower, 2.54, 0.005);
  EXPECT_NEAR(r.upper, 3.50, 0.005);
  EXPECT_TRUE(r.contains(3.0));
  EXPECT_FALSE(r.contains(3.6));
}

TEST(ChiSquare, QuantilesMatchTablesAndClosedForms) {
  // Standard table values.
  EXPECT_NEAR(chiSquareQuantile(0.95, 1), 3.841459, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(0.95, 2), 5.991465, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(0.025, 10), 3.246973, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(0.975, 10), 20.483177, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(0.99, 6), 16.811894, 1e-6);
  // k = 2: F(x) = 1 − exp(−x/2), so the quantile is −2 ln(1 − p).
  for (double p : {1e-6, 0.01, 0.3, 0.5, 0.9, 0.999999})
    EXPECT_NEAR(chiSquareQuantile(p, 2), -2 * std::log(1 - p), 1e-10 * (1 - 2 * std::log(1 - p)))
        << p;
  // k = 1: F(x) = erf(sqrt(x/2)); k = 3: erf(sqrt(x/2)) − sqrt(2x/π) exp(−x/2).
  for (double x : {0.01, 0.5, 1.0, 4.0, 30.0}) {
    EXPECT_NEAR(chiSquareCdf(x, 1), std::erf(std::sqrt(x / 2)), 1e-13) << x;
    EXPECT_NEAR(chiSquareCdf(x, 3),
                std::erf(std::sqrt(x / 2)) - std::sqrt(2 * x / M_PI) * std::exp(-x / 2), 1e-13)
        << x;
  }
  // Large DoF (both branches of the incomplete gamma), and the quantile inverts the CDF.
  for (double k : {0.5, 6.0, 300.0, 6000.0})
    for (double p : {0.025, 0.5, 0.975})
      EXPECT_NEAR(chiSquareCdf(chiSquareQuantile(p, k), k), p, 1e-11) << k;
  EXPECT_THROW(chiSquareQuantile(0.0, 3), std::invalid_argument);
  EXPECT_THROW(chiSquareQuantile(0.5, 0), std::invalid_argument);
}

TEST(Nees, IsChiSquareForGaussianErrorsAndUsesTheRangeOfSingularCovariances) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01;
  Matrix6d A;
  for (int i = 0; i < 36; ++i) A(i / 6, i % 6) = n01(rng);
  const Matrix6d Sigma = A * A.transpose() + 0.1 * Matrix6d::Identity();
  const Matrix6d L = Sigma.llt().matrixL();
  double sum = 0;
  int above = 0;
  const int n = 20000;
  const double q95 = chiSquareQuantile(0.95, 6);
  for (int i = 0; i < n; ++i) {
    Vector6d z;
    for (int q = 0; q < 6; ++q) z[q] = n01(rng);
    const Nees v = computeNees(L * z, Sigma);
    EXPECT_EQ(v.dof, 6);
    sum += v.value;
    above += v.value > q95;
  }
  EXPECT_NEAR(sum / n, 6.0, 4 * std::sqrt(12.0 / n));
  EXPECT_NEAR(above / double(n), 0.05, 4 * std::sqrt(0.05 * 0.95 / n));
  // Rank 5 (a removed direction u): NEES uses the 5-dimensional range; the error along u is
  // ignored.
  Vector6d u = Vector6d::Zero();
  u[0] = 1;
  const Matrix6d P = Matrix6d::Identity() - u * u.transpose();
  const Matrix6d S5 = P * Sigma * P;
  Vector6d e = P * (L * Vector6d::Ones());
  const Nees v5 = computeNees(e + 3.0 * u, S5);
  EXPECT_EQ(v5.dof, 5);
  Eigen::Matrix<double, 5, 5> S55 = S5.bottomRightCorner<5, 5>();
  EXPECT_NEAR(v5.value, e.tail<5>().dot(S55.inverse() * e.tail<5>()), 1e-9 * v5.value);
  EXPECT_EQ(computeNees(e, Matrix6d::Zero()).dof, 0);
}

TEST(Spearman, MatchesTheRankFormulaAndHandlesTies) {
  // No ties: ρ = 1 − 6 Σ d² / (n (n² − 1)).
  const std::vector<double> x{1.2, 3.4, 0.5, 8.0, 2.2, 6.1, 4.4},
      y{2.0, 1.0, 0.3, 9.5, 3.3, 4.0, 8.8};
  const std::vector<double> rx{2, 4, 1, 7, 3, 6, 5}, ry{3, 2, 1, 7, 4, 5, 6};  // ranks, by hand
  double d2 = 0;
  for (std::size_t i = 0; i < x.size(); ++i) d2 += (rx[i] - ry[i]) * (rx[i] - ry[i]);
  const double n = x.size();
  EXPECT_NEAR(spearmanCorrelation(x, y), 1 - 6 * d2 / (n * (n * n - 1)), 1e-12);
  // Invariant under monotone transforms, antisymmetric under reversal.
  std::vector<double> xe;
  for (double v : x) xe.push_back(std::exp(v));
  EXPECT_NEAR(spearmanCorrelation(xe, y), spearmanCorrelation(x, y), 1e-15);
  std::vector<double> yneg;
  for (double v : y) yneg.push_back(-v);
  EXPECT_NEAR(spearmanCorrelation(x, yneg), -spearmanCorrelation(x, y), 1e-15);
  // Ties take their average rank: x = (1, 2, 2, 3) → ranks (1, 2.5, 2.5, 4), Pearson with y's
  // ranks.
  const std::vector<double> xt{1, 2, 2, 3}, yt{10, 30, 20, 40};
  const Eigen::Vector4d a(1, 2.5, 2.5, 4), b(1, 3, 2, 4);
  const Eigen::Vector4d ac = a.array() - a.mean(), bc = b.array() - b.mean();
  EXPECT_NEAR(spearmanCorrelation(xt, yt), ac.dot(bc) / (ac.norm() * bc.norm()), 1e-15);
  EXPECT_EQ(spearmanCorrelation({1, 1, 1}, {1, 2, 3}), 0.0);
}

TEST(Summary, CoverageInflationAndRegionOfKnownSamples) {
  // Exact Gaussian errors with a known diagonal covariance, 4 samples per run.
  std::mt19937_64 rng(9);
  std::normal_distribution<double> n01;
  Matrix6d Sigma = Matrix6d::Zero();
  Sigma.diagonal() << 1e-4, 4e-4, 9e-4, 1e-6, 4e-6, 2e-6;
  std::vector<NeesSample> s;
  for (int run = 0; run < 3000; ++run)
    for (int g = 0; g < 4; ++g) {
      Vector6d e;
      for (int q = 0; q < 6; ++q) e[q] = std::sqrt(Sigma(q, q)) * n01(rng);
      s.push_back(makeSample(run, "g" + std::to_string(g), e, Sigma));
    }
  s.push_back(makeSample(0, "fixed", Vector6d::Zero(), Matrix6d::Zero()));  // no sample
  const ConsistencyStats st = summarize(s);
  EXPECT_EQ(st.samples, 12000u);
  EXPECT_EQ(st.runs, 3000);
  EXPECT_EQ(st.dof, 6.0);
  EXPECT_NEAR(st.anees, 6.0, 0.1);
  EXPECT_TRUE(st.inside);
  const auto nominal = nominalCoverage();
  EXPECT_NEAR(nominal[0], 0.682689, 1e-6);
  EXPECT_NEAR(nominal[2], 0.997300, 1e-6);
  for (int m = 0; m < 3; ++m) {
    EXPECT_NEAR(st.coverage_all[m], nominal[m], 0.01) << m + 1 << " sigma";
    for (int q = 0; q < 6; ++q) EXPECT_NEAR(st.coverage(q, m), nominal[m], 0.02);
  }
  // 12000 samples: the tail's binomial σ is 0.2 %; 4σ.
  EXPECT_NEAR(st.tail_95, 0.05, 0.008);
  // Covariances 9× too small: NEES ×9, the fitted inflation is 9 and undoes it.
  const std::vector<NeesSample> small = inflate(s, 1.0 / 9.0);
  // χ²₆ > 12.59 / 9 = 1.40 has probability 0.966.
  EXPECT_NEAR(summarize(small).tail_95, 0.966, 0.01);
  EXPECT_NEAR(summarize(small).anees, 9 * st.anees, 1e-9 * st.anees);
  EXPECT_FALSE(summarize(small).inside);
  EXPECT_NEAR(fitInflation(small), 9 * st.anees / 6.0, 1e-9);
  EXPECT_NEAR(summarize(inflate(small, fitInflation(small))).anees, 6.0, 1e-9);
  EXPECT_THROW(summarize({}), std::invalid_argument);
  EXPECT_THROW(fitInflation({}), std::invalid_argument);
}

TEST(Summary, SpearmanSeesPredictedUncertaintyThatTracksTheError) {
  // Samples whose covariance scale varies 100× and whose errors follow it: strong rank correlation.
  std::mt19937_64 rng(4);
  std::normal_distribution<double> n01;
  std::vector<NeesSample> s;
  for (int i = 0; i < 400; ++i) {
    const double scale = std::pow(10.0, 2.0 * i / 400);
    const Matrix6d Sigma = scale * Matrix6d::Identity();
    Vector6d e;
    for (int q = 0; q < 6; ++q) e[q] = std::sqrt(scale) * n01(rng);
    s.push_back(makeSample(i, "x", e, Sigma));
  }
  const ConsistencyStats st = summarize(s);
  EXPECT_GT(st.spearman_translation, 0.7);
  EXPECT_GT(st.spearman_rotation, 0.7);
}

TEST(PoseError, IsTheRightTangentOfSpec3) {
  const Vector6d xi = (Vector6d() << 0.1, -0.2, 0.3, 0.02, -0.01, 0.03).finished();
  const Eigen::Isometry3d T_est = expSE3((Vector6d() << 1, 2, 3, 0.4, 0.5, 0.6).finished());
  EXPECT_LT((poseError(T_est, T_est * expSE3(xi)) - xi).norm(), 1e-12);
  EXPECT_GT((poseError(T_est, expSE3(xi) * T_est) - xi).norm(),
            1e-3);  // a left perturbation is not it
}

}  // namespace
}  // namespace dbacov
