// --keep-going (default) and --fail-fast of dba-covariance and droid2rawlog: with --fail-fast the
// first failing snapshot ends the run with exit 1 and no output appears (previous files stay as
// they were); with --keep-going the others are processed and every output is written. The last
// line sums up the run with the failures grouped by kind.
#include <filesystem>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/droid2rawlog_app.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace fail_policy {  // not anonymous: the suite is compiled as a unity build

using testing::AppResult;
namespace fs = std::filesystem;

/// The note that --graph adds: the droid preset's hard gauge fixes the pair of keyframes 0 and 1.
constexpr const char* kGaugeNote =
    "dba-covariance: note: 1 keyframe pairs got no graph edge: every snapshot's gauge fixed their "
    "relative pose\n";

AppResult covariance(const std::vector<std::string>& args) {
  return testing::runApp(app::runCovarianceApp, "dba-covariance", args);
}
AppResult droid2rawlog(const std::vector<std::string>& args) {
  return testing::runApp(app::runDroid2RawlogApp, "droid2rawlog", args);
}

/// in/a.npz (id 1), in/b.npz (damaged), in/c.npz (id 3), in/d.npz (numerical failure, id 4),
/// and previous versions of every output.
struct Inputs {
  testing::TempDir dir;
  std::vector<std::string> outputs;  ///< options and paths of every file output

  Inputs() {
    fs::create_directory(dir.file("in"));
    testing::writeTinySnapshot(dir.file("in/a.npz"), 1, 1);
    std::ofstream(dir.file("in/b.npz")) << "damaged";
    testing::writeTinySnapshot(dir.file("in/c.npz"), 3, 3);
    Snapshot d = testing::tinySnapshot(4, 4).snapshot;
    std::fill(d.weight.begin(), d.weight.begin() + 4 * 2 * d.pixelsPerFrame(), 0.0f);
    for (int e = 0; e < d.numEdges(); ++e)  // keyframe 5 loses every weighted pixel
      if (d.ii[e] == 5 || d.jj[e] == 5)
        std::fill(d.weight.begin() + e * 2 * d.pixelsPerFrame(),
                  d.weight.begin() + (e + 1) * 2 * d.pixelsPerFrame(), 0.0f);
    io::saveSnapshotNpz(dir.file("in/d.npz"), d);
    outputs = {"--csv",
               dir.file("k.csv"),
               "--relative-csv",
               dir.file("r.csv"),
               "-o",
               dir.file("p.rawlog"),
               "--graph",
               dir.file("g"),
               "--graph-edges",  // the old graph: its stderr note about the gauge pair
               "snapshot-marginals-not-fusable",
               "--depth-sigma",
               dir.file("sigma")};
    for (const char* name :
         {"k.csv", "r.csv", "p.rawlog", "g.graphbin", "g.graph", "g.g2o", "g.nodes.csv"})
      std::ofstream(dir.file(name)) << "previous " << name;
  }
  std::vector<std::string> args(std::initializer_list<std::string> extra) const {
    std::vector<std::string> a{"-i", dir.file("in"), "--weight-scale", "4"};
    a.insert(a.end(), outputs.begin(), outputs.end());
    a.insert(a.end(), extra);
    return a;
  }
  bool untouched() const {
    for (const char* name :
         {"k.csv", "r.csv", "p.rawlog", "g.graphbin", "g.graph", "g.g2o", "g.nodes.csv"})
      if (testing::readFile(dir.file(name)) != std::string("previous ") + name) return false;
    return dir.entries() == std::vector<std::string>{"g.g2o",       "g.graph", "g.graphbin",
                                                     "g.nodes.csv", "in",      "k.csv",
                                                     "p.rawlog",    "r.csv"};
  }
};

TEST(FailPolicy, FailFastStopsAtTheFirstFailureAndWritesNothing) {
  Inputs run;
  const AppResult r = covariance(run.args({"--fail-fast"}));
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "dba-covariance: error: " + run.dir.file("in/b.npz") +
                       ": cannot open as a .npz (zip) archive: Not a zip archive\n"
                       "dba-covariance: 2 snapshots read, 1 processed, 1 failed: 1 invalid input "
                       "(b.npz); --fail-fast: stopped at the first failure, no output written\n");
  EXPECT_TRUE(run.untouched());
  EXPECT_FALSE(fs::exists(run.dir.file("sigma")));

  // A numerical failure stops it the same way, after the snapshots before it were processed.
  fs::remove(run.dir.file("in/b.npz"));
  const AppResult n = covariance(run.args({"--fail-fast"}));
  EXPECT_EQ(n.code, 1);
  EXPECT_EQ(n.err.substr(n.err.rfind("dba-covariance: ")),
            "dba-covariance: 3 snapshots read, 2 processed, 1 failed: 1 numerical (d.npz: no gauge "
            "reaches keyframes 5); --fail-fast: stopped at the first failure, no output written\n");
  EXPECT_TRUE(run.untouched());
}

