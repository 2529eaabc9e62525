// Rawlogs in and out: the snapshot observation class, the real rawlog-edit (with and without the
// plugin), and the chain .npz → droid2rawlog → dba-covariance -o.
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>
#include <mrpt/obs/CObservationRobotPose.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/droid2rawlog_app.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/pipeline.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/observation_dba_snapshot.h"
#include "dbacov/mrpt/pose_conversion.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "dbacov/sim/sensor_modes.h"
#include "fixtures.h"
#include "gz_members.h"
#include "snapshot_compare.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

using testing::AppResult;

const std::string kBin = std::string(DBACOV_BINARY_DIR) + "/bin/";
const std::string kPlugin = std::string(DBACOV_BINARY_DIR) + "/lib/libdbacov_mrpt.so";
// MRPT's own rawlog-edit; DBACOV_PLUGIN_ENV preloads the sanitizer runtime that an instrumented
// plugin needs (empty in normal builds, see CMakeLists.txt).
const std::string kRawlogEdit = std::string(DBACOV_PLUGIN_ENV) + "rawlog-edit ";
const std::string kShared = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

bool contains(const std::string& hay, const std::string& needle) {
  return hay.find(needle) != std::string::npos;
}

AppResult covariance(const std::vector<std::string>& args) {
  return testing::runApp(app::runCovarianceApp, "dba-covariance", args);
}
AppResult droid2rawlog(const std::vector<std::string>& args) {
  return testing::runApp(app::runDroid2RawlogApp, "droid2rawlog", args);
}

/// The "Overall number of objects" line of `rawlog-edit --info`.
int rawlogEditObjectCount(const std::string& rawlog, bool plugin) {
  const AppResult r = testing::runCommand(
      kRawlogEdit + (plugin ? "-p " + kPlugin + " " : std::string()) + "--info -i " + rawlog);
  const auto pos = r.out.find("Overall number of objects");
  if (r.code != 0 || pos == std::string::npos) return -1;
  return std::stoi(r.out.substr(r.out.find(':', pos) + 1));
}

std::vector<mrpt::obs::CObservationRobotPose::Ptr> readPoses(const std::string& path) {
  std::vector<mrpt::obs::CObservationRobotPose::Ptr> out;
  mrpt_bridge::RawlogReader reader(path);
  while (auto obj = reader.next()) {
    auto p = std::dynamic_pointer_cast<mrpt::obs::CObservationRobotPose>(obj);
    EXPECT_TRUE(p) << "unexpected class in " << path;
    if (p) out.push_back(p);
  }
  return out;
}

/// How many of the file's gzip members (GzOutputStream's, with the 'DB' size subfield) start with
/// a stored deflate block.
int storedMembers(const std::string& path) {
  const std::vector<unsigned char> f = testing::fileBytes(path);
  int stored = 0;
  for (const std::size_t at : testing::members(f)) stored += testing::firstBlockType(f, at) == 0;
  return stored;
}

using ::dbacov::testing::expectSameSnapshot;

TEST(Rawlog, SnapshotObservationRoundTrip) {
  testing::TempDir dir;
  const auto a = testing::tinySnapshot(1, 5), b = testing::tinySnapshot(2, 9);
  {
    mrpt_bridge::RawlogWriter w(dir.file("s.rawlog"));
    for (const auto* syn : {&a, &b}) {
      CObservationDbaSnapshot obs;
      obs.snapshot = syn->snapshot;
      obs.timestamp = mrpt::Clock::fromDouble(1234.5);
      obs.sensorLabel = "LABEL";
      w.write(obs);
    }
    w.commit();
  }
  mrpt_bridge::RawlogReader reader(dir.file("s.rawlog"));
  for (const auto* syn : {&a, &b}) {
    auto obs = std::dynamic_pointer_cast<CObservationDbaSnapshot>(reader.next());
    ASSERT_TRUE(obs);
    expectSameSnapshot(obs->snapshot, syn->snapshot);
    EXPECT_EQ(obs->sensorLabel, "LABEL");
    EXPECT_DOUBLE_EQ(mrpt::Clock::toDouble(obs->timestamp), 1234.5);
  }
  EXPECT_FALSE(reader.next());
}

