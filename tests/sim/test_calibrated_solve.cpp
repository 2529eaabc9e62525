// The DBA solved at the calibrated weights of its depth-only factors (calibrated_solve.h): a
// state solved with the sensor depths or stereo edges claimed more precise than they are is
// biased (the translation shrinks), and re-weighting them at their calibrated variance ratio to
// the flow removes the bias. By Monte Carlo against the truth, on runs nothing was tuned on.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "dbacov/core/calibrated_solve.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/errors.h"
#include "dbacov/core/self_calibration.h"
#include "dbacov/core/self_calibration_fit.h"
#include "dbacov/sim/consistency.h"
#include "dbacov/sim/monte_carlo.h"
#include "dbacov/sim/scenario.h"

namespace dbacov::sim {
namespace {

/// The self-calibration tests' DROID-mode scene: 6 keyframes, 24 × 32, weight scale 100, one
/// held pose (metric scale).
ScenarioConfig droidScene(SensorMode mode) {
  ScenarioConfig c;
  c.camera.H = 24;
  c.camera.W = 32;
  c.trajectory.num_keyframes = 6;
  c.mode = SimulationMode::WholeTrajectory;
  c.weight_scale = 100.0;
  c.seed = 23;
  c.sensor.mode = mode;
  c.gauge.type = GaugeOptions::Type::Droid;
  return c;
}

/// Σ_k <t_k − t_0, t̂_k − t̂_0> / Σ_k |t_k − t_0|²: the estimate's translation scale against the
/// truth's (1 = unbiased in scale).
double translationScale(const Snapshot& s, const std::vector<Eigen::Isometry3d>& truth) {
  double num = 0, den = 0;
  for (int k = 1; k < s.numKeyframes(); ++k) {
    const Eigen::Vector3d t = truth[k].translation() - truth[0].translation();
    num += t.dot(s.T_wc(k).translation() - s.T_wc(0).translation());
    den += t.squaredNorm();
  }
  return num / den;
}

/// The stereo edges' confidences claimed k× their information.
void overWeightStereoEdges(Snapshot& s, double k) {
  for (int e = 0; e < s.numEdges(); ++e)
    if (s.ii[e] == s.jj[e]) divideEdgeWeights(s, e, 1.0 / k);
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

struct Outcome {
  ConsistencyStats claimed_raw, calibrated;        ///< solved at the claimed / calibrated weights
  double claimed_scale = 0, calibrated_scale = 0;  ///< mean translation scale over the runs
  std::vector<double> factors;  ///< the readings' α factor, or the stereo edges' factors
  int unsettled = 0, max_solves = 0;
};

/// Runs `runs` draws from `first`: each snapshot solved at the claimed options (`claim` edits
/// the snapshot's weights first), raw covariances; and solved at the calibrated weights, default
/// self-calibration.
template <class Claim>
Outcome monteCarlo(const Scenario& sc, const DbaOptions& o, std::uint64_t first, int runs,
                   Claim claim) {
  Outcome out;
  EvaluationSamples raw, cal;
  const SelfCalibrationOptions def;
  for (int r = 0; r < runs; ++r) {
    SimulatedSnapshot a = sc.simulate(0, first + r);
    claim(a.snapshot);
    SimulatedSnapshot b = a;
    EXPECT_TRUE(solveDba(a.snapshot, o).converged());
    raw.append(evaluateSnapshot(a, o, r));
    out.claimed_scale += translationScale(a.snapshot, a.T_wc_true) / runs;
    const CalibratedSolve c = solveDbaAtCalibratedWeights(b.snapshot, o);
    EXPECT_TRUE(c.solver.converged());
    cal.append(evaluateSnapshot(b, c.options, r, PairSelection::Consecutive, &def));
    out.calibrated_scale += translationScale(b.snapshot, b.T_wc_true) / runs;
    out.unsettled += !c.settled;
    out.max_solves = std::max(out.max_solves, c.solves);
    if (b.snapshot.disps_sens) out.factors.push_back(c.sensor_depth_factor);
    for (int e = 0; e < b.snapshot.numEdges(); ++e) {
      if (b.snapshot.ii[e] == b.snapshot.jj[e])
        out.factors.push_back(c.edge_factors[e]);
      else
        EXPECT_EQ(c.edge_factors[e], 1.0) << "flow edge " << e << " re-weighted";
    }
  }
  out.claimed_raw = summarize(raw.absolute);
  out.calibrated = summarize(cal.absolute);
  std::printf(
      "claimed weights: raw ANEES %.2f, translation scale %.4f; calibrated weights: "
      "self-calibrated ANEES %.2f [%.2f, %.2f], 1 sigma %.3f, tail %.3f, translation scale "
      "%.4f, factor median %.3f, at most %d solves\n",
      out.claimed_raw.anees, out.claimed_scale, out.calibrated.anees, out.calibrated.region.lower,
      out.calibrated.region.upper, out.calibrated.coverage_all[0], out.calibrated.tail_95,
      out.calibrated_scale, median(out.factors), out.max_solves);
  return out;
}

/// At the claimed weights the scene shows the bias (ANEES above 3× the region, the translation
/// shrunk); at the calibrated ones it is gone: inside the region, scale 1 ± 0.02, the factors
/// 4 ± `tolerance` (the truth), every snapshot settled.
void expectBiasShownAndRemoved(const Outcome& m, double tolerance, const char* factors) {
  EXPECT_GT(m.claimed_raw.anees, 3 * m.claimed_raw.region.upper) << "the scene shows no bias";
  EXPECT_LT(m.claimed_scale, 0.95);
  EXPECT_TRUE(m.calibrated.inside)
      << m.calibrated.anees << " outside [" << m.calibrated.region.lower << ", "
      << m.calibrated.region.upper << "]";
  EXPECT_NEAR(m.calibrated_scale, 1.0, 0.02);
  EXPECT_NEAR(median(m.factors), 4.0, tolerance) << factors;
  EXPECT_EQ(m.unsettled, 0);
}

/// RGB-D readings whose α is claimed 4× their information: solved at that α every run's
/// translation shrinks (0.87–0.91 of the truth on runs 700–709; 0.900 and ANEES 99 over runs
/// 740–759) and the ANEES is ~100; at the
/// calibrated α the bias is gone and the default self-calibration is inside its region. (Before
/// this solve, `--converge` solved at the claimed α: the first row.)
TEST(CalibratedSolve, OverWeightedSensorDepthsBiasTheSolveAndReweightingRemovesIt) {
  const ScenarioConfig cfg = droidScene(SensorMode::Rgbd);
  const Scenario sc(cfg);
  DbaOptions o = cfg.engineOptions();
  o.sensor_depth_weight *= 4.0;
  const Outcome m = monteCarlo(sc, o, 740, 20, [](Snapshot&) {});
  expectBiasShownAndRemoved(m, 0.5, "the readings' α factor (truth: 4)");
}

/// Stereo edges whose confidences claim 4× their information (weights × 4), flow as claimed:
/// the same bias through the stereo depths (runs 740–759: raw ANEES 128, translation scale
/// 0.889), removed by re-weighting each stereo edge (6.32, 1.003).
TEST(CalibratedSolve, OverWeightedStereoEdgesBiasTheSolveAndReweightingRemovesThem) {
  const ScenarioConfig cfg = droidScene(SensorMode::Stereo);
  const Scenario sc(cfg);
  const DbaOptions o = cfg.engineOptions();
  const Outcome m = monteCarlo(sc, o, 740, 20, [](Snapshot& s) { overWeightStereoEdges(s, 4.0); });
  expectBiasShownAndRemoved(m, 0.6, "the stereo edges' factors (truth: 4)");
}

/// The ratios are against the flow edges' own pooled scale: with the stereo edges in the pool
/// (SelfCalibration::global_scale) every step fell short by their share of the redundancy (stereo
/// × 4 took 5 solves, × 1e6 did not settle in 6).
TEST(CalibratedSolve, RatiosAreAgainstTheFlowEdgesAlone) {
  const ScenarioConfig cfg = droidScene(SensorMode::Stereo);
  const Scenario sc(cfg);
  const DbaOptions o = cfg.engineOptions();
  Snapshot s = sc.simulate(0, 11).snapshot;
  overWeightStereoEdges(s, 4.0);
  const SelfCalibration cal = varianceComponents(s, o);
  double q = 0, red = 0;
  int stereo = 0;
  for (const EdgeCalibration& e : cal.edges) {
    if (e.i == e.j) {
      ++stereo;
      continue;
    }
    q += e.vce_scale * e.redundancy;
    red += e.redundancy;
  }
  ASSERT_GT(stereo, 0);
  const DepthOnlyRatios r = depthOnlyRatios(cal, s.numEdges());
  EXPECT_NEAR(r.flow_scale, q / red, 1e-12 * q / red);
  EXPECT_GT(cal.global_scale, 1.2 * r.flow_scale) << "the stereo edges are not in the global pool";
  EXPECT_EQ(r.sensor, 1.0);
  EXPECT_FALSE(r.readings_unmeasured);
  EXPECT_TRUE(r.unmeasured_edges.empty());
  for (const EdgeCalibration& e : cal.edges)
    EXPECT_DOUBLE_EQ(r.edge[e.edge], e.i == e.j ? e.vce_scale / r.flow_scale : 1.0);
  EXPECT_GT(r.stereoMedian(), 3.0);
  EXPECT_LT(r.stereoMedian(), 5.5);
}

/// A component with rows but no redundancy fits its measurements exactly: its factor cannot be
/// measured, and it is listed as such (not taken as 1).
TEST(CalibratedSolve, ComponentsWithoutRedundancyAreUnmeasured) {
  SelfCalibration cal;
  cal.edges.resize(3);
  for (int e = 0; e < 3; ++e) {
    cal.edges[e].edge = e;
    cal.edges[e].i = e == 2 ? 1 : 0;
    cal.edges[e].j = 1;
    cal.edges[e].rows = 100;
    cal.edges[e].redundancy = e == 2 ? 0.2 : 80;
    cal.edges[e].vce_scale = e == 2 ? 1.0 : 2.0;
  }
  cal.sensor_depth_rows = 50;
  cal.sensor_depth_redundancy = 0.1;
  const DepthOnlyRatios r = depthOnlyRatios(cal, 3);
  EXPECT_DOUBLE_EQ(r.flow_scale, 2.0);
  EXPECT_TRUE(r.readings_unmeasured);
  EXPECT_EQ(r.sensor, 1.0);
  ASSERT_EQ(r.unmeasured_edges.size(), 1u);
  EXPECT_EQ(r.unmeasured_edges[0], 2);
  EXPECT_EQ(r.stereoMedian(), 1.0);
  cal.sensor_depth_redundancy = 40;
  cal.sensor_depth_scale = 8.0;
  EXPECT_DOUBLE_EQ(depthOnlyRatios(cal, 3).sensor, 4.0);
}

/// Readings claimed 25 000× their information, and 1e-11 of it: one pass saturates (it measures ≈ 5
/// whatever the true factor); the secant's doubling reaches the factor in a few solves. Capped at 2
/// solves the run says it did not settle, with the ratio left.
TEST(CalibratedSolve, GrosslyOverWeightedReadingsSettleAndACappedRunSaysItDidNot) {
  const ScenarioConfig cfg = droidScene(SensorMode::Rgbd);
  const Scenario sc(cfg);
  const DbaOptions o = cfg.engineOptions();
  DbaOptions claimed = o;
  claimed.sensor_depth_weight *= 25000.0;
  Snapshot s = sc.simulate(0, 23).snapshot, capped = s;
  const CalibratedSolve c = solveDbaAtCalibratedWeights(s, claimed);
  EXPECT_TRUE(c.settled) << c.solves << " solves, " << c.last_ratio << "x left";
  EXPECT_TRUE(c.solver.converged());
  EXPECT_NEAR(c.sensor_depth_factor / 25000.0, 1.0, 0.15);
  EXPECT_NEAR(c.options.sensor_depth_weight, claimed.sensor_depth_weight / c.sensor_depth_factor,
              1e-9 * c.options.sensor_depth_weight);
  EXPECT_LE(c.last_ratio, 1.02);

  // 1e11× under-weighted: the ratio pass is not clamped (clamped at 1e-9 it read as a
  // measurement and the secant overshot 10×, then settled in 6).
  DbaOptions low = o;
  low.sensor_depth_weight *= 1e-11;
  Snapshot u = sc.simulate(0, 23).snapshot;
  const CalibratedSolve l = solveDbaAtCalibratedWeights(u, low);
  EXPECT_TRUE(l.settled) << l.solves << " solves, " << l.last_ratio << "x left";
  EXPECT_LE(l.solves, 4);
  EXPECT_NEAR(l.sensor_depth_factor / 1e-11, 1.0, 0.15);

  DbaOptions four = o;
  four.sensor_depth_weight *= 4.0;
  const CalibratedSolve d = solveDbaAtCalibratedWeights(capped, four, 2);
  EXPECT_FALSE(d.settled);
  EXPECT_EQ(d.solves, 2);
  EXPECT_GT(d.last_ratio, 1.02);
  EXPECT_TRUE(d.solver.converged());
  EXPECT_GT(d.sensor_depth_factor, 2.0) << "the step goes the right way";
}

/// A re-solve that does not converge (here: 3 iterations allowed, the state already at the
/// claimed weights' optimum so the first solve converges) leaves the last converged state, its
/// α, its stereo weights and its solver summary, not the unconverged one. RGB-D (α claimed × 4)
/// and stereo (the stereo edges' weights × 4).
TEST(CalibratedSolve, AFailedReSolveKeepsTheLastConvergedState) {
  for (const SensorMode mode : {SensorMode::Rgbd, SensorMode::Stereo}) {
    SCOPED_TRACE(mode == SensorMode::Rgbd ? "rgbd" : "stereo");
    const ScenarioConfig cfg = droidScene(mode);
    const Scenario sc(cfg);
    DbaOptions claimed = cfg.engineOptions();
    Snapshot s = sc.simulate(0, 23).snapshot;
    if (mode == SensorMode::Rgbd) claimed.sensor_depth_weight *= 4.0;
    overWeightStereoEdges(s, 4.0);
    ASSERT_TRUE(solveDba(s, claimed).converged());
    const Snapshot at_claimed = s;
    DbaSolverOptions few;
    few.max_iterations = 3;
    const CalibratedSolve c = solveDbaAtCalibratedWeights(s, claimed, 8, 0.02, few);
    ASSERT_TRUE(c.failed_solve.has_value()) << "the re-solve converged in 3 iterations: no test";
    EXPECT_FALSE(c.failed_solve->converged());
    EXPECT_FALSE(c.settled);
    EXPECT_EQ(c.solves, 2);
    EXPECT_TRUE(c.solver.converged());
    EXPECT_EQ(c.options.sensor_depth_weight, claimed.sensor_depth_weight);
    EXPECT_EQ(c.sensor_depth_factor, 1.0);
    for (double f : c.edge_factors) EXPECT_EQ(f, 1.0);
    EXPECT_GT(c.last_ratio, 1.5);
    // The first solve started at its optimum: the state is that optimum (to its last step).
    for (int k = 0; k < s.numKeyframes(); ++k)
      EXPECT_LT((s.T_wc(k).translation() - at_claimed.T_wc(k).translation()).norm(), 1e-6) << k;
    EXPECT_TRUE(s.weight == at_claimed.weight) << "the stereo weights were not restored";
  }
}

/// Monocular: nothing to re-weight, one solve, the state solveDba's to the bit.
TEST(CalibratedSolve, MonocularIsOneSolveAtTheClaimedWeights) {
  ScenarioConfig cfg = droidScene(SensorMode::Mono);
  cfg.gauge.type = GaugeOptions::Type::TwoPose;
  const Scenario sc(cfg);
  const DbaOptions o = cfg.engineOptions();
  Snapshot a = sc.simulate(0, 1).snapshot, b = a;
  const std::vector<float> weights = a.weight;
  const DbaSolverSummary plain = solveDba(a, o);
  const CalibratedSolve c = solveDbaAtCalibratedWeights(b, o);
  EXPECT_EQ(c.solves, 1);
  EXPECT_TRUE(c.settled);
  EXPECT_EQ(c.sensor_depth_factor, 1.0);
  EXPECT_EQ(c.options.sensor_depth_weight, o.sensor_depth_weight);
  EXPECT_EQ(c.solver.iterations, plain.iterations);
  EXPECT_TRUE(a.poses_cw == b.poses_cw);
  EXPECT_TRUE(a.disps == b.disps);
  EXPECT_TRUE(b.weight == weights);
  for (double f : c.edge_factors) EXPECT_EQ(f, 1.0);
  EXPECT_THROW(solveDbaAtCalibratedWeights(b, o, 0), std::invalid_argument);
  EXPECT_THROW(solveDbaAtCalibratedWeights(b, o, 6, 0.0), std::invalid_argument);
  EXPECT_THROW(solveDbaAtCalibratedWeights(b, o, 6, 1.0), std::invalid_argument);
}

/// DROID's one-pose gauge on RGB-D leaves the scale to the sensor readings: with their weight
/// claimed 1e-30 of what it is the scale is unobservable. The self-calibration must say so as the
/// plain covariance does (it said only "not positive definite (self-calibration)"): the keyframe
/// where S breaks down, and the likely cause.
TEST(CalibratedSolve, AScaleLeftToNegligibleSensorDepthsIsANamedNumericalError) {
  const ScenarioConfig cfg = droidScene(SensorMode::Rgbd);
  const Scenario sc(cfg);
  DbaOptions o = cfg.engineOptions();
  o.sensor_depth_weight *= 1e-30;
  const Snapshot s = sc.simulate(0, 23).snapshot;
  try {
    (void)selfCalibrate(s, o, SelfCalibrationOptions{});
    ADD_FAILURE() << "expected a NumericalError";
  } catch (const NumericalError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("the reduced information matrix S is not positive definite in the "
                         "self-calibration (breakdown at keyframe ",
                         0),
              0u)
        << what;
    EXPECT_NE(what.find("a scale fixed only by sensor depths whose weight is negligible"),
              std::string::npos)
        << what;
    ASSERT_EQ(e.keyframes().size(), 1u);
    EXPECT_GT(e.keyframes()[0], 0) << "keyframe 0 is held by the gauge";
    // The same keyframe as the plain covariance's own dense factorization names (both find the
    // first bad pivot of the same reduced S).
    CovarianceOptions dense;
    dense.kind = SolverKind::Dense;
    try {
      (void)DbaCovariance(s, o, dense);
      ADD_FAILURE() << "the plain covariance factorized the same S";
    } catch (const NumericalError& plain) {
      EXPECT_EQ(plain.keyframes(), e.keyframes()) << plain.what();
    }
  }
  // The Monte Carlo evaluation (dba-evaluate) names the snapshot the error is of, once.
  const SelfCalibrationOptions def;
  const SimulatedSnapshot sim = sc.simulate(0, 23);
  try {
    (void)evaluateSnapshot(sim, o, 0, PairSelection::Consecutive, &def);
    ADD_FAILURE() << "expected a NumericalError";
  } catch (const NumericalError& e) {
    const std::string what = e.what(), name = sim.snapshot.source + " (snapshot ";
    EXPECT_EQ(what.rfind(name, 0), 0u) << what;
    EXPECT_EQ(what.find(sim.snapshot.source, name.size()), std::string::npos) << what;
    EXPECT_NE(what.find("not positive definite in the self-calibration"), std::string::npos)
        << what;
  }
}

}  // namespace
}  // namespace dbacov::sim
