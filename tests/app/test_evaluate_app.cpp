// dba-evaluate end to end: simul-dba → dba-covariance (tables and pose rawlog) → dba-evaluate, with
// the NEES of every sample checked against a direct computation (engine covariances, simulator
// truth, NEES by a Cholesky solve), ground truth in TUM and EuRoC form, image-time lists, the sim3
// alignment, the Monte Carlo mode with calibration, and bad usage.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <nlohmann/json.hpp>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/csv_format.h"
#include "dbacov/app/evaluate_app.h"
#include "dbacov/app/evaluation_inputs.h"
#include "dbacov/app/simul_app.h"
#include "dbacov/core/covariance.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/sim/consistency.h"
#include "dbacov/sim/monte_carlo.h"
#include "dbacov/sim/scenario.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

using testing::AppResult;

AppResult evaluate(const std::vector<std::string>& args) {
  return testing::runApp(app::runEvaluateApp, "dba-evaluate", args);
}

bool contains(const std::string& hay, const std::string& needle) {
  return hay.find(needle) != std::string::npos;
}

/// eᵀ Σ⁻¹ e by a Cholesky solve (the reference for full-rank covariances).
double referenceNees(const Eigen::Isometry3d& T_est, const Eigen::Isometry3d& T_true,
                     const Matrix6d& Sigma) {
  const Vector6d e = logSE3(T_est.inverse() * T_true);
  return e.dot(Sigma.llt().solve(e));
}

/// The simulated sequence shared by the file-mode tests: 3 sliding-window snapshots.
struct Fixture {
  testing::TempDir dir;
  sim::ScenarioConfig config;
  Fixture() {
    config.camera.H = 12;
    config.camera.W = 16;
    config.window = 4;
    config.trajectory.num_keyframes = 6;
    config.weight_scale = 400;
    EXPECT_EQ(testing::runApp(app::runSimulApp, "simul-dba",
                              {"-o", dir.file("sim"), "--height", "12", "--width", "16", "--window",
                               "4", "--snapshots", "3", "--weight-scale", "400", "-q"})
                  .code,
              0);
    const AppResult r =
        testing::runApp(app::runCovarianceApp, "dba-covariance",
                        {"-i", dir.file("sim"), "--weight-scale", "400", "--csv",
                         dir.file("kf.csv"), "--relative-csv", dir.file("rel.csv"), "-o",
                         dir.file("poses.rawlog"), "--emit", "all", "-q", "--stated-model"});
    EXPECT_EQ(r.code, 0) << r.err;
  }
  std::vector<std::string> tableArgs() const {
    return {"--csv",          dir.file("kf.csv"),
            "--relative-csv", dir.file("rel.csv"),
            "--gt",           dir.file("sim/groundtruth.tum"),
            "--fps",          "20",
            "--start-time",   "1.7e9"};
  }
};

/// section → (run, group) → NEES, from --samples-csv.
std::map<std::string, std::map<std::pair<long, std::string>, double>> readSamples(
    const std::string& path) {
  std::map<std::string, std::map<std::pair<long, std::string>, double>> out;
  const auto lines = testing::splitLines(testing::readFile(path));
  EXPECT_EQ(lines.at(0).substr(0, 30), "section,run,group,dof,nees,e_0");
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto f = testing::splitCsv(lines[i]);
    out[f[0]][{std::stol(f[1]), f[2]}] = std::stod(f[4]);
  }
  return out;
}

