// Self-calibration of the pixel noise from the residuals of one snapshot (no ground truth).
//
// The covariance engine (covariance.h) assumes independent pixel factors with information
// Λ = weight_scale · diag(w_x, w_y). Real flow errors are larger or smaller than the confidences
// claim (a wrong `weight_scale`) and correlated within an edge (smooth flow errors). The
// residuals r = target − π(Y) at the linearization point (DBA's optimum) carry both: this module
// estimates per edge e a variance factor ("inflation") c_e, so that the edge's pixel information
// becomes Λ / c_e, or (sandwich, nuisance) a covariance of the poses under the fitted noise
// model, and the query API of DbaCovariance answers with the calibrated model. Conventions:
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
// Methods (SelfCalibrationMethod):
//   vce       Förstner/Helmert variance-component estimation, one component per edge:
//             c_e ← c_e · q_e / ρ_e with q_e = Σ λ r² and the redundancy ρ_e = n_e − Σ lev,
//             iterated (weights, Σ and redundancies recomputed). Corrects scale, not correlation.
//   autocorr  vce's scale times τ_e = Σ_Δ w(Δ) ρ_e(Δ), the Bartlett-tapered sum of the 2-D
//             autocorrelation of the edge's standardized residual field r·√λ/√(1 − lev) on the
//             H×W grid over lags |Δx|, |Δy| <= L (`autocorr_lag`); effective pixels n_e / τ_e.
//             Captures correlation up to the lag window only.
//   score     c_e ← c_e · scale_e · ratio_e: vce's scale times the score ratio κ_e / scale_e with
//             κ_e = g_eᵀ Σ g_e / E[g_eᵀ Σ g_e], the expectation under the
//             current model: tr(Σ I_e) − tr(Σ D_e) − tr((Σ I_e)²), D_e = Σ_k c_k c_kᵀ / h_k with
//             c_k = Σ_{rows of e at pixel k} λ J_d v (what the shared depth takes out of the edge's
//             score) and the last term what the poses take out. It measures the edge's error in
//             the pose directions that the covariance weighs, whatever its spatial structure
//             (a scalar cluster-robust estimate). With score_metric Information (Covariance is the
//             default) the statistic is g_eᵀ I_e⁺ g_e instead, expectation rank(I_e) − tr(I_e⁺ D_e)
//             − tr(Σ I_e): far more degrees of freedom per edge. The ratio has few degrees of
//             freedom (ν_e = tr(ΣI_e)² / tr((ΣI_e)²)), so it is shrunk towards the ratio pooled
//             over all edges (score_prior_dof); iterated like vce.
//   sandwich  the cluster-robust covariance Σ (Σ_e g_e g_eᵀ / f_e) Σ with clusters = edges, in
//             the gauge's reduced coordinates, and the small-sample correction
//             f_e = E[g_eᵀ Σ g_e] / tr(Σ I_e) (what the fit takes out of each cluster's score;
//             a scalar form of the CR3 correction). Needs more edges than free pose DoF; shape
//             and scale both come from the scores (noisy for few edges).
//   nuisance  a per-edge low-order flow error field n_e(x, y) = Φ(x, y) a_e (Φ: affine [1, u, v]
//             per channel, plus with nuisance_nodes = G ≥ 2 a G×G bilinear tent spline; u, v
//             the grid coordinates scaled to [−1, 1]) with a_e ~ N(0, D), D = σ_a² on the
//             affine coefficients and σ_f² on the tents' node values (two variance components
//             shared by all edges), on top of white noise of variance s_e / λ per edge. The
//             whitened, depth-reduced nuisance columns give per edge C_e = Σ_{rows of e} v φᵀ
//             (what the field does to the reduced score), the field's information after the
//             poses and depths M_e = Φ_eᵀ Λ P⊥ Φ_e (= Φ̃ᵀΛΦ̃ − C_eᵀ Σ C_e) and its score
//             t_e = Φ̃_eᵀ Λ r, with E[t tᵀ] = (M_s D M_s)_ee + s_e M_e (M_s: the fields of
//             all edges leaving the edge's source, which its depths couple). σ_a², σ_f² are the
//             maximum-likelihood estimates over all edges' t (projected Fisher scoring on M_e's
//             range), s_e = (q_e − |t_e|²_{M_e⁺} + excess) / (ρ_e − rank M_e); alternated to
//             convergence. The covariance is then that of DBA's actual estimate under this
//             noise model, Σ (S + Σ_e (s_e − 1) I_e + Σ_e C_e D C_eᵀ) Σ (a model-based
//             sandwich: no per-edge empirical meat), handed over as a reduced covariance like
//             sandwich. Captures a smooth error of every edge's field in the pose directions
//             it reaches; a field finer than the basis is seen only by its white scale s_e.
//   bootstrap nuisance, then a parametric bootstrap that re-solves the DBA: R replicates of the
//             snapshot whose targets are the state's predicted flow plus noise drawn from the
//             fitted model (white of variance s_e / λ, or the rows' own residuals with random
//             signs at that energy: bootstrap_resampling; fields a_e ~ N(0, D)), each solved to
//             the optimum from the state (the project's DBA solver) and calibrated like the
//             snapshot. The state against each replicate's estimate and covariance is the
//             evaluation's NEES with the state as the truth; per keyframe its mean over 6 is k_a
//             (1 up to sampling, sd √(2 / 6R), where the solve is linear; beyond it what the
//             solve's nonlinearity at low SNR adds). The covariance is D^½ V D^½, D = k_a per
//             keyframe. Needs the solver, so it runs through runSelfCalibration
//             (dbacov/study/bootstrap.h); selfCalibrate refuses it.
// Factors on the depths alone (DROID's stereo edges k == k, RGB-D readings) have no pose rows:
// v = −(√λ J_d / h_k) b_k. Each stereo edge gets its own vce scale and the readings one shared
// scale (SelfCalibration::sensor_depth_scale), in every method: inflation / α divided (vce,
// score, autocorr), (s − 1) I in nuisance's meat, clusters of the sandwich's.
// Default: nuisance with nuisance_nodes = 4 (developed on one set of simulated runs, confirmed on
// runs it was not tuned on; docs/studies/self-calibration.md).
// All but sandwich and nuisance produce per-edge inflations; selfCalibratedSnapshot() then divides
// the edge's weights by c_e and DbaCovariance recomputes the covariance. Assumptions: the state is
// (close to) the optimum of the snapshot's own factors (see distanceFromOptimum), errors are
// independent across edges, and the linearization holds (high SNR).
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dbacov/core/covariance.h"
#include "dbacov/core/options.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {

