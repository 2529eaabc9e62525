// Pose graphs from DBA covariances: file round trips (binary exact, MRPT text with its documented
// loss, g2o layout), the optimizer through dba-posegraph, and the end-to-end evidence that the DBA
// information beats identity information on a drifting loop closed by one constraint.
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/posegraph_app.h"
#include "dbacov/core/pipeline.h"
#include "dbacov/core/pose_graph.h"
#include "dbacov/io/atomic_file.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/pose_graph_io.h"
#include "dbacov/sim/scenario.h"
#include "dbacov/sim/sensor_modes.h"
#include "dbacov/sim/synthetic_snapshot.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

using testing::AppResult;

AppResult posegraph(const std::vector<std::string>& args) {
  return testing::runApp(app::runPoseGraphApp, "dba-posegraph", args);
}

bool contains(const std::string& hay, const std::string& needle) {
  return hay.find(needle) != std::string::npos;
}

/// Sliding-window DBA snapshots at the truth along a loop: their pose graph, and the truth.
struct LoopScenario {
  PoseGraph graph;
  std::vector<Eigen::Isometry3d> truth;
  std::size_t uninformative = 0;
};

LoopScenario loopScenario(int keyframes, int per_lap, int window) {
  LoopScenario sc;
  sim::SyntheticSnapshotConfig c;
  c.H = 12;
  c.W = 16;
  c.fx = c.fy = 14;
  c.cx = 7.5;
  c.cy = 5.5;
  c.trajectory.type = sim::TrajectoryType::Loop;
  c.trajectory.keyframes_per_lap = per_lap;
  c.trajectory.num_keyframes = keyframes;
  c.covisibility.edge_radius = 2;
  c.noise = false;
  DbaOptions o;
  o.weight_scale = 4;
  PoseGraphBuilder builder;
  for (int s = 0; s + window <= keyframes; ++s) {
    c.num_keyframes = s + window;
    c.first_keyframe = s;
    c.seed = 100 + s;
    auto syn = sim::generateSyntheticSnapshot(c);
    deriveKeyframeTimes(syn.snapshot, 20);
    builder.add(syn.snapshot, DbaCovariance(syn.snapshot, o));
    sc.truth = syn.T_wc_true;
  }
  sc.graph = builder.graph();
  sc.uninformative = builder.numUninformativePairs();
  return sc;
}

