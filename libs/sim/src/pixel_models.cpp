#include "dbacov/sim/pixel_models.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace dbacov::sim {

void WeightModel::validate() const {
  auto finite = [](double v) { return std::isfinite(v); };
  if (!finite(min) || !finite(max) || !(min >= 0) || !(min <= max))
    throw std::invalid_argument("weights: need 0 <= min <= max");
  if (distribution == Distribution::Beta &&
      !(alpha > 0 && beta > 0 && finite(alpha) && finite(beta)))
    throw std::invalid_argument("weights: beta shapes alpha, beta must be > 0");
  if (distribution == Distribution::Constant && !(value > 0 && finite(value)))
    throw std::invalid_argument("weights: constant value must be > 0");
  if (!(zero_fraction >= 0 && zero_fraction < 1))
    throw std::invalid_argument("weights: zero_fraction must be in [0, 1)");
}

double WeightModel::sample(std::mt19937_64& rng) const {
  switch (distribution) {
    case Distribution::Uniform:
      return std::uniform_real_distribution<double>(min, max)(rng);
    case Distribution::Beta: {
      // X / (X + Y) with X ~ Gamma(alpha), Y ~ Gamma(beta) is Beta(alpha, beta).
      const double x = std::gamma_distribution<double>(alpha, 1.0)(rng);
      const double y = std::gamma_distribution<double>(beta, 1.0)(rng);
      return min + (max - min) * (x + y > 0 ? x / (x + y) : 0.5);
    }
    case Distribution::Constant:
      return value;
  }
  return value;
}

WeightModel::Distribution parseWeightDistribution(const std::string& name) {
  if (name == "uniform") return WeightModel::Distribution::Uniform;
  if (name == "beta") return WeightModel::Distribution::Beta;
  if (name == "constant") return WeightModel::Distribution::Constant;
  throw std::invalid_argument("unknown weight distribution '" + name +
                              "', expected uniform, beta or constant");
}

std::string toString(WeightModel::Distribution d) {
  switch (d) {
    case WeightModel::Distribution::Uniform:
      return "uniform";
    case WeightModel::Distribution::Beta:
      return "beta";
    case WeightModel::Distribution::Constant:
      return "constant";
  }
  return "?";
}

void NoiseModel::validate() const {
  if (type == Type::Correlated &&
      !(correlation_length_px > 0 && std::isfinite(correlation_length_px)))
    throw std::invalid_argument("noise: correlation length must be > 0 pixels");
  if (!(amplitude >= 0 && std::isfinite(amplitude)))
    throw std::invalid_argument("noise: amplitude must be finite and >= 0");
  if (!(affine_px >= 0 && std::isfinite(affine_px)) || !(field_px >= 0 && std::isfinite(field_px)))
    throw std::invalid_argument("noise: affine_px and field_px must be finite and >= 0");
  if (!(field_length_px > 0 && std::isfinite(field_length_px)))
    throw std::invalid_argument("noise: field_length_px must be positive");
  if (!(outlier_fraction >= 0 && outlier_fraction < 1) ||
      !(outlier_factor >= 0 && std::isfinite(outlier_factor)))
    throw std::invalid_argument("noise: outlier_fraction must be in [0, 1), outlier_factor >= 0");
}

NoiseModel::Type parseNoiseType(const std::string& name) {
  if (name == "white") return NoiseModel::Type::White;
  if (name == "correlated") return NoiseModel::Type::Correlated;
  throw std::invalid_argument("unknown noise model '" + name + "', expected white or correlated");
}

std::string toString(NoiseModel::Type t) {
  return t == NoiseModel::Type::White ? "white" : "correlated";
}

NoiseModel::Persistence parseNoisePersistence(const std::string& name) {
  if (name == "snapshot") return NoiseModel::Persistence::Snapshot;
  if (name == "edge") return NoiseModel::Persistence::Edge;
  throw std::invalid_argument("unknown noise persistence '" + name +
                              "', expected snapshot or edge");
}

std::string toString(NoiseModel::Persistence p) {
  return p == NoiseModel::Persistence::Snapshot ? "snapshot" : "edge";
}

UnitNoiseField::UnitNoiseField(const NoiseModel& model, int H, int W)
    : model_(model), H_(H), W_(W) {
  model_.validate();
  if (model_.type == NoiseModel::Type::White) return;
  if (!(model_.correlation_length_px <= std::max(H, W)))  // the kernel would outgrow the grid
    throw std::invalid_argument(
        "noise: correlation length of " +
        std::to_string(static_cast<long long>(model_.correlation_length_px)) +
        " px exceeds the grid (" + std::to_string(W) + "x" + std::to_string(H) + " px)");
  // Kernel k(u) = exp(−u²/(2 s²)), s = ℓ/√2, truncated at 4 s. The 2-D field f = Σ k(u)k(v) n is
  // unit variance when Σ_u k(u)² = 1 per dimension.
  const double s = model_.correlation_length_px / std::sqrt(2.0);
  radius_ = static_cast<int>(std::ceil(4.0 * s));
  kernel_.resize(2 * radius_ + 1);
  double norm2 = 0;
  for (int u = -radius_; u <= radius_; ++u) {
    kernel_[u + radius_] = std::exp(-0.5 * u * u / (s * s));
    norm2 += kernel_[u + radius_] * kernel_[u + radius_];
  }
  for (double& k : kernel_) k /= std::sqrt(norm2);
}

std::vector<double> UnitNoiseField::sample(std::mt19937_64& rng) const {
  std::normal_distribution<double> n01(0.0, 1.0);
  if (model_.type == NoiseModel::Type::White) {
    std::vector<double> f(static_cast<std::size_t>(H_) * W_);
    for (double& v : f) v = n01(rng);
    return f;
  }
  // White noise on the padded grid, then the kernel along x (rows), then along y (columns).
  const int r = radius_, Hp = H_ + 2 * r, Wp = W_ + 2 * r;
  std::vector<double> white(static_cast<std::size_t>(Hp) * Wp);
  for (double& v : white) v = n01(rng);
  std::vector<double> rows(static_cast<std::size_t>(Hp) * W_, 0.0);
  for (int y = 0; y < Hp; ++y)
    for (int x = 0; x < W_; ++x) {
      double acc = 0;
      for (int u = 0; u <= 2 * r; ++u)
        acc += kernel_[u] * white[static_cast<std::size_t>(y) * Wp + x + u];
      rows[static_cast<std::size_t>(y) * W_ + x] = acc;
    }
  std::vector<double> f(static_cast<std::size_t>(H_) * W_, 0.0);
  for (int y = 0; y < H_; ++y)
    for (int x = 0; x < W_; ++x) {
      double acc = 0;
      for (int u = 0; u <= 2 * r; ++u)
        acc += kernel_[u] * rows[static_cast<std::size_t>(y + u) * W_ + x];
      f[static_cast<std::size_t>(y) * W_ + x] = acc;
    }
  return f;
}

}  // namespace dbacov::sim
