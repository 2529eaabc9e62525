// Per-pixel models of the simulator against closed forms: the correlated noise field's variance and
// correlation function, the weight distributions' moments, and the scene's ray casting.
#include <gtest/gtest.h>

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
FieldMoments moments(const UnitNoiseField& field, int H, int W, int dx, int dy, int fields) {
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

TEST(NoiseField, RejectsInvalidModels) {
  NoiseModel m;
  m.type = NoiseModel::Type::Correlated;
  m.correlation_length_px = 0;
  EXPECT_THROW(m.validate(), std::invalid_argument);
  m.correlation_length_px = 1;
  m.amplitude = -1;
  EXPECT_THROW(m.validate(), std::invalid_argument);
  EXPECT_THROW(parseNoiseType("pink"), std::invalid_argument);
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