TEST(EvaluateApp, TablesGiveTheNeesOfADirectComputation) {
  Fixture fx;
  auto args = fx.tableArgs();
  for (const char* a : {"--samples-csv", "samples.csv", "--json", "out.json"})
    args.push_back(a[0] == '-' ? a : fx.dir.file(a));
  const AppResult r = evaluate(args);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "absolute NEES")) << r.out;
  EXPECT_TRUE(contains(r.out, "relative NEES")) << r.out;
  const auto samples = readSamples(fx.dir.file("samples.csv"));

  const sim::Scenario sc(fx.config);
  DbaOptions o = DbaOptions::droid();
  o.weight_scale = 400;
  double sum_abs = 0;
  std::size_t n_abs = 0, n_rel = 0;
  for (int s = 0; s < 3; ++s) {
    char name[64];
    std::snprintf(name, sizeof name, "sim/snapshot_%04d.npz", s);
    const Snapshot snap = io::loadSnapshotNpz(fx.dir.file(name), s);
    const DbaCovariance cov(snap, o);
    const auto& kf = cov.keyframes();
    for (std::size_t q = 0; q < kf.size(); ++q) {
      const int k = kf[q];
      if (cov.freeDof(k) == 0) {
        EXPECT_FALSE(
            samples.at("absolute").count({s, "kf" + std::to_string(k)}));  // hard-fixed: no sample
        continue;
      }
      const double ref = referenceNees(snap.T_wc(k), sc.groundTruth()[k], cov.marginal(k));
      EXPECT_NEAR(samples.at("absolute").at({s, "kf" + std::to_string(k)}), ref, 1e-6 * ref)
          << "snapshot " << s << " kf " << k;
      sum_abs += ref;
      ++n_abs;
      if (q + 1 < kf.size() && cov.freeDof(kf[q + 1]) > 0) {
        const int b = kf[q + 1];
        const double rel =
            referenceNees(snap.T_wc(k).inverse() * snap.T_wc(b),
                          sc.groundTruth()[k].inverse() * sc.groundTruth()[b], cov.relative(k, b));
        EXPECT_NEAR(samples.at("relative").at({s, std::to_string(k) + "-" + std::to_string(b)}),
                    rel, 1e-6 * rel);
        ++n_rel;
      }
    }
  }
  EXPECT_EQ(samples.at("absolute").size(), n_abs);
  EXPECT_GE(samples.at("relative").size(),
            n_rel);  // + the pairs of a gauge keyframe and a free one
  const auto j = nlohmann::json::parse(testing::readFile(fx.dir.file("out.json")));
  EXPECT_NEAR(j["absolute"]["anees"].get<double>(), sum_abs / n_abs, 1e-6 * sum_abs / n_abs);
  EXPECT_EQ(j["absolute"]["runs"].get<int>(), 3);
}

TEST(EvaluateApp, RawlogEurocAndImageTimesGiveTheSameNees) {
  Fixture fx;
  ASSERT_EQ(
      evaluate({"--csv", fx.dir.file("kf.csv"), "--gt", fx.dir.file("sim/groundtruth.tum"), "--fps",
                "20", "--start-time", "1.7e9", "--samples-csv", fx.dir.file("a.csv")})
          .code,
      0);
  const auto ref = readSamples(fx.dir.file("a.csv")).at("absolute");

  // The pose rawlog (every keyframe of every snapshot, covariance in [x y z yaw pitch roll]).
  AppResult r =
      evaluate({"--rawlog", fx.dir.file("poses.rawlog"), "--gt", fx.dir.file("sim/groundtruth.tum"),
                "--samples-csv", fx.dir.file("b.csv")});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto raw = readSamples(fx.dir.file("b.csv")).at("rawlog_absolute");
  ASSERT_EQ(raw.size(), ref.size());  // every keyframe of every snapshot; compared as sorted values
  std::vector<double> a, b;
  for (const auto& [key, v] : ref) a.push_back(v);
  for (const auto& [key, v] : raw) b.push_back(v);
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(b[i], a[i], 1e-5 * a[i]);

  // EuRoC ground truth: nanoseconds, body frame (T_wb = T_wc T_bc⁻¹), qw first, extra columns.
  const Eigen::Isometry3d T_bc =
      expSE3((Vector6d() << 0.02, -0.06, 0.01, 1.2, -0.3, 1.5).finished());
  {
    std::ofstream f(fx.dir.file("euroc.csv"));
    f << "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
         "q_RS_z [], v_x\n";
    for (const auto& line :
         testing::splitLines(testing::readFile(fx.dir.file("sim/groundtruth.tum")))) {
      std::istringstream is(line);
      double v[8];
      for (double& x : v) is >> x;
      const Eigen::Isometry3d T_wb = poseFromTQ(v + 1) * T_bc.inverse();
      const auto tq = poseToTQ(T_wb);
      f << static_cast<long long>(std::llround(v[0] * 1e9));
      for (int q : {0, 1, 2, 6, 3, 4, 5}) f << ", " << app::formatDouble(tq[q]);
      f << ", 0.5\n";
    }
  }
  const auto tq_bc = poseToTQ(T_bc);
  std::vector<std::string> args{"--csv",
                                fx.dir.file("kf.csv"),
                                "--gt",
                                fx.dir.file("euroc.csv"),
                                "--fps",
                                "20",
                                "--start-time",
                                "1.7e9",
                                "--samples-csv",
                                fx.dir.file("c.csv"),
                                "--body-to-camera"};
  for (int q = 0; q < 7; ++q) args.push_back(app::formatDouble(tq_bc[q]));
  r = evaluate(args);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto euroc = readSamples(fx.dir.file("c.csv")).at("absolute");
  ASSERT_EQ(euroc.size(), ref.size());
  for (const auto& [key, v] : euroc) EXPECT_NEAR(v, ref.at(key), 1e-5 * v);

  // Image times: tstamp k is line k (seconds).
  {
    std::ofstream f(fx.dir.file("times.txt"));
    f << "# image times\n";
    for (int i = 0; i < 30; ++i) f << app::formatDouble(1.7e9 + i / 20.0) << '\n';
  }
  r = evaluate({"--csv", fx.dir.file("kf.csv"), "--gt", fx.dir.file("sim/groundtruth.tum"),
                "--image-times", fx.dir.file("times.txt"), "--samples-csv", fx.dir.file("d.csv")});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(readSamples(fx.dir.file("d.csv")).at("absolute"), ref);
}

