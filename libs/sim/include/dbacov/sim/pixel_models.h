// Per-pixel models of the simulator: the network's confidences (weights) and the errors of its
// predicted targets (noise).
//
// Weights: per pixel and axis, w ~ Uniform[min, max], Beta(alpha, beta) rescaled to [min, max], or
// a constant; a fraction `zero_fraction` of the pixels gets w = 0 on both axes (no information).
// Noise: a target's error on each axis has variance 1/(weight_scale · w), the information the
// covariance engine assigns to it (conventions §2), so the marginal of every pixel is right by
// construction. Its structure within an edge is either
//   White       independent across pixels: the engine's model holds exactly (consistent);
//   Correlated  a stationary Gaussian random field per edge and axis with correlation
//               ρ(Δ) = exp(−|Δ|² / (2 ℓ²)) between pixels Δ apart (ℓ = correlation_length_px),
//               scaled pixel-wise by 1/sqrt(weight_scale · w). The engine still treats the pixels
//               as independent, so its covariances are over-confident, like raw DROID confidences
//               (conventions §7).
// The field is white noise smoothed by a separable Gaussian kernel of standard deviation ℓ/√2 (the
// autocorrelation of a Gaussian kernel of std s is a Gaussian of std s√2), computed on a padded
// grid so that every pixel has full kernel support, and divided by the kernel's norm so that its
// marginal variance is exactly 1.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace dbacov::sim {

struct WeightModel {
  enum class Distribution { Uniform, Beta, Constant };
  Distribution distribution = Distribution::Uniform;
  double min = 0.2, max = 1.0;     ///< range (Uniform, Beta)
  double alpha = 2.0, beta = 2.0;  ///< shape (Beta)
  double value = 1.0;              ///< Constant
  double zero_fraction = 0.1;      ///< fraction of pixels with w = 0 on both axes

  /// Throws std::invalid_argument for values out of their domain (0 <= min <= max, shapes > 0,
  /// value > 0, zero_fraction in [0, 1)).
  void validate() const;
  /// One confidence (> 0 unless min = 0).
  double sample(std::mt19937_64& rng) const;
};
/// "uniform", "beta", "constant"; throws std::invalid_argument otherwise.
WeightModel::Distribution parseWeightDistribution(const std::string& name);
std::string toString(WeightModel::Distribution d);

struct NoiseModel {
  enum class Type { White, Correlated };
  Type type = Type::White;
  /// Which flows share their errors. Snapshot: every snapshot redraws the confidences and target
  /// errors of all its edges (independent measurements per snapshot). Edge: an edge's
  /// confidences and errors are drawn once per run and are the same in every snapshot that holds
  /// the edge, as DROID's network predicts the same flow again for the same pair of images (its
  /// windows then share their measurements: what --graph's "counted once" is about).
  enum class Persistence { Snapshot, Edge };
  Persistence persistence = Persistence::Snapshot;
  double correlation_length_px = 3.0;  ///< ℓ (Correlated)
  /// Multiplies every target error: 1 = the variance the weights claim (consistent), 0 = exact
  /// targets, 2 = four times the claimed variance.
  double amplitude = 1.0;
  // Errors the confidences do not describe, added on top (self-calibration studies; all in px,
  // independent of the weights, independent across edges and runs):
  /// Per edge and axis a flow error a0 + a1·u + a2·v, u = (x − cx)/(W/2), v = (y − cy)/(H/2),
  /// each coefficient ~ N(0, affine_px²).
  double affine_px = 0.0;
  /// A Gaussian random field per edge and axis, correlation length field_length_px (the
  /// Correlated model's field), standard deviation field_px.
  double field_px = 0.0;
  double field_length_px = 4.0;
  /// A fraction of the pixels (both axes) whose total error is multiplied by outlier_factor.
  double outlier_fraction = 0.0;
  double outlier_factor = 10.0;
  /// Each edge's white errors scaled by exp(edge_scale_spread · z), z ~ N(0, 1) per edge and run:
  /// edges whose confidences are off by different factors.
  double edge_scale_spread = 0.0;
  /// Heavy tails: the white errors are Student-t with this many degrees of freedom (> 2), scaled
  /// to the claimed variance; 0 = Gaussian.
  double student_t_dof = 0.0;
  /// The random field (field_px) from random Fourier features (FourierNoiseField) instead of the
  /// smoothed white noise: any correlation length, also beyond the image, at a cost that does not
  /// grow with it.
  bool field_fourier = false;

  /// Throws std::invalid_argument for a non-positive correlation length or negative amplitude.
  void validate() const;
};
/// Which error model a simulated run follows: the configured one (Fixed) or one drawn from the
/// open family around it (Open, drawNoiseModel).
enum class NoiseFamily { Fixed, Open };
/// "fixed", "open"; throws std::invalid_argument otherwise.
NoiseFamily parseNoiseFamily(const std::string& name);
std::string toString(NoiseFamily f);

/// The open family of error sources (simul-dba --noise-family open, the self-calibration study's
/// --family): one model drawn from wide ranges around `base` (its type, persistence and claimed
/// white noise), every component switched on independently, so that mixtures occur:
///   white scale       amplitude × 2^U(−2, 2) (¼ to 4 times the claimed σ), always;
///   per-edge spread   edge_scale_spread ~ U(0, 0.7), with probability ½;
///   random field      length 2^U(0, log2(4 max(H, W))) px (1 px to 4 times the image), σ
///                     2^U(log2 0.02, log2 0.5) px, Fourier features, with probability ½;
///   per-edge affine   σ 2^U(log2 0.005, log2 0.15) px, with probability ½;
///   outliers          fraction U(0, 5 %) at 5–30 times, with probability ⅓;
///   heavy tails       Student-t with 3–30 degrees of freedom, with probability ⅓.
/// The same seed gives the same model.
NoiseModel drawNoiseModel(const NoiseModel& base, std::uint64_t seed, int H, int W);
/// One line naming the model's error components ("white 1.3x, field 12 px 0.08 px, ...").
std::string describe(const NoiseModel& m);

/// "white", "correlated"; throws std::invalid_argument otherwise.
NoiseModel::Type parseNoiseType(const std::string& name);
std::string toString(NoiseModel::Type t);
/// "snapshot", "edge"; throws std::invalid_argument otherwise.
NoiseModel::Persistence parseNoisePersistence(const std::string& name);
std::string toString(NoiseModel::Persistence p);

/// Unit-variance noise fields of one H×W grid (C order) under a noise model.
class UnitNoiseField {
 public:
  UnitNoiseField(const NoiseModel& model, int H, int W);
  /// A new field: i.i.d. N(0, 1) (White) or the correlated field above.
  std::vector<double> sample(std::mt19937_64& rng) const;

 private:
  NoiseModel model_;
  int H_, W_, radius_ = 0;
  std::vector<double> kernel_;  ///< normalized so that the field has unit variance
};

/// A stationary random field of unit variance with the Gaussian correlation
/// ρ(Δ) = exp(−|Δ|² / (2 ℓ²)) in expectation, as a sum of F random Fourier features
/// √(2/F) Σ_f cos(ω_f · x + b_f), ω_f ~ N(0, I/ℓ²), b_f ~ U(0, 2π), drawn anew by every sample:
/// a generator independent of UnitNoiseField's, for any ℓ (also beyond the grid) in O(H W F).
class FourierNoiseField {
 public:
  FourierNoiseField(double correlation_length_px, int H, int W, int features = 64);
  std::vector<double> sample(std::mt19937_64& rng) const;

 private:
  double length_;
  int H_, W_, features_;
};

}  // namespace dbacov::sim