TEST(PoseGraphFiles, BinaryKeepsEveryEntryTextLosesOnlyRotationOffDiagonals) {
  const LoopScenario sc = loopScenario(12, 40, 6);
  ASSERT_GT(sc.graph.edges.size(), 10u);
  EXPECT_EQ(sc.uninformative, 1u);  // the two gauge keyframes of the first window only
  testing::TempDir dir;
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), sc.graph);
  mrpt_bridge::writeGraphText(dir.file("g.graph"), sc.graph, mrpt_bridge::GraphTextLayout::Mrpt258);
  mrpt_bridge::writeGraphText(dir.file("g.g2o"), sc.graph, mrpt_bridge::GraphTextLayout::G2o);

  const PoseGraph bin =
      mrpt_bridge::fromNetwork(mrpt_bridge::readGraphBinary(dir.file("g.graphbin")));
  const PoseGraph txt =
      mrpt_bridge::fromNetwork(mrpt_bridge::readGraphMrptText(dir.file("g.graph")));
  const PoseGraph g2o_as_mrpt =
      mrpt_bridge::fromNetwork(mrpt_bridge::readGraphMrptText(dir.file("g.g2o")));
  ASSERT_EQ(bin.edges.size(), sc.graph.edges.size());
  ASSERT_EQ(txt.edges.size(), sc.graph.edges.size());
  for (std::size_t i = 0; i < sc.graph.edges.size(); ++i) {
    const PoseGraphEdge& e = sc.graph.edges[i];
    EXPECT_EQ(bin.edges[i].from, e.from);
    EXPECT_EQ(bin.edges[i].to, e.to);
    EXPECT_EQ(bin.edges[i].information, e.information) << "binary must keep every entry";
    EXPECT_LT((bin.edges[i].Z.matrix() - e.Z.matrix()).norm(), 1e-12);
    const Matrix6d& I = e.information;
    const Matrix6d& L = txt.edges[i].information;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) {
        if (r >= 3 && c >= 3 && r != c)
          EXPECT_EQ(L(r, c), 0.0) << "documented loss at (" << r << "," << c << ")";
        else
          EXPECT_NEAR(L(r, c), I(r, c), 1e-12 * I.norm()) << "(" << r << "," << c << ")";
      }
    // The g2o layout read by MRPT's loader puts the rotation diagonal in reverse order.
    EXPECT_GT(std::abs(g2o_as_mrpt.edges[i].information(3, 3) - I(3, 3)), 1e-6 * I(3, 3));
  }
  // The g2o file holds D Λ D (D = diag(1,1,1,2,2,2)), row-major upper triangle.
  std::ifstream g2o(dir.file("g.g2o"));
  std::string line;
  while (std::getline(g2o, line) && line.rfind("EDGE_SE3:QUAT", 0) != 0) {
  }
  std::istringstream ls(line);
  std::string key;
  int from, to;
  double v[28];
  ls >> key >> from >> to;
  for (double& x : v) ls >> x;
  const Matrix6d& I0 = sc.graph.edges[0].information;
  EXPECT_EQ(from, sc.graph.edges[0].from);
  EXPECT_NEAR(v[7], I0(0, 0), 1e-12 * I0.norm());          // (0,0)
  EXPECT_NEAR(v[7 + 3], 2 * I0(0, 3), 1e-12 * I0.norm());  // (0,3): translation x rotation
  EXPECT_NEAR(v[27], 4 * I0(5, 5), 1e-12 * I0.norm());     // (5,5)
}

void writeNodes(const std::string& path, const PoseGraph& g) {
  io::writeFileAtomically(path, [&](std::ostream& os) {
    os << "node,tstamp,time_s\n";
    for (const auto& [id, T] : g.nodes) os << id << ',' << id << ',' << 1000 + 0.1 * id << '\n';
  });
}

std::vector<Eigen::Isometry3d> readTum(const std::string& path) {
  std::vector<Eigen::Isometry3d> out;
  std::ifstream in(path);
  double v[8];
  while (in >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6] >> v[7])
    out.push_back(poseFromTQ(v + 1));
  return out;
}

double ate(const std::vector<Eigen::Isometry3d>& est, const std::vector<Eigen::Isometry3d>& truth) {
  double s = 0;
  for (std::size_t k = 0; k < est.size(); ++k)
    s += (est[k].translation() - truth[k].translation()).squaredNorm();
  return std::sqrt(s / est.size());
}

TEST(PoseGraphOptimizer, ConvergesFromTheExportedGuessAndReportsCovariances) {
  const LoopScenario sc = loopScenario(10, 40, 6);
  testing::TempDir dir;
  PoseGraph perturbed = sc.graph;
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0, 0.01);
  for (auto& [id, T] : perturbed.nodes)
    if (id != 0)
      T = T * expSE3((Vector6d() << n(rng), n(rng), n(rng), n(rng), n(rng), n(rng)).finished());
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), perturbed);
  writeNodes(dir.file("g.nodes.csv"), perturbed);
  const AppResult r = posegraph(
      {"-g", dir.file("g.graphbin"), "--tum", dir.file("o.tum"), "-o", dir.file("o.rawlog")});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "iterations")) << r.err;
  const auto est = readTum(dir.file("o.tum"));
  ASSERT_EQ(est.size(), sc.graph.nodes.size());
  for (const auto& [id, T] : sc.graph.nodes)  // the graph is consistent: its nodes are the optimum
    EXPECT_LT((est[id].matrix() - T.matrix()).norm(), 1e-6) << "node " << id;
  EXPECT_EQ(testing::readFile(dir.file("o.tum")).substr(0, 5), "1000 ");
}