/// Rewrites the tables with every estimate moved by a world similarity (scale s): T → S T,
/// covariance translation rows scaled by s.
void writeTransformedTables(const std::string& kf_in, const std::string& rel_in,
                            const std::string& kf_out, const std::string& rel_out, double s,
                            const Eigen::Isometry3d& G) {
  Vector6d d;
  d << s, s, s, 1, 1, 1;
  {
    std::ofstream f(kf_out);
    f << testing::splitLines(testing::readFile(kf_in)).at(0) << '\n';
    for (const auto& r : app::readKeyframeCsv(kf_in)) {
      Eigen::Isometry3d T = r.T_wc;
      T.translation() = s * T.translation();
      T = G * T;
      f << r.snapshot << ',' << r.keyframe << ',' << app::formatDouble(r.tstamp) << ','
        << app::poseValues(T) << ",0,0,0,0,0,0,"
        << app::upperTriangleValues(d.asDiagonal() * r.Sigma * d.asDiagonal()) << ",stated\n";
    }
  }
  std::ofstream f(rel_out);
  f << testing::splitLines(testing::readFile(rel_in)).at(0) << '\n';
  for (const auto& r : app::readRelativeCsv(rel_in)) {
    Eigen::Isometry3d Z = r.Z;
    Z.translation() *= s;
    f << r.snapshot << ',' << r.from << ',' << r.to << ',' << app::poseValues(Z) << ','
      << app::upperTriangleValues(d.asDiagonal() * r.Sigma * d.asDiagonal()) << ",stated\n";
  }
}

