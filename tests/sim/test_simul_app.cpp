// simul-dba end to end: the demo's command line, outputs against the in-process simulator and the
// trajectory definition, configuration files and overrides, rawlog output, bad usage.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/simul_app.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "dbacov/sim/scenario.h"
#include "snapshot_compare.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

using testing::AppResult;
using testing::expectSameSnapshot;

AppResult simul(const std::vector<std::string>& args) {
  return testing::runApp(app::runSimulApp, "simul-dba", args);
}

bool contains(const std::string& hay, const std::string& needle) {
  return hay.find(needle) != std::string::npos;
}

TEST(SimulApp, DemoCommandLineWritesSolvedSnapshotsAndTheirGroundTruth) {
  testing::TempDir dir;
  // scripts/demo.sh: simul-dba -o DIR --snapshots 5 --seed 1, then dba-covariance --weight-scale 4.
  const AppResult r = simul({"-o", dir.path(), "--snapshots", "5", "--seed", "1"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "wrote 5 snapshots")) << r.out;
  EXPECT_TRUE(contains(r.out, "5 converged")) << r.out;
  EXPECT_EQ(dir.entries(),
            (std::vector<std::string>{"groundtruth.tum", "scenario.json", "snapshot_0000.npz",
                                      "snapshot_0001.npz", "snapshot_0002.npz", "snapshot_0003.npz",
                                      "snapshot_0004.npz"}));
  // The last snapshot is the simulator's, bit for bit: defaults = 48×64, window 8, weight scale 4.
  sim::ScenarioConfig c;
  c.trajectory.num_keyframes = 12;
  const sim::Scenario sc(c);
  const Snapshot s4 = io::loadSnapshotNpz(dir.file("snapshot_0004.npz"), 4);
  EXPECT_EQ(s4.H, 48);
  EXPECT_EQ(s4.W, 64);
  expectSameSnapshot(s4, sc.simulate(4, 0).snapshot, true);
  // Ground truth: every keyframe, t tx ty tz qx qy qz qw, camera-to-world, full precision.
  const auto lines = testing::splitLines(testing::readFile(dir.file("groundtruth.tum")));
  ASSERT_EQ(lines.size(), 12u);
  for (int k = 0; k < 12; ++k) {
    std::istringstream is(lines[k]);
    double v[8];
    for (double& x : v) ASSERT_TRUE(is >> x);
    EXPECT_EQ(v[0], 1.7e9 + 3.0 * k / 20.0);
    const Eigen::Isometry3d T = sim::trajectoryPose(c.trajectory, k);
    const auto tq = poseToTQ(T);
    for (int q = 0; q < 7; ++q) EXPECT_EQ(v[q + 1], tq[q]) << "keyframe " << k;
  }
  // dba-covariance takes them as they are.
  const AppResult cov =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.path(), "--weight-scale", "4", "--csv", dir.file("c.csv"), "-q"});
  EXPECT_EQ(cov.code, 0) << cov.err;
}

TEST(SimulApp, ConfigFileThenOptionsAndTheEffectiveConfigurationIsWritten) {
  testing::TempDir dir;
  {
    std::ofstream f(dir.file("s.json"));
    f << R"({"mode": "whole", "camera": {"height": 10, "width": 12},
             "trajectory": {"type": "loop", "keyframes": 6, "keyframes_per_lap": 12},
             "noise": {"model": "correlated", "correlation_length_px": 2}, "seed": 5})";
  }
  const AppResult r = simul(
      {"-o", dir.file("out"), "--config", dir.file("s.json"), "--width", "14", "--no-solve", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "");  // -q
  const Snapshot s = io::loadSnapshotNpz(dir.file("out/snapshot_0000.npz"), 0);
  EXPECT_EQ(s.numKeyframes(), 6);
  EXPECT_EQ(s.H, 10);
  EXPECT_EQ(s.W, 14);
  const std::string json = testing::readFile(dir.file("out/scenario.json"));
  EXPECT_TRUE(contains(json, "\"correlated\"")) << json;
  EXPECT_TRUE(contains(json, "\"solve\": false")) << json;
  // Running from the written configuration reproduces the run.
  ASSERT_EQ(simul({"-o", dir.file("again"), "--config", dir.file("out/scenario.json"), "-q"}).code,
            0);
  expectSameSnapshot(io::loadSnapshotNpz(dir.file("again/snapshot_0000.npz"), 0), s, true);
}