TEST(Rawlog, DroidModesSurviveTheRawlog) {
  // Stereo edges with their rig, RGB-D readings and DROID's t0 (serialization version 1): the
  // record carries every key of conventions §1, so droid2rawlog and simul-dba --rawlog lose none.
  testing::TempDir dir;
  Snapshot s = testing::tinySnapshot(3, 4).snapshot;
  sim::addStereoEdges(s, sim::StereoConfig{});
  sim::addSensorDepth(s, sim::RgbdConfig{});
  s.t0 = 1;
  s.validate();
  {
    mrpt_bridge::RawlogWriter w(dir.file("s.rawlog"));
    CObservationDbaSnapshot obs;
    obs.snapshot = s;
    w.write(obs);
    w.commit();
  }
  mrpt_bridge::RawlogReader reader(dir.file("s.rawlog"));
  auto obs = std::dynamic_pointer_cast<CObservationDbaSnapshot>(reader.next());
  ASSERT_TRUE(obs);
  ASSERT_TRUE(obs->snapshot.stereo_rig && obs->snapshot.disps_sens && obs->snapshot.t0);
  expectSameSnapshot(obs->snapshot, s);
  EXPECT_FALSE(reader.next());
  // Through droid2rawlog from a .npz too.
  io::saveSnapshotNpz(dir.file("s.npz"), s);
  ASSERT_EQ(droid2rawlog({"-i", dir.file("s.npz"), "-o", dir.file("d.rawlog"), "-q"}).code, 0);
  mrpt_bridge::RawlogReader converted(dir.file("d.rawlog"));
  auto again = std::dynamic_pointer_cast<CObservationDbaSnapshot>(converted.next());
  ASSERT_TRUE(again);
  expectSameSnapshot(again->snapshot, s, /*intrinsics_as_float32=*/true);
}

TEST(Rawlog, RawlogEditReadsSnapshotsOnlyWithThePlugin) {
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 0);
  testing::writeTinySnapshot(dir.file("b.npz"), 2, 1);
  testing::writeTinySnapshot(dir.file("c.npz"), 3, 2);
  ASSERT_EQ(droid2rawlog({"-i", dir.path(), "-o", dir.file("s.rawlog"), "-q"}).code, 0);
  EXPECT_EQ(rawlogEditObjectCount(dir.file("s.rawlog"), true), 3);
  // Without the plugin MRPT stops at the unknown class and still exits 0 (conventions §6).
  EXPECT_LT(rawlogEditObjectCount(dir.file("s.rawlog"), false), 3);
  const AppResult info =
      testing::runCommand(kRawlogEdit + "-p " + kPlugin + " --info -i " + dir.file("s.rawlog"));
  EXPECT_TRUE(contains(info.out, "DBA_SNAPSHOT /      3")) << info.out;
}

