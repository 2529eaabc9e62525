// Declared sizes that the data does not back (an .npy header, a zip directory, a rawlog record)
// are refused before anything of that size is allocated: each case names the file and what was
// wrong, and the largest single allocation made while reading it stays small
// (largest_allocation.h).
#include <cstdlib>
#include <filesystem>
#include <regex>

#include <gtest/gtest.h>
#include <mrpt/obs/CSensoryFrame.h>

#include "app_runner.h"
#include "bad_inputs.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/app/simul_app.h"
#include "dbacov/io/memory_budget.h"
#include "dbacov/io/snapshot_npz.h"
#include "dbacov/mrpt/rawlog_io.h"
#include "fixtures.h"
#include "largest_allocation.h"
#include "rawlog_records.h"
#include "temp_dir.h"

namespace dbacov {
namespace huge_sizes {  // not anonymous: the suite is compiled as a unity build

constexpr std::size_t kMiB = std::size_t{1} << 20;

/// The message of the InputError that `f` throws, and the largest allocation while it ran.
template <typename F>
std::pair<std::string, std::size_t> refusal(F&& f) {
  std::string message = "(no InputError)";
  const std::size_t largest = testing::largestAllocationDuring([&] {
    try {
      f();
    } catch (const InputError& e) {
      message = e.what();
    }
  });
  return {message, largest};
}

/// refusal() of loading the snapshot archive `path`.
std::pair<std::string, std::size_t> npzRefusal(const std::string& path) {
  return refusal([&] { io::loadSnapshotNpz(path, 0); });
}

/// refusal() of reading the first snapshot of the rawlog `path`.
std::pair<std::string, std::size_t> rawlogRefusal(const std::string& path) {
  return refusal([&] {
    mrpt_bridge::RawlogSnapshotReader reader(path, 0);
    Snapshot s;
    reader.next(&s);
  });
}

/// A snapshot archive whose member `key` is replaced by `member` (stored, hand-made zip).
std::vector<unsigned char> withMember(const std::string& key, std::vector<unsigned char> member,
                                      std::uint32_t declared_size = 0) {
  auto members = testing::npyMembers(testing::snapshotArrays(testing::tinySnapshot(1, 1).snapshot));
  for (auto& m : members)
    if (m.name == key + ".npy") m = {m.name, std::move(member), declared_size};
  return testing::storedZip(members);
}

TEST(HugeSizes, TrackerSeesLargeAllocations) {
  const auto [message, largest] = refusal([] {
    std::vector<char> v(8 * kMiB, 1);
    if (v[v.size() / 2] != 1) throw InputError("unexpected");
  });
  EXPECT_EQ(message, "(no InputError)");
  EXPECT_GE(largest, 8 * kMiB);
}

TEST(HugeSizes, NpyHeadersDeclaringMoreThanTheMemberHoldsAreRefusedBeforeAllocation) {
  struct Case {
    std::string key, shape, error;
  };
  for (const Case& c : std::vector<Case>{
           {"target", "(1099511627776, 2, 1024, 1024)",  // petabytes
            "declared shape (1099511627776,2,1024,1024) of float32 needs 9223372036854775808 "
            "data bytes, but 64 are present"},
           {"weight", "(18, 2, 8000, 10000)",
            "declared shape (18,2,8000,10000) of float32 needs 11520000000 data bytes, but 64 "
            "are present"}}) {
    SCOPED_TRACE(c.key);
    testing::TempDir dir;
    testing::writeBytes(dir.file("s.npz"),
                        withMember(c.key, testing::rawNpy("{'descr': '<f4', 'fortran_order': "
                                                          "False, 'shape': " +
                                                              c.shape + ", }",
                                                          64)));
    const auto [message, largest] = npzRefusal(dir.file("s.npz"));
    EXPECT_EQ(message, dir.file("s.npz") + ": key '" + c.key + "': " + c.error);
    EXPECT_LT(largest, kMiB);
  }
}

TEST(HugeSizes, NpyHeaderLengthOf4GiBIsRefused) {
  testing::TempDir dir;
  const std::vector<unsigned char> v1 =
      testing::rawNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (6,), }", 48);
  // Version 2.0: a 4-byte header length, here 0xFFFFFFFF.
  std::vector<unsigned char> v2(v1.begin(), v1.begin() + 8);
  v2[6] = 2;
  v2.resize(12, 0xff);
  v2.insert(v2.end(), v1.begin() + 10, v1.end());
  testing::writeBytes(dir.file("s.npz"), withMember("tstamp", v2));
  const auto [message, largest] = npzRefusal(dir.file("s.npz"));
  EXPECT_EQ(message, dir.file("s.npz") +
                         ": key 'tstamp': .npy header of 4294967295 bytes is longer than the "
                         "accepted 65536");
  EXPECT_LT(largest, kMiB);
}

TEST(HugeSizes, ZipDirectoryDeclaringAHugeMemberIsRefusedBeforeAllocation) {
  testing::TempDir dir;
  auto arrays = testing::snapshotArrays(testing::tinySnapshot(1, 1).snapshot);
  const std::vector<unsigned char> disps = io::serializeNpy(testing::arrayOf(arrays, "disps"));
  testing::writeBytes(dir.file("s.npz"), withMember("disps", disps, 0xF0000000u));
  const auto [message, largest] = npzRefusal(dir.file("s.npz"));
  EXPECT_EQ(message.substr(0, message.find(" in a file of")),
            dir.file("s.npz") + ": key 'disps': member claims 4026531840 compressed bytes");
  EXPECT_LT(largest, kMiB);
}

TEST(HugeSizes, ZipEndRecordDeclaringManyEntriesIsRefused) {
  testing::TempDir dir;
  const auto members =
      testing::npyMembers(testing::snapshotArrays(testing::tinySnapshot(1, 1).snapshot));
  testing::writeBytes(dir.file("s.npz"), testing::storedZip(members, 65535));
  const auto [message, largest] = npzRefusal(dir.file("s.npz"));
  EXPECT_EQ(message,
            dir.file("s.npz") + ": cannot open as a .npz (zip) archive: Zip archive inconsistent");
  EXPECT_LT(largest, kMiB);
}

TEST(HugeSizes, RawlogRecordDeclaringHugeSizesIsRefusedBeforeAllocation) {
  testing::TempDir dir;
  testing::writeRecord(
      dir.file("s.rawlog"), testing::tinySnapshot(1, 1).snapshot,
      [](testing::RecordBytes& r) { r.setSizes(2000000000, 30000, 30000, 2000000000); });
  const auto [message, largest] = rawlogRefusal(dir.file("s.rawlog"));
  EXPECT_EQ(message, dir.file("s.rawlog") +
                         ": entry 0 cannot be read: snapshot record declares N=2000000000, "
                         "H=30000, W=30000, E=2000000000 (3.6e+19 bytes), more than the limit of "
                         "8589934592 bytes");
  EXPECT_LT(largest, kMiB);
}

TEST(HugeSizes, TruncatedRawlogRecordCostsOnlyTheMemoryOfItsData) {
  testing::TempDir dir;
  // 6 keyframes of 4000×4000 pixels: 384 MB of inverse depths declared, 320 bytes present.
  testing::writeRecord(dir.file("s.rawlog"), testing::tinySnapshot(1, 1).snapshot,
                       [](testing::RecordBytes& r) { r.setSizes(6, 4000, 4000, 18); });
  const auto [message, largest] = rawlogRefusal(dir.file("s.rawlog"));
  EXPECT_EQ(message.substr(0, message.find(" bytes) but")),
            dir.file("s.rawlog") +
                ": entry 0 cannot be read: snapshot record truncated in 'disps': it declares "
                "96000000 values (384000000");
  EXPECT_LT(largest, 20 * kMiB);
}

TEST(HugeSizes, RawlogLabelOf4GiBIsRefused) {
  testing::TempDir dir;
  testing::writeRecord(dir.file("s.rawlog"), testing::tinySnapshot(1, 1).snapshot,
                       [](testing::RecordBytes& r) { r.setLabelLength(0xFFFFFFF0u); });
  const auto [message, largest] = rawlogRefusal(dir.file("s.rawlog"));
  EXPECT_EQ(message, dir.file("s.rawlog") +
                         ": entry 0 cannot be read: snapshot record declares a sensorLabel of "
                         "4294967280 bytes, more than the 65536 accepted");
  EXPECT_LT(largest, kMiB);
}

TEST(HugeSizes, SensoryFrameDeclaringBillionsOfObservationsIsRefusedBeforeAllocation) {
  // Found by fuzz_rawlog: MRPT's CSensoryFrame grows its container to the declared count.
  testing::TempDir dir;
  auto frame = mrpt::obs::CSensoryFrame::Create();
  auto obs = std::make_shared<CObservationDbaSnapshot>();
  obs->snapshot = testing::tinySnapshot(1, 1).snapshot;
  frame->insert(obs);
  mrpt::io::CMemoryStream mem;
  auto arch = mrpt::serialization::archiveFrom(mem);
  arch << *frame;
  const auto* p = static_cast<const unsigned char*>(mem.getRawBufferData());
  std::vector<unsigned char> bytes(p, p + mem.getTotalBytesCount());
  const std::string name = "mrpt::obs::CSensoryFrame";
  ASSERT_EQ(std::string(bytes.begin() + 1, bytes.begin() + 1 + name.size()), name);
  for (int i = 0; i < 4; ++i) bytes[1 + name.size() + 1 + i] = 0xfe;  // 4278124286 observations
  testing::writeGz(dir.file("s.rawlog"), bytes);
  const auto [message, largest] = rawlogRefusal(dir.file("s.rawlog"));
  EXPECT_EQ(message, dir.file("s.rawlog") +
                         ": entry 0 cannot be read: CSensoryFrame declares 4278124286 "
                         "observations, more than the 65536 accepted");
  EXPECT_LT(largest, kMiB);
}

/// Sets an environment variable for the scope.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) { ::setenv(name, value, 1); }
  ~ScopedEnv() { ::unsetenv(name_); }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
};

