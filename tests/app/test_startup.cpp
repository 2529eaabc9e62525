// A run that reads and writes no MRPT format loads neither MRPT nor OpenCV (the MRPT bridge is
// loaded on demand, bridge.h); one that writes a rawlog loads the bridge. Each test of this file
// runs in a process of its own (ctest), which links no MRPT library.
#include <fstream>
#include <string>

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

}  // namespace
}  // namespace dbacov
