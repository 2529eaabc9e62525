// What a new user meets first: help texts without CLI11's range noise that say what -i
// takes and which outputs need keyframe times, a first-line fix when times are missing, the real
// data .graph that MRPT's text loader cannot hold refused with the command to run instead, and the
// simulator's room limit explained.
#include <filesystem>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/droid2rawlog_app.h"
#include "dbacov/app/evaluate_app.h"
#include "dbacov/app/posegraph_app.h"
#include "dbacov/app/simul_app.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

const std::string kShared = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

bool contains(const std::string& hay, const std::string& needle) {
  return hay.find(needle) != std::string::npos;
}

TEST(FirstContact, HelpHasNoRangeAnnotations) {
  const std::vector<std::pair<testing::AppMain, std::string>> apps{
      {app::runCovarianceApp, "dba-covariance"},
      {app::runDroid2RawlogApp, "droid2rawlog"},
      {app::runPoseGraphApp, "dba-posegraph"},
      {app::runSimulApp, "simul-dba"},
      {app::runEvaluateApp, "dba-evaluate"}};
  for (const auto& [main_fn, name] : apps) {
    const auto r = testing::runApp(main_fn, name, {"--help"});
    EXPECT_EQ(r.code, 0) << name;
    EXPECT_TRUE(contains(r.out, "Usage: " + name)) << name;
    EXPECT_FALSE(contains(r.out, " in [")) << name << ":\n" << r.out;
  }
  const auto r = testing::runApp(app::runCovarianceApp, "dba-covariance", {"--help"});
  EXPECT_TRUE(contains(r.out, "--threads UINT ")) << r.out;
  // The ranges are still enforced, and the error names them.
  const auto bad = testing::runApp(app::runCovarianceApp, "dba-covariance",
                                   {"-i", kShared, "--threads", "5000"});
  EXPECT_EQ(bad.code, 2);
  EXPECT_TRUE(contains(bad.err, "4096")) << bad.err;
}

TEST(FirstContact, HelpSaysInputsMayBeRawlogsAndWhichOutputsNeedTimes) {
  const auto r = testing::runApp(app::runCovarianceApp, "dba-covariance", {"--help"});
  ASSERT_EQ(r.code, 0);
  EXPECT_TRUE(contains(r.out, "or a rawlog of snapshots (droid2rawlog)")) << r.out;
  EXPECT_TRUE(contains(r.out, "needs keyframe times: 'timestamps_s' in the snapshots, or --fps"));
  EXPECT_TRUE(contains(r.out, "Camera frame rate: keyframe times = start + tstamp / fps"));
}

TEST(FirstContact, MissingKeyframeTimesGiveTheFixOnTheFirstLine) {
  if (!std::filesystem::exists(kShared)) GTEST_SKIP() << "missing " << kShared;
  testing::TempDir dir;
  const auto r = testing::runApp(app::runCovarianceApp, "dba-covariance",
                                 {"-i", kShared, "-o", dir.file("p.rawlog")});
  EXPECT_EQ(r.code, 1);
  const auto lines = testing::splitLines(r.err);
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines[0], "dba-covariance: error: " + kShared +
                          " (snapshot 55): -o needs keyframe times and the snapshot has none: add "
                          "--fps F (keyframe time = tstamp / F, F = the camera's frame rate), or "
                          "dump the image times as 'timestamps_s'");
  // The fix works.
  const auto ok = testing::runApp(app::runCovarianceApp, "dba-covariance",
                                  {"-i", kShared, "--fps", "20", "-o", dir.file("p.rawlog"), "-q"});
  EXPECT_EQ(ok.code, 0) << ok.err;
  // droid2rawlog says the same.
  const auto d = testing::runApp(app::runDroid2RawlogApp, "droid2rawlog",
                                 {"-i", kShared, "-o", dir.file("s.rawlog")});
  EXPECT_EQ(d.code, 1);
  EXPECT_TRUE(contains(d.err, "no keyframe times: add --fps F")) << d.err;
}

TEST(FirstContact, RealDataGraphTextFileNamesTheGraphbinToRun) {
  if (!std::filesystem::exists(kShared)) GTEST_SKIP() << "missing " << kShared;
  testing::TempDir dir;
  const auto c = testing::runApp(app::runCovarianceApp, "dba-covariance",
                                 {"-i", kShared, "--fps", "20", "--graph", dir.file("seq"), "-q"});
  ASSERT_EQ(c.code, 0) << c.err;
  const auto text =
      testing::runApp(app::runPoseGraphApp, "dba-posegraph",
                      {"-g", dir.file("seq.graph"), "--tum", dir.file("o.tum"), "-q"});
  EXPECT_EQ(text.code, 1);
  const auto lines = testing::splitLines(text.err);
  ASSERT_FALSE(lines.empty());
  EXPECT_TRUE(contains(lines[0], "MRPT's text loader cannot hold this graph")) << text.err;
  EXPECT_TRUE(contains(lines[0], "run dba-posegraph -g " + dir.file("seq.graphbin"))) << text.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.tum")));
  // What it says to run works.
  const auto bin = testing::runApp(app::runPoseGraphApp, "dba-posegraph",
                                   {"-g", dir.file("seq.graphbin"), "--tum", dir.file("o.tum"),
                                    "--nodes", dir.file("seq.nodes.csv"), "-q"});
  EXPECT_EQ(bin.code, 0) << bin.err;
  const auto g2o = testing::runApp(app::runPoseGraphApp, "dba-posegraph",
                                   {"-g", dir.file("seq.g2o"), "--tum", dir.file("o.tum")});
  EXPECT_EQ(g2o.code, 2);
  EXPECT_TRUE(contains(g2o.err, "run dba-posegraph -g " + dir.file("seq.graphbin"))) << g2o.err;
}

TEST(FirstContact, SimulatorOutsideTheRoomHintsAtTheTrajectoryLength) {
  testing::TempDir dir;
  const auto r = testing::runApp(app::runSimulApp, "simul-dba",
                                 {"-o", dir.file("s"), "--snapshots", "200", "--no-solve", "-q"});
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_TRUE(contains(r.err, "outside the room")) << r.err;
  EXPECT_TRUE(contains(r.err,
                       "a line trajectory leaves the room after 50 keyframes (this run "
                       "needs 207 = snapshots + window - 1)"))
      << r.err;
  EXPECT_TRUE(contains(r.err, "--trajectory loop")) << r.err;
}

}  // namespace
}  // namespace dbacov
