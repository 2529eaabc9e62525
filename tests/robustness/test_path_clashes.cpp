// Data loss through paths: an output that is an input (same file by device + inode,
// whatever the name: the path itself, a symlink, a hard link, `dir/../file`, a file of an input
// directory), two outputs on one file (also the derived names of --graph PREFIX), and outputs
// that are not regular files (a FIFO and a character device are written in place, a symlink is
// followed and its target replaced). Every clash is refused before anything is written (exit 2,
// naming both paths), and the test checks that every file is byte for byte what it was.
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/droid2rawlog_app.h"
#include "dbacov/app/evaluate_app.h"
#include "dbacov/app/posegraph_app.h"
#include "dbacov/app/simul_app.h"
#include "dbacov/io/path_guard.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace path_clashes {  // not anonymous: the suite is compiled as a unity build

using testing::AppResult;
namespace fs = std::filesystem;

AppResult covariance(const std::vector<std::string>& args) {
  return testing::runApp(app::runCovarianceApp, "dba-covariance", args);
}

/// Every entry under `dir`: regular files with their contents, others by kind.
std::map<std::string, std::string> treeOf(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const fs::file_status st = fs::symlink_status(e.path());
    files[e.path().string()] = fs::is_symlink(st) ? "-> " + fs::read_symlink(e.path()).string()
                               : fs::is_regular_file(st) ? testing::readFile(e.path().string())
                               : fs::is_fifo(st)         ? "<fifo>"
                                                         : "<other>";
  }
  return files;
}

std::string usage(const std::string& app, const std::string& message) {
  return app + ": " + message + "\nRun with --help for usage.\n";
}

std::string isInput(const std::string& out_opt, const std::string& out, const std::string& in_opt,
                    const std::string& in) {
  return out_opt + " " + out + " is the input " + in_opt + " " + in +
         " (the same file): writing it would destroy the input; choose another output path";
}

/// A directory with a snapshot v.npz, a rawlog r.rawlog of it, a graph g.* and a keyframe CSV
/// k.csv (made by the apps themselves).
struct Workspace {
  testing::TempDir dir;
  std::string f(const std::string& name) const { return dir.file(name); }
  Workspace() {
    testing::writeTinySnapshot(f("v.npz"), 1, 1);
    EXPECT_EQ(covariance({"-i", f("v.npz"), "--csv", f("k.csv"), "--graph", f("g"),
                          "--weight-scale", "4", "-q"})
                  .code,
              0);
    EXPECT_EQ(testing::runApp(app::runDroid2RawlogApp, "droid2rawlog",
                              {"-i", f("v.npz"), "-o", f("r.rawlog"), "-q"})
                  .code,
              0);
  }
};

