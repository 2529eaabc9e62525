#include "dbacov/io/memory_budget.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>

#include "dbacov/core/errors.h"

namespace dbacov::io {
namespace {

constexpr std::uint64_t kUnlimited = std::numeric_limits<std::uint64_t>::max();

std::uint64_t physicalMemory() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page <= 0) return kUnlimited;
  return static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page);
}

std::uint64_t addressSpaceLimit() {
  rlimit lim{};
  if (getrlimit(RLIMIT_AS, &lim) != 0 || lim.rlim_cur == RLIM_INFINITY) return kUnlimited;
  return static_cast<std::uint64_t>(lim.rlim_cur);
}

/// cgroup v2's memory.max of this process's group ("max" or absent: no limit).
std::uint64_t cgroupLimit() {
  std::ifstream self("/proc/self/cgroup");
  std::string line, group;
  while (std::getline(self, line))
    if (line.rfind("0::", 0) == 0) group = line.substr(3);
  if (group.empty()) return kUnlimited;
  std::ifstream max("/sys/fs/cgroup" + group + "/memory.max");
  std::string value;
  if (!(max >> value) || value == "max") return kUnlimited;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(value.c_str(), &end, 10);
  return end && *end == '\0' && v > 0 ? static_cast<std::uint64_t>(v) : kUnlimited;
}

/// "512M" → 512·2^20; nullopt-like 0 when the text is not a positive size.
std::uint64_t parseSize(const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || errno != 0 || !std::isfinite(v) || v <= 0) return 0;
  double scale = 1;
  const std::string suffix(end);
  if (suffix == "K" || suffix == "k")
    scale = 1024.0;
  else if (suffix == "M")
    scale = 1024.0 * 1024;
  else if (suffix == "G")
    scale = 1024.0 * 1024 * 1024;
  else if (suffix == "T")
    scale = 1024.0 * 1024 * 1024 * 1024;
  else if (!suffix.empty())
    return 0;
  const double bytes = std::floor(v * scale);
  if (bytes < 1 || bytes >= 1.8e19) return 0;
  return static_cast<std::uint64_t>(bytes);
}

}  // namespace

MemoryBudget memoryBudget() {
  if (const char* env = std::getenv("DBACOV_MEMORY_BUDGET"); env && *env) {
    const std::uint64_t v = parseSize(env);
    if (v == 0)
      throw InputError(std::string("DBACOV_MEMORY_BUDGET='") + env +
                       "' is not a size (bytes, or a number with a K, M, G or T suffix, e.g. 8G)");
    return {v, "set by DBACOV_MEMORY_BUDGET"};
  }
  const std::uint64_t usable = std::min({physicalMemory(), addressSpaceLimit(), cgroupLimit()});
  const char* how = "; the environment variable DBACOV_MEMORY_BUDGET, e.g. 16G, sets another";
  if (usable != kUnlimited && usable / 3 < kDefaultMemoryBudget)
    return {usable / 3, std::string("a third of this process's memory") + how};
  return {kDefaultMemoryBudget, std::string("the default cap of 4 GiB") + how};
}

std::string sizeText(std::uint64_t bytes) {
  if (bytes < 1024) return std::to_string(bytes) + (bytes == 1 ? " byte" : " bytes");
  const char* units[] = {"KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  double v = static_cast<double>(bytes) / 1024;
  int u = 0;
  while (v >= 1023.95 && u < 5) {
    v /= 1024;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, v < 99.95 ? "%.1f %s" : "%.0f %s", v, units[u]);
  return buf;
}

}  // namespace dbacov::io
