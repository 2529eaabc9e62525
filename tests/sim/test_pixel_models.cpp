// Per-pixel models of the simulator against closed forms: the correlated noise field's variance and
// correlation function, the weight distributions' moments, and the scene's ray casting.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "dbacov/sim/pixel_models.h"
#include "dbacov/sim/scene.h"

namespace dbacov::sim {
namespace {

/// Empirical variance and correlation at lag (dx, dy), pooled over all pixel pairs of many fields.
struct FieldMoments {
  double var = 0, corr = 0;
};
template <typename Field>
FieldMoments moments(const Field& field, int H, int W, int dx, int dy, int fields) {
  std::mt19937_64 rng(11);
  double s2 = 0, sxy = 0;
  std::size_t n2 = 0, nxy = 0;
  for (int f = 0; f < fields; ++f) {
    const std::vector<double> v = field.sample(rng);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const double a = v[y * W + x];
        s2 += a * a;
        ++n2;
        if (x + dx < W && y + dy < H) {
          sxy += a * v[(y + dy) * W + x + dx];
          ++nxy;
        }
      }
  }
  return {s2 / n2, (sxy / nxy) / (s2 / n2)};
}

TEST(NoiseField, CorrelatedFieldHasUnitVarianceAndGaussianCorrelation) {
  const int H = 16, W = 20;
  const double ell = 2.5;
  NoiseModel m;
  m.type = NoiseModel::Type::Correlated;
  m.correlation_length_px = ell;
  const UnitNoiseField field(m, H, W);
  for (auto [dx, dy] : {std::pair{1, 0}, {0, 2}, {3, 0}, {2, 2}, {6, 0}}) {
    const FieldMoments mo = moments(field, H, W, dx, dy, 1500);
    const double expected = std::exp(-(dx * dx + dy * dy) / (2 * ell * ell));
    EXPECT_NEAR(mo.var, 1.0, 0.03);
    EXPECT_NEAR(mo.corr, expected, 0.03) << "lag (" << dx << ", " << dy << ")";
  }
}

TEST(NoiseField, WhiteFieldIsUncorrelated) {
  const UnitNoiseField field(NoiseModel{}, 8, 10);
  const FieldMoments mo = moments(field, 8, 10, 1, 0, 2000);
  EXPECT_NEAR(mo.var, 1.0, 0.02);
  EXPECT_NEAR(mo.corr, 0.0, 0.02);
}

TEST(NoiseField, FourierFieldHasUnitVarianceAndGaussianCorrelationAtAnyLength) {
  const int H = 12, W = 16;
  // Lengths within the grid and far beyond it (where UnitNoiseField refuses).
  for (double ell : {1.5, 4.0, 60.0}) {
    const FourierNoiseField field(ell, H, W);
    for (auto [dx, dy] : {std::pair{1, 0}, {0, 2}, {3, 1}}) {
      const FieldMoments mo = moments(field, H, W, dx, dy, 3000);
      const double expected = std::exp(-(dx * dx + dy * dy) / (2 * ell * ell));
      EXPECT_NEAR(mo.var, 1.0, 0.05) << "length " << ell;
      EXPECT_NEAR(mo.corr, expected, 0.04)
          << "length " << ell << ", lag (" << dx << ", " << dy << ")";
    }
  }
  EXPECT_THROW(FourierNoiseField(0.0, H, W), std::invalid_argument);
}

TEST(NoiseFamily, DrawsEveryComponentWithinItsRangeAndMixesThem) {
  const NoiseModel base;
  const int H = 24, W = 32, draws = 2000;
  int spread = 0, field = 0, affine = 0, outliers = 0, tails = 0, mixtures = 0;
  double min_amp = 1e9, max_amp = 0, min_len = 1e9, max_len = 0;
  for (int d = 0; d < draws; ++d) {
    const NoiseModel m = drawNoiseModel(base, 1000 + d, H, W);
    EXPECT_NO_THROW(m.validate());
    min_amp = std::min(min_amp, m.amplitude);
    max_amp = std::max(max_amp, m.amplitude);
    const int on = (m.edge_scale_spread > 0) + (m.field_px > 0) + (m.affine_px > 0) +
                   (m.outlier_fraction > 0) + (m.student_t_dof > 0);
    spread += m.edge_scale_spread > 0;
    tails += m.student_t_dof > 0;
    affine += m.affine_px > 0;
    mixtures += on >= 2;
    if (m.field_px > 0) {
      ++field;
      EXPECT_TRUE(m.field_fourier);
      EXPECT_GE(m.field_px, 0.02);
      EXPECT_LE(m.field_px, 0.5);
      min_len = std::min(min_len, m.field_length_px);
      max_len = std::max(max_len, m.field_length_px);
    }
    if (m.outlier_fraction > 0) {
      ++outliers;
      EXPECT_LE(m.outlier_fraction, 0.05);
      EXPECT_GE(m.outlier_factor, 5.0);
      EXPECT_LE(m.outlier_factor, 30.0);
    }
    if (m.student_t_dof > 0) {
      EXPECT_GE(m.student_t_dof, 3.0);
    }
  }
  // ¼–4× the claimed σ, lengths from 1 px to 4 times the image, each component at its rate.
  EXPECT_GE(min_amp, 0.25);
  EXPECT_LT(min_amp, 0.27);
  EXPECT_LE(max_amp, 4.0);
  EXPECT_GT(max_amp, 3.7);
  EXPECT_LT(min_len, 1.1);
  EXPECT_GT(max_len, 100.0);
  const auto rate = [&](int count, double p) {
    EXPECT_NEAR(count / double(draws), p, 4 * std::sqrt(p * (1 - p) / draws));
  };
  rate(spread, 0.5);
  rate(field, 0.5);
  rate(affine, 0.5);
  rate(outliers, 1.0 / 3);
  rate(tails, 1.0 / 3);
  EXPECT_GT(mixtures, draws / 2);
  // The same seed, the same model; another seed, another.
  EXPECT_EQ(describe(drawNoiseModel(base, 7, H, W)), describe(drawNoiseModel(base, 7, H, W)));
  EXPECT_NE(describe(drawNoiseModel(base, 7, H, W)), describe(drawNoiseModel(base, 8, H, W)));
  EXPECT_EQ(parseNoiseFamily("open"), NoiseFamily::Open);
  EXPECT_THROW(parseNoiseFamily("closed"), std::invalid_argument);
}

TEST(NoiseField, RejectsInvalidModels) {
  NoiseModel m;
  m.type = NoiseModel::Type::Correlated;
  m.correlation_length_px = 0;
  EXPECT_THROW(m.validate(), std::invalid_argument);
  m.correlation_length_px = 1;
  m.amplitude = -1;
  EXPECT_THROW(m.validate(), std::invalid_argument);
  EXPECT_THROW(parseNoiseType("pink"), std::invalid_argument);
  m.amplitude = 1;
  m.student_t_dof = 2;  // no finite variance
  EXPECT_THROW(m.validate(), std::invalid_argument);
  m.student_t_dof = 0;
  m.edge_scale_spread = -0.1;
  EXPECT_THROW(m.validate(), std::invalid_argument);
}

TEST(Weights, DistributionsHaveTheirClosedFormMoments) {
  std::mt19937_64 rng(3);
  const int n = 40000;
  auto stats = [&](const WeightModel& m) {
    double s = 0, s2 = 0, lo = 1e9, hi = -1e9;
    for (int i = 0; i < n; ++i) {
      const double w = m.sample(rng);
      s += w;
      s2 += w * w;
      lo = std::min(lo, w);
      hi = std::max(hi, w);
    }
    const double mean = s / n;
    return std::array<double, 4>{mean, s2 / n - mean * mean, lo, hi};
  };
  WeightModel beta;
  beta.distribution = WeightModel::Distribution::Beta;
  beta.alpha = 2;
  beta.beta = 5;
  beta.min = 0.1;
  beta.max = 0.9;
  const double r = beta.max - beta.min, a = beta.alpha, b = beta.beta;
  const double mean = beta.min + r * a / (a + b),
               var = r * r * a * b / ((a + b) * (a + b) * (a + b + 1));
  auto st = stats(beta);
  EXPECT_NEAR(st[0], mean, 4 * std::sqrt(var / n));
  EXPECT_NEAR(st[1], var, 0.03 * var);
  EXPECT_GE(st[2], beta.min);
  EXPECT_LE(st[3], beta.max);

  WeightModel uni;  // U[0.2, 1]: mean 0.6, variance 0.8²/12
  st = stats(uni);
  EXPECT_NEAR(st[0], 0.6, 4 * std::sqrt(0.64 / 12 / n));
  EXPECT_NEAR(st[1], 0.64 / 12, 0.03 * 0.64 / 12);
  EXPECT_GE(st[2], 0.2);
  EXPECT_LT(st[3], 1.0);

  WeightModel constant;
  constant.distribution = WeightModel::Distribution::Constant;
  constant.value = 0.7;
  st = stats(constant);
  EXPECT_EQ(st[2], 0.7);
  EXPECT_EQ(st[3], 0.7);

  WeightModel bad;
  bad.min = 0.9;
  bad.max = 0.1;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = WeightModel{};
  bad.zero_fraction = 1.0;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  EXPECT_THROW(parseWeightDistribution("gauss"), std::invalid_argument);
}

TEST(Scene, RayCastingHitsTheNearestBoxFaceOrWall) {
  RoomScene room;  // walls at x -3..6, y -1.5..1.5, z -2..5
  room.boxes.push_back({Eigen::Vector3d(-0.5, -0.5, 2.0), Eigen::Vector3d(0.5, 0.5, 3.0)});
  room.validate();
  const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();    // at the origin, looking along +z
  EXPECT_DOUBLE_EQ(room.inverseDepth(T, 0.0, 0.0), 1.0 / 2.0);  // front face of the box
  EXPECT_DOUBLE_EQ(room.inverseDepth(T, 0.2, 0.0), 1.0 / 2.0);  // x = 0.4 at depth 2: still the box
  EXPECT_DOUBLE_EQ(room.inverseDepth(T, 0.3, 0.0),
                   1.0 / 5.0);  // x = 0.6 at z = 2: misses, far wall
  EXPECT_DOUBLE_EQ(room.inverseDepth(T, 0.0, 1.0), 1.0 / 1.5);  // y = 1.5 at depth 1.5: the ceiling
  EXPECT_FALSE(room.isFree(Eigen::Vector3d(0, 0, 2.5)));
  EXPECT_TRUE(room.isFree(Eigen::Vector3d(0, 0, 1.0)));
  EXPECT_FALSE(room.isFree(Eigen::Vector3d(7, 0, 0)));
  room.boxes.push_back({Eigen::Vector3d(5, 0, 0), Eigen::Vector3d(7, 1, 1)});
  EXPECT_THROW(room.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace dbacov::sim
