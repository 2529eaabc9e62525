// Self-calibration of the pixel noise from the residuals of one snapshot (no ground truth).
//
// The covariance engine (covariance.h) assumes independent pixel factors with information
// Λ = weight_scale · diag(w_x, w_y). Real flow errors are larger or smaller than the confidences
// claim (a wrong `weight_scale`) and correlated within an edge (smooth flow errors). The
// residuals r = target − π(Y) at the linearization point (DBA's optimum) carry both: this module
// fits a noise model to them (below) and gives the covariance of the poses under it, and the
// query API of DbaCovariance answers with the calibrated model. Conventions:
// docs/conventions.md §2 (factor), §3 (tangent), §4 (Schur complement and gauge).
//
// Notation, for the whitened rows of edge e (one per pixel and axis with w > 0): λ the row's
// information, u its pose Jacobian on the slots that the source keyframe touches, J_d its depth
// derivative, and for the source pixel k the depth terms h_k = Σ λ J_d², b_k = Σ λ J_d u over all
// edges leaving the source. The depth-reduced row v = u − (J_d / h_k) b_k satisfies
// S = Σ_rows λ v vᵀ (the reduced pose information) and g_S = Σ_rows λ r v (the reduced gradient),
// so per edge
//   I_e  = Σ_{rows of e} λ v vᵀ        (the edge's share of S),
//   g_e  = Σ_{rows of e} λ r v         (the edge's depth-reduced score),
//   lev  = λ (vᵀ Σ v + J_d² / h_k)     (the row's leverage: what poses and depth absorb),
// with Σ the dense pose covariance (full tangent, zero along removed gauge directions).
//
// The noise model: a per-edge low-order flow error field n_e(x, y) = Φ(x, y) a_e (Φ: affine
// [1, u, v] per channel, plus with nuisance_nodes = G ≥ 2 a G×G bilinear tent spline; u, v the
// grid coordinates scaled to [−1, 1]) with a_e ~ N(0, D), D = σ_a² on the affine coefficients and
// σ_f² on the tents' node values (two variance components shared by all edges), on top of white
// noise of variance s_e / λ per edge. The whitened, depth-reduced field columns give per edge
// C_e = Σ_{rows of e} v φᵀ (what the field does to the reduced score), the field's information
// after the poses and depths M_e = Φ_eᵀ Λ P⊥ Φ_e (= Φ̃ᵀΛΦ̃ − C_eᵀ Σ C_e) and its score
// t_e = Φ̃_eᵀ Λ r, with E[t tᵀ] = (M_s D M_s)_ee + s_e M_e (M_s: the fields of all edges leaving
// the edge's source, which its depths couple). σ_a², σ_f² are the maximum-likelihood estimates
// over all edges' t (projected Fisher scoring on M_e's range), s_e = (q_e − |t_e|²_{M_e⁺} +
// excess) / (ρ_e − rank M_e) with q_e = Σ λ r² and the redundancy ρ_e = n_e − Σ lev; alternated
// to convergence. The covariance is then that of DBA's actual estimate under this noise model,
// Σ (S + Σ_e (s_e − 1) I_e + Σ_e C_e D C_eᵀ) Σ (a model-based sandwich: no per-edge empirical
// meat), plus the depths' second-order term of each edge's white noise (depth_noise). It
// captures a smooth error of every edge's field in the pose directions it reaches; a field finer
// than the basis is seen only by its white scale s_e, and a field that looks like motion is
// absorbed by the poses (no residual shows it).
//
// Factors on the depths alone (DROID's stereo edges k == k, RGB-D readings) have no pose rows:
// v = −(√λ J_d / h_k) b_k. Each stereo edge gets its own white scale and the readings one shared
// scale (SelfCalibration::sensor_depth_scale), entering the covariance's (s − 1) I term.
// Default: nuisance_nodes = 4 (developed on one set of simulated runs, confirmed on runs it was
// not tuned on; docs/studies/self-calibration.md, which also keeps the methods that lost).
// The white scales are held within [1e-9, 1e9] times the snapshot's pooled scale Σ q / Σ ρ, so
// that the answer does not depend on the weight scale the snapshot claims. Assumptions: the
// state is (close to) the optimum of the snapshot's own factors (see distanceFromOptimum),
// errors are independent across edges, and the linearization holds (high SNR).
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "dbacov/core/covariance.h"
#include "dbacov/core/options.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

struct SelfCalibrationOptions {
  /// The field's basis per channel, 0 = affine [1, u, v], G in 2..8 = G × G bilinear tents.
  /// The default, 4, by measurement (docs/studies/self-calibration.md): ANEES, 1σ coverage and
  /// NEES tail inside their targets on the correlated sources, slightly conservative on OpenCV
  /// flow.
  int nuisance_nodes = 4;
  /// Adds the depths' second-order noise term (depth_noise.h, docs/studies/depth-noise.md) of each
  /// edge's white noise to the calibrated covariance: what the linearization misses where the
  /// depths are poorly determined (white noise 2x, the low-SNR scene). On by default: held out, it
  /// brings white 2x and the low-SNR scene inside their regions and moves no other source out.
  bool depth_noise = true;
  /// With depth_noise: the term's fourth-cumulant share, from the residuals' excess kurtosis and
  /// the two flow axes' joint fourth cumulant (heavy-tailed flow, outliers; depth_noise.h).
  bool depth_noise_kurtosis = true;
  /// Throws std::invalid_argument for values out of their domain.
  void validate() const;
};

