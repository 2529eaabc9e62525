// The DROID-SLAM modes beyond monocular DBA (docs/conventions.md §2, §4): the RGB-D depth-sensor
// factor, the stereo factor of ii == jj edges with a fixed rig transform, and the `droid` gauge
// (DROID's fixed poses below t0). Each against the dense reference of the full (poses + depths)
// information matrix, and their gradients against finite differences of the cost.
#include <gtest/gtest.h>

#include "dbacov/core/covariance.h"
#include "dbacov/core/linearization.h"
#include "dbacov/sim/sensor_modes.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "dense_reference.h"
#include "fixtures.h"

namespace dbacov {
namespace {

using testing::gaugeOptions;

double relErr(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / std::max(b.norm(), 1e-300);
}

Snapshot baseSnapshot(std::uint64_t seed, int keyframes = 5) {
  return sim::generateSyntheticSnapshot(testing::gridConfig(seed, keyframes, 6, 8)).snapshot;
}

Snapshot stereoSnapshot(std::uint64_t seed) {
  Snapshot s = baseSnapshot(seed);
  sim::StereoConfig c;
  c.seed = seed;
  sim::addStereoEdges(s, c);
  s.validate();
  return s;
}

Snapshot rgbdSnapshot(std::uint64_t seed) {
  Snapshot s = baseSnapshot(seed);
  sim::RgbdConfig c;
  c.seed = seed;
  sim::addSensorDepth(s, c);
  s.validate();
  return s;
}

DbaOptions withAlpha(DbaOptions o, double alpha) {
  o.sensor_depth_weight = alpha;
  return o;
}

void expectMatchesDense(const Snapshot& s, const DbaOptions& o, double tol) {
  const testing::DenseReference ref = testing::denseReference(s, o);
  for (SolverKind kind : {SolverKind::Sparse, SolverKind::Dense}) {
    SCOPED_TRACE(kind == SolverKind::Sparse ? "sparse solver" : "dense solver");
    CovarianceOptions so;
    so.kind = kind;
    so.depth_variances = true;
    const DbaCovariance cov(s, o, so);
    ASSERT_EQ(cov.keyframes(), ref.keyframes);
    int compared = 0;
    for (int a : cov.keyframes()) {
      const Matrix6d R = ref.marginal(a);
      if (R.norm() == 0) {
        EXPECT_EQ(cov.marginal(a).norm(), 0.0) << "keyframe " << a;
        continue;
      }
      ++compared;
      EXPECT_LT(relErr(cov.marginal(a), R), tol) << "keyframe " << a;
      for (int b : cov.keyframes())
        EXPECT_LT((cov.joint(a, b).topRightCorner<6, 6>() - ref.cross(a, b)).norm(), tol * R.norm())
            << "pair " << a << "," << b;
    }
    EXPECT_GT(compared, 0);
    // Per-pixel inverse-depth sigma against the dense depth variances.
    for (std::size_t v = 0; v < ref.depth_vars.size(); ++v) {
      const auto [k, p] = ref.depth_vars[v];
      const double dense = std::sqrt(ref.Sigma_full(ref.numPoseDims() + v, ref.numPoseDims() + v));
      const double got = cov.inverseDepthSigma(k)[p];
      ASSERT_TRUE(std::isfinite(got)) << "keyframe " << k << " pixel " << p;
      EXPECT_NEAR(got, dense, 1e-5 * dense) << "keyframe " << k << " pixel " << p;
    }
  }
}

TEST(DroidModes, StereoMatchesDenseReference) {
  for (std::uint64_t seed : {1, 2}) {
    const Snapshot s = stereoSnapshot(seed);
    expectMatchesDense(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), 1e-8);
    expectMatchesDense(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0.02, 0.05), 1e-8);
  }
}

TEST(DroidModes, RgbdMatchesDenseReference) {
  const Snapshot s = rgbdSnapshot(3);
  expectMatchesDense(s, withAlpha(gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), 400.0), 1e-8);
  expectMatchesDense(s, withAlpha(gaugeOptions(GaugeOptions::Type::Minimal, 0, 0), 0.05), 1e-8);
}

TEST(DroidModes, DroidGaugeHoldsThePosesBelowT0) {
  Snapshot s = stereoSnapshot(4);
  s.t0 = 2;  // DROID optimized poses 2.. in that update: 0 and 1 held
  DbaOptions o = gaugeOptions(GaugeOptions::Type::Droid, 0, 0);
  expectMatchesDense(s, o, 1e-8);
  const DbaCovariance cov(s, o);
  EXPECT_EQ(cov.gaugeKeyframes(), (std::vector<int>{0, 1}));
  EXPECT_EQ(cov.marginal(0).norm(), 0.0);
  EXPECT_EQ(cov.marginal(1).norm(), 0.0);
  EXPECT_EQ(cov.freeDof(2), 6);
  Snapshot no_t0 = s;
  no_t0.t0.reset();
  EXPECT_THROW(DbaCovariance(no_t0, o), InputError);
}

