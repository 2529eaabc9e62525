// What a covariance computation did, for logs and reports (Ceres' Solver::Summary in spirit):
// DbaCovariance::summary() fills it; brief() is one line, full() a small table.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace dbacov {

/// Counts of the linearization (conventions §2, §4).
struct LinearizationStats {
  std::size_t factors_used = 0;         ///< pixel factors (edge, pixel) that carry information
  std::size_t factors_filtered = 0;     ///< dropped by the depth filters or behind the camera
  std::size_t depths_used = 0;          ///< depth variables eliminated
  std::size_t depths_unobservable = 0;  ///< depth variables with 0 < Hdd <= eps (not eliminated)
  double chi2 = 0.0;                    ///< Σ rᵀ Λ r over used factors
};

/// Per-edge variance factors of a self-calibrated covariance (empty when none was applied).
struct SelfCalibrationSummary {
  std::string method;               ///< the method's name; empty: no self-calibration
  std::vector<double> edge_factor;  ///< per edge (snapshot order): variance inflation
  /// What the depths' second-order term adds to the trace: its trace over the trace of the
  /// method's own covariance, in the gauge's reduced coordinates (so m² and rad² add up; may
  /// exceed 1); 0 when it was not applied (depth_noise off, or the bootstrap).
  double depth_noise_share = 0;
  /// The term's inputs: the residuals' excess kurtosis γ₂ it used (0: Gaussian tails, or not
  /// applied), the two flow axes' joint fourth cumulant γ_xy (depth_noise.h; 0 likewise) and
  /// the largest share ρ of a direction's information the depths' noise takes (beyond 0.9 the
  /// second-order expansion holds it at 0.9; self_calibration.cpp).
  double depth_noise_kurtosis = 0;
  double depth_noise_cross_kurtosis = 0;
  double depth_noise_max_rho = 0;
  double sensor_depth_scale = 1;  ///< RGB-D: the sensor readings' variance factor (1: none)
  /// The noise model's fit check. The spread of the edges' white scales: (q75 − q25) / 1.349 of
  /// log edge_factor over the edges (a standard deviation that a few extreme edges do not move;
  /// 0 with fewer than 4 edges).
  double edge_scale_spread = 0;
  /// The check failed: edge_scale_spread > kPoorFitScaleSpread or the residuals' excess kurtosis
  /// > kPoorFitKurtosis. Where the study's open family of simulated error sources showed either,
  /// the calibrated covariance came out over-confident (docs/guides/self-calibration.md): its σ
  /// are then a lower bound.
  bool poor_fit = false;
  /// Sets edge_scale_spread and poor_fit from edge_factor and depth_noise_kurtosis.
  void checkFit();
};

/// The fit check's limits (SelfCalibrationSummary::poor_fit), chosen on one half of the open
/// family's models and confirmed on the other (docs/studies/self-calibration.md).
inline constexpr double kPoorFitScaleSpread = 0.3;
inline constexpr double kPoorFitKurtosis = 10.0;

struct CovarianceSummary {
  std::string solver;    ///< "cholmod" or "dense"
  std::string ordering;  ///< the requested fill-reducing ordering (sparse solver)
  int keyframes = 0;     ///< graph keyframes
  int edges = 0;
  int free_dof = 0;                ///< dimension of the reduced system after the gauge
  std::size_t factor_entries = 0;  ///< nnz(L) (dense: n²)
  LinearizationStats linearization;
  double seconds_linearize = 0;  ///< linearization + Schur complement over the depths
  double seconds_gauge = 0;      ///< gauge parameterization and reduction
  double seconds_factorize = 0;  ///< factorization (and the selected inverse, when eager)
  SelfCalibrationSummary self_calibration;

  /// One line, e.g. "11 keyframes, 58 edges, 120341 pixel factors, cholmod (auto) nnz(L) 1830,
  /// 8.1 ms".
  std::string brief() const;
  /// Every field, one per line.
  std::string full() const;
};

}  // namespace dbacov
