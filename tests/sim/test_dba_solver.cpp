// The DBA solver (core/dba_solver.h) against independent references:
//   - its Schur step equals the step of a dense solve of the full (poses + depths) damped normal
//     equations, assembled here row by row from the pixel factors (no Schur complement, no block
//     storage, gauge by an explicit selection matrix whose minimal-gauge direction comes from
//     finite differences of the centre distance), for every gauge and with and without damping;
//   - the state it returns is a stationary point of the DBA cost, checked by central differences
//     of a cost evaluated with the 4×4-matrix residual of dba_factor.h;
//   - it converges to the truth as the target noise vanishes, and holds the gauge.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>

#include "dbacov/core/dba_factor.h"
#include "dbacov/core/dba_solver.h"
#include "dbacov/core/linearization.h"
#include "dbacov/sim/scenario.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "dense_reference.h"
#include "fixtures.h"

namespace dbacov {
namespace {

using testing::gaugeOptions;

sim::SyntheticSnapshotConfig tinyConfig(std::uint64_t seed) {
  return testing::gridConfig(seed, 5, 6, 8);
}

/// The synthetic snapshot with its graph poses and depths moved away from the optimum.
Snapshot perturbed(std::uint64_t seed) {
  Snapshot s = sim::generateSyntheticSnapshot(tinyConfig(seed)).snapshot;
  std::mt19937_64 rng(seed + 100);
  std::normal_distribution<double> n01;
  for (int k = 0; k < s.numKeyframes(); ++k) {
    Vector6d xi;
    for (int q = 0; q < 6; ++q) xi[q] = 0.01 * n01(rng);
    s.setT_wc(k, s.T_wc(k) * expSE3(xi));
  }
  for (float& d : s.disps) d *= static_cast<float>(1.0 + 0.03 * n01(rng));
  return s;
}

struct DenseStep {
  Eigen::VectorXd xi;                        // 6 per slot
  std::map<std::pair<int, int>, double> dd;  // (keyframe, pixel) → δd
  double predicted = 0;
};

/// The damped Gauss-Newton step of the full system, built densely from the pixel factors
/// (tests/common/dense_reference.h).
DenseStep denseStep(const Snapshot& s, const DbaOptions& o, double lambda) {
  const testing::DenseFullSystem sys = testing::denseFullSystem(s, o);
  const Eigen::MatrixXd& P = sys.P;
  Eigen::MatrixXd H_l = sys.H;
  H_l.diagonal() += lambda * sys.H.diagonal();
  const Eigen::VectorXd delta = P * (P.transpose() * H_l * P).ldlt().solve(-P.transpose() * sys.g);
  DenseStep out;
  const int np = sys.numPoseDims();
  out.xi = delta.head(np);
  for (std::size_t v = 0; v < sys.depth_vars.size(); ++v) out.dd[sys.depth_vars[v]] = delta[np + v];
  out.predicted = -sys.g.dot(delta) - 0.5 * delta.dot(sys.H * delta);
  return out;
}

void expectStepMatchesDense(const Snapshot& s, const DbaOptions& o, double lambda) {
  const DbaStep st = computeDbaStep(s, o, lambda);
  const DenseStep ref = denseStep(s, o, lambda);
  ASSERT_EQ(st.xi.size(), ref.xi.size());
  EXPECT_GT(ref.xi.norm(), 1e-4);  // a real step, not a trivial zero
  EXPECT_LT((st.xi - ref.xi).norm(), 1e-7 * ref.xi.norm()) << st.xi.transpose() << "\nvs\n"
                                                           << ref.xi.transpose();
  double ref_norm = 0, diff = 0;
  std::size_t nonzero = 0;
  for (const auto& [key, v] : ref.dd) {
    const double mine =
        st.disp[static_cast<std::size_t>(key.first) * s.pixelsPerFrame() + key.second];
    ref_norm += v * v;
    diff += (mine - v) * (mine - v);
    nonzero += mine != 0;
  }
  EXPECT_EQ(nonzero, ref.dd.size());
  EXPECT_LT(std::sqrt(diff), 1e-7 * std::sqrt(ref_norm));
  EXPECT_NEAR(st.predicted_decrease, ref.predicted, 1e-7 * std::abs(ref.predicted));
}

TEST(DbaSolver, SchurStepEqualsDenseFullSolveForEveryGauge) {
  const Snapshot s = perturbed(1);
  for (double lambda : {0.0, 0.3}) {
    SCOPED_TRACE("lambda " + std::to_string(lambda));
    {
      SCOPED_TRACE("two-pose hard");
      expectStepMatchesDense(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), lambda);
    }
    {
      SCOPED_TRACE("two-pose soft");
      expectStepMatchesDense(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0.02, 0.05), lambda);
    }
    {
      SCOPED_TRACE("two-pose mixed");
      expectStepMatchesDense(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0.05), lambda);
    }
    {
      SCOPED_TRACE("minimal");
      expectStepMatchesDense(s, gaugeOptions(GaugeOptions::Type::Minimal, 0, 0), lambda);
    }
  }
}

