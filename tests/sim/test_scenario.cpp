// The simulated scenarios (sim/scenario.h): the noise their targets carry against the variance the
// confidences claim, visibility, the sliding-window structure and gauge, reproducibility, and the
// JSON configurations (sim/scenario_json.h, share/sim/*.json).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>

#include "dbacov/core/errors.h"
#include "dbacov/sim/scenario.h"
#include "dbacov/sim/scenario_json.h"
#include "temp_dir.h"

namespace dbacov::sim {
namespace {

ScenarioConfig tinyWhole(int keyframes = 4) {
  ScenarioConfig c;
  c.camera.H = 12;
  c.camera.W = 16;
  c.mode = SimulationMode::WholeTrajectory;
  c.trajectory.num_keyframes = keyframes;
  c.solve = false;
  return c;
}

/// A small sliding-window scenario (12×16 grid, DROID's window of 8 unless changed).
ScenarioConfig tinySliding(int keyframes, double weight_scale) {
  ScenarioConfig c;
  c.camera.H = 12;
  c.camera.W = 16;
  c.trajectory.num_keyframes = keyframes;
  c.weight_scale = weight_scale;
  return c;
}

/// Normalized target errors z = (target − true projection) · sqrt(weight_scale · w) of every
/// weighted pixel, per edge in raster order (NaN-free), with the true projection computed from the
/// scene's ray-cast point in world coordinates.
std::vector<std::vector<std::pair<int, double>>> normalizedErrors(const Scenario& sc,
                                                                  const SimulatedSnapshot& sim,
                                                                  int axis) {
  const Snapshot& s = sim.snapshot;
  const PinholeIntrinsics K = sc.config().camera.intrinsics();
  std::vector<std::vector<std::pair<int, double>>> out;
  for (int e = 0; e < s.numEdges(); ++e) {
    const int i = static_cast<int>(s.ii[e]), j = static_cast<int>(s.jj[e]);
    std::vector<std::pair<int, double>> z;
    for (int p = 0; p < static_cast<int>(s.pixelsPerFrame()); ++p) {
      const double w = s.weightPlane(e, axis)[p];
      if (w == 0) continue;
      const double xn = (p % s.W - K.cx) / K.fx, yn = (p / s.W - K.cy) / K.fy;
      const Eigen::Vector3d X =
          sim.T_wc_true[i] *
          (Eigen::Vector3d(xn, yn, 1) / sc.config().scene.inverseDepth(sim.T_wc_true[i], xn, yn));
      const Eigen::Vector3d Xj = sim.T_wc_true[j].inverse() * X;
      const double proj = axis == 0 ? K.fx * Xj.x() / Xj.z() + K.cx : K.fy * Xj.y() / Xj.z() + K.cy;
      z.emplace_back(p,
                     (s.targetPlane(e, axis)[p] - proj) * std::sqrt(sc.config().weight_scale * w));
    }
    out.push_back(std::move(z));
  }
  return out;
}

TEST(Scenario, WhiteTargetsCarryTheVarianceTheConfidencesClaim) {
  for (double amplitude : {1.0, 2.0}) {
    ScenarioConfig c = tinyWhole();
    c.weight_scale = 25;  // σ = 0.2–0.45 px, well above the float rounding of the targets
    c.noise.amplitude = amplitude;
    const Scenario sc(c);
    double s1 = 0, s2 = 0, lag = 0;
    std::size_t n = 0, nl = 0;
    for (std::uint64_t run = 0; run < 3; ++run)
      for (int axis = 0; axis < 2; ++axis)
        for (const auto& edge : normalizedErrors(sc, sc.simulate(0, run), axis))
          for (std::size_t q = 0; q < edge.size(); ++q) {
            s1 += edge[q].second;
            s2 += edge[q].second * edge[q].second;
            ++n;
            if (q + 1 < edge.size() && edge[q + 1].first == edge[q].first + 1) {
              lag += edge[q].second * edge[q + 1].second;
              ++nl;
            }
          }
    const double var = amplitude * amplitude;
    EXPECT_NEAR(s1 / n, 0.0, 4 * std::sqrt(var / n));
    EXPECT_NEAR(s2 / n, var, 4 * var * std::sqrt(2.0 / n)) << n << " samples";
    EXPECT_NEAR(lag / nl / var, 0.0, 4 / std::sqrt(double(nl)));
  }
}

TEST(Scenario, CorrelatedTargetsKeepTheMarginalAndCorrelateNeighbours) {
  ScenarioConfig c = tinyWhole();
  c.weight_scale = 25;
  c.noise.type = NoiseModel::Type::Correlated;
  c.noise.correlation_length_px = 2.0;
  const Scenario sc(c);
  double s2 = 0, lag = 0;
  std::size_t n = 0, nl = 0;
  for (std::uint64_t run = 0; run < 6; ++run)
    for (int axis = 0; axis < 2; ++axis)
      for (const auto& edge : normalizedErrors(sc, sc.simulate(0, run), axis))
        for (std::size_t q = 0; q < edge.size(); ++q) {
          s2 += edge[q].second * edge[q].second;
          ++n;
          if (q + 1 < edge.size() && edge[q + 1].first == edge[q].first + 1) {
            lag += edge[q].second * edge[q + 1].second;
            ++nl;
          }
        }
  EXPECT_NEAR(s2 / n, 1.0, 0.1);  // correlated samples: a looser bound than for white noise
  EXPECT_NEAR(lag / nl, std::exp(-1.0 / 8.0), 0.06);
}

/// Excess kurtosis and variance of the normalized errors of runs [0, runs) of snapshot 0.
std::pair<double, double> varianceAndKurtosis(const Scenario& sc, int runs) {
  double s2 = 0, s4 = 0;
  std::size_t n = 0;
  for (int run = 0; run < runs; ++run)
    for (int axis = 0; axis < 2; ++axis)
      for (const auto& edge : normalizedErrors(sc, sc.simulate(0, run), axis))
        for (const auto& [p, z] : edge) {
          s2 += z * z;
          s4 += z * z * z * z;
          ++n;
        }
  const double var = s2 / n;
  return {var, s4 / n / (var * var) - 3};
}

TEST(Scenario, StudentTailsKeepTheClaimedVarianceWithTheirKurtosis) {
  ScenarioConfig c = tinyWhole();
  c.weight_scale = 25;
  c.noise.student_t_dof = 6;  // excess kurtosis 6 / (ν − 4) = 3
  const auto [var, kurtosis] = varianceAndKurtosis(Scenario(c), 12);
  EXPECT_NEAR(var, 1.0, 0.08);
  EXPECT_GT(kurtosis, 1.5);
  c.noise.student_t_dof = 0;
  const auto [var0, kurtosis0] = varianceAndKurtosis(Scenario(c), 12);
  EXPECT_NEAR(var0, 1.0, 0.05);
  EXPECT_NEAR(kurtosis0, 0.0, 0.3);
}

TEST(Scenario, EdgeScaleSpreadGivesEachEdgeItsOwnWhiteScale) {
  ScenarioConfig c = tinyWhole(5);
  c.weight_scale = 25;
  c.noise.edge_scale_spread = 0.5;
  const Scenario sc(c);
  // log of each edge's error variance: spread 2·0.5 = 1 in log-variance across edges, against the
  // sampling noise of ~100 pixels (≈ 0.14) without the spread.
  std::vector<double> logvar;
  for (const auto& edge : normalizedErrors(sc, sc.simulate(0, 3), 0)) {
    if (edge.size() < 50) continue;
    double s2 = 0;
    for (const auto& [p, z] : edge) s2 += z * z;
    logvar.push_back(std::log(s2 / edge.size()));
  }
  ASSERT_GE(logvar.size(), 6u);
  double mean = 0, sd = 0;
  for (double v : logvar) mean += v / logvar.size();
  for (double v : logvar) sd += (v - mean) * (v - mean) / (logvar.size() - 1);
  EXPECT_GT(std::sqrt(sd), 0.5);
  EXPECT_LT(std::sqrt(sd), 1.6);
}

TEST(Scenario, OpenNoiseFamilyDrawsOneModelPerRun) {
  ScenarioConfig c = tinySliding(10, 4);
  c.solve = false;
  c.noise_family = NoiseFamily::Open;
  const Scenario sc(c);
  const SimulatedSnapshot a = sc.simulate(0, 5), b = sc.simulate(1, 5), other = sc.simulate(0, 6);
  EXPECT_EQ(describe(a.noise), describe(b.noise));  // one model per run, shared by its snapshots
  EXPECT_NE(describe(a.noise), describe(other.noise));
  // The fixed family reports the configured model.
  c.noise_family = NoiseFamily::Fixed;
  EXPECT_EQ(describe(Scenario(c).simulate(0, 5).noise), describe(c.noise));
  // Every drawn model simulates (fields beyond the grid included).
  c.noise_family = NoiseFamily::Open;
  const Scenario open(c);
  for (int run = 0; run < 20; ++run) EXPECT_NO_THROW(open.simulate(0, run)) << run;
}

TEST(Scenario, WeightedPixelsAreVisibleInTheTargetView) {
  ScenarioConfig c = tinyWhole(10);
  c.trajectory.type = TrajectoryType::Loop;
  c.trajectory.keyframes_per_lap = 12;
  c.edges.edge_radius = 3;
  c.scene.boxes.push_back({Eigen::Vector3d(2.8, -1.5, 0.8), Eigen::Vector3d(3.6, 0.5, 2.2)});
  const Scenario sc(c);
  const SimulatedSnapshot sim = sc.simulate(0);
  const Snapshot& s = sim.snapshot;
  const PinholeIntrinsics K = c.camera.intrinsics();
  std::size_t weighted = 0, zero = 0;
  for (int e = 0; e < s.numEdges(); ++e) {
    const int i = static_cast<int>(s.ii[e]), j = static_cast<int>(s.jj[e]);
    for (int p = 0; p < static_cast<int>(s.pixelsPerFrame()); ++p) {
      if (s.weightPlane(e, 0)[p] == 0) {
        ++zero;
        continue;
      }
      ++weighted;
      const double xn = (p % s.W - K.cx) / K.fx, yn = (p / s.W - K.cy) / K.fy;
      const Eigen::Vector3d X = sim.T_wc_true[i] * (Eigen::Vector3d(xn, yn, 1) /
                                                    c.scene.inverseDepth(sim.T_wc_true[i], xn, yn));
      const Eigen::Vector3d Xj = sim.T_wc_true[j].inverse() * X;
      ASSERT_GT(Xj.z(), 0);
      const double u = K.fx * Xj.x() / Xj.z() + K.cx, v = K.fy * Xj.y() / Xj.z() + K.cy;
      EXPECT_TRUE(u >= -0.5 && u <= s.W - 0.5 && v >= -0.5 && v <= s.H - 0.5)
          << "edge " << e << " pixel " << p;
      // Nothing nearer along the ray from camera j.
      const double seen =
          1.0 / c.scene.inverseDepth(sim.T_wc_true[j], Xj.x() / Xj.z(), Xj.y() / Xj.z());
      EXPECT_GT(seen, Xj.z() * (1 - 2e-3)) << "edge " << e << " pixel " << p << " is hidden";
    }
  }
  // Beyond the 10 % random zero confidences, hidden and out-of-view pixels got none.
  EXPECT_GT(static_cast<double>(zero) / (zero + weighted), 0.15);
}

TEST(Scenario, SlidingWindowSnapshotsFollowDroidsFrontendAndHoldTheGaugeAtTheTruth) {
  ScenarioConfig c = tinySliding(7, 400);
  c.window = 4;
  const Scenario sc(c);
  ASSERT_EQ(sc.numSnapshots(), 4);
  for (int s = 0; s < 4; ++s) {
    const SimulatedSnapshot sim = sc.simulate(s, 1);
    const Snapshot& snap = sim.snapshot;
    EXPECT_TRUE(sim.solver.converged()) << sim.solver.brief();
    ASSERT_EQ(snap.numKeyframes(), s + 4);
    EXPECT_EQ(snap.id, s);
    std::set<std::pair<std::int64_t, std::int64_t>> edges;
    for (int e = 0; e < snap.numEdges(); ++e) {
      EXPECT_GE(std::min(snap.ii[e], snap.jj[e]), s);
      edges.emplace(snap.ii[e], snap.jj[e]);
    }
    for (const auto& [i, j] : edges)
      EXPECT_TRUE(edges.count({j, i})) << i << "->" << j << " without its reverse";
    for (int k = 0; k < snap.numKeyframes(); ++k) {
      EXPECT_EQ(snap.tstamp[k], 3.0 * k);
      EXPECT_EQ((*snap.timestamps_s)[k], 1.7e9 + 3.0 * k / 20.0);
      const Eigen::Isometry3d T = trajectoryPose(c.trajectory, k);
      EXPECT_TRUE(sim.T_wc_true[k].isApprox(T, 1e-15));
      // Keyframes before the window and the two gauge keyframes stay at the truth; the rest move.
      const double err = (snap.T_wc(k).matrix() - T.matrix()).norm();
      if (k <= s + 1)
        EXPECT_LT(err, 1e-14) << "keyframe " << k;
      else
        EXPECT_GT(err, 1e-9) << "keyframe " << k;
    }
  }
}

TEST(Scenario, IsReproducibleAndRedrawsOnlyTheNoisePerRun) {
  ScenarioConfig c = tinyWhole(5);
  c.solve = true;
  c.weight_scale = 400;
  const Scenario sc(c);
  const SimulatedSnapshot a = sc.simulate(0, 4), b = sc.simulate(0, 4), other = sc.simulate(0, 5);
  EXPECT_EQ(a.snapshot.target, b.snapshot.target);
  EXPECT_EQ(a.snapshot.disps, b.snapshot.disps);
  EXPECT_EQ(a.snapshot.poses_cw, b.snapshot.poses_cw);
  EXPECT_EQ(a.snapshot.weight, other.snapshot.weight);  // the scenario's confidences
  EXPECT_NE(a.snapshot.target, other.snapshot.target);  // a new noise draw
  c.seed = 2;
  EXPECT_NE(Scenario(c).simulate(0, 4).snapshot.weight, a.snapshot.weight);
}

// Edge persistence: an edge's confidences and target errors are the same in every snapshot that
// holds it (and still redrawn per run); snapshot persistence redraws them per snapshot. The
// errors of persistent edges still carry the variance the confidences claim.
TEST(Scenario, EdgePersistenceSharesAnEdgesFlowsAcrossSnapshots) {
  ScenarioConfig c = tinySliding(12, 25);
  c.solve = false;
  auto edgePlanes = [](const Snapshot& s) {
    std::map<std::pair<int, int>, std::pair<std::vector<float>, std::vector<float>>> m;
    const std::size_t n = 2 * s.pixelsPerFrame();
    for (int e = 0; e < s.numEdges(); ++e)
      m[{static_cast<int>(s.ii[e]), static_cast<int>(s.jj[e])}] = {
          std::vector<float>(s.targetPlane(e, 0), s.targetPlane(e, 0) + n),
          std::vector<float>(s.weightPlane(e, 0), s.weightPlane(e, 0) + n)};
    return m;
  };
  for (auto persistence : {NoiseModel::Persistence::Snapshot, NoiseModel::Persistence::Edge}) {
    c.noise.persistence = persistence;
    const Scenario sc(c);
    const auto a = edgePlanes(sc.simulate(1, 0).snapshot),
               b = edgePlanes(sc.simulate(2, 0).snapshot);
    const auto other_run = edgePlanes(sc.simulate(2, 1).snapshot);
    int shared = 0, same_targets = 0, same_weights = 0;
    for (const auto& [ij, planes] : a) {
      const auto it = b.find(ij);
      if (it == b.end()) continue;
      ++shared;
      same_targets += planes.first == it->second.first;
      same_weights += planes.second == it->second.second;
      EXPECT_NE(it->second.first, other_run.at(ij).first) << "a new run redraws the errors";
    }
    ASSERT_GT(shared, 5);
    if (persistence == NoiseModel::Persistence::Edge) {
      EXPECT_EQ(same_targets, shared);
      EXPECT_EQ(same_weights, shared);
    } else {
      EXPECT_EQ(same_targets, 0);
      EXPECT_EQ(same_weights, 0);
    }
  }
  c.noise.persistence = NoiseModel::Persistence::Edge;
  const Scenario sc(c);
  double s2 = 0;
  std::size_t n = 0;
  for (std::uint64_t run = 0; run < 3; ++run)
    for (int axis = 0; axis < 2; ++axis)
      for (const auto& edge : normalizedErrors(sc, sc.simulate(0, run), axis))
        for (const auto& [p, z] : edge) s2 += z * z, ++n;
  EXPECT_NEAR(s2 / n, 1.0, 4 * std::sqrt(2.0 / n)) << n << " samples";
}

// --gauge-hold estimate: a snapshot's gauge keyframes are held exactly at the previous snapshot's
// estimates (not at the truth, which they then differ from), so the window's frame and scale are
// inherited as in DROID's frontend; without the previous snapshot it is refused.
TEST(Scenario, GaugeHeldAtThePreviousEstimate) {
  ScenarioConfig c = tinySliding(11, 25);
  c.gauge_hold = GaugeHold::Estimate;
  const Scenario sc(c);
  const SimulatedSnapshot s0 = sc.simulate(0, 3);
  const SimulatedSnapshot s1 = sc.simulate(1, 3, &s0.snapshot);
  const auto& ii = s1.snapshot.ii;
  const int ga = static_cast<int>(*std::min_element(ii.begin(), ii.end()));
  ASSERT_EQ(ga, 1);
  for (int g : {1, 2}) {
    EXPECT_EQ(s1.snapshot.poses_cw.row(g), s0.snapshot.poses_cw.row(g)) << "gauge keyframe " << g;
    // Keyframe 1 was snapshot 0's held gauge keyframe (at the truth); keyframe 2 its estimate.
    const double off =
        (s1.snapshot.T_wc(g).translation() - sc.groundTruth()[g].translation()).norm();
    if (g == 1)
      EXPECT_LT(off, 1e-6);
    else
      EXPECT_GT(off, 1e-6);
  }
  EXPECT_TRUE(s1.solver.converged());
  EXPECT_THROW(sc.simulate(1, 3), std::invalid_argument);
  // Held at the truth (the default), the same snapshot's gauge keyframes are the true poses.
  c.gauge_hold = GaugeHold::Truth;
  const SimulatedSnapshot t1 = Scenario(c).simulate(1, 3);
  EXPECT_LT((t1.snapshot.T_wc(2).translation() - sc.groundTruth()[2].translation()).norm(), 1e-6);
}

TEST(Scenario, RejectsInvalidConfigurations) {
  ScenarioConfig c = tinyWhole();
  c.mode = SimulationMode::SlidingWindow;
  c.window = 9;  // more than the 4 keyframes
  EXPECT_THROW(Scenario{c}, std::invalid_argument);
  c = tinyWhole();
  c.scene.boxes.push_back(
      {Eigen::Vector3d(-0.5, -0.5, -0.5), Eigen::Vector3d(0.5, 0.5, 0.5)});  // around keyframe 0
  try {
    Scenario{c};
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 0"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parseSimulationMode("batch"), std::invalid_argument);
}

TEST(ScenarioJson, RoundTripsEverySetting) {
  ScenarioConfig c;
  c.seed = 99;
  c.mode = SimulationMode::WholeTrajectory;
  c.window = 5;
  c.weight_scale = 12.5;
  c.solve = false;
  c.camera.H = 20;
  c.camera.fx = 33.0;
  c.scene.boxes.push_back({Eigen::Vector3d(1, -1, 3), Eigen::Vector3d(2, 0, 4)});
  c.trajectory.type = TrajectoryType::Loop;
  c.trajectory.num_keyframes = 33;
  c.trajectory.loop_center = Eigen::Vector3d(1, 2, 3);
  c.edges.overlap_threshold = 0.25;
  c.weights.distribution = WeightModel::Distribution::Beta;
  c.weights.alpha = 3;
  c.noise.type = NoiseModel::Type::Correlated;
  c.noise.correlation_length_px = 4.5;
  c.noise.amplitude = 0.5;
  c.noise.persistence = NoiseModel::Persistence::Edge;
  c.noise.student_t_dof = 5;
  c.noise.edge_scale_spread = 0.3;
  c.noise.field_fourier = true;
  c.noise_family = NoiseFamily::Open;
  c.gauge_hold = GaugeHold::Estimate;
  c.gauge.type = GaugeOptions::Type::Minimal;
  c.perturbation.rotation = 0.03;
  c.solver.max_iterations = 7;
  c.time.fps = 30;
  const std::string json = scenarioConfigToJson(c);
  ScenarioConfig back;
  applyScenarioJson(json, "mem", back);
  EXPECT_EQ(scenarioConfigToJson(back), json);
  EXPECT_EQ(back.seed, 99u);
  EXPECT_EQ(back.scene.boxes.size(), 1u);
  EXPECT_EQ(back.noise.correlation_length_px, 4.5);
  EXPECT_EQ(back.noise.persistence, NoiseModel::Persistence::Edge);
  EXPECT_EQ(back.noise.student_t_dof, 5);
  EXPECT_EQ(back.noise.edge_scale_spread, 0.3);
  EXPECT_TRUE(back.noise.field_fourier);
  EXPECT_EQ(back.noise_family, NoiseFamily::Open);
  EXPECT_EQ(back.gauge_hold, GaugeHold::Estimate);
  EXPECT_EQ(*back.camera.fx, 33.0);
  EXPECT_EQ(back.solver.max_iterations, 7);
}

TEST(ScenarioJson, ErrorsNameTheFileAndTheKey) {
  auto message = [](const std::string& text) {
    ScenarioConfig c;
    try {
      applyScenarioJson(text, "x.json", c);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(R"({"noise": {"modle": "white"}})"), "x.json: key 'noise.modle': unknown key");
  EXPECT_EQ(message(R"({"window": 2.5})"), "x.json: key 'window': expected an integer");
  EXPECT_EQ(message(R"({"scene": {"min": [1, 2]}})"),
            "x.json: key 'scene.min': expected an array of 3 numbers");
  EXPECT_NE(message(R"({"trajectory": {"type": "spiral"}})")
                .find("key 'trajectory.type': unknown trajectory 'spiral'"),
            std::string::npos);
  EXPECT_NE(message(R"({"scene": {"boxes": [{"min": [0,0,0], "max": [1,1,1], "colour": 1}]}})")
                .find("key 'scene.boxes[0].colour': unknown key"),
            std::string::npos);
  EXPECT_NE(message("{ not json").find("x.json: invalid JSON"), std::string::npos);
  EXPECT_EQ(message("[1, 2]"), "x.json: the file: expected an object");
  EXPECT_THROW(loadScenarioConfig("/nonexistent/dir/x.json"), InputError);
}

TEST(ScenarioJson, ShippedConfigurationsAreValid) {
  const std::string dir = std::string(DBACOV_SOURCE_DIR) + "/share/sim";
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().string());
    const ScenarioConfig c = loadScenarioConfig(entry.path().string());
    EXPECT_NO_THROW(c.validate());
    EXPECT_GE(Scenario(c).numSnapshots(), 1);
    ++n;
  }
  EXPECT_GE(n, 3);
}

}  // namespace
}  // namespace dbacov::sim