TEST(SimulApp, RawlogHoldsTheSameSnapshots) {
  testing::TempDir dir;
  const AppResult r =
      simul({"-o", dir.path(), "--height", "8", "--width", "10", "--snapshots", "2", "--window",
             "3", "--rawlog", dir.file("s.rawlog"), "--no-npz", "--run", "2", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("snapshot_0000.npz")));
  sim::ScenarioConfig c;
  c.camera.H = 8;
  c.camera.W = 10;
  c.window = 3;
  c.trajectory.num_keyframes = 4;
  const sim::Scenario sc(c);
  int n = 0;
  mrpt_bridge::RawlogSnapshotReader reader(dir.file("s.rawlog"), 0);
  for (Snapshot s; reader.next(&s); ++n) {
    EXPECT_NO_THROW(s.validate());
    expectSameSnapshot(s, sc.simulate(n, 2).snapshot);  // a rawlog keeps float64
  }
  EXPECT_EQ(n, 2);
}

TEST(SimulApp, StereoAndRgbdSnapshotsCarryTheirFactorsAndDroidsGauge) {
  for (const std::string sensor : {"stereo", "rgbd"}) {
    SCOPED_TRACE(sensor);
    testing::TempDir dir;
    const AppResult r = simul({"-o", dir.path(), "--sensor", sensor, "--gauge", "droid",
                               "--snapshots", "2", "--height", "12", "--width", "16", "-q"});
    ASSERT_EQ(r.code, 0) << r.err;
    const Snapshot s1 = io::loadSnapshotNpz(dir.file("snapshot_0001.npz"), 1);
    EXPECT_EQ(s1.t0, std::optional<std::int64_t>(2));  // snapshot 1's graph starts at keyframe 1
    int stereo_edges = 0;
    for (int e = 0; e < s1.numEdges(); ++e) stereo_edges += s1.ii[e] == s1.jj[e];
    if (sensor == "stereo") {
      ASSERT_TRUE(s1.stereo_rig);
      EXPECT_EQ(s1.stereo_rig->head<3>(), Eigen::Vector3d(-0.1, 0, 0));
      EXPECT_EQ(stereo_edges, 8);  // one per keyframe of the window
      EXPECT_FALSE(s1.disps_sens);
    } else {
      ASSERT_TRUE(s1.disps_sens);
      EXPECT_EQ(stereo_edges, 0);
      int readings = 0;
      for (float d : *s1.disps_sens) readings += d > 0;
      EXPECT_GT(readings, 8 * 12 * 16 / 2);
    }
    // dba-covariance with the same gauge (and, for RGB-D, the simulated α) holds one keyframe.
    std::vector<std::string> args{"-i",    dir.path(), "--weight-scale",  "4", "--gauge",
                                  "droid", "--csv",    dir.file("c.csv"), "-q"};
    if (sensor == "rgbd") args.insert(args.end(), {"--sensor-depth-weight", "400"});
    const AppResult cov = testing::runApp(app::runCovarianceApp, "dba-covariance", args);
    ASSERT_EQ(cov.code, 0) << cov.err;
  }
  testing::TempDir dir;
  const AppResult mono = simul({"-o", dir.file("mono"), "--gauge", "droid"});
  EXPECT_EQ(mono.code, 2);
  EXPECT_TRUE(contains(mono.err, "--sensor stereo or rgbd")) << mono.err;
  EXPECT_TRUE(dir.entries().empty());
}

