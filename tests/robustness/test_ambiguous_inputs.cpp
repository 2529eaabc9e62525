// Inputs that two outputs or two readings could take differently, each refused naming the files,
// key, option or value, with every input and every previous output left as it was: two inputs
// with one snapshot id (dba-covariance), a table with one key twice and a --body-to-camera
// without a pose (dba-evaluate); and usage messages that print their bound readably or say why an
// option pair cannot work.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/evaluate_app.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace ambiguous_inputs {  // not anonymous: the suite is compiled as a unity build

using testing::AppResult;
namespace fs = std::filesystem;

const std::string kClash =
    ": the outputs name snapshots by it (the tables' snapshot column, --depth-sigma's "
    "DIR/<snapshot>_<keyframe>.npy), so one would overwrite or duplicate the other; give each "
    "snapshot a distinct 'id' (e.g. process each run on its own)";

TEST(AmbiguousInputs, TwoInputsWithOneSnapshotIdAreRefusedBeforeAnyWork) {
  testing::TempDir dir;
  fs::create_directories(dir.file("run1"));
  fs::create_directories(dir.file("run2"));
  for (int k = 0; k < 2; ++k) {  // both runs numbered from 0
    testing::writeTinySnapshot(dir.file("run1/00" + std::to_string(k) + ".npz"), 1 + k, k);
    testing::writeTinySnapshot(dir.file("run2/00" + std::to_string(k) + ".npz"), 7 + k, k);
  }
  std::ofstream(dir.file("k.csv")) << "previous\n";
  const std::string run1_0 = testing::readFile(dir.file("run1/000.npz"));
  const AppResult r =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.file("run1"), "-i", dir.file("run2"), "--csv", dir.file("k.csv"),
                       "--depth-sigma", dir.file("ds"), "--stated-model"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "dba-covariance: error: " + dir.file("run1/000.npz") + " (id 0) and " +
                       dir.file("run2/000.npz") + " (id 0) are both snapshot 0" + kClash + "\n");
  EXPECT_EQ(testing::readFile(dir.file("k.csv")), "previous\n");
  EXPECT_FALSE(fs::exists(dir.file("ds")));
  EXPECT_EQ(testing::readFile(dir.file("run1/000.npz")), run1_0);

  // Two single files with one id.
  testing::writeTinySnapshot(dir.file("one.npz"), 3, 1);
  const AppResult twice = testing::runApp(
      app::runCovarianceApp, "dba-covariance",
      {"-i", dir.file("run1/001.npz"), "-i", dir.file("one.npz"), "--csv", dir.file("k.csv")});
  EXPECT_EQ(twice.code, 1);
  EXPECT_EQ(twice.err, "dba-covariance: error: " + dir.file("run1/001.npz") + " (id 1) and " +
                           dir.file("one.npz") + " (id 1) are both snapshot 1" + kClash + "\n");
  EXPECT_EQ(testing::readFile(dir.file("k.csv")), "previous\n");

  // Distinct ids: processed.
  const AppResult ok =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.file("run1"), "--csv", dir.file("k.csv"), "-q", "--stated-model"});
  EXPECT_EQ(ok.code, 0) << ok.err;
}

TEST(AmbiguousInputs, EvaluateRefusesATableWithOneKeyTwice) {
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("v.npz"), 1, 1);
  ASSERT_EQ(testing::runApp(app::runCovarianceApp, "dba-covariance",
                            {"-i", dir.file("v.npz"), "--csv", dir.file("k.csv"), "--relative-csv",
                             dir.file("r.csv"), "-q", "--stated-model"})
                .code,
            0);
  std::ofstream(dir.file("gt.tum")) << "1000 0 0 0 0 0 0 1\n1001 0 0 0 0 0 0 1\n";
  for (const auto& [table, what] :
       std::vector<std::pair<std::string, std::string>>{{"k.csv", "keyframe"}, {"r.csv", "pair"}}) {
    SCOPED_TRACE(table);
    const auto lines = testing::splitLines(testing::readFile(dir.file(table)));
    ASSERT_GE(lines.size(), 3u);
    {
      std::ofstream out(dir.file("dup_" + table));
      for (const std::string& l : lines) out << l << '\n';
      out << lines[1] << '\n';  // row 1 again, at line lines.size() + 1
    }
    const auto f = testing::splitCsv(lines[1]);
    const std::string key = table == "k.csv" ? "snapshot 1, keyframe " + f[1]
                                             : "snapshot 1, pair " + f[1] + " -> " + f[2];
    const std::string dup = dir.file("dup_" + table);
    std::vector<std::string> args = {"--gt",   dir.file("gt.tum"),  "--fps",
                                     "20",     "--start-time",      "1000",
                                     "--json", dir.file("out.json")};
    if (table == "k.csv") {
      args.insert(args.end(), {"--csv", dup});
    } else {
      args.insert(args.end(), {"--csv", dir.file("k.csv"), "--relative-csv", dup});
    }
    std::ofstream(dir.file("out.json")) << "previous\n";
    const AppResult r = testing::runApp(app::runEvaluateApp, "dba-evaluate", args);
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, "dba-evaluate: error: " + dup + ":" + std::to_string(lines.size() + 1) + ": " +
                         key + " is already at " + dup +
                         ":2: each key may appear once (were two inputs with one snapshot id "
                         "processed in one run? give each snapshot a distinct id)\n");
    EXPECT_EQ(testing::readFile(dir.file("out.json")), "previous\n");
  }
}