TEST(DroidModes, StereoAndRgbdFixTheScaleMonocularCannot) {
  // DROID's gauge with t0 = 1 holds only keyframe 0: 6 DoF. Monocular DBA keeps its scale free
  // (singular), stereo and RGB-D determine it.
  DbaOptions o = gaugeOptions(GaugeOptions::Type::Droid, 0, 0);
  Snapshot mono = baseSnapshot(5);
  mono.t0 = 1;
  EXPECT_THROW(DbaCovariance(mono, o), NumericalError);
  Snapshot stereo = stereoSnapshot(5), rgbd = rgbdSnapshot(5);
  stereo.t0 = rgbd.t0 = 1;
  expectMatchesDense(stereo, o, 1e-7);
  expectMatchesDense(rgbd, withAlpha(o, 400.0), 1e-7);
}

TEST(DroidModes, SensorAndStereoGradientsMatchFiniteDifferencesOfTheCost) {
  // g_d = Σ J_dᵀΛr is half the derivative of the cost χ² = Σ rᵀΛr with respect to the inverse
  // depth (r = target − π for the stereo factor, d_sens − d for the sensor factor); h_d is its
  // Gauss–Newton curvature. Checked through the eliminated depth terms of linearizeDba.
  Snapshot s = stereoSnapshot(6);
  sim::RgbdConfig rc;
  sim::addSensorDepth(s, rc);
  const DbaOptions o = withAlpha(gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), 400.0);
  const DbaNormalEquations ne = linearizeDba(s, o, true);
  int checked = 0;
  for (const DepthTerms& dt : ne.depths) {
    const int k = ne.keyframes[dt.source_slot];
    for (std::size_t c = 0; c < dt.pixel.size(); c += 7) {
      const std::size_t at = static_cast<std::size_t>(k) * s.pixelsPerFrame() + dt.pixel[c];
      const double step = 1e-3 * s.disps[at];
      auto chi2 = [&](double delta) {
        Snapshot t = s;
        t.disps[at] = static_cast<float>(s.disps[at] + delta);
        return linearizeDba(t, o).stats.chi2;
      };
      const double d_plus = static_cast<float>(s.disps[at] + step) - s.disps[at];
      const double d_minus = static_cast<float>(s.disps[at] - step) - s.disps[at];
      const double fd = (chi2(d_plus) - chi2(d_minus)) / (d_plus - d_minus);
      EXPECT_NEAR(2 * dt.g[c], fd, 2e-3 * std::abs(fd) + 1e-6) << "keyframe " << k;
      ++checked;
    }
  }
  EXPECT_GT(checked, 20);
}

TEST(DroidModes, SensorFactorAddsAlphaToTheDepthDiagonal) {
  Snapshot s = rgbdSnapshot(7);
  const DbaOptions off = withAlpha(gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), 0.0);
  const DbaOptions on = withAlpha(off, 0.05);  // DROID's α
  const DbaNormalEquations a = linearizeDba(s, off, true), b = linearizeDba(s, on, true);
  ASSERT_EQ(a.depths.size(), b.depths.size());
  int with_reading = 0;
  for (std::size_t q = 0; q < a.depths.size(); ++q) {
    const int k = a.keyframes[a.depths[q].source_slot];
    for (std::size_t c = 0; c < a.depths[q].pixel.size(); ++c) {
      const int p = a.depths[q].pixel[c];
      const auto it = std::lower_bound(b.depths[q].pixel.begin(), b.depths[q].pixel.end(), p);
      ASSERT_TRUE(it != b.depths[q].pixel.end() && *it == p);
      const std::size_t cb = it - b.depths[q].pixel.begin();
      const std::size_t at = static_cast<std::size_t>(k) * s.pixelsPerFrame() + p;
      const double ds = (*s.disps_sens)[at], d = s.disps[at];
      const double dh = ds > 0 ? 0.05 : 0.0;
      with_reading += ds > 0;
      EXPECT_NEAR(b.depths[q].h[cb], a.depths[q].h[c] + dh, 1e-12 * b.depths[q].h[cb]);
      EXPECT_NEAR(b.depths[q].g[cb], a.depths[q].g[c] + (ds > 0 ? 0.05 * (d - ds) : 0.0), 1e-12);
    }
  }
  EXPECT_GT(with_reading, 50);
  // Without a rig transform an ii == jj edge is invalid input.
  Snapshot bad = stereoSnapshot(8);
  bad.stereo_rig.reset();
  EXPECT_THROW(bad.validate(), InputError);
}

}  // namespace
}  // namespace dbacov