enum class SelfCalibrationMethod { Vce, Autocorr, Score, Sandwich, Nuisance, Bootstrap };
template <>
struct EnumNames<SelfCalibrationMethod> {
  static constexpr const char* what = "self-calibration method";
  static constexpr std::array<std::pair<SelfCalibrationMethod, const char*>, 6> entries{
      {{SelfCalibrationMethod::Score, "score"},
       {SelfCalibrationMethod::Vce, "vce"},
       {SelfCalibrationMethod::Autocorr, "autocorr"},
       {SelfCalibrationMethod::Sandwich, "sandwich"},
       {SelfCalibrationMethod::Nuisance, "nuisance"},
       {SelfCalibrationMethod::Bootstrap, "bootstrap"}}};
};
/// Parses a method name (parseEnum); throws std::invalid_argument naming the valid ones.
inline SelfCalibrationMethod parseSelfCalibrationMethod(const std::string& name) {
  return parseEnum<SelfCalibrationMethod>(name);
}

/// How the bootstrap draws each replicate's white noise. Parametric: Gaussian of variance s_e / λ
/// at every row. Wild: the row's own standardized residual with a random sign, rescaled per edge
/// to the same energy s_e (the residuals' heavy tails, and where they are, carried over).
enum class BootstrapResampling { Parametric, Wild };
template <>
struct EnumNames<BootstrapResampling> {
  static constexpr const char* what = "bootstrap resampling";
  static constexpr std::array<std::pair<BootstrapResampling, const char*>, 2> entries{
      {{BootstrapResampling::Parametric, "parametric"}, {BootstrapResampling::Wild, "wild"}}};
};

/// The metric of the score statistic: I_e⁺ (every direction of the edge's information equally:
/// many degrees of freedom) or Σ (the pose covariance: the directions the covariance weighs).
enum class ScoreMetric { Information, Covariance };

struct SelfCalibrationOptions {
  /// The default by measurement (docs/studies/self-calibration.md): nuisance with a
  /// 4 × 4 spline is the one method with ANEES, 1σ coverage and NEES tail inside their targets on
  /// the correlated sources, and slightly conservative (ANEES just below its region) on OpenCV
  /// flow, where the others are over-confident.
  SelfCalibrationMethod method = SelfCalibrationMethod::Nuisance;
  int iterations = 1;    ///< reweighting passes of vce / score / autocorr (>= 1)
  int autocorr_lag = 4;  ///< L of autocorr (>= 1)
  /// score: prior degrees of freedom ν₀ of the shrinkage of an edge's score ratio κ_e/scale_e
  /// (ν_e degrees of freedom) towards the pooled ratio: (ν_e ratio_e + ν₀ pooled)/(ν_e + ν₀).
  double score_prior_dof = 30.0;
  ScoreMetric score_metric = ScoreMetric::Covariance;
  /// nuisance: the field's basis per channel, 0 = affine [1, u, v], G >= 2 = G × G bilinear tents.
  int nuisance_nodes = 4;
  /// bootstrap: re-solved replicates (>= 4) and the seed of their noise (the same seed gives the
  /// same covariance, whatever the number of threads).
  int bootstrap_replicates = 32;
  unsigned long long bootstrap_seed = 1;
  BootstrapResampling bootstrap_resampling = BootstrapResampling::Parametric;
  /// Adds the depths' second-order noise term (depth_noise.h, docs/studies/depth-noise.md) of each
  /// edge's white noise to the calibrated covariance: what the linearization misses where the
  /// depths are poorly determined (white noise 2x, the low-SNR scene). Not with the bootstrap,
  /// which re-solves. On by default: held out, it brings white 2x and the low-SNR scene inside
  /// their regions and moves no other source out (docs/studies/depth-noise.md).
  bool depth_noise = true;
  /// With depth_noise: the term's fourth-cumulant share, from the residuals' excess kurtosis and
  /// the two flow axes' joint fourth cumulant (heavy-tailed flow, outliers; depth_noise.h).
  bool depth_noise_kurtosis = true;
  double min_inflation = 1e-9;  ///< inflations are clamped to [min, max]
  double max_inflation = 1e9;
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
  double vce_scale = 1;        ///< q / redundancy at the last pass
  /// Beyond scale: τ (autocorr), κ·c/vce (score), 1 + field / white share of q (nuisance).
  double correlation = 1;
  double inflation = 1;         ///< c_e: the edge's variance factor (1 for sandwich; nuisance: s_e)
  double effective_pixels = 0;  ///< pixels / correlation (autocorr: pixels / τ)
};