Matrix6d randomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Matrix<double, 6, 6> A;
  for (int i = 0; i < 36; ++i) A.data()[i] = u(rng);
  Vector6d scale;
  scale << 1, 3, 10, 30, 2, 20;
  const Matrix6d I =
      scale.asDiagonal() * (A * A.transpose() + 0.1 * Matrix6d::Identity()) * scale.asDiagonal();
  return 0.5 * (I + I.transpose());
}

/// The optimum of a small graph by our own Gauss-Newton with the conventions §3 residuals (node 0
/// fixed).
std::map<int, Eigen::Isometry3d> referenceOptimum(PoseGraph g) {
  for (int it = 0; it < 100; ++it) {
    const int n = static_cast<int>(g.nodes.size()) - 1;
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(6 * n, 6 * n);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(6 * n);
    for (const PoseGraphEdge& e : g.edges) {
      Vector6d r;
      Matrix6d Jf, Jt;
      poseGraphEdgeResidual(g.nodes[e.from], g.nodes[e.to], e.Z, &r, &Jf, &Jt);
      const std::pair<int, const Matrix6d*> parts[2] = {{e.from, &Jf}, {e.to, &Jt}};
      for (const auto& [i, Ji] : parts) {
        if (i == 0) continue;
        b.segment<6>(6 * (i - 1)) += Ji->transpose() * e.information * r;
        for (const auto& [j, Jj] : parts)
          if (j != 0)
            H.block<6, 6>(6 * (i - 1), 6 * (j - 1)) += Ji->transpose() * e.information * *Jj;
      }
    }
    const Eigen::VectorXd delta = -H.ldlt().solve(b);
    for (int i = 1; i <= n; ++i) g.nodes[i] = g.nodes[i] * expSE3(delta.segment<6>(6 * (i - 1)));
    if (delta.norm() < 1e-13) break;
  }
  return g.nodes;
}

std::string constraintLine(const char* kind, int from, int to, const Eigen::Isometry3d& Z,
                           const Matrix6d& information) {
  std::ostringstream os;
  os << kind << ' ' << from << ' ' << to << std::setprecision(17);
  const auto tq = poseToTQ(Z);
  for (int i = 0; i < 7; ++i) os << ' ' << tq[i];
  const Matrix6d C = information.inverse();
  for (int r = 0; r < 6; ++r)
    for (int c = r; c < 6; ++c) os << ' ' << C(r, c);
  return os.str();
}

struct LoopResult {
  double odometry, identity, dba;  // ATE [length unit]
};