TEST(PathClashes, AnOutputThatIsAnInputIsRefusedInEveryApp) {
  Workspace w;
  fs::create_symlink(w.f("v.npz"), w.f("link.npz"));
  fs::create_hard_link(w.f("v.npz"), w.f("hard.npz"));
  fs::create_directory(w.f("sub"));
  fs::create_directory(w.f("snaps"));
  fs::copy_file(w.f("v.npz"), w.f("snaps/a.npz"));
  const auto before = treeOf(w.dir.path());
  struct Case {
    testing::AppMain app;
    std::string name;
    std::vector<std::string> args;
    std::string message;
  };
  const std::string v = w.f("v.npz");
  const std::string dotdot = w.f("sub/../v.npz");
  const std::vector<Case> cases{
      {app::runCovarianceApp,
       "dba-covariance",
       {"-i", v, "--csv", v},
       isInput("--csv", v, "-i", v)},
      {app::runCovarianceApp,
       "dba-covariance",
       {"-i", v, "--relative-csv", w.f("link.npz")},
       isInput("--relative-csv", w.f("link.npz"), "-i", v)},
      {app::runCovarianceApp,
       "dba-covariance",
       {"-i", v, "--scene", w.f("hard.npz")},
       isInput("--scene", w.f("hard.npz"), "-i", v)},
      {app::runCovarianceApp,
       "dba-covariance",
       {"-i", v, "--snapshot", dotdot},
       isInput("--snapshot", dotdot, "-i", v)},
      {app::runCovarianceApp,
       "dba-covariance",
       {"-i", w.f("snaps"), "-o", w.f("snaps/a.npz")},
       isInput("-o", w.f("snaps/a.npz"), "-i " + w.f("snaps") + ":", w.f("snaps/a.npz"))},
      {app::runCovarianceApp,
       "dba-covariance",
       {"-i", w.f("r.rawlog"), "-o", w.f("r.rawlog")},
       isInput("-o", w.f("r.rawlog"), "-i", w.f("r.rawlog"))},
      {app::runCovarianceApp,
       "dba-covariance",
       {"-i", w.f("g.nodes.csv"), "--graph", w.f("g")},
       isInput("--graph", w.f("g.nodes.csv"), "-i", w.f("g.nodes.csv"))},
      {app::runCovarianceApp,
       "dba-covariance",
       {"-i", v, "--depth-sigma", v},
       isInput("--depth-sigma", v, "-i", v)},
      {app::runDroid2RawlogApp,
       "droid2rawlog",
       {"-i", v, "-o", w.f("link.npz")},
       isInput("-o", w.f("link.npz"), "-i", v)},
      {app::runPoseGraphApp,
       "dba-posegraph",
       {"-g", w.f("g.graphbin"), "--tum", w.f("g.graphbin")},
       isInput("--tum", w.f("g.graphbin"), "-g", w.f("g.graphbin"))},
      {app::runPoseGraphApp,
       "dba-posegraph",
       {"-g", w.f("g.graphbin"), "-o", w.f("g.nodes.csv")},
       isInput("-o", w.f("g.nodes.csv"), "-g (its nodes)", w.f("g.nodes.csv"))},
      {app::runEvaluateApp,
       "dba-evaluate",
       {"--csv", w.f("k.csv"), "--gt", w.f("g.nodes.csv"), "--fps", "20", "--json", w.f("k.csv")},
       isInput("--json", w.f("k.csv"), "--csv", w.f("k.csv"))},
      {app::runEvaluateApp,
       "dba-evaluate",
       {"--csv", w.f("k.csv"), "--gt", w.f("g.nodes.csv"), "--fps", "20", "--samples-csv",
        w.f("g.nodes.csv")},
       isInput("--samples-csv", w.f("g.nodes.csv"), "--gt", w.f("g.nodes.csv"))},
      {app::runSimulApp,
       "simul-dba",
       {"-o", w.f("sim"), "--config", w.f("k.csv"), "--rawlog", w.f("k.csv")},
       isInput("--rawlog", w.f("k.csv"), "--config", w.f("k.csv"))},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name + " " + c.args.back());
    const AppResult r = testing::runApp(c.app, c.name, c.args);
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(r.err, usage(c.name, c.message));
    EXPECT_EQ(treeOf(w.dir.path()), before);  // nothing written, nothing created
  }
}

TEST(PathClashes, TwoOutputsOnOneFileAreRefused) {
  Workspace w;
  fs::create_symlink(w.f("new.csv"), w.f("dangling.csv"));  // would create new.csv
  fs::create_directory(w.f("sub"));
  const auto before = treeOf(w.dir.path());
  const std::string v = w.f("v.npz");
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  auto same = [](const std::string& a, const std::string& pa, const std::string& b,
                 const std::string& pb) {
    return a + " " + pa + " and " + b + " " + pb +
           " are the same file: one output would overwrite the other; give each output its own "
           "path";
  };
  for (const Case& c : std::vector<Case>{
           {{"--csv", w.f("x.csv"), "--relative-csv", w.f("x.csv")},
            same("--relative-csv", w.f("x.csv"), "--csv", w.f("x.csv"))},
           {{"--csv", w.f("k.csv"), "--relative-csv", w.f("sub/../k.csv")},
            same("--relative-csv", w.f("sub/../k.csv"), "--csv", w.f("k.csv"))},
           {{"--csv", w.f("g.nodes.csv"), "--graph", w.f("g")},
            same("--graph", w.f("g.nodes.csv"), "--csv", w.f("g.nodes.csv"))},
           {{"--csv", w.f("h.g2o"), "--graph", w.f("h")},  // files that do not exist yet
            same("--graph", w.f("h.g2o"), "--csv", w.f("h.g2o"))},
           {{"--csv", w.f("dangling.csv"), "-o", w.f("new.csv")},
            same("-o", w.f("new.csv"), "--csv", w.f("dangling.csv"))},
           {{"--scene", w.f("s.png"), "--snapshot", w.f("s.png")},
            same("--snapshot", w.f("s.png"), "--scene", w.f("s.png"))},
       }) {
    SCOPED_TRACE(c.args[1]);
    std::vector<std::string> args{"-i", v};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const AppResult r = covariance(args);
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(r.err, usage("dba-covariance", c.message));
    EXPECT_EQ(treeOf(w.dir.path()), before);
  }
  // Outputs of the other apps.
  const AppResult r =
      testing::runApp(app::runPoseGraphApp, "dba-posegraph",
                      {"-g", w.f("g.graphbin"), "-o", w.f("t.txt"), "--tum", w.f("t.txt")});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, usage("dba-posegraph", same("--tum", w.f("t.txt"), "-o", w.f("t.txt"))));
  EXPECT_EQ(treeOf(w.dir.path()), before);
}