/// A deflate bomb: a valid two-keyframe snapshot on a 256×256 grid of constant planes, which
/// deflate packs about 1000:1 (~2.5 MiB of arrays in ~10 KiB).
std::string writeDeflateBomb(const testing::TempDir& dir) {
  Snapshot s = testing::tinySnapshot(1, 1, 2).snapshot;
  s.H = s.W = 256;
  const std::size_t plane = 256 * 256, N = static_cast<std::size_t>(s.numKeyframes()),
                    E = static_cast<std::size_t>(s.numEdges());
  s.disps.assign(N * plane, 0.5f);
  s.target.assign(E * 2 * plane, 1.f);
  s.weight.assign(E * 2 * plane, 1.f);
  const std::string path = dir.file("bomb.npz");
  io::saveSnapshotNpz(path, s);
  return path;
}

TEST(HugeSizes, DeflateBombIsRefusedByTheMemoryBudgetBeforeInflating) {
  testing::TempDir dir;
  const std::string path = writeDeflateBomb(dir);
  ASSERT_LT(std::filesystem::file_size(path), 100'000u);
  {
    const ScopedEnv budget("DBACOV_MEMORY_BUDGET", "1M");
    const auto [message, largest] = npzRefusal(path);
    EXPECT_EQ(std::regex_replace(message, std::regex("[0-9.]+ (KiB|MiB)"), "#"),
              path +
                  ": its arrays declare # uncompressed (the largest, key 'target', #; the "
                  "archive itself is #), more than the memory budget of # (set by "
                  "DBACOV_MEMORY_BUDGET)");
    EXPECT_NE(message.find("budget of 1.0 MiB"), std::string::npos) << message;
    EXPECT_LT(largest, kMiB);
    // The CLI: that message, exit 1 (every snapshot failed), no output written.
    const auto r = testing::runApp(app::runCovarianceApp, "dba-covariance",
                                   {"-i", path, "--csv", dir.file("k.csv")});
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("more than the memory budget of 1.0 MiB"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("k.csv")));
  }
  // Without the budget's override the same file is an ordinary snapshot.
  EXPECT_NO_THROW(io::loadSnapshotNpz(path, 0));
}