/// One lap of 40 keyframes plus 4 that overlap the start; odometry edges drawn from their own DBA
/// covariances (so they drift), one loop-closure constraint 0 → last; lengths in `unit`s of the
/// simulation's metres (monocular DBA has no metric scale: any unit is as legitimate).
LoopResult optimizeDriftingLoop(const LoopScenario& sc, std::uint32_t seed, double unit) {
  const int n = static_cast<int>(sc.truth.size());
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01;
  std::vector<Eigen::Isometry3d> truth = sc.truth;
  for (auto& T : truth) T.translation() *= unit;
  PoseGraph noisy = sc.graph;
  for (auto& [id, T] : noisy.nodes) T.translation() *= unit;
  Vector6d d;
  d << 1 / unit, 1 / unit, 1 / unit, 1, 1, 1;
  for (PoseGraphEdge& e : noisy.edges) {
    e.Z.translation() *= unit;
    e.information = d.asDiagonal() * e.information * d.asDiagonal();
    const Matrix6d L = e.information.inverse().llt().matrixL();
    Vector6d w;
    for (int i = 0; i < 6; ++i) w[i] = n01(rng);
    e.Z = e.Z * expSE3(L * w);
  }
  // Initial guess: chain the consecutive noisy edges from the true first pose (keyframe 1 stays at
  // its estimate: the pair 0–1 is fixed by the gauge of the first window and has no edge).
  noisy.nodes[0] = truth[0];
  for (int k = 1; k < n; ++k)
    for (const PoseGraphEdge& e : noisy.edges)
      if (e.from == k - 1 && e.to == k) noisy.nodes[k] = noisy.nodes[k - 1] * e.Z;
  testing::TempDir dir;
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), noisy);
  writeNodes(dir.file("g.nodes.csv"), noisy);
  const Matrix6d loop_info =
      (Vector6d() << 1e6 / (unit * unit), 1e6 / (unit * unit), 1e6 / (unit * unit), 1e6, 1e6, 1e6)
          .finished()
          .asDiagonal();  // 1 mm, 1 mrad
  std::ofstream(dir.file("loop.txt"))
      << "# loop closure\n"
      << constraintLine("relative", 0, n - 1, truth[0].inverse() * truth[n - 1], loop_info) << "\n";
  const std::vector<std::string> args{"-g", dir.file("g.graphbin"), "--extra", dir.file("loop.txt"),
                                      "-q"};
  auto with = [&](std::vector<std::string> extra) {
    extra.insert(extra.begin(), args.begin(), args.end());
    return extra;
  };
  EXPECT_EQ(posegraph(with({"--tum", dir.file("dba.tum")})).code, 0);
  EXPECT_EQ(posegraph(with({"--tum", dir.file("id.tum"), "--identity-information"})).code, 0);
  std::vector<Eigen::Isometry3d> odometry;
  for (const auto& [id, T] : noisy.nodes) odometry.push_back(T);
  return {ate(odometry, truth), ate(readTum(dir.file("id.tum")), truth),
          ate(readTum(dir.file("dba.tum")), truth)};
}

TEST(PoseGraphOptimizer, DbaInformationBeatsIdentityOnADriftingLoop) {
  const LoopScenario sc = loopScenario(44, 40, 6);
  for (double unit : {1.0, 10.0}) {
    double odometry = 0, identity = 0, dba = 0;
    const int runs = 6;
    for (int seed = 1; seed <= runs; ++seed) {
      const LoopResult r = optimizeDriftingLoop(sc, seed, unit);
      odometry += r.odometry / runs;
      identity += r.identity / runs;
      dba += r.dba / runs;
      // The DBA information makes the answer independent of the length unit; identity does not.
      if (unit != 1.0) {
        const LoopResult metres = optimizeDriftingLoop(sc, seed, 1.0);
        EXPECT_NEAR(r.dba, unit * metres.dba, 1e-6 * r.dba) << "seed " << seed;
      }
    }
    std::cout << "mean ATE over " << runs << " drifting loops, length unit " << 1 / unit
              << " m: odometry " << odometry << ", identity information " << identity
              << ", DBA information " << dba << "\n";
    EXPECT_LT(dba, identity) << "unit " << unit;
    EXPECT_LT(dba, 0.5 * odometry) << "unit " << unit;
  }
}