TEST(EvaluateApp, Sim3AlignmentMakesRelativeNeesIndependentOfFrameAndScale) {
  Fixture fx;
  const Eigen::Isometry3d G = expSE3((Vector6d() << 3, -1, 2, 0.3, 1.1, -0.4).finished());
  writeTransformedTables(fx.dir.file("kf.csv"), fx.dir.file("rel.csv"), fx.dir.file("kf2.csv"),
                         fx.dir.file("rel2.csv"), 2.5, G);
  auto run = [&](const std::string& kf, const std::string& rel, const std::string& out,
                 const std::string& align) {
    const AppResult r =
        evaluate({"--csv", kf, "--relative-csv", rel, "--gt", fx.dir.file("sim/groundtruth.tum"),
                  "--fps", "20", "--start-time", "1.7e9", "--align", align, "--samples-csv", out});
    EXPECT_EQ(r.code, 0) << r.err;
    return readSamples(out);
  };
  const auto plain =
      run(fx.dir.file("kf.csv"), fx.dir.file("rel.csv"), fx.dir.file("p.csv"), "none");
  const auto aligned =
      run(fx.dir.file("kf.csv"), fx.dir.file("rel.csv"), fx.dir.file("a.csv"), "sim3");
  const auto moved =
      run(fx.dir.file("kf2.csv"), fx.dir.file("rel2.csv"), fx.dir.file("m.csv"), "sim3");
  EXPECT_FALSE(aligned.count("absolute"));  // no absolute NEES after a fitted alignment
  ASSERT_EQ(aligned.at("relative").size(), plain.at("relative").size());
  for (const auto& [key, v] : aligned.at("relative"))
    EXPECT_NEAR(moved.at("relative").at(key), v, 1e-6 * v)
        << key.second;  // frame and scale do not matter
  // Without the alignment the scaled estimate is far off.
  const auto wrong =
      run(fx.dir.file("kf2.csv"), fx.dir.file("rel2.csv"), fx.dir.file("w.csv"), "none");
  for (const auto& [key, v] : wrong.at("relative"))
    EXPECT_GT(v, 30 * aligned.at("relative").at(key)) << key.second;
}

// dba-evaluate --monte-carlo by default: the NEES are those of the self-calibrated covariances,
// as sim::runMonteCarlo computes them with the default options (and not the stated model's,
// which correlated flow errors make over-confident); --stated-model evaluates the latter.
TEST(EvaluateApp, MonteCarloModeEvaluatesTheSelfCalibratedCovariances) {
  testing::TempDir dir;
  const std::vector<std::string> scene{"--monte-carlo",
                                       "3",
                                       "--height",
                                       "12",
                                       "--width",
                                       "16",
                                       "--mode",
                                       "whole",
                                       "--keyframes",
                                       "5",
                                       "--weight-scale",
                                       "400",
                                       "--noise",
                                       "correlated",
                                       "--correlation-length",
                                       "2",
                                       "-q"};
  const auto aneesOf = [&](const std::vector<std::string>& extra, const std::string& json) {
    std::vector<std::string> args = scene;
    args.insert(args.end(), extra.begin(), extra.end());
    args.insert(args.end(), {"--json", dir.file(json)});
    const AppResult r = evaluate(args);
    EXPECT_EQ(r.code, 0) << r.err;
    return nlohmann::json::parse(testing::readFile(dir.file(json)))["absolute"]["anees"]
        .get<double>();
  };
  const double raw = aneesOf({"--stated-model"}, "raw.json");
  const double cal = aneesOf({}, "cal.json");
  sim::ScenarioConfig c;
  c.camera.H = 12;
  c.camera.W = 16;
  c.mode = sim::SimulationMode::WholeTrajectory;
  c.trajectory.num_keyframes = 5;
  c.weight_scale = 400;
  c.noise.type = sim::NoiseModel::Type::Correlated;
  c.noise.correlation_length_px = 2;
  const sim::Scenario sc(c);
  const SelfCalibrationOptions defaults;
  const auto anees = [&](const SelfCalibrationOptions* calibration) {
    return summarize(sim::runMonteCarlo(sc, 0, 3, c.engineOptions(),
                                        sim::PairSelection::Consecutive, {}, calibration)
                         .samples.absolute)
        .anees;
  };
  const double expected = anees(&defaults), stated = anees(nullptr);
  EXPECT_NEAR(cal, expected, 1e-9 * expected);
  EXPECT_NEAR(raw, stated, 1e-9 * stated);
  EXPECT_GT(std::abs(cal - raw), 0.05 * raw) << "stated " << raw << ", self-calibrated " << cal;
}

