// An output that cannot be written in the middle of a run (disk full, quota, file size limit):
// the real dba-covariance runs under a file size limit (RLIMIT_FSIZE through the shell's ulimit,
// SIGXFSZ ignored, so writes past it fail with EFBIG as on a full disk). Each output that fails is
// reported once, at the snapshot where it failed, is not written (the previous file stays), and
// the run goes on with the other outputs; the summary counts it.
#include <filesystem>
#include <fstream>
#include <regex>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace disk_full {  // not anonymous: the suite is compiled as a unity build

const std::string kBin = std::string(DBACOV_BINARY_DIR) + "/bin/";

TEST(DiskFull, AnOutputThatFailsMidRunIsGivenUpAndTheOthersGoOn) {
  testing::TempDir dir;
  std::filesystem::create_directory(dir.file("in"));
  for (int n = 0; n < 30; ++n) {  // different seeds: data that does not compress away
    char name[32];
    std::snprintf(name, sizeof name, "in/s%02d.npz", n);
    testing::writeTinySnapshot(dir.file(name), 10 + n, n);
  }
  for (const char* name : {"k.csv", "p.rawlog"}) std::ofstream(dir.file(name)) << "previous";
  // 8 KiB per file: the table fails within a few snapshots, the compressed rawlog later (zlib
  // writes it in 8 KiB blocks); the graph files, written at the end, are small enough.
  const testing::AppResult r = testing::runCommand(
      "bash -c \"trap '' XFSZ; ulimit -f 8; exec " + kBin + "dba-covariance -i " + dir.file("in") +
      " --csv " + dir.file("k.csv") + " -o " + dir.file("p.rawlog") + " --emit all --graph " +
      dir.file("g") + " --weight-scale 4 --stated-model\"");
  EXPECT_EQ(r.code, 1);
  const std::vector<std::string> lines = testing::splitLines(r.out);
  ASSERT_EQ(lines.size(), 4u) << r.out;
  const std::string snapshot =
      "dba-covariance: error: " + dir.file("in") + "/s[0-9]+\\.npz \\(snapshot [0-9]+\\): ";
  EXPECT_TRUE(std::regex_match(
      lines[0], std::regex(snapshot + dir.file("k.csv") + ": write failed: File too large")))
      << lines[0];
  EXPECT_TRUE(std::regex_match(lines[1], std::regex(snapshot + dir.file("p.rawlog") +
                                                    ": write failed: File too large \\(at entry "
                                                    "[0-9]+\\)")))
      << lines[1];
  // The graph's account (sequence information).
  EXPECT_EQ(lines[2].rfind("dba-covariance: graph: ", 0), 0u) << lines[2];
  // Each failing output costs exactly one snapshot; every other snapshot is processed.
  EXPECT_TRUE(std::regex_match(
      lines[3], std::regex("dba-covariance: 30 snapshots read, 28 processed, 2 failed: 2 output "
                           "\\(s[0-9]+\\.npz, s[0-9]+\\.npz\\); 2 outputs not written")))
      << lines[3];
  for (const char* name : {"k.csv", "p.rawlog"})
    EXPECT_EQ(testing::readFile(dir.file(name)), "previous");
  EXPECT_TRUE(std::filesystem::exists(dir.file("g.graphbin")));  // the graph was still written
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"g.g2o", "g.graph", "g.graphbin",
                                                     "g.nodes.csv", "in", "k.csv", "p.rawlog"}));
}

}  // namespace disk_full
}  // namespace dbacov