/// What the self-calibration found for one edge.
struct EdgeCalibration {
  int edge = 0, i = 0, j = 0;  ///< index into ii/jj, source and target keyframe
  std::size_t pixels = 0;      ///< pixels with at least one used factor axis
  std::size_t rows = 0;        ///< used factor axes (w > 0)
  double residual_rms = 0;     ///< px, RMS of r over the used axes
  double chi2 = 0;             ///< Σ λ r² with the snapshot's weights
  double redundancy = 0;       ///< n − Σ lev under the final weights (vce's denominator)
  double vce_scale = 1;        ///< q / redundancy: the white scale if the edge had no field
  /// 1 + the field's share of the edge's pose information beyond its white noise.
  double correlation = 1;
  double inflation = 1;         ///< s_e: the edge's white-noise variance factor
  double effective_pixels = 0;  ///< pixels / correlation
};

/// How far the snapshot's state is from the optimum of its own factors: the reduced gradient and
/// one undamped Gauss-Newton step of the poses (δ = −S_r⁻¹ g_r) in units of their uncertainty.
/// At DBA's optimum the step is 0; a state off by δ adds δᵀ S_r δ = step_sigma² to the residuals'
/// χ² and about as much to the scores' Σ g_eᵀ Σ g_e, whose expectation is ≈ free_dof: a
/// residual-based estimate is then biased by up to step_sigma² / free_dof.
struct OptimumDistance {
  double gradient_norm = 0;  ///< |g_r| (gauge-reduced, Euclidean)
  double step_sigma = 0;     ///< sqrt(δᵀ S_r δ) = sqrt(g_rᵀ S_r⁻¹ g_r)
  double max_step_sigma = 0;  ///< max over keyframes of sqrt(δ_aᵀ Σ_a⁻¹ δ_a) (marginal units)
  int free_dof = 0;           ///< K, free pose DoF after the gauge
  /// step_sigma² > fraction · K: the scores may be biased by more than `fraction`.
  bool unreliable(double fraction = 0.1) const {
    return step_sigma * step_sigma > fraction * std::max(1, free_dof);
  }
};
/// The fitted model's covariance and linearization, which selfCalibratedCovariance answers with
/// (internal: dbacov/core/self_calibration_fit.h).
struct SelfCalibrationFit;

struct SelfCalibration {
  /// The noise model's name in outputs: "nuisance" (the study's bootstrap names its own).
  std::string method = "nuisance";
  std::vector<EdgeCalibration> edges;  ///< one per snapshot edge, in edge order
  /// Σ q / Σ redundancy at the snapshot's weights over the edges (stereo ones too; not the
  /// sensor readings)
  double global_scale = 1;
  int passes = 0;           ///< linearizations done
  OptimumDistance optimum;  ///< of the snapshot's state (its weights)
  /// RGB-D: the sensor readings' variance factor (their information becomes α / factor), one
  /// for all of the snapshot's readings: Σ α r² / (rows − Σ lev); their rows and redundancy.
  /// 1 without readings.
  double sensor_depth_scale = 1;
  std::size_t sensor_depth_rows = 0;
  double sensor_depth_redundancy = 0;
  /// σ_a (px) of the per-edge field's coefficients, and their number per edge.
  double nuisance_sigma = 0;
  double nuisance_fine_sigma = 0;  ///< σ of the G × G tents' node values (px), with nodes >= 2
  int nuisance_params = 0;
  /// The options' depth_noise: selfCalibratedCovariance adds the depths' second-order term;
  /// depth_noise_kurtosis: with its fourth-cumulant share.
  bool depth_noise = false;
  bool depth_noise_kurtosis = false;
  /// Empty when the gauge holds every pose (nothing to calibrate: every covariance is 0).
  std::shared_ptr<const SelfCalibrationFit> fit;
  /// Per-edge white-noise factors s_e in edge order.
  std::vector<double> inflations() const;
};

/// Estimates the noise of every edge from the snapshot's residuals. Throws InputError for an
/// invalid snapshot, std::invalid_argument for invalid options and NumericalError when the
/// reduced system is not positive definite.
SelfCalibration selfCalibrate(const Snapshot& snapshot, const DbaOptions& options,
                              const SelfCalibrationOptions& calibration = {});

/// A copy of the snapshot whose weights of edge e are divided by inflation[e].
Snapshot inflateWeights(const Snapshot& snapshot, const std::vector<double>& inflation);

/// The self-calibrated covariance (with the depths' term when the calibration says so) in the
/// DbaCovariance query API; std::invalid_argument when `calibration` is of another snapshot.
DbaCovariance selfCalibratedCovariance(const Snapshot& snapshot, const DbaOptions& options,
                                       const CovarianceOptions& solver,
                                       const SelfCalibration& calibration);

/// The same, on its own (one linearization and a dense inverse).
OptimumDistance distanceFromOptimum(const Snapshot& snapshot, const DbaOptions& options);

}  // namespace dbacov