TEST(SimulApp, BadUsageAndFailuresAreReported) {
  testing::TempDir dir;
  AppResult r = simul({"--snapshots", "2"});
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.err, "--out-dir is required")) << r.err;
  r = simul({"-o", dir.path(), "--config", dir.file("missing.json")});
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.err, dir.file("missing.json") + ": cannot open")) << r.err;
  {
    std::ofstream f(dir.file("bad.json"));
    f << R"({"noise": {"model": "pink"}})";
  }
  r = simul({"-o", dir.path(), "--config", dir.file("bad.json")});
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.err, "bad.json: key 'noise.model': unknown noise model 'pink'")) << r.err;
  r = simul({"-o", dir.path(), "--no-npz"});
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.err, "--rawlog")) << r.err;
  r = simul({"-o", dir.path(), "--mode", "whole", "--snapshots", "3"});
  EXPECT_EQ(r.code, 2);
  r = simul({"-o", dir.path(), "--window", "9", "--keyframes", "4"});
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.err, "window")) << r.err;
  // Numbers out of their range, or no numbers, are named as such (nothing written).
  for (const auto& [args, message] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--height", "1"}, "simul-dba: --height: 1 is not in 2..4096\n"},
           {{"--width", "2.5"}, "simul-dba: --width: '2.5' is not an integer in 2..4096\n"},
           {{"--snapshots", "many"},
            "simul-dba: --snapshots: 'many' is not an integer in "
            "1..1000000\n"},
           {{"--overlap-threshold", "2"}, "simul-dba: --overlap-threshold: 2 is not in [0, 1]\n"},
           {{"--overlap-threshold", "nan"},
            "simul-dba: --overlap-threshold: nan is not in [0, 1]\n"},
           {{"--overlap-threshold", "x"},
            "simul-dba: --overlap-threshold: 'x' is not a number in [0, 1]\n"}}) {
    std::vector<std::string> full = {"-o", dir.file("ranges")};
    full.insert(full.end(), args.begin(), args.end());
    r = simul(full);
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_TRUE(contains(r.err, message)) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("ranges")));
  }
  // An unknown flow estimator, before anything is written (this test program registers none).
  r = simul({"-o", dir.file("flow"), "--flow", "bogus"});
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.err, "flow source 'bogus' (--flow, flow.source)")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("flow")));
  // An output that cannot be created: exit 1.
  { std::ofstream f(dir.file("file")); }
  r = simul({"-o", dir.file("file") + "/sub", "--height", "8", "--width", "10", "--snapshots", "1",
             "-q"});
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, "cannot create the output directory")) << r.err;
}

TEST(SimulApp, HelpDocumentsEveryOptionAndTheConventions) {
  const AppResult r = simul({"--help"});
  ASSERT_EQ(r.code, 0);
  for (const char* opt : {"--out-dir",
                          "--rawlog",
                          "--label",
                          "--no-npz",
                          "--run",
                          "--quiet",
                          "--config",
                          "--mode",
                          "--trajectory",
                          "--keyframes",
                          "--snapshots",
                          "--window",
                          "--height",
                          "--width",
                          "--edge-radius",
                          "--overlap-threshold",
                          "--weights",
                          "--weight-min",
                          "--weight-max",
                          "--zero-fraction",
                          "--noise",
                          "--correlation-length",
                          "--noise-amplitude",
                          "--weight-scale",
                          "--gauge",
                          "--seed",
                          "--fps",
                          "--start-time",
                          "--no-solve",
                          "camera-to-world",
                          "AT THE TRUTH",
                          "Exit status"})
    EXPECT_TRUE(contains(r.out, opt)) << opt;
}

// --set KEY=VALUE: any setting of the scenario schema by its JSON key, the ones without a flag
// too, applied after the flags; a number, a name, a vector; bad ones are bad usage naming them.
TEST(SimulApp, SetGivesEverySettingByItsKey) {
  testing::TempDir dir;
  const AppResult r = simul({"-o",
                             dir.file("out"),
                             "--mode",
                             "whole",
                             "--keyframes",
                             "4",
                             "--height",
                             "10",
                             "--width",
                             "14",
                             "--no-solve",
                             "-q",
                             "--noise-amplitude",
                             "2",
                             "--set",
                             "noise.outlier_fraction=0.02",
                             "--set",
                             "noise.model=correlated",
                             "--set",
                             "noise.amplitude=3",
                             "--set",
                             "scene.min=[-4, -2, -1]"});
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string json = testing::readFile(dir.file("out/scenario.json"));
  EXPECT_TRUE(contains(json, "\"outlier_fraction\": 0.02")) << json;
  EXPECT_TRUE(contains(json, "\"correlated\"")) << json;
  EXPECT_TRUE(contains(json, "\"amplitude\": 3.0")) << json;  // --set after the flag
  EXPECT_TRUE(contains(json, "-4.0")) << json;
  for (const auto& [arg, message] : std::vector<std::pair<std::string, std::string>>{
           {"noise.outlier_fraction",
            "simul-dba: --set 'noise.outlier_fraction': expected KEY=VALUE"},
           {"noise.bogus=1",
            "simul-dba: --set: unknown scenario key 'noise.bogus'; the keys: seed"},
           {"noise.amplitude=loud", "--set noise.amplitude"},
           {"noise.model=purple", "--set noise.model"}}) {
    const AppResult bad = simul({"-o", dir.file("bad"), "-q", "--set", arg});
    EXPECT_EQ(bad.code, 2) << arg << ": " << bad.err;
    EXPECT_TRUE(contains(bad.err, message)) << bad.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("bad"))) << arg;
  }
}

}  // namespace
}  // namespace dbacov