TEST(Rawlog, Droid2RawlogTimesAndInfo) {
  testing::TempDir dir;
  auto syn = testing::tinySnapshot(4, 3);
  syn.snapshot.timestamps_s.reset();
  io::saveSnapshotNpz(dir.file("a.npz"), syn.snapshot);
  // Without keyframe times and without --fps the snapshot cannot be timestamped.
  AppResult r = droid2rawlog({"-i", dir.file("a.npz"), "-o", dir.file("s.rawlog")});
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, "a.npz (snapshot 3)")) << r.err;
  EXPECT_TRUE(contains(r.err, "--fps")) << r.err;
  r = droid2rawlog({"-i", dir.file("a.npz"), "-o", dir.file("s.rawlog"), "--fps", "10", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  mrpt_bridge::RawlogReader reader(dir.file("s.rawlog"));
  auto obs = std::dynamic_pointer_cast<CObservationDbaSnapshot>(reader.next());
  ASSERT_TRUE(obs);
  const int newest = syn.snapshot.graphKeyframes().back();
  EXPECT_DOUBLE_EQ(mrpt::Clock::toDouble(obs->timestamp), syn.snapshot.tstamp[newest] / 10);
  ASSERT_TRUE(obs->snapshot.timestamps_s);
  EXPECT_DOUBLE_EQ((*obs->snapshot.timestamps_s)[2], syn.snapshot.tstamp[2] / 10);

  r = droid2rawlog({"--info", dir.file("s.rawlog"), dir.file("a.npz")});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(testing::splitLines(r.out).size(), 2u) << r.out;
  EXPECT_TRUE(contains(r.out, "s.rawlog#0: snapshot 3, 6 keyframes")) << r.out;
  EXPECT_EQ(droid2rawlog({"-i", dir.file("a.npz")}).code, 2);
  EXPECT_EQ(droid2rawlog({"--info", dir.file("a.npz"), "-o", dir.file("x.rawlog")}).code, 2);
}

TEST(Rawlog, CorruptRawlogNamesFileAndEntry) {
  testing::TempDir dir;
  for (int i = 0; i < 3; ++i)
    testing::writeTinySnapshot(dir.file("s" + std::to_string(i) + ".npz"), i + 1, i);
  ASSERT_EQ(droid2rawlog({"-i", dir.path(), "-o", dir.file("s.rawlog"), "-q"}).code, 0);
  // Truncate the (uncompressed) stream inside the third object: re-compress a cut copy.
  ASSERT_EQ(std::system(("cd " + dir.path() + " && gzip -dc s.rawlog | head -c " +
                         std::to_string(2 * 18000 + 5000) + " | gzip > cut.rawlog")
                            .c_str()),
            0);
  const AppResult r =
      covariance({"-i", dir.file("cut.rawlog"), "--csv", dir.file("o.csv"), "--weight-scale", "4"});
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(contains(r.err, "cut.rawlog: entry ")) << r.err;
  EXPECT_TRUE(contains(r.err, "snapshot record truncated in '")) << r.err;
  EXPECT_FALSE(contains(r.err, "Call stack")) << r.err;
  // Whatever came before the cut was processed and written.
  const auto lines = testing::splitLines(testing::readFile(dir.file("o.csv")));
  EXPECT_GE(lines.size(), 1u + 6);
}

TEST(Rawlog, ChainNpzToRawlogToPoseRawlog) {
  testing::TempDir dir;
  std::vector<sim::SyntheticSnapshot> syn;
  for (int i = 0; i < 3; ++i)
    syn.push_back(testing::writeTinySnapshot(dir.file("s" + std::to_string(i) + ".npz"), i + 1,
                                             10 + i, 5 + i));
  ASSERT_EQ(droid2rawlog({"-i", dir.path(), "-o", dir.file("snap.rawlog"), "-q"}).code, 0);
  DbaOptions o = DbaOptions::droid();
  o.weight_scale = 4;

  // latest: the newest keyframe of each snapshot, mean T_wc, covariance J Σ Jᵀ.
  AppResult r = covariance({"-i", dir.file("snap.rawlog"), "-o", dir.file("latest.rawlog"),
                            "--weight-scale", "4", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  auto poses = readPoses(dir.file("latest.rawlog"));
  ASSERT_EQ(poses.size(), 3u);
  EXPECT_EQ(rawlogEditObjectCount(dir.file("latest.rawlog"), false), 3);
  for (int i = 0; i < 3; ++i) {
    const Snapshot& s = syn[i].snapshot;
    const int k = s.graphKeyframes().back();
    // The default pipeline (self-calibrated), named so by the observations' label.
    PipelineOptions p;
    p.engine = o;
    const PipelineResult result = computeCovariance(s, p);
    const DbaCovariance& cov = *result.cov;
    const auto expected = mrpt_bridge::toPoseGaussian(s.T_wc(k), cov.marginal(k));
    EXPECT_EQ(poses[i]->sensorLabel, "DBA_COVARIANCE_CALIBRATED");
    EXPECT_DOUBLE_EQ(mrpt::Clock::toDouble(poses[i]->timestamp), (*s.timestamps_s)[k]);
    EXPECT_NEAR((poses[i]->pose.mean.translation() - expected.mean.translation()).norm(), 0, 1e-12);
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b)
        EXPECT_NEAR(poses[i]->pose.cov(a, b), expected.cov(a, b), 1e-12 * expected.cov.norm());
  }

  // all: every graph keyframe of every snapshot.
  r = covariance({"-i", dir.file("snap.rawlog"), "-o", dir.file("all.rawlog"), "--weight-scale",
                  "4", "--emit", "all", "--label", "X", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(readPoses(dir.file("all.rawlog")).size(), 5u + 6u + 7u);
  EXPECT_EQ(readPoses(dir.file("all.rawlog")).front()->sensorLabel, "X");

  // final: each keyframe once (7 distinct), in time order, from the last snapshot holding it.
  // (the stated model here: the engine's covariance, DBA_COVARIANCE)
  r = covariance({"-i", dir.file("snap.rawlog"), "-o", dir.file("final.rawlog"), "--weight-scale",
                  "4", "--emit", "final", "-q", "--stated-model"});
  ASSERT_EQ(r.code, 0) << r.err;
  poses = readPoses(dir.file("final.rawlog"));
  ASSERT_EQ(poses.size(), 7u);
  EXPECT_EQ(poses.front()->sensorLabel, "DBA_COVARIANCE");
  const DbaCovariance last(syn[2].snapshot, o);
  for (int k = 0; k < 7; ++k) {
    EXPECT_DOUBLE_EQ(mrpt::Clock::toDouble(poses[k]->timestamp),
                     (*syn[2].snapshot.timestamps_s)[k]);
    const auto expected = mrpt_bridge::toPoseGaussian(syn[2].snapshot.T_wc(k), last.marginal(k));
    EXPECT_NEAR((poses[k]->pose.cov - expected.cov).norm(), 0, 1e-12 * (1 + expected.cov.norm()));
  }
}

TEST(Rawlog, SharedDroidSnapshotThroughTheChain) {
  if (!std::filesystem::exists(kShared)) GTEST_SKIP() << "missing " << kShared;
  testing::TempDir dir;
  ASSERT_EQ(droid2rawlog({"-i", kShared, "-o", dir.file("snap.rawlog"), "--fps", "20", "-q"}).code,
            0);
  // The snapshot's flows barely compress, so they are stored blocks, which MRPT reads too.
  EXPECT_GE(storedMembers(dir.file("snap.rawlog")), 3);
  EXPECT_EQ(rawlogEditObjectCount(dir.file("snap.rawlog"), true), 1);
  const AppResult r = covariance({"-i", dir.file("snap.rawlog"), "-o", dir.file("poses.rawlog"),
                                  "--emit", "all", "--csv", dir.file("c.csv"), "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(rawlogEditObjectCount(dir.file("poses.rawlog"), false), 10);
  const auto poses = readPoses(dir.file("poses.rawlog"));
  ASSERT_EQ(poses.size(), 10u);
  EXPECT_DOUBLE_EQ(mrpt::Clock::toDouble(poses.back()->timestamp), 55.0 / 20);
  // The snapshot read back from the rawlog is the .npz, bit for bit.
  mrpt_bridge::RawlogReader reader(dir.file("snap.rawlog"));
  auto obs = std::dynamic_pointer_cast<CObservationDbaSnapshot>(reader.next());
  ASSERT_TRUE(obs);
  Snapshot npz = io::loadSnapshotNpz(kShared, 0);
  deriveKeyframeTimes(npz, 20);
  expectSameSnapshot(obs->snapshot, npz);
}

}  // namespace
}  // namespace dbacov
