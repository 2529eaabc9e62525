// A kill inside the commit: the outputs of a run change together. Every output is
// prepared first (written, fsync'ed, still unnamed); then one tight loop renames them all. The
// real dba-covariance is killed (SIGKILL, by its fault-injection hook DBACOV_TEST_KILL_IN_COMMIT=k)
// after k renames: before the first, every previous file is intact and nothing else exists; after
// k, exactly the first k outputs in commit order are new and no temporary is left. Without the
// hook the same run replaces every output.
#include <filesystem>
#include <fstream>
#include <map>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace kill_in_commit {  // not anonymous: the suite is compiled as a unity build

namespace fs = std::filesystem;
const std::string kBin = std::string(DBACOV_BINARY_DIR) + "/bin/";

/// Relative name → contents of every file under `dir`.
std::map<std::string, std::string> filesUnder(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file())
      files[fs::relative(e.path(), dir).string()] = testing::readFile(e.path().string());
  return files;
}

std::string command(const std::string& in, const std::string& out) {
  return kBin + "dba-covariance -q --weight-scale 4 -i " + in + " --csv " + out + "/k.csv" +
         " --relative-csv " + out + "/r.csv --depth-sigma " + out + "/sigma --graph " + out +
         "/g -o " + out + "/p.rawlog";
}

TEST(KillInCommit, LeavesTheFirstKOutputsNewAndTheOthersPrevious) {
  testing::TempDir dir;
  fs::create_directories(dir.file("in"));
  for (int i = 0; i < 2; ++i)
    testing::writeTinySnapshot(dir.file("in/s" + std::to_string(i) + ".npz"), i + 1, i);
  // The new outputs, from a run that is not killed.
  fs::create_directories(dir.file("ref"));
  const testing::AppResult ref = testing::runCommand(command(dir.file("in"), dir.file("ref")));
  ASSERT_EQ(ref.code, 0) << ref.out;
  const auto fresh = filesUnder(dir.file("ref"));
  // Commit order: the sinks in order (--csv, --relative-csv, --depth-sigma maps in the order they
  // were computed, --graph's four files, -o).
  std::vector<std::string> order{"k.csv", "r.csv"};
  for (int s = 0; s < 2; ++s)
    for (int k = 0; k < 6; ++k) {
      const std::string name = "sigma/" + std::to_string(s) + "_" + std::to_string(k) + ".npy";
      if (fresh.count(name)) order.push_back(name);
    }
  for (const char* f : {"g.graphbin", "g.graph", "g.g2o", "g.nodes.csv", "p.rawlog"})
    order.push_back(f);
  ASSERT_EQ(order.size(), fresh.size());
  ASSERT_GT(order.size(), 10u);

  for (const std::size_t k : {std::size_t{0}, std::size_t{1}, std::size_t{3}, order.size()}) {
    SCOPED_TRACE("killed after " + std::to_string(k) + " renames");
    const std::string out = dir.file("out" + std::to_string(k));
    fs::create_directories(out + "/sigma");
    for (const std::string& name : order) std::ofstream(out + "/" + name) << "previous " << name;
    const testing::AppResult r = testing::runCommand(
        "DBACOV_TEST_KILL_IN_COMMIT=" + std::to_string(k) + " " + command(dir.file("in"), out));
    EXPECT_TRUE(r.code == -1 || r.code == 128 + 9) << r.code << r.out;  // SIGKILL
    std::map<std::string, std::string> expected;
    for (std::size_t i = 0; i < order.size(); ++i)
      expected[order[i]] = i < k ? fresh.at(order[i]) : "previous " + order[i];
    EXPECT_EQ(filesUnder(out), expected);  // and nothing else: no temporary
  }
}

}  // namespace kill_in_commit
}  // namespace dbacov