/// F = ½ Σ w r² (+ soft priors ½ Σ (e_q/σ_q)², e = Log(T0⁻¹ T)) with the 4×4-matrix residual of
/// dba_factor.h: the reference cost for the stationarity checks.
double referenceCost(const Snapshot& s, const DbaOptions& o,
                     const std::map<int, Eigen::Isometry3d>& prior_mean = {}) {
  const PinholeIntrinsics K = PinholeIntrinsics::fromVector(s.intrinsics);
  const int HW = static_cast<int>(s.pixelsPerFrame());
  double F = 0;
  for (int e = 0; e < s.numEdges(); ++e) {
    const int i = static_cast<int>(s.ii[e]), j = static_cast<int>(s.jj[e]);
    const Eigen::Isometry3d Ti = s.T_wc(i), Tj = s.T_wc(j);
    for (int p = 0; p < HW; ++p) {
      const double d = s.disp(i, p / s.W, p % s.W);
      if (!(d > 0)) continue;
      const Eigen::Vector3d Y =
          (Tj.inverse() * Ti) *
          (Eigen::Vector3d((p % s.W - K.cx) / K.fx, (p / s.W - K.cy) / K.fy, 1) / d);
      if (!keepPixelFactor(o, d, Y.z() * d)) continue;
      const Eigen::Vector2d r = pixelFactorResidual(Ti, Tj, K, p % s.W, p / s.W, d,
                                                    s.targetPlane(e, 0)[p], s.targetPlane(e, 1)[p]);
      for (int c = 0; c < 2; ++c) F += 0.5 * o.weight_scale * s.weightPlane(e, c)[p] * r[c] * r[c];
    }
  }
  for (const auto& [k, T0] : prior_mean) {
    const Vector6d e = logSE3(T0.inverse() * s.T_wc(k));
    for (int q = 0; q < 6; ++q) {
      const double sigma = q < 3 ? o.gauge.sigma_trans : o.gauge.sigma_rot;
      if (sigma > 0) F += 0.5 * e[q] * e[q] / (sigma * sigma);
    }
  }
  return F;
}

/// max over the free pose coordinates of |∂F/∂ξ_q| / sqrt(∂²F/∂ξ_q²) by central differences: the
/// distance to the optimum along one coordinate, in standard deviations. 0 at a stationary point.
double worstPoseStationarity(const Snapshot& s, const DbaOptions& o, const std::vector<int>& fixed,
                             const std::map<int, Eigen::Isometry3d>& prior_mean = {}) {
  const double h = 1e-5, F0 = referenceCost(s, o, prior_mean);
  double worst = 0;
  for (int k : s.graphKeyframes()) {
    if (std::find(fixed.begin(), fixed.end(), k) != fixed.end()) continue;
    for (int q = 0; q < 6; ++q) {
      Snapshot plus = s, minus = s;
      Vector6d dx = Vector6d::Zero();
      dx[q] = h;
      plus.setT_wc(k, s.T_wc(k) * expSE3(dx));
      minus.setT_wc(k, s.T_wc(k) * expSE3(-dx));
      const double Fp = referenceCost(plus, o, prior_mean),
                   Fm = referenceCost(minus, o, prior_mean);
      const double g = (Fp - Fm) / (2 * h), curv = (Fp - 2 * F0 + Fm) / (h * h);
      worst = std::max(worst, std::abs(g) / std::sqrt(std::max(curv, 1e-300)));
    }
  }
  return worst;
}

