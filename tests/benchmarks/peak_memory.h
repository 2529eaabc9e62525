// Peak resident memory of a phase of a benchmark (Linux): reset the high-water mark, run the
// phase, read VmHWM. The result includes what was resident before the phase, so callers report
// peak − baseline.
#pragma once

#include <fstream>
#include <string>

namespace dbacov::bench {

inline long readStatusKb(const std::string& field) {
  std::ifstream f("/proc/self/status");
  for (std::string line; std::getline(f, line);)
    if (line.rfind(field + ":", 0) == 0) return std::stol(line.substr(field.size() + 1));
  return -1;
}

/// Resets VmHWM to the current RSS (Linux >= 4.0); returns the current RSS in bytes.
inline double resetPeakRss() {
  std::ofstream("/proc/self/clear_refs") << "5";
  return readStatusKb("VmRSS") * 1024.0;
}

inline double peakRss() {
  return readStatusKb("VmHWM") * 1024.0;
}

}  // namespace dbacov::bench