TEST(PathClashes, NamesLongerThanTheFileSystemAllowsAreRefusedBeforeTheWork) {
  Workspace w;
  const auto before = treeOf(w.dir.path());
  const std::string name(256, 'n'), longest(255 - 4, 'n');
  auto tooLong = [&](const std::string& option, const std::string& path) {
    return option + " " + path + ": the name '" + name.substr(0, 40) + "...' is " +
           std::to_string(path.size() - path.rfind('/') - 1) +
           " bytes long, more than the 255 its file system allows: choose a shorter name";
  };
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  for (const Case& c : std::vector<Case>{
           {{"--csv", w.f(name + ".csv")}, tooLong("--csv", w.f(name + ".csv"))},
           {{"-o", w.f(name)}, tooLong("-o", w.f(name))},
           // --graph PREFIX: the first of its four files whose name is too long.
           {{"--graph", w.f(longest)}, tooLong("--graph", w.f(longest + ".graphbin"))},
       }) {
    SCOPED_TRACE(c.args[0]);
    std::vector<std::string> args{"-i", w.f("v.npz")};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const AppResult r = covariance(args);
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(r.err, usage("dba-covariance", c.message));
    EXPECT_EQ(treeOf(w.dir.path()), before);
  }
  // A name of exactly 255 bytes is a name like any other.
  EXPECT_EQ(covariance({"-i", w.f("v.npz"), "--csv", w.f(longest + ".csv"), "-q"}).code, 0);
  EXPECT_TRUE(fs::exists(w.f(longest + ".csv")));
  fs::remove(w.f(longest + ".csv"));
  // The other apps' outputs go through the same plan.
  const AppResult r = testing::runApp(app::runPoseGraphApp, "dba-posegraph",
                                      {"-g", w.f("g.graphbin"), "-o", w.f(name)});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, usage("dba-posegraph", tooLong("-o", w.f(name))));
  EXPECT_EQ(treeOf(w.dir.path()), before);
}

TEST(PathClashes, GraphPrefixThatNamesADirectoryIsRefused) {
  Workspace w;
  fs::create_directory(w.f("d"));
  const auto before = treeOf(w.dir.path());
  for (const std::string& prefix : {w.f("d/"), w.f("d/."), std::string(".")}) {
    SCOPED_TRACE(prefix);
    const AppResult r = covariance({"-i", w.f("v.npz"), "--graph", prefix});
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("--graph " + prefix +
                         ": PREFIX names a directory, not a file prefix (it would write hidden "
                         "files such as '"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(treeOf(w.dir.path()), before);
  }
  const AppResult r = covariance({"-i", w.f("v.npz"), "--graph", w.f("d/")});
  EXPECT_EQ(r.err, usage("dba-covariance",
                         "--graph " + w.f("d/") +
                             ": PREFIX names a directory, not a file prefix (it would write "
                             "hidden files such as '" +
                             w.f("d/") + ".graphbin'); give e.g. --graph " + w.f("d/") + "graph"));
}

TEST(PathClashes, SymlinkedOutputsReplaceTheirTargetAndStayLinks) {
  Workspace w;
  fs::create_directory(w.f("real"));
  std::ofstream(w.f("real/k.csv")) << "previous";
  fs::create_symlink("real/k.csv", w.f("link.csv"));             // relative, existing target
  fs::create_symlink(w.f("real/new.csv"), w.f("dangling.csv"));  // target does not exist yet
  const AppResult r = covariance({"-i", w.f("v.npz"), "--csv", w.f("link.csv"), "--relative-csv",
                                  w.f("dangling.csv"), "--weight-scale", "4", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::is_symlink(w.f("link.csv")));
  EXPECT_TRUE(fs::is_symlink(w.f("dangling.csv")));
  EXPECT_EQ(fs::read_symlink(w.f("link.csv")), "real/k.csv");
  EXPECT_EQ(testing::readFile(w.f("real/k.csv")), testing::readFile(w.f("k.csv")));
  EXPECT_EQ(
      testing::splitLines(testing::readFile(w.f("real/new.csv")))[0],
      testing::splitLines(testing::readFile(w.f("real/new.csv")))[0]);  // written (header below)
  EXPECT_EQ(testing::readFile(w.f("real/new.csv")).rfind("snapshot,from,to,", 0), 0u);
  EXPECT_EQ(fs::directory_iterator(w.f("real")) == fs::directory_iterator(), false);
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(w.f("real"))) ++entries;
  EXPECT_EQ(entries, 2u);  // no temporary left next to the targets
}

TEST(PathClashes, AFifoOutputIsWrittenInPlaceAndStaysAFifo) {
  Workspace w;
  ASSERT_EQ(::mkfifo(w.f("pipe.csv").c_str(), 0644), 0);
  std::string received;
  std::thread reader([&] { received = testing::readFile(w.f("pipe.csv")); });
  const AppResult r =
      covariance({"-i", w.f("v.npz"), "--csv", w.f("pipe.csv"), "--weight-scale", "4", "-q"});
  reader.join();
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::is_fifo(w.f("pipe.csv")));
  EXPECT_EQ(received, testing::readFile(w.f("k.csv")));  // the whole table, as a file gets it
}