TEST(HugeSizes, SimulatorRefusesASnapshotBeyondTheMemoryBudgetBeforeTheWork) {
  testing::TempDir dir;
  const ScopedEnv budget("DBACOV_MEMORY_BUDGET", "100K");
  const auto r = testing::runApp(app::runSimulApp, "simul-dba",
                                 {"-o", dir.file("w"), "--mode", "whole", "--keyframes", "8"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(std::regex_replace(r.err, std::regex("[0-9]+ edges|[0-9.]+ (KiB|MiB)"), "#"),
            "simul-dba: error: snapshot 0 would hold # of arrays (8 keyframes, # on a 48x64 "
            "grid), more than the memory budget of # (set by DBACOV_MEMORY_BUDGET): ask for "
            "fewer keyframes, a smaller grid or --mode sliding-window\n");
  EXPECT_FALSE(std::filesystem::exists(dir.file("w")));
}

TEST(HugeSizes, MemoryBudgetIsASizeOrTheRunStops) {
  EXPECT_GT(io::memoryBudget().bytes, 0u);
  EXPECT_LE(io::memoryBudget().bytes, io::kDefaultMemoryBudget);
  for (const char* bad : {"0", "-1", "lots", "8Q", "nan", "1e40"}) {
    const ScopedEnv budget("DBACOV_MEMORY_BUDGET", bad);
    try {
      io::memoryBudget();
      ADD_FAILURE() << bad << " accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()), std::string("DBACOV_MEMORY_BUDGET='") + bad +
                                           "' is not a size (bytes, or a number with a K, M, G "
                                           "or T suffix, e.g. 8G)");
    }
  }
  const ScopedEnv budget("DBACOV_MEMORY_BUDGET", "1.5G");
  EXPECT_EQ(io::memoryBudget().bytes, std::uint64_t{3} << 29);
  EXPECT_EQ(io::memoryBudget().source, "set by DBACOV_MEMORY_BUDGET");
  EXPECT_EQ(io::sizeText(17), "17 bytes");
  EXPECT_EQ(io::sizeText(5'312'000'000), "4.9 GiB");
  EXPECT_EQ(io::sizeText(812'400'000), "775 MiB");
  EXPECT_EQ(io::sizeText(std::uint64_t{4} << 30), "4.0 GiB");
}

}  // namespace huge_sizes
}  // namespace dbacov