sim::ScenarioConfig smallScenario(double noise_amplitude) {
  sim::ScenarioConfig c;
  c.camera.H = 12;
  c.camera.W = 16;
  c.mode = sim::SimulationMode::WholeTrajectory;
  c.trajectory.num_keyframes = 5;
  c.weight_scale = 1e4;  // target sigmas 0.01–0.02 px: well-determined depths, a few iterations
  c.noise.amplitude = noise_amplitude;
  c.seed = 7;
  return c;
}

double maxPoseError(const sim::SimulatedSnapshot& sim) {
  double worst = 0;
  for (int k : sim.snapshot.graphKeyframes())
    worst = std::max(worst, logSE3(sim.snapshot.T_wc(k).inverse() * sim.T_wc_true[k]).norm());
  return worst;
}

TEST(DbaSolver, ConvergesToTheTruthAsTheNoiseVanishes) {
  double previous = 0;
  for (double a : {1.0, 0.1, 0.01, 0.0}) {
    SCOPED_TRACE("noise amplitude " + std::to_string(a));
    const sim::Scenario sc(smallScenario(a));
    const sim::SimulatedSnapshot sim = sc.simulate(0, 3);
    EXPECT_TRUE(sim.solver.converged()) << sim.solver.brief();
    EXPECT_LT(sim.solver.final_cost, sim.solver.initial_cost);
    const double err = maxPoseError(sim);
    if (a == 1.0) {
      EXPECT_GT(err, 1e-4);  // the noise moves the optimum away from the truth...
    } else if (a > 0) {
      EXPECT_LT(err, 0.2 * previous);  // ...in proportion to its amplitude...
      EXPECT_GT(err, 0.02 * previous);
    } else {
      EXPECT_LT(err, 1e-5);  // ...and exact targets give the truth (float targets: ~1e-7)
    }
    previous = err;
  }
}

TEST(DbaSolver, ReturnsAStationaryPointOfTheCost) {
  for (auto type : {GaugeOptions::Type::TwoPose, GaugeOptions::Type::Minimal}) {
    sim::ScenarioConfig c = smallScenario(1.0);
    c.gauge.type = type;
    c.solve = false;  // the truth, then the perturbed start and the solve by hand
    const sim::Scenario sc(c);
    Snapshot s = sc.simulate(0, 1).snapshot;
    const DbaOptions o = c.engineOptions();
    const std::vector<int> fixed =
        type == GaugeOptions::Type::TwoPose ? std::vector<int>{0, 1} : std::vector<int>{0};
    // At the truth the noisy targets pull every free pose away (many sigmas of gradient).
    EXPECT_GT(worstPoseStationarity(s, o, fixed), 1.0);
    const Snapshot truth = s;
    for (int k = 2; k < s.numKeyframes(); ++k)
      s.setT_wc(
          k, s.T_wc(k) * expSE3((Vector6d() << 0.01, -0.02, 0.01, 0.01, 0.005, -0.01).finished()));
    const DbaSolverSummary sum = solveDba(s, o);
    EXPECT_TRUE(sum.converged()) << sum.brief();
    EXPECT_LT(worstPoseStationarity(s, o, fixed), 1e-3) << sum.brief();
    // The gauge is held: fixed keyframes bit-identical; minimal: the first two centres' distance.
    EXPECT_EQ(s.poses_cw.row(0), truth.poses_cw.row(0));
    if (type == GaugeOptions::Type::TwoPose) {
      EXPECT_EQ(s.poses_cw.row(1), truth.poses_cw.row(1));
    } else {
      const double D0 = (truth.T_wc(1).translation() - truth.T_wc(0).translation()).norm();
      EXPECT_NEAR((s.T_wc(1).translation() - s.T_wc(0).translation()).norm(), D0, 1e-12 * D0);
      EXPECT_NE(s.poses_cw.row(1), truth.poses_cw.row(1));  // its other 5 DoF moved
    }
  }
}

