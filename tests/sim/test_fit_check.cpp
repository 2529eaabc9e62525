// The self-calibration's noise-model fit check (SelfCalibrationSummary::checkFit, summary.h): the
// spread of the edges' white scales as a robust log-scale deviation, and the check on simulated
// snapshots whose errors the study's open family showed over-confident (a per-edge scale spread,
// outlier pixels) against white noise as claimed, which it must not flag.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dbacov/core/summary.h"
#include "dbacov/sim/monte_carlo.h"

namespace dbacov::sim {
namespace {

/// The standard normal quantile at p, by bisection on erfc.
double normalQuantile(double p) {
  double lo = -10, hi = 10;
  for (int k = 0; k < 200; ++k) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

TEST(FitCheck, SpreadIsARobustLogScaleDeviation) {
  SelfCalibrationSummary s;
  // Edge factors exp(σ z) at the normal quantiles: the interquartile range over 1.349 is σ.
  const int n = 401;
  for (int k = 0; k < n; ++k)
    s.edge_factor.push_back(std::exp(0.5 * normalQuantile((k + 0.5) / n)));
  s.checkFit();
  EXPECT_NEAR(s.edge_scale_spread, 0.5, 0.01);
  EXPECT_TRUE(s.poor_fit);  // 0.5 > the limit
  // A few edges without redundancy (their factor held at the bounds) hardly move it.
  for (int k = 0; k < 4; ++k) s.edge_factor.push_back(1e9);
  s.checkFit();
  EXPECT_NEAR(s.edge_scale_spread, 0.5, 0.02);
  // Equal scales: no spread; the kurtosis alone decides, strictly above its limit.
  s.edge_factor.assign(50, 2.0);
  s.depth_noise_kurtosis = kPoorFitKurtosis;
  s.checkFit();
  EXPECT_EQ(s.edge_scale_spread, 0.0);
  EXPECT_FALSE(s.poor_fit);
  s.depth_noise_kurtosis = 1.01 * kPoorFitKurtosis;
  s.checkFit();
  EXPECT_TRUE(s.poor_fit);
  // Fewer than four edges: no spread to speak of.
  s.edge_factor = {0.1, 10, 100};
  s.depth_noise_kurtosis = 0;
  s.checkFit();
  EXPECT_EQ(s.edge_scale_spread, 0.0);
  EXPECT_FALSE(s.poor_fit);
}

/// The self-calibration's summary of run `run` of a small whole-trajectory scene under `noise`.
SelfCalibrationSummary calibrated(const NoiseModel& noise, int run) {
  ScenarioConfig c;
  c.camera.H = 16;
  c.camera.W = 20;
  c.mode = SimulationMode::WholeTrajectory;
  c.trajectory.num_keyframes = 6;
  c.weight_scale = 3000;
  c.seed = 21;
  c.noise = noise;
  const Scenario sc(c);
  const SelfCalibrationOptions defaults;
  const SimulatedSnapshot snap = sc.simulate(0, static_cast<std::uint64_t>(run));
  return pipelineCovariance(&defaults)(snap.snapshot, c.engineOptions()).summary().self_calibration;
}

TEST(FitCheck, FlagsPerEdgeScaleSpreadAndOutliersNotWhiteNoiseOrAField) {
  NoiseModel white, spread, outliers, field;
  spread.edge_scale_spread = 0.7;
  outliers.outlier_fraction = 0.03;
  outliers.outlier_factor = 20;
  field.field_px = 0.03;
  field.field_length_px = 3.0;
  for (int run = 0; run < 3; ++run) {
    const SelfCalibrationSummary w = calibrated(white, run), f = calibrated(field, run);
    EXPECT_FALSE(w.poor_fit) << "white, run " << run << ": spread " << w.edge_scale_spread
                             << ", kurtosis " << w.depth_noise_kurtosis;
    EXPECT_FALSE(f.poor_fit) << "field, run " << run << ": spread " << f.edge_scale_spread
                             << ", kurtosis " << f.depth_noise_kurtosis;
    const SelfCalibrationSummary s = calibrated(spread, run);
    EXPECT_TRUE(s.poor_fit) << "spread, run " << run << ": " << s.edge_scale_spread;
    EXPECT_GT(s.edge_scale_spread, kPoorFitScaleSpread);
    const SelfCalibrationSummary o = calibrated(outliers, run);
    EXPECT_TRUE(o.poor_fit) << "outliers, run " << run << ": kurtosis " << o.depth_noise_kurtosis;
    EXPECT_GT(o.depth_noise_kurtosis, kPoorFitKurtosis);
  }
}

}  // namespace
}  // namespace dbacov::sim
