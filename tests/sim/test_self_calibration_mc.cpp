// Self-calibration by Monte Carlo (self_calibration.h), the reference being the chi-square
// distribution: a per-edge affine flow error that the confidences do not describe makes the raw
// covariances over-confident (ANEES far above the 95 % region); the default self-calibration,
// from each snapshot's residuals alone, brings the absolute and relative ANEES inside, and the
// shape too: 1σ coverage and the NEES tail within their binomial regions, where one white scale
// per edge (the variance components without the field) leaves the coverage far above nominal.
#include <gtest/gtest.h>

#include <cmath>

#include "dbacov/core/self_calibration.h"
#include "dbacov/core/self_calibration_fit.h"
#include "dbacov/sim/monte_carlo.h"

namespace dbacov::sim {
namespace {

/// The regime of test_monte_carlo.cpp (16×20 grid, weight scale 3000: target sigmas 0.02–0.04
/// px) with every edge's flow off by a random affine field of 0.02 px per coefficient.
ScenarioConfig affineScenario() {
  ScenarioConfig c;
  c.camera.H = 16;
  c.camera.W = 20;
  c.mode = SimulationMode::WholeTrajectory;
  c.trajectory.num_keyframes = 6;
  c.weight_scale = 3000;
  c.noise.affine_px = 0.02;
  c.seed = 21;
  return c;
}

TEST(SelfCalibrationMonteCarlo, DefaultMethodBringsAffineFlowErrorsInsideTheRegion) {
  const Scenario sc(affineScenario());
  const DbaOptions o = sc.config().engineOptions();
  const SelfCalibrationOptions defaults;
  const MonteCarloResult raw = runMonteCarlo(sc, 0, 40, o);
  const MonteCarloResult cal =
      runMonteCarlo(sc, 0, 40, o, PairSelection::Consecutive, {}, &defaults);
  const ConsistencyStats r = summarize(raw.samples.absolute), c = summarize(cal.samples.absolute);
  EXPECT_GT(r.anees, 2 * r.region.upper) << "raw ANEES " << r.anees;
  EXPECT_TRUE(c.inside) << "self-calibrated ANEES " << c.anees << " outside [" << c.region.lower
                        << ", " << c.region.upper << "]";
  const ConsistencyStats cr = summarize(cal.samples.relative);
  EXPECT_TRUE(cr.inside) << "self-calibrated relative ANEES " << cr.anees;
  // The shape: with n samples (runs × keyframes, correlated within a run: the regions are 3σ of
  // the binomial, widened ×1.5 for that), 1σ coverage near 68.3 % (pooled over the six axes:
  // 6n draws, treated as n) and the fraction above χ²(0.95) near 5 %.
  const double n = static_cast<double>(c.samples);
  const double cov_sd = 1.5 * std::sqrt(0.683 * 0.317 / n),
               tail_sd = 1.5 * std::sqrt(0.05 * 0.95 / n);
  EXPECT_NEAR(c.coverage_all[0], 0.683, 3 * cov_sd) << "1-sigma coverage, " << n << " samples";
  EXPECT_NEAR(c.tail_95, 0.05, 3 * tail_sd) << "NEES tail, " << n << " samples";
  // One white scale per edge on the same runs (each edge's weights divided by its q / ρ, no
  // field): coverage far from nominal (one scale per edge cannot make an affine error's few
  // directions and the rest both right). Checked so that the shape test above is not void.
  const CovarianceFunction per_edge_scale = [](const Snapshot& s, const DbaOptions& opt) {
    std::vector<double> scales;
    for (const EdgeCalibration& e : varianceComponents(s, opt).edges)
      scales.push_back(e.vce_scale > 0 && std::isfinite(e.vce_scale) ? e.vce_scale : 1.0);
    return DbaCovariance(inflateWeights(s, scales), opt);
  };
  const MonteCarloResult scaled =
      runMonteCarlo(sc, 0, 40, o, PairSelection::Consecutive, {}, per_edge_scale);
  EXPECT_GT(std::abs(summarize(scaled.samples.absolute).coverage_all[0] - 0.683), 3 * cov_sd);
}

/// The study's "field" source in this regime: a Gaussian random field on each edge's flow
/// (length 3 px, 0.03 px, about the white noise's size here) and white noise 1.5x the claimed.
TEST(SelfCalibrationMonteCarlo, DefaultMethodOnARandomFieldAndWiderWhiteNoiseIsNotOverConfident) {
  ScenarioConfig cfg = affineScenario();
  cfg.noise.affine_px = 0;
  cfg.noise.field_px = 0.03;
  cfg.noise.field_length_px = 3.0;
  cfg.noise.amplitude = 1.5;
  const Scenario sc(cfg);
  const DbaOptions o = sc.config().engineOptions();
  const SelfCalibrationOptions defaults;
  const MonteCarloResult raw = runMonteCarlo(sc, 0, 40, o);
  const MonteCarloResult cal =
      runMonteCarlo(sc, 0, 40, o, PairSelection::Consecutive, {}, &defaults);
  const ConsistencyStats r = summarize(raw.samples.absolute), c = summarize(cal.samples.absolute);
  RecordProperty("raw_anees", std::to_string(r.anees));
  RecordProperty("anees", std::to_string(c.anees));
  RecordProperty("coverage1", std::to_string(c.coverage_all[0]));
  RecordProperty("tail", std::to_string(c.tail_95));
  EXPECT_GT(r.anees, r.region.upper) << "raw ANEES " << r.anees;
  // Held out (the scene was fixed before its first run): raw 250, self-calibrated 4.88 against
  // [4.97, 7.12], relative 4.69: slightly conservative here, 1σ 70.0 %, tail 1.9 %
  // (docs/development/testing.md, *Study*). The bounds: never over-confident, and at most 10 %
  // below the region, so that a change that makes it over-confident or more conservative fails; the
  // shape below (with n = 240 the tail's band reaches below 0: only its upper side can fail).
  for (const ConsistencyStats& x : {c, summarize(cal.samples.relative)}) {
    EXPECT_LE(x.anees, x.region.upper) << "self-calibrated ANEES " << x.anees;
    EXPECT_GE(x.anees, 0.9 * x.region.lower) << "self-calibrated ANEES " << x.anees;
  }
  const double n = static_cast<double>(c.samples);
  const double cov_sd = 1.5 * std::sqrt(0.683 * 0.317 / n),
               tail_sd = 1.5 * std::sqrt(0.05 * 0.95 / n);
  EXPECT_NEAR(c.coverage_all[0], 0.683, 3 * cov_sd) << "1-sigma coverage, " << n << " samples";
  EXPECT_NEAR(c.tail_95, 0.05, 3 * tail_sd) << "NEES tail, " << n << " samples";
}

}  // namespace
}  // namespace dbacov::sim
