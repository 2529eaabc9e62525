// A run that reads and writes no MRPT format loads neither MRPT nor OpenCV (the MRPT bridge is
// loaded on demand, bridge.h); one that writes a rawlog loads the bridge. Each test of this file
// runs in a process of its own (ctest), which links no MRPT library. And a run advises its heap
// for transparent huge pages (allocator_reuse.h).
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/app/covariance_app.h"
#include "dbacov/mrpt/bridge.h"
#include "fixtures.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

/// Whether a shared object whose file name contains `name` is mapped into this process.
bool mapped(const std::string& name) {
  std::ifstream maps("/proc/self/maps");
  for (std::string line; std::getline(maps, line);)
    if (line.find(name) != std::string::npos) return true;
  return false;
}

TEST(Startup, NpzToCsvLoadsNoMrptAndNoOpenCv) {
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 0);
  ASSERT_FALSE(mapped("libmrpt")) << "the test binary itself must not link MRPT";
  const auto r =
      testing::runApp(app::runCovarianceApp, "dba-covariance",
                      {"-i", dir.file("a.npz"), "--csv", dir.file("k.csv"), "--relative-csv",
                       dir.file("r.csv"), "--weight-scale", "4", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(mrpt_bridge::mrptBridgeLoaded());
  EXPECT_FALSE(mapped("libmrpt"));
  EXPECT_FALSE(mapped("libopencv"));
}

TEST(Startup, APoseRawlogLoadsTheBridgeOnDemand) {
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 0);
  const auto r = testing::runApp(app::runCovarianceApp, "dba-covariance",
                                 {"-i", dir.file("a.npz"), "-o", dir.file("p.rawlog"), "--fps",
                                  "10", "--weight-scale", "4", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(mrpt_bridge::mrptBridgeLoaded());
  EXPECT_TRUE(mapped("libdbacov_mrpt.so"));
  EXPECT_TRUE(mapped("libmrpt-obs"));
}

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define DBACOV_OTHER_MALLOC 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define DBACOV_OTHER_MALLOC 1
#endif
#endif

#if defined(__GLIBC__) && !defined(DBACOV_OTHER_MALLOC)
/// The header line and the VmFlags line of the mapping of this process that contains `address`
/// (empty strings if none).
std::pair<std::string, std::string> mappingAt(std::uintptr_t address) {
  std::ifstream smaps("/proc/self/smaps");
  std::string header;
  bool inside = false;
  for (std::string line; std::getline(smaps, line);) {
    std::uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream range(line);
    if (range >> std::hex >> lo >> dash >> hi && dash == '-' &&
        line.find(' ') != std::string::npos && line.find(':') > line.find(' ')) {
      inside = address >= lo && address < hi;
      if (inside) header = line;
      continue;
    }
    if (inside && line.rfind("VmFlags:", 0) == 0) return {header, line};
  }
  return {};
}
#endif

TEST(Startup, ARunAdvisesItsHeapForHugePages) {
#if defined(DBACOV_OTHER_MALLOC) || !defined(__GLIBC__)
  GTEST_SKIP() << "glibc's malloc only (the sanitizers bring their own)";
#else
  if (!std::filesystem::exists("/sys/kernel/mm/transparent_hugepage"))
    GTEST_SKIP() << "this kernel has no transparent huge pages";
  testing::TempDir dir;
  testing::writeTinySnapshot(dir.file("a.npz"), 1, 0);
  const auto r = testing::runApp(app::runCovarianceApp, "dba-covariance",
                                 {"-i", dir.file("a.npz"), "--csv", dir.file("k.csv"), "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  // A snapshot-sized block now comes from the heap's advised part: "hg" (MADV_HUGEPAGE) among
  // the flags of its mapping.
  void* block = std::malloc(std::size_t{8} << 20);
  ASSERT_NE(block, nullptr);
  const auto [header, flags] = mappingAt(reinterpret_cast<std::uintptr_t>(block) + (4u << 20));
  std::free(block);
  if (header.find("[heap]") == std::string::npos)
    GTEST_SKIP() << "malloc is not glibc's brk heap here (a preloaded allocator?): " << header;
  EXPECT_NE(flags.find(" hg"), std::string::npos) << header << "\n" << flags;
#endif
}

}  // namespace
}  // namespace dbacov