TEST(PoseGraphOptimizer, BadExtraConstraintsAreExplained) {
  const LoopScenario sc = loopScenario(8, 40, 6);
  testing::TempDir dir;
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), sc.graph);
  writeNodes(dir.file("g.nodes.csv"), sc.graph);
  const std::vector<std::pair<std::string, std::string>> cases{
      {"loop 0 1 0 0 0 0 0 0 1 0.1 0.1", ":1: unknown constraint 'loop'"},
      {"\n\nrelative 0 99 0 0 0 0 0 0 1 0.1 0.1", ":3: node 99 is not in the graph"},
      {"relative 0 1 0 0 0 0 0 0 1 0.1", ":1: expected a pose (7 numbers) and a covariance"},
      {"relative 0 1 0 0 0 0 0 0 0 0.1 0.1", ":1: the quaternion is zero"},
      {"relative 0 1 0 0 0 0 0 0 1 -0.1 0.1", ":1: sigmas must be > 0"},
      {"relative 0 1 0 0 x 0 0 0 1 0.1 0.1", ":1: 'x' is not a number"},
      {"relative 0 1 0 0 nan 0 0 0 1 0.1 0.1", ":1: value 'nan' is not finite"},
      {"relative 1 1 0 0 0 0 0 0 1 0.1 0.1", ":1: a relative constraint needs two different nodes"},
      {"absolute 2 0 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 -1 0 0 1 0 1",
       ":1: the covariance is not positive definite"}};
  for (const auto& [text, message] : cases) {
    std::ofstream(dir.file("x.txt")) << text << "\n";
    const AppResult r = posegraph(
        {"-g", dir.file("g.graphbin"), "--extra", dir.file("x.txt"), "--tum", dir.file("o.tum")});
    EXPECT_EQ(r.code, 1) << text;
    EXPECT_TRUE(contains(r.err, dir.file("x.txt") + message)) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("o.tum")));
  }
  // An absolute prior anchors the graph instead of the first node.
  const auto tq = poseToTQ(sc.graph.nodes.at(3));
  std::ofstream(dir.file("abs.txt"))
      << "absolute 3 " << tq[0] << ' ' << tq[1] << ' ' << tq[2] << ' ' << tq[3] << ' ' << tq[4]
      << ' ' << tq[5] << ' ' << tq[6] << " 0.01 0.01\n";
  const AppResult r = posegraph({"-g", dir.file("g.graphbin"), "--extra", dir.file("abs.txt"),
                                 "--tum", dir.file("o.tum"), "-q"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(readTum(dir.file("o.tum")).size(), sc.graph.nodes.size());
  EXPECT_EQ(posegraph({"-g", dir.file("g.graphbin")}).code, 2);  // no output
  EXPECT_EQ(posegraph({"-g", dir.file("g.g2o"), "--tum", dir.file("o.tum")}).code, 2);
}

TEST(PoseGraphOptimizer, ReachesTheWeightedOptimumOfATriangle) {
  // A triangle 0 → 1 → 2, 0 → 2 with inconsistent measurements and strongly anisotropic,
  // correlated informations: the result must be the optimum of an independent dense Gauss-Newton
  // on the conventions §3 residuals.
  std::mt19937 rng(11);
  PoseGraph g;
  g.nodes[0] = expSE3((Vector6d() << 0.3, 0.1, -0.2, 0.4, -0.3, 1.2).finished());
  const Eigen::Isometry3d Z01 = expSE3((Vector6d() << 1.0, 0.2, 0.1, 0.1, 0.5, -0.3).finished());
  const Eigen::Isometry3d Z12 = expSE3((Vector6d() << 0.2, -0.8, 0.3, -0.4, 0.1, 0.2).finished());
  const Eigen::Isometry3d Z02 =
      Z01 * Z12 * expSE3((Vector6d() << 0.02, -0.01, 0.03, 0.02, 0.01, -0.02).finished());
  g.nodes[1] = g.nodes[0] * Z01;
  g.nodes[2] = g.nodes[1] * Z12;
  g.edges = {{0, 1, Z01, randomInformation(rng)},
             {1, 2, Z12, randomInformation(rng)},
             {0, 2, Z02, randomInformation(rng)}};
  testing::TempDir dir;
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), g);
  writeNodes(dir.file("g.nodes.csv"), g);
  const AppResult r = posegraph({"-g", dir.file("g.graphbin"), "--tum", dir.file("o.tum"), "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto want = referenceOptimum(g);
  const auto got = readTum(dir.file("o.tum"));
  const double moved = logSE3(g.nodes[2].inverse() * want.at(2)).norm();
  ASSERT_GT(moved, 1e-3);  // the test has teeth: the optimum is far from the start
  for (int k = 1; k <= 2; ++k)
    EXPECT_LT(logSE3(want.at(k).inverse() * got[k]).norm(), 1e-3 * moved) << "node " << k;
  // MRPT 2.5.8 alone stops short of it (see optimizePoseGraph): the refinement is needed.
  ASSERT_EQ(
      posegraph({"-g", dir.file("g.graphbin"), "--tum", dir.file("m.tum"), "--no-refine", "-q"})
          .code,
      0);
  EXPECT_GT(logSE3(want.at(2).inverse() * readTum(dir.file("m.tum"))[2]).norm(), 1e-2 * moved);
}

TEST(PoseGraphOptimizer, ParallelEdgesAreFusedIntoTheirWeightedMean) {
  // A loop closure beside an existing edge: MRPT alone would not move (see fuseParallelEdges).
  std::mt19937 rng(12);
  PoseGraph g;
  g.nodes[0] = expSE3((Vector6d() << 0.3, 0.1, -0.2, 0.4, -0.3, 1.2).finished());
  const Eigen::Isometry3d Za = expSE3((Vector6d() << 1.0, 0.2, 0.1, 0.1, 0.5, -0.3).finished());
  const Eigen::Isometry3d Zb =
      Za * expSE3((Vector6d() << 0.02, -0.01, 0.03, 0.02, 0.01, -0.02).finished());
  const Matrix6d La = randomInformation(rng), Lb = randomInformation(rng);
  g.nodes[1] = g.nodes[0] * Za;
  g.edges = {{0, 1, Za, La}};
  testing::TempDir dir;
  mrpt_bridge::writeGraphBinary(dir.file("g.graphbin"), g);
  writeNodes(dir.file("g.nodes.csv"), g);
  // Given the other way round (1 → 0), to exercise the exact turning of an edge.
  const Matrix6d Ad =
      adjoint(Zb.inverse());  // r_10 = −Ad(Z_01) r_01 ⇒ Λ_10 = Ad(Z_10)ᵀ Λ_01 Ad(Z_10)
  std::ofstream(dir.file("b.txt"))
      << constraintLine("relative", 1, 0, Zb.inverse(), Ad.transpose() * Lb * Ad) << "\n";
  const AppResult r = posegraph(
      {"-g", dir.file("g.graphbin"), "--extra", dir.file("b.txt"), "--tum", dir.file("o.tum")});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "1 merged into parallel edges")) << r.err;
  PoseGraph ref = g;
  ref.edges.push_back({0, 1, Zb, Lb});
  const auto want = referenceOptimum(ref);
  const auto got = readTum(dir.file("o.tum"));
  const double moved = logSE3(Za.inverse() * g.nodes[0].inverse() * want.at(1)).norm();
  ASSERT_GT(moved, 1e-3);
  EXPECT_LT(logSE3(want.at(1).inverse() * got[1]).norm(), 1e-3 * moved);
}

}  // namespace
}  // namespace dbacov

