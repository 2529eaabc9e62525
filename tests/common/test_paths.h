// Where a test program finds the checkout, its build tree and the shared data: read at run time
// from the build tree that holds the program (<build>/bin/<program> and <build>/CMakeCache.txt),
// not compiled in, so that no compiled test object depends on where the checkout is (a fresh clone
// elsewhere reuses ccache's objects). tests/CMakeLists.txt force-includes this header into every
// test and benchmark program, which use the three names below.
#pragma once

#include <unistd.h>

#include <fstream>
#include <string>

namespace dbacov::testing::paths {

/// <build>: the directory above the running program's bin/.
inline const std::string& binaryDir() {
  static const std::string dir = [] {
    char buf[4096];
    const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
    std::string path = n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
    for (int up = 0; up < 2; ++up) {  // drop the program's name, then bin/
      const std::size_t slash = path.rfind('/');
      path.resize(slash == std::string::npos ? 0 : slash);
    }
    return path;
  }();
  return dir;
}

/// The value of `key` in <build>/CMakeCache.txt; a path that names the missing entry otherwise,
/// so that a test that needs it fails saying what it looked for.
inline std::string cacheEntry(const std::string& key) {
  std::ifstream in(binaryDir() + "/CMakeCache.txt");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key + ":", 0) == 0 && line.find('=') != std::string::npos)
      return line.substr(line.find('=') + 1);
  return "/missing-" + key + "-in-" + binaryDir() + "/CMakeCache.txt";
}

inline const std::string& sourceDir() {
  static const std::string dir = cacheEntry("CMAKE_HOME_DIRECTORY");
  return dir;
}

inline const std::string& sharedDataDir() {
  static const std::string dir = cacheEntry("DBACOV_SHARED_DATA_DIR");
  return dir;
}

}  // namespace dbacov::testing::paths

#define DBACOV_SOURCE_DIR ::dbacov::testing::paths::sourceDir()
#define DBACOV_BINARY_DIR ::dbacov::testing::paths::binaryDir()
#define DBACOV_SHARED_DATA_DIR ::dbacov::testing::paths::sharedDataDir()