TEST(EvaluateApp, MonteCarloModeFitsTheInflationOnTheCalibrationRuns) {
  testing::TempDir dir;
  // The stated model (correlated noise makes it over-confident), fitted k against a reference.
  const AppResult r = evaluate({"--stated-model",
                                "--monte-carlo",
                                "10",
                                "--calibration-runs",
                                "4",
                                "--height",
                                "12",
                                "--width",
                                "16",
                                "--mode",
                                "whole",
                                "--keyframes",
                                "5",
                                "--weight-scale",
                                "400",
                                "--noise",
                                "correlated",
                                "--correlation-length",
                                "2",
                                "--gauge",
                                "minimal",
                                "--json",
                                dir.file("j.json"),
                                "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  // Reference: k = Σ NEES / Σ DoF of the relative NEES of runs 0..3, computed here directly.
  sim::ScenarioConfig c;
  c.camera.H = 12;
  c.camera.W = 16;
  c.mode = sim::SimulationMode::WholeTrajectory;
  c.trajectory.num_keyframes = 5;
  c.weight_scale = 400;
  c.noise.type = sim::NoiseModel::Type::Correlated;
  c.noise.correlation_length_px = 2;
  c.gauge.type = GaugeOptions::Type::Minimal;
  const sim::Scenario sc(c);
  double sum = 0, dof = 0;
  for (int run = 0; run < 4; ++run) {
    const sim::SimulatedSnapshot sim = sc.simulate(0, run);
    const DbaCovariance cov(sim.snapshot, c.engineOptions());
    for (int k = 1; k + 1 < 5;
         ++k) {  // pair 0-1 has 5 DoF (scale fixed): skip it here, count below
      sum +=
          referenceNees(sim.snapshot.T_wc(k).inverse() * sim.snapshot.T_wc(k + 1),
                        sim.T_wc_true[k].inverse() * sim.T_wc_true[k + 1], cov.relative(k, k + 1));
      dof += 6;
    }
    // Pair 0-1: rank 5; NEES on its range by an eigen-decomposition written here.
    const Matrix6d S = cov.relative(0, 1);
    const Vector6d e = logSE3((sim.snapshot.T_wc(0).inverse() * sim.snapshot.T_wc(1)).inverse() *
                              (sim.T_wc_true[0].inverse() * sim.T_wc_true[1]));
    Eigen::SelfAdjointEigenSolver<Matrix6d> es(S);
    for (int q = 1; q < 6; ++q)
      sum += std::pow(es.eigenvectors().col(q).dot(e), 2) / es.eigenvalues()[q];
    dof += 5;
  }
  const auto j = nlohmann::json::parse(testing::readFile(dir.file("j.json")));
  const double k = j["calibration"]["k"].get<double>();
  EXPECT_NEAR(k, sum / dof, 1e-6 * k);
  EXPECT_NEAR(j["calibration"]["calibrated_weight_scale"].get<double>(), 400 / k, 1e-9 * 400 / k);
  EXPECT_GT(k, 2.0);                               // correlated noise: over-confident
  EXPECT_EQ(j["relative"]["runs"].get<int>(), 6);  // held-out runs 4..9
  EXPECT_NEAR(j["relative_calibrated"]["anees"].get<double>(),
              j["relative"]["anees"].get<double>() / k, 1e-9);
  char expected[128];
  std::snprintf(expected, sizeof expected, "dba-covariance --weight-scale %.6g", 400 / k);
  EXPECT_TRUE(contains(r.out, expected)) << r.out;
  EXPECT_TRUE(contains(r.out, "held-out relative NEES")) << r.out;
}

TEST(EvaluateApp, GroundTruthInterpolatesAndRefusesGaps) {
  testing::TempDir dir;
  {
    std::ofstream f(dir.file("gt.tum"));
    f << "# t tx ty tz qx qy qz qw\n";
    for (int i = 0; i <= 10; ++i) {  // 10 Hz, constant velocity, constant rate about z
      const Eigen::Quaterniond q(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitZ()));
      f << app::formatDouble(100 + 0.1 * i) << ' ' << 0.5 * i << " 1 -2 "
        << app::formatDouble(q.x()) << ' ' << app::formatDouble(q.y()) << ' '
        << app::formatDouble(q.z()) << ' ' << app::formatDouble(q.w()) << '\n';
    }
    f << "102 9 9 9 0 0 0 1\n";  // after a 1 s gap
  }
  const app::GroundTruth gt = app::GroundTruth::load(dir.file("gt.tum"));
  EXPECT_EQ(gt.size(), 12u);
  const auto T = gt.at(100.43, 1e-3, 0.2);
  ASSERT_TRUE(T);
  EXPECT_NEAR((T->translation() - Eigen::Vector3d(2.15, 1, -2)).norm(), 0, 1e-9);
  EXPECT_NEAR(Eigen::AngleAxisd(T->linear()).angle(), 0.43, 1e-9);
  EXPECT_FALSE(gt.at(101.5, 1e-3, 0.2));    // inside the gap
  EXPECT_FALSE(gt.at(99.0, 1e-3, 0.2));     // before the first sample
  EXPECT_TRUE(gt.at(102.0005, 1e-3, 0.2));  // within the tolerance of the last one
  {
    std::ofstream f(dir.file("bad.tum"));
    f << "1 2 3\n";
  }
  try {
    app::GroundTruth::load(dir.file("bad.tum"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), "bad.tum:1: 3 fields, expected t tx ty tz qx qy qz qw"))
        << e.what();
  }
}