namespace dbacov {
namespace {

TEST(PoseGraphFiles, StereoAndRgbdSequencesKeepTheirDepthOnlyFactorsInTheGraph) {
  // The sequence problem carries DROID's stereo rig and RGB-D readings: a stereo sequence is
  // exported (it failed at the end: "a stereo edge needs the rig transform"), and an RGB-D
  // sequence's graph has more information with its readings than without (α = 0).
  for (const sim::SensorMode mode : {sim::SensorMode::Stereo, sim::SensorMode::Rgbd}) {
    SCOPED_TRACE(sim::toString(mode));
    testing::TempDir dir;
    sim::ScenarioConfig cfg;
    cfg.camera.H = 12;
    cfg.camera.W = 16;
    cfg.sensor.mode = mode;
    const sim::Scenario sc(cfg);
    for (int i = 0; i < std::min(3, sc.numSnapshots()); ++i)
      io::saveSnapshotNpz(dir.file("s" + std::to_string(i) + ".npz"), sc.simulate(i).snapshot);
    std::filesystem::create_directory(dir.file("out"));
    const auto graph = [&](const std::string& name, std::vector<std::string> extra) {
      // The stated model: what the readings add at their claimed weight.
      std::vector<std::string> args{"-i", dir.path(), "--graph", dir.file("out/" + name),
                                    "--stated-model"};
      args.insert(args.end(), extra.begin(), extra.end());
      const AppResult r = testing::runApp(app::runCovarianceApp, "dba-covariance", args);
      EXPECT_EQ(r.code, 0) << r.err;
      return mrpt_bridge::fromNetwork(
          mrpt_bridge::readGraphBinary(dir.file("out/" + name + ".graphbin")));
    };
    const PoseGraph g = graph("g", {});
    ASSERT_FALSE(g.edges.empty());
    if (mode != sim::SensorMode::Rgbd) continue;
    const PoseGraph none = graph("none", {"--sensor-depth-weight", "0"});
    ASSERT_EQ(none.edges.size(), g.edges.size());
    double with = 0, without = 0;
    for (std::size_t k = 0; k < g.edges.size(); ++k) {
      if (g.edges[k].from == 0 && g.edges[k].to == 1) continue;  // the gauge pair's stiffness
      with += g.edges[k].information.trace();
      without += none.edges[k].information.trace();
    }
    EXPECT_GT(with, 1.05 * without);
  }
}

TEST(PoseGraphFiles, SelfCalibratedSequenceGraphDoesNotDependOnTheClaimedWeightScale) {
  // --graph, self-calibrated (the default): the sequence's flows enter at each snapshot's
  // calibrated variance factors. A weight scale claimed 100x larger is then corrected (the white
  // scales are 100x larger), and the graphs agree; with --stated-model their information differs
  // 100x.
  testing::TempDir dir;
  for (int i = 0; i < 3; ++i)
    testing::writeTinySnapshot(dir.file("s" + std::to_string(i) + ".npz"), i + 1, i, 5 + i);
  const auto graphAt = [&](const std::string& name, const char* weight_scale, bool calibrate) {
    std::vector<std::string> args{"-i",           dir.path(),       "--graph",
                                  dir.file(name), "--weight-scale", weight_scale};
    if (!calibrate) args.push_back("--stated-model");
    const AppResult r = testing::runApp(app::runCovarianceApp, "dba-covariance", args);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(contains(r.err,
                       "self-calibrated (nuisance): each snapshot's edges at their variance "
                       "factors"),
              calibrate)
        << r.err;
    return mrpt_bridge::fromNetwork(mrpt_bridge::readGraphBinary(dir.file(name + ".graphbin")));
  };
  const PoseGraph raw4 = graphAt("raw4", "4", false), raw400 = graphAt("raw400", "400", false);
  const PoseGraph cal4 = graphAt("cal4", "4", true), cal400 = graphAt("cal400", "400", true);
  ASSERT_EQ(raw4.edges.size(), cal4.edges.size());
  ASSERT_EQ(cal4.edges.size(), cal400.edges.size());
  ASSERT_FALSE(cal4.edges.empty());
  double calibration_moved = 0;
  for (std::size_t k = 0; k < cal4.edges.size(); ++k) {
    const Matrix6d& a = cal4.edges[k].information;
    const Matrix6d& b = cal400.edges[k].information;
    if (cal4.edges[k].from == 0 && cal4.edges[k].to == 1) continue;  // the gauge pair's stiffness
    EXPECT_LT((a - b).norm(), 1e-4 * a.norm()) << cal4.edges[k].from << "->" << cal4.edges[k].to;
    EXPECT_GT((raw400.edges[k].information - raw4.edges[k].information).norm(),
              10 * raw4.edges[k].information.norm());
    calibration_moved =
        std::max(calibration_moved, (a - raw4.edges[k].information).norm() / a.norm());
  }
  EXPECT_GT(calibration_moved, 1e-3);  // the calibrated graph is not the claimed one
}

TEST(PoseGraphFiles, DbaCovarianceWritesTheGraphOfTheSequence) {
  testing::TempDir dir;
  std::vector<Snapshot> snaps;
  for (int i = 0; i < 3; ++i) {
    auto syn =
        testing::writeTinySnapshot(dir.file("s" + std::to_string(i) + ".npz"), i + 1, i, 5 + i);
    snaps.push_back(syn.snapshot);
  }
  const AppResult r =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.path(), "--graph", dir.file("out/g"), "--weight-scale", "4"});
  EXPECT_EQ(r.code, 1);  // the output directory does not exist: refused before any work
  EXPECT_TRUE(contains(r.err, "out/g.graphbin")) << r.err;
  std::filesystem::create_directory(dir.file("out"));
  // The default graph: the sequence information counted once (sequence_information.h).
  const AppResult seq =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.path(), "--graph", dir.file("out/s"), "--weight-scale", "4"});
  ASSERT_EQ(seq.code, 0) << seq.err;
  EXPECT_TRUE(contains(seq.err, "covisibility export of")) << seq.err;
  EXPECT_TRUE(contains(seq.err, "KL to the dense information")) << seq.err;
  const PoseGraph sg =
      mrpt_bridge::fromNetwork(mrpt_bridge::readGraphBinary(dir.file("out/s.graphbin")));
  EXPECT_EQ(sg.nodes.size(), 7u);
  for (const PoseGraphEdge& e : sg.edges) {
    Matrix6d unused;
    EXPECT_TRUE(informationOf(e.information.inverse(), &unused)) << e.from << "->" << e.to;
  }
  // The old per-snapshot graph, named as what it is.
  const AppResult ok =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.path(), "--graph", dir.file("out/g"), "--weight-scale", "4",
                       "--graph-edges", "snapshot-marginals-not-fusable"});
  ASSERT_EQ(ok.code, 0) << ok.err;
  EXPECT_TRUE(contains(ok.err, "1 keyframe pairs got no graph edge")) << ok.err;
  for (const char* ext : {".graphbin", ".graph", ".g2o", ".nodes.csv"})
    EXPECT_TRUE(std::filesystem::exists(dir.file(std::string("out/g") + ext))) << ext;
  const PoseGraph g =
      mrpt_bridge::fromNetwork(mrpt_bridge::readGraphBinary(dir.file("out/g.graphbin")));
  ASSERT_EQ(g.nodes.size(), 7u);
  // Nodes take their latest estimate; edges the last snapshot with both keyframes.
  for (int k = 0; k < 7; ++k)
    EXPECT_LT((g.nodes.at(k).matrix() - snaps[2].T_wc(k).matrix()).norm(), 1e-12) << "node " << k;
  // The default pipeline's covariance (self-calibrated) of the last snapshot.
  PipelineOptions p;
  p.engine.weight_scale = 4;
  const PipelineResult result = computeCovariance(snaps[2], p);
  const DbaCovariance& last = *result.cov;
  for (const PoseGraphEdge& e : g.edges) {
    EXPECT_LT(e.from, e.to);
    if (e.from == 0 && e.to == 1) ADD_FAILURE() << "the gauge pair has no information";
    if (e.from >= 2) {  // pairs that the last snapshot does not fix
      Matrix6d expected;
      ASSERT_TRUE(informationOf(last.relative(e.from, e.to), &expected));
      EXPECT_LT((e.information - expected).norm(), 1e-9 * expected.norm())
          << e.from << "->" << e.to;
    }
  }
  const auto lines = testing::splitLines(testing::readFile(dir.file("out/g.nodes.csv")));
  EXPECT_EQ(lines.front(), "node,tstamp,time_s");
  EXPECT_EQ(lines.size(), 8u);
  EXPECT_EQ(lines[2], "1,3,1000.15");  // tstamp 3 at 20 Hz from 1000 s
}

}  // namespace
}  // namespace dbacov