/// How far the snapshot's state is from the optimum of its own factors: the reduced gradient and
/// one undamped Gauss-Newton step of the poses (δ = −S_r⁻¹ g_r) in units of their uncertainty.
/// At DBA's optimum the step is 0; a state off by δ adds δᵀ S_r δ = step_sigma² to the residuals'
/// χ² and about as much to the scores' Σ g_eᵀ Σ g_e, whose expectation is ≈ free_dof: a
/// residual-based estimate (score, sandwich) is then biased by up to step_sigma² / free_dof.
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
struct SelfCalibration {
  SelfCalibrationMethod method = SelfCalibrationMethod::Nuisance;
  std::vector<EdgeCalibration> edges;  ///< one per snapshot edge, in edge order
  /// Σ q / Σ redundancy at the snapshot's weights over the edges (stereo ones too; not the
  /// sensor readings)
  double global_scale = 1;
  int passes = 0;           ///< linearizations done
  OptimumDistance optimum;  ///< of the snapshot's state (first pass, its weights)
  /// RGB-D: the sensor readings' variance factor (their information becomes α / factor), one
  /// for all of the snapshot's readings: Σ α r² / (rows − Σ lev), iterated with vce / score /
  /// autocorr; their rows and redundancy at the last pass. 1 without readings.
  double sensor_depth_scale = 1;
  std::size_t sensor_depth_rows = 0;
  double sensor_depth_redundancy = 0;
  /// Nuisance only: σ_a (px) of the per-edge field's coefficients, and their number per edge.
  double nuisance_sigma = 0;
  double nuisance_fine_sigma = 0;  ///< σ of the G × G tents' node values (px), with nodes >= 2
  int nuisance_params = 0;
  /// Bootstrap only: the scale k of the nuisance covariance, the replicates it is the mean of
  /// and those left out because their solve did not converge.
  double bootstrap_scale = 1;
  /// Per graph keyframe (ascending), the scale k_a of its marginal (1 for a fixed keyframe).
  std::vector<double> bootstrap_keyframe_scales;
  int bootstrap_replicates = 0;
  int bootstrap_failed = 0;
  /// Sandwich and nuisance: the covariance in the gauge's reduced coordinates (for
  /// CovarianceOptions).
  std::shared_ptr<const Eigen::MatrixXd> reduced_covariance;
  /// Nuisance: the linearization reduced_covariance was computed with (the snapshot's own, at its
  /// weights), so that selfCalibratedCovariance of the same snapshot does not linearize again.
  std::shared_ptr<const DbaNormalEquations> linearization;
  /// The options' depth_noise: selfCalibratedCovariance adds the depths' second-order term;
  /// depth_noise_kurtosis: with its fourth-cumulant share.
  bool depth_noise = false;
  bool depth_noise_kurtosis = false;
  /// Per-edge inflations in edge order.
  std::vector<double> inflations() const;
};

/// Estimates the noise of every edge from the snapshot's residuals. Throws InputError for an
/// invalid snapshot, std::invalid_argument for invalid options and NumericalError when the
/// reduced system is not positive definite or (sandwich) there are not enough edges;
/// std::invalid_argument for the bootstrap method, which needs the DBA solver
/// (runSelfCalibration, dbacov/study/bootstrap.h).
SelfCalibration selfCalibrate(const Snapshot& snapshot, const DbaOptions& options,
                              const SelfCalibrationOptions& calibration = {});

/// A copy of the snapshot whose weights of edge e are divided by inflation[e].
Snapshot inflateWeights(const Snapshot& snapshot, const std::vector<double>& inflation);

/// The self-calibrated covariance: the inflated snapshot (or, for sandwich, the given reduced
/// covariance) in the DbaCovariance query API.
DbaCovariance selfCalibratedCovariance(const Snapshot& snapshot, const DbaOptions& options,
                                       const CovarianceOptions& solver,
                                       const SelfCalibration& calibration);

/// The same, on its own (one linearization and a dense inverse).
OptimumDistance distanceFromOptimum(const Snapshot& snapshot, const DbaOptions& options);

}  // namespace dbacov