TEST(EvaluateApp, BadUsageAndBadInputs) {
  Fixture fx;
  auto expectUsage = [](const std::vector<std::string>& args, const std::string& message) {
    const AppResult r = evaluate(args);
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_TRUE(contains(r.err, message)) << r.err;
  };
  expectUsage({}, "nothing to evaluate");
  expectUsage({"--csv", fx.dir.file("kf.csv"), "--gt", fx.dir.file("sim/groundtruth.tum")},
              "--fps");
  expectUsage({"--relative-csv", fx.dir.file("rel.csv"), "--gt", "x", "--fps", "20"},
              "--relative-csv needs --csv");
  expectUsage({"--csv", fx.dir.file("kf.csv"), "--fps", "20"}, "--gt is required");
  expectUsage({"--monte-carlo", "5", "--csv", fx.dir.file("kf.csv")}, "simulates its own data");
  expectUsage({"--monte-carlo", "5", "--calibration-runs", "5"},
              "--calibration-runs must be smaller");
  expectUsage({"--csv", fx.dir.file("kf.csv"), "--gt", "x", "--fps", "20", "--trajectory", "loop"},
              "--monte-carlo only");
  expectUsage({"--rawlog", fx.dir.file("poses.rawlog"), "--gt", "x", "--align", "sim3"},
              "a rawlog has no joint");
  expectUsage({"--monte-carlo", "2", "--gauge-hold", "estimate"},
              "needs each snapshot's gauge held at the truth");
  // Inputs that fail: exit 1, naming the file.
  auto args = fx.tableArgs();
  args[5] = fx.dir.file("missing.tum");
  AppResult r = evaluate(args);
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, "missing.tum: cannot open the ground truth")) << r.err;
  args = fx.tableArgs();
  args[9] = "0";  // wrong start time: no keyframe has ground truth
  r = evaluate(args);
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, "no ground truth at t = ")) << r.err;
  EXPECT_TRUE(contains(r.err, "no sample could be evaluated")) << r.err;
  {
    std::ofstream f(fx.dir.file("broken.csv"));
    f << "snapshot,keyframe\n1,2\n";
  }
  args = fx.tableArgs();
  args[1] = fx.dir.file("broken.csv");
  r = evaluate(args);
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, "broken.csv:1: header has no column 'tstamp'")) << r.err;
}

TEST(EvaluateApp, HelpDocumentsEveryOptionAndWhereTheDefinitionsAre) {
  const AppResult r = evaluate({"--help"});
  ASSERT_EQ(r.code, 0);
  for (const char* opt : {"--csv",
                          "--relative-csv",
                          "--rawlog",
                          "--rawlog-label",
                          "--gt",
                          "--gt-format",
                          "--body-to-camera",
                          "--image-times",
                          "--time-tolerance",
                          "--max-gap",
                          "--align",
                          "--pairs",
                          "--monte-carlo",
                          "--first-run",
                          "--calibration-runs",
                          "--calibrate",
                          "--inflation",
                          "--json",
                          "--samples-csv",
                          "--quiet",
                          "--config",
                          "--weight-scale",
                          "docs/apps/dba-evaluate.md",
                          "docs/conventions.md",
                          "Exit status"})
    EXPECT_TRUE(contains(r.out, opt)) << opt;
}

}  // namespace
}  // namespace dbacov
