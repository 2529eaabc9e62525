// Consistency statistics of pose covariances against ground truth (conventions §7).
//
// Error:    e = Log(T_est⁻¹ T_true) in the tangent of conventions §3: the truth is T_est · Exp(e),
// so a
//           consistent covariance Σ of the estimate is the covariance of e.
// NEES:     eᵀ Σ⁺ e over the range of Σ; its DoF is the rank of Σ (6, 5 for the scale keyframe of
//           the minimal gauge, 0 for a hard-fixed keyframe, which is not a sample). Eigenvalues at
//           or below 1e-12 × the largest count as zero. A consistent Σ gives NEES ~ χ²(DoF).
// ANEES:    the mean NEES of a set of samples. For the mean of N independent χ²(k) values the
//           two-sided (1 − α) region is [χ²_{Nk}(α/2), χ²_{Nk}(1 − α/2)] / N; conventions §7: k =
//           6, N = 50 → [5.08, 7.00]. Samples are grouped into *runs* (independent noise draws,
//           e.g. Monte Carlo runs or snapshots of the simulator); several samples of one run (the
//           keyframes of one snapshot) are correlated. summarize() therefore uses N = number of
//           runs and k = mean DoF: the variance of a mean of correlated χ²(k) values is at most
//           that of one of them (Cauchy–Schwarz), so this region is conservative (too wide, never
//           too narrow) for the pooled ANEES, and exact for one sample per run.
// Coverage: per axis i, the fraction of samples with |e_i| <= m·sqrt(Σ_ii), m = 1, 2, 3; nominal
//           68.27 / 95.45 / 99.73 % for a Gaussian.
// Tail:     the fraction of samples with NEES above χ²_dof(0.95); nominal 5 %. It sees what the
//           ANEES averages away: a covariance too wide in most directions and too narrow in a
//           few has a fair ANEES and a heavy tail.
// Spearman: rank correlation (ties get their average rank) between the predicted uncertainty
//           sqrt(trace Σ_block) and the actual error norm |e_block|, for the translation and the
//           rotation blocks: does a larger predicted uncertainty go with a larger error?
// Inflation: Σ → kΣ divides every NEES by k; the k that makes the ANEES equal the mean DoF is
//           Σ NEES / Σ DoF (fitInflation).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dbacov/core/se3.h"

namespace dbacov {

/// Regularized lower incomplete gamma function P(a, x), a > 0, x >= 0 (series for x < a + 1, a
/// continued fraction otherwise; relative accuracy ~1e-14).
double regularizedGammaP(double a, double x);
/// CDF of the chi-square distribution with k > 0 (real) degrees of freedom.
double chiSquareCdf(double x, double k);
/// The p-quantile (0 < p < 1) of χ²(k): Wilson–Hilferty start, then safeguarded Newton steps on
/// chiSquareCdf to ~1e-12 relative. Throws std::invalid_argument outside the domain.
double chiSquareQuantile(double p, double k);

struct ChiSquareRegion {
  double lower = 0, upper = 0;
  bool contains(double v) const { return v >= lower && v <= upper; }
};
/// Two-sided (1 − alpha) region of the mean of `runs` independent χ²(dof) values.
ChiSquareRegion aneesRegion(double dof, int runs, double alpha = 0.05);

/// e = Log(T_est⁻¹ T_true) (conventions §3 tangent).
Vector6d poseError(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_true);

struct Nees {
  double value = 0;
  int dof = 0;
};
/// eᵀ Σ⁺ e on the range of Σ (see above). Precondition: Σ symmetric positive semi-definite.
Nees computeNees(const Vector6d& e, const Matrix6d& Sigma);

/// One evaluated pose (a keyframe, or the relative pose of a pair) of one run.
struct NeesSample {
  std::int64_t run = 0;  ///< independence group (Monte Carlo run, or snapshot)
  std::string group;     ///< what it is across runs, e.g. "kf 7" or "7-8"
  Vector6d e = Vector6d::Zero();
  Matrix6d Sigma = Matrix6d::Zero();
  Nees nees;
};
/// A sample with its NEES; returns nees.dof == 0 for a singular (hard-fixed) covariance.
NeesSample makeSample(std::int64_t run, std::string group, const Vector6d& e,
                      const Matrix6d& Sigma);

struct ConsistencyStats {
  std::size_t samples = 0;
  int runs = 0;
  double anees = 0;        ///< mean NEES
  double dof = 0;          ///< mean DoF
  ChiSquareRegion region;  ///< for `runs` runs of `dof` DoF (conservative, see above)
  bool inside = false;
  /// coverage(i, m − 1): fraction of samples with |e_i| <= m σ_i (axes with σ_i > 0 only).
  Eigen::Matrix<double, 6, 3> coverage = Eigen::Matrix<double, 6, 3>::Zero();
  std::array<double, 3> coverage_all{};  ///< pooled over the six axes
  double tail_95 = 0;                    ///< fraction with NEES > χ²_dof(0.95) (nominal 0.05)
  double spearman_translation = 0;       ///< 0 when undefined (fewer than 3 samples, constant)
  double spearman_rotation = 0;
};
/// Statistics of the samples with dof > 0. Throws std::invalid_argument when there is none.
ConsistencyStats summarize(const std::vector<NeesSample>& samples, double alpha = 0.05);

/// Spearman rank correlation of x and y (same size >= 2); 0 when either is constant.
double spearmanCorrelation(const std::vector<double>& x, const std::vector<double>& y);

/// Σ NEES / Σ DoF over samples with dof > 0: the variance inflation factor that makes the ANEES
/// equal its DoF. Throws std::invalid_argument when there is no sample.
double fitInflation(const std::vector<NeesSample>& samples);
/// The samples with Σ → kΣ (NEES / k).
std::vector<NeesSample> inflate(std::vector<NeesSample> samples, double k);

/// Nominal Gaussian coverage of ±1, 2, 3 sigma: 0.6827, 0.9545, 0.9973 (erf(m/√2)).
std::array<double, 3> nominalCoverage();

}  // namespace dbacov