TEST(PathClashes, ACharacterDeviceOutputIsWrittenInPlace) {
  Workspace w;
  // A private null device (root only): the test never risks the system's /dev/null.
  if (::mknod(w.f("null").c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0)
    GTEST_SKIP() << "cannot create a device node here (needs root)";
  struct stat before {};
  ASSERT_EQ(::stat(w.f("null").c_str(), &before), 0);
  // Several outputs may share a character device.
  const AppResult r = covariance({"-i", w.f("v.npz"), "--csv", w.f("null"), "--relative-csv",
                                  w.f("null"), "--weight-scale", "4", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  struct stat after {};
  ASSERT_EQ(::stat(w.f("null").c_str(), &after), 0);
  EXPECT_TRUE(S_ISCHR(after.st_mode));
  EXPECT_EQ(after.st_ino, before.st_ino);
  EXPECT_EQ(after.st_rdev, before.st_rdev);
}

TEST(PathClashes, ARunThatProcessesNoSnapshotLeavesThePreviousFiles) {
  Workspace w;
  // Every snapshot fails: -o needs keyframe times, this snapshot has none (and no --fps).
  auto syn = testing::tinySnapshot(3, 7);
  syn.snapshot.timestamps_s.reset();
  io::saveSnapshotNpz(w.f("untimed.npz"), syn.snapshot);
  ASSERT_EQ(covariance({"-i", w.f("v.npz"), "-o", w.f("p.rawlog"), "--relative-csv", w.f("r.csv"),
                        "--weight-scale", "4", "-q"})
                .code,
            0);
  const auto before = treeOf(w.dir.path());
  const AppResult r =
      covariance({"-i", w.f("untimed.npz"), "--csv", w.f("k.csv"), "-o", w.f("p.rawlog"),
                  "--relative-csv", w.f("r.csv"), "--graph", w.f("g"), "--weight-scale", "4"});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("dba-covariance: no snapshot was processed: no output written, previous "
                       "files untouched\n"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(treeOf(w.dir.path()), before);
}

TEST(PathClashes, PlanComparesIdentityNotNames) {
  testing::TempDir dir;
  std::ofstream(dir.file("a")) << "a";
  std::ofstream(dir.file("b")) << "b";
  io::OutputPlan ok;
  ok.input(dir.file("a"), "-i");
  ok.input(dir.file("missing"), "-i");  // an input that does not exist clashes with nothing
  ok.output(dir.file("b"), "--x");
  ok.output(dir.file("missing"), "--y");
  ok.output("", "--z");
  EXPECT_NO_THROW(ok.check());
  fs::create_symlink(dir.file("c"), dir.file("l1"));
  fs::create_symlink("l1", dir.file("l2"));  // a chain of dangling links
  io::OutputPlan chain;
  chain.output(dir.file("l2"), "--x");
  chain.output(dir.file("c"), "--y");
  EXPECT_THROW(chain.check(), InputError);
  EXPECT_EQ(io::resolveOutputTarget(dir.file("l2")), dir.file("c"));
  fs::create_symlink("loop", dir.file("loop"));
  EXPECT_THROW(io::resolveOutputTarget(dir.file("loop")), InputError);
}

}  // namespace path_clashes
}  // namespace dbacov
