#include "dbacov/sim/pixel_models.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
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
  if (!(edge_scale_spread >= 0 && std::isfinite(edge_scale_spread)))
    throw std::invalid_argument("noise: edge_scale_spread must be finite and >= 0");
  if (!(student_t_dof == 0 || (student_t_dof > 2 && std::isfinite(student_t_dof))))
    throw std::invalid_argument(
        "noise: student_t_dof must be 0 (Gaussian) or > 2 (a finite variance)");
}

NoiseFamily parseNoiseFamily(const std::string& name) {
  if (name == "fixed") return NoiseFamily::Fixed;
  if (name == "open") return NoiseFamily::Open;
  throw std::invalid_argument("unknown noise family '" + name + "', expected fixed or open");
}

std::string toString(NoiseFamily f) {
  return f == NoiseFamily::Fixed ? "fixed" : "open";
}

NoiseModel drawNoiseModel(const NoiseModel& base, std::uint64_t seed, int H, int W) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * u01(rng); };
  const auto log2Uniform = [&](double lo, double hi) {
    return std::exp2(uniform(std::log2(lo), std::log2(hi)));
  };
  // Every component is drawn whether or not it is switched on, so that the draws of one component
  // do not depend on another's switch.
  NoiseModel m = base;
  m.amplitude = base.amplitude * std::exp2(uniform(-2.0, 2.0));
  const double spread = uniform(0.0, 0.7);
  m.edge_scale_spread = u01(rng) < 0.5 ? spread : 0.0;
  const double length = log2Uniform(1.0, 4.0 * std::max(H, W)), field = log2Uniform(0.02, 0.5);
  const bool with_field = u01(rng) < 0.5;
  m.field_px = with_field ? field : 0.0;
  m.field_length_px = length;
  m.field_fourier = true;
  const double affine = log2Uniform(0.005, 0.15);
  m.affine_px = u01(rng) < 0.5 ? affine : 0.0;
  const double fraction = uniform(0.0, 0.05), factor = uniform(5.0, 30.0);
  const bool with_outliers = u01(rng) < 1.0 / 3.0;
  m.outlier_fraction = with_outliers ? fraction : 0.0;
  m.outlier_factor = with_outliers ? factor : base.outlier_factor;
  const double dof = uniform(3.0, 30.0);
  m.student_t_dof = u01(rng) < 1.0 / 3.0 ? dof : 0.0;
  m.validate();
  return m;
}

std::string describe(const NoiseModel& m) {
  char buf[256];
  std::string out;
  const auto add = [&out](const char* text) {
    out += (out.empty() ? "" : ", ") + std::string(text);
  };
  std::snprintf(buf, sizeof buf, "white %.2fx", m.amplitude);
  add(buf);
  if (m.type == NoiseModel::Type::Correlated) {
    std::snprintf(buf, sizeof buf, "correlated %.1f px", m.correlation_length_px);
    add(buf);
  }
  if (m.edge_scale_spread > 0) {
    std::snprintf(buf, sizeof buf, "edge spread %.2f", m.edge_scale_spread);
    add(buf);
  }
  if (m.student_t_dof > 0) {
    std::snprintf(buf, sizeof buf, "t%.1f", m.student_t_dof);
    add(buf);
  }
  if (m.field_px > 0) {
    std::snprintf(buf, sizeof buf, "field %.1f px x %.3f px", m.field_length_px, m.field_px);
    add(buf);
  }
  if (m.affine_px > 0) {
    std::snprintf(buf, sizeof buf, "affine %.3f px", m.affine_px);
    add(buf);
  }
  if (m.outlier_fraction > 0) {
    std::snprintf(buf, sizeof buf, "outliers %.1f %% x%.0f", 100 * m.outlier_fraction,
                  m.outlier_factor);
    add(buf);
  }
  return out;
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

FourierNoiseField::FourierNoiseField(double correlation_length_px, int H, int W, int features)
    : length_(correlation_length_px), H_(H), W_(W), features_(features) {
  if (!(length_ > 0 && std::isfinite(length_)))
    throw std::invalid_argument("noise: field_length_px must be positive");
  if (features_ < 1) throw std::invalid_argument("noise: a Fourier field needs a feature");
}

std::vector<double> FourierNoiseField::sample(std::mt19937_64& rng) const {
  std::normal_distribution<double> omega(0.0, 1.0 / length_);
  std::uniform_real_distribution<double> phase(0.0, 2.0 * M_PI);
  std::vector<double> f(static_cast<std::size_t>(H_) * W_, 0.0);
  const double a = std::sqrt(2.0 / features_);
  for (int q = 0; q < features_; ++q) {
    const double wx = omega(rng), wy = omega(rng), b = phase(rng);
    for (int y = 0; y < H_; ++y)
      for (int x = 0; x < W_; ++x)
        f[static_cast<std::size_t>(y) * W_ + x] += a * std::cos(wx * x + wy * y + b);
  }
  return f;
}

}  // namespace dbacov::sim