TEST(DbaSolver, SoftTwoPosePriorIsPartOfTheOptimum) {
  sim::ScenarioConfig c = smallScenario(1.0);
  c.solve = false;
  const sim::Scenario sc(c);
  Snapshot s = sc.simulate(0, 2).snapshot;
  DbaOptions o = c.engineOptions();
  o.gauge.sigma_rot = 1e-4;  // comparable to what the data say about keyframes 0 and 1
  o.gauge.sigma_trans = 1e-4;
  const std::map<int, Eigen::Isometry3d> mean{{0, s.T_wc(0)}, {1, s.T_wc(1)}};
  const DbaSolverSummary sum = solveDba(s, o);
  EXPECT_TRUE(sum.converged()) << sum.brief();
  EXPECT_NE(s.poses_cw.row(0), sc.simulate(0, 2).snapshot.poses_cw.row(0));  // soft: it moved
  EXPECT_LT(worstPoseStationarity(s, o, {}, mean), 1e-3);
  EXPECT_GT(worstPoseStationarity(s, o, {}, {}), 1e-2);  // without the priors it is no optimum
}

TEST(DbaSolver, ReportsMisuseAndUnobservableVariables) {
  Snapshot s = perturbed(2);
  DbaSolverOptions bad;
  bad.max_iterations = 0;
  EXPECT_THROW(solveDba(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), bad),
               std::invalid_argument);
  EXPECT_THROW(computeDbaStep(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), -1.0),
               std::invalid_argument);
  // Keyframe 4 loses every weight: no information, no step (damping cannot help).
  for (int e = 0; e < s.numEdges(); ++e)
    if (s.ii[e] == 4 || s.jj[e] == 4)
      for (int c = 0; c < 2; ++c)
        std::fill_n(const_cast<float*>(s.weightPlane(e, c)), s.pixelsPerFrame(), 0.0f);
  try {
    solveDba(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0));
    FAIL() << "expected NumericalError";
  } catch (const NumericalError& e) {
    EXPECT_EQ(e.keyframes(), std::vector<int>{4}) << e.what();
  }
}

TEST(DbaSolver, StopsAtMaxIterationsAndSaysSo) {
  Snapshot s = perturbed(3);
  DbaSolverOptions so;
  so.max_iterations = 1;
  const DbaSolverSummary sum = solveDba(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), so);
  EXPECT_EQ(sum.iterations, 1);
  EXPECT_EQ(sum.termination, DbaTermination::MaxIterations);
  EXPECT_FALSE(sum.converged());
  EXPECT_NE(sum.brief().find("max iterations"), std::string::npos);
}

TEST(DbaSolver, ReportsEachIterationAndStopsWhenTheReportThrows) {
  Snapshot s = perturbed(3);
  DbaSolverOptions so;
  std::vector<DbaSolverSummary> seen;
  so.on_iteration = [&](const DbaSolverSummary& it) { seen.push_back(it); };
  const DbaSolverSummary sum = solveDba(s, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), so);
  // After every iteration but the last (whose summary the solve returns).
  ASSERT_EQ(static_cast<int>(seen.size()), sum.iterations - 1);
  ASSERT_GE(seen.size(), 2u);
  for (std::size_t k = 0; k < seen.size(); ++k) {
    EXPECT_EQ(seen[k].iterations, static_cast<int>(k) + 1);
    EXPECT_EQ(seen[k].initial_cost, sum.initial_cost);
    EXPECT_LE(seen[k].final_cost, k ? seen[k - 1].final_cost : sum.initial_cost);
  }
  EXPECT_LE(sum.final_cost, seen.back().final_cost);
  // An exception from the report ends the solve (a user's interrupt, a time limit).
  Snapshot t = perturbed(3);
  so.on_iteration = [](const DbaSolverSummary& it) {
    if (it.iterations == 2) throw std::runtime_error("stop at 2");
  };
  EXPECT_THROW(solveDba(t, gaugeOptions(GaugeOptions::Type::TwoPose, 0, 0), so),
               std::runtime_error);
}

}  // namespace
}  // namespace dbacov