TEST(AmbiguousInputs, BodyToCameraWithoutAPoseIsBadUsage) {
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("v.npz"), 1, 1);
  ASSERT_EQ(
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.file("v.npz"), "--csv", dir.file("k.csv"), "-q", "--stated-model"})
          .code,
      0);
  std::ofstream(dir.file("gt.tum")) << "1000 0 0 0 0 0 0 1\n1001 0 0 0 0 0 0 1\n";
  std::ofstream(dir.file("out.json")) << "previous\n";
  for (const auto& [pose, error] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"0", "nan", "0", "0", "0", "0", "1"}, "ty is nan, expected a finite number"},
           {{"0", "0", "0", "0", "0", "0", "inf"}, "qw is inf, expected a finite number"},
           {{"0", "0", "0", "0", "0", "0", "0"},
            "the quaternion qx qy qz qw = 0 0 0 0 is no rotation (norm 0): give a unit "
            "quaternion (0 0 0 1 for none)"},
           {{"0", "0", "0", "1e-300", "0", "0", "0"},
            "the quaternion qx qy qz qw = 1e-300 0 0 0 is no rotation (norm 1e-300): give a "
            "unit quaternion (0 0 0 1 for none)"},
           {{"0", "0", "0", "1e300", "1e300", "0", "0"},
            "the quaternion qx qy qz qw = 1e+300 1e+300 0 0 is no rotation (norm 1.41421e+300): "
            "give a unit quaternion (0 0 0 1 for none)"},
       }) {
    SCOPED_TRACE(error);
    std::vector<std::string> args = {"--csv",
                                     dir.file("k.csv"),
                                     "--gt",
                                     dir.file("gt.tum"),
                                     "--fps",
                                     "20",
                                     "--start-time",
                                     "1000",
                                     "--json",
                                     dir.file("out.json"),
                                     "--body-to-camera"};
    args.insert(args.end(), pose.begin(), pose.end());
    const AppResult r = testing::runApp(app::runEvaluateApp, "dba-evaluate", args);
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(r.err.substr(0, r.err.find('\n')), "dba-evaluate: --body-to-camera: " + error);
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(testing::readFile(dir.file("out.json")), "previous\n");
  }
}

TEST(AmbiguousInputs, UsageMessagesSayWhatIsWrongReadably) {
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("v.npz"), 1, 1);
  std::ofstream(dir.file("k.csv")) << "previous\n";
  for (const auto& [args, message] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--weight-scale", "1e400"}, "--weight-scale: '1e400' is not a finite number > 0"},
           {{"--weight-scale", "-1"}, "--weight-scale: '-1' is not a finite number > 0"},
           {{"--graph", dir.file("g"), "--gauge", "droid"},
            "--graph cannot take --gauge droid: DROID's t0 holds poses of one window, and the "
            "sequence graph joins every window into one problem that has no t0 (it is anchored "
            "at its two lowest keyframes); give --gauge two-pose or minimal with --graph, or run "
            "--gauge droid without --graph"},
       }) {
    SCOPED_TRACE(message);
    std::vector<std::string> a = {"-i", dir.file("v.npz"), "--csv", dir.file("k.csv")};
    a.insert(a.end(), args.begin(), args.end());
    const AppResult r = testing::runApp(app::runCovarianceApp, "dba-covariance", a);
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(r.err.substr(0, r.err.find('\n')), "dba-covariance: " + message);
    EXPECT_EQ(testing::readFile(dir.file("k.csv")), "previous\n");
    EXPECT_FALSE(fs::exists(dir.file("g.graphbin")));
  }
  const AppResult r = testing::runApp(app::runEvaluateApp, "dba-evaluate",
                                      {"--monte-carlo", "2", "--time-tolerance", "-1"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err.substr(0, r.err.find('\n')),
            "dba-evaluate: --time-tolerance: '-1' is not a finite number >= 0");
}

}  // namespace ambiguous_inputs
}  // namespace dbacov