TEST(FailPolicy, KeepGoingIsTheDefaultAndWritesEveryGoodSnapshot) {
  for (const char* flag : {"--keep-going", "-q"}) {
    SCOPED_TRACE(flag);
    Inputs run;
    const AppResult r = covariance(run.args({flag}));
    EXPECT_EQ(r.code, 1);
    const std::string d = run.dir.file("in/d.npz");
    if (std::string(flag) == "--keep-going") {
      EXPECT_EQ(r.err.substr(r.err.rfind("dba-covariance: ")),
                "dba-covariance: 4 snapshots read, 2 processed, 2 failed: 1 invalid input (b.npz), "
                "1 numerical (d.npz: no gauge reaches keyframes 5)\n");
    }
    EXPECT_NE(
        r.err.find("dba-covariance: error: " + d + " (snapshot 4): no gauge reaches keyframes 5: "),
        std::string::npos)
        << r.err;
    std::set<std::string> ids;
    for (const auto& line : testing::splitLines(testing::readFile(run.dir.file("k.csv"))))
      ids.insert(testing::splitCsv(line)[0]);
    EXPECT_EQ(ids, (std::set<std::string>{"snapshot", "1", "3"}));
    EXPECT_TRUE(fs::exists(run.dir.file("sigma/1_0.npy")));
    EXPECT_TRUE(fs::exists(run.dir.file("sigma/3_0.npy")));
    EXPECT_NE(testing::readFile(run.dir.file("g.graphbin")), "previous g.graphbin");
  }
}

TEST(FailPolicy, FailFastWithoutFailureWritesEverything) {
  Inputs run;
  fs::remove(run.dir.file("in/b.npz"));
  fs::remove(run.dir.file("in/d.npz"));
  const AppResult r = covariance(run.args({"--fail-fast"}));
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err,
            std::string(kGaugeNote) + "dba-covariance: 2 snapshots read, 2 processed, 0 failed\n");
  EXPECT_EQ(testing::splitLines(testing::readFile(run.dir.file("k.csv"))).size(), 1u + 12);
}

TEST(FailPolicy, BothPoliciesAtOnceIsBadUsage) {
  Inputs run;
  EXPECT_EQ(covariance(run.args({"--fail-fast", "--keep-going"})).code, 2);
  EXPECT_EQ(droid2rawlog({"-i", run.dir.file("in"), "-o", run.dir.file("s.rawlog"), "--fail-fast",
                          "--keep-going"})
                .code,
            2);
  EXPECT_TRUE(run.untouched());
}

TEST(FailPolicy, AnOutputThatCannotBeCommittedDoesNotStopTheOthers) {
  Inputs run;
  fs::remove(run.dir.file("in/b.npz"));
  fs::remove(run.dir.file("in/d.npz"));
  fs::remove(run.dir.file("g.graph"));
  fs::create_directory(run.dir.file("g.graph"));  // found when the graph files are written
  const AppResult r = covariance(run.args({}));
  EXPECT_EQ(r.code, 1);
  const auto lines = testing::splitLines(r.err);
  ASSERT_EQ(lines.size(), 3u) << r.err;
  EXPECT_EQ(lines[1] + "\n", kGaugeNote);
  EXPECT_EQ(lines[0], "dba-covariance: error: " + run.dir.file("g.graph") +
                          ": is a directory, expected a file path");
  EXPECT_EQ(lines[2],
            "dba-covariance: 2 snapshots read, 2 processed, 0 failed; 1 output not written");
  // The sinks after the graph were still committed.
  EXPECT_EQ(testing::splitLines(testing::readFile(run.dir.file("k.csv"))).size(), 1u + 12);
  EXPECT_NE(testing::readFile(run.dir.file("p.rawlog")), "previous p.rawlog");
  EXPECT_TRUE(fs::exists(run.dir.file("sigma/3_2.npy")));
  for (const auto& name : run.dir.entries())
    EXPECT_EQ(name.find(".tmp."), std::string::npos) << name;
}

TEST(FailPolicy, Droid2RawlogFailFastWritesNoRawlog) {
  Inputs run;
  std::ofstream(run.dir.file("s.rawlog")) << "previous";
  AppResult r =
      droid2rawlog({"-i", run.dir.file("in"), "-o", run.dir.file("s.rawlog"), "--fail-fast"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "droid2rawlog: error: " + run.dir.file("in/b.npz") +
                       ": cannot open as a .npz (zip) archive: Not a zip archive\n"
                       "droid2rawlog: 2 snapshots read, 1 processed, 1 failed: 1 invalid input "
                       "(b.npz); --fail-fast: stopped at the first failure, " +
                       run.dir.file("s.rawlog") + " not written\n");
  EXPECT_EQ(testing::readFile(run.dir.file("s.rawlog")), "previous");

  r = droid2rawlog({"-i", run.dir.file("in"), "-o", run.dir.file("s.rawlog")});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err.substr(r.err.find('\n') + 1),
            "droid2rawlog: 4 snapshots read, 3 processed, 1 failed: 1 invalid input (b.npz); 3 "
            "written to " +
                run.dir.file("s.rawlog") + "\n");
  const AppResult info = droid2rawlog({"--info", run.dir.file("s.rawlog")});
  EXPECT_EQ(info.code, 0) << info.err;
  EXPECT_EQ(testing::splitLines(info.out).size(), 3u);
}

TEST(FailPolicy, HelpStatesBothPoliciesAndTheSummary) {
  for (const std::string app : {"dba-covariance", "droid2rawlog"}) {
    SCOPED_TRACE(app);
    const AppResult r =
        testing::runCommand(std::string(DBACOV_BINARY_DIR) + "/bin/" + app + " --help");
    EXPECT_EQ(r.code, 0);
    for (const char* text : {"--keep-going", "--fail-fast", "(default)", "no output",
                             "N snapshots read, P processed,", "F failed: K invalid input"})
      EXPECT_NE(r.out.find(text), std::string::npos) << "missing '" << text << "' in\n" << r.out;
  }
}

}  // namespace fail_policy
}  // namespace dbacov
