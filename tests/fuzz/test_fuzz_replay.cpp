// The fuzz targets replayed by ctest, in every build (Release and the sanitizer pass): their seed
// corpora, which must be valid inputs, and every input of tests/fuzz/regressions/<target>/ — each
// one a crash or sanitizer report that fuzzing found once and that must never come back.
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "fuzz_seeds.h"

extern "C" int dbacovFuzzNpz(const std::uint8_t* data, std::size_t size);
extern "C" int dbacovFuzzRawlog(const std::uint8_t* data, std::size_t size);
extern "C" int dbacovFuzzGraph(const std::uint8_t* data, std::size_t size);
extern "C" int dbacovFuzzGroundTruth(const std::uint8_t* data, std::size_t size);
extern "C" int dbacovFuzzPythonSnapshot(const std::uint8_t* data, std::size_t size);

namespace dbacov {
namespace {

const std::string kRegressions = std::string(DBACOV_SOURCE_DIR) + "/tests/fuzz/regressions/";

/// The files of tests/fuzz/regressions/<target>/, sorted; fails the test when there are none (a
/// replay of an empty or missing corpus would pass whatever the target does).
std::vector<std::string> regressions(const std::string& target) {
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(kRegressions + target, ec))
    if (e.is_regular_file() && e.path().filename().string()[0] != '.')
      files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  EXPECT_FALSE(files.empty()) << kRegressions + target << ": no regression inputs"
                              << (ec ? " (" + ec.message() + ")" : std::string());
  return files;
}

std::vector<unsigned char> readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), {});
}

TEST(FuzzReplay, NpzSeedsAreValidSnapshots) {
  const fuzz::Corpus seeds = fuzz::npzSeeds();
  ASSERT_GE(seeds.size(), 4u);
  for (const auto& [name, bytes] : seeds) {
    SCOPED_TRACE(name);
    EXPECT_NO_THROW(EXPECT_EQ(fuzz::snapshotsInSeed("npz", name, bytes), 1));
    EXPECT_EQ(dbacovFuzzNpz(bytes.data(), bytes.size()), 0);
  }
}

TEST(FuzzReplay, RawlogSeedsHoldValidSnapshots) {
  const fuzz::Corpus seeds = fuzz::rawlogSeeds();
  ASSERT_GE(seeds.size(), 3u);
  for (const auto& [name, bytes] : seeds) {
    SCOPED_TRACE(name);
    int n = 0;
    EXPECT_NO_THROW(n = fuzz::snapshotsInSeed("rawlog", name, bytes));
    EXPECT_GE(n, 1);
    EXPECT_EQ(dbacovFuzzRawlog(bytes.data(), bytes.size()), 0);
  }
}

TEST(FuzzReplay, NpzRegressions) {
  for (const std::string& file : regressions("npz")) {
    SCOPED_TRACE(file);
    const std::vector<unsigned char> bytes = readBytes(file);
    EXPECT_EQ(dbacovFuzzNpz(bytes.data(), bytes.size()), 0);
  }
}

TEST(FuzzReplay, RawlogRegressions) {
  for (const std::string& file : regressions("rawlog")) {
    SCOPED_TRACE(file);
    const std::vector<unsigned char> bytes = readBytes(file);
    EXPECT_EQ(dbacovFuzzRawlog(bytes.data(), bytes.size()), 0);
  }
}

TEST(FuzzReplay, GraphSeedsAreValidGraphs) {
  const fuzz::Corpus seeds = fuzz::graphSeeds();
  ASSERT_GE(seeds.size(), 3u);
  for (const auto& [name, bytes] : seeds) {
    SCOPED_TRACE(name);
    int n = 0;
    EXPECT_NO_THROW(n = fuzz::itemsInSeed("graph", name, bytes));
    EXPECT_GE(n, 2);
    EXPECT_EQ(dbacovFuzzGraph(bytes.data(), bytes.size()), 0);
  }
}

TEST(FuzzReplay, GroundTruthSeedsAreValid) {
  const fuzz::Corpus seeds = fuzz::groundTruthSeeds();
  ASSERT_GE(seeds.size(), 4u);
  for (const auto& [name, bytes] : seeds) {
    SCOPED_TRACE(name);
    int n = 0;
    EXPECT_NO_THROW(n = fuzz::itemsInSeed("ground_truth", name, bytes));
    EXPECT_GE(n, 2);
    EXPECT_EQ(dbacovFuzzGroundTruth(bytes.data(), bytes.size()), 0);
  }
}

TEST(FuzzReplay, GraphRegressions) {
  for (const std::string& file : regressions("graph")) {
    SCOPED_TRACE(file);
    const std::vector<unsigned char> bytes = readBytes(file);
    EXPECT_EQ(dbacovFuzzGraph(bytes.data(), bytes.size()), 0);
  }
}

TEST(FuzzReplay, GroundTruthRegressions) {
  for (const std::string& file : regressions("ground_truth")) {
    SCOPED_TRACE(file);
    const std::vector<unsigned char> bytes = readBytes(file);
    EXPECT_EQ(dbacovFuzzGroundTruth(bytes.data(), bytes.size()), 0);
  }
}

TEST(FuzzReplay, PythonSnapshotSeedsAreValid) {
  const fuzz::Corpus seeds = fuzz::pythonSnapshotSeeds();
  ASSERT_GE(seeds.size(), 4u);
  for (const auto& [name, bytes] : seeds) {
    SCOPED_TRACE(name);
    EXPECT_NO_THROW(EXPECT_EQ(fuzz::itemsInSeed("python_snapshot", name, bytes), 1));
    EXPECT_EQ(dbacovFuzzPythonSnapshot(bytes.data(), bytes.size()), 0);
  }
}

TEST(FuzzReplay, PythonSnapshotRegressions) {
  for (const std::string& file : regressions("python_snapshot")) {
    SCOPED_TRACE(file);
    const std::vector<unsigned char> bytes = readBytes(file);
    EXPECT_EQ(dbacovFuzzPythonSnapshot(bytes.data(), bytes.size()), 0);
  }
}

}  // namespace
}  // namespace dbacov
