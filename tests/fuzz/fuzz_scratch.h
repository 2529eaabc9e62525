// For the fuzz targets whose reader takes a path (the pose-graph and ground-truth readers): the
// input's bytes in a scratch file of this process, rewritten for every input.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

namespace dbacov::fuzz {

/// Writes `size` bytes to a scratch file named after the process and `name` (its extension is
/// what the reader sees), in /dev/shm when there is one (no disk I/O), else the temporary
/// directory; returns its path. The file is removed when the process ends.
inline std::string scratchFile(const std::string& name, const std::uint8_t* data,
                               std::size_t size) {
  struct Scratch {
    std::string path;
    ~Scratch() {
      if (!path.empty()) std::remove(path.c_str());
    }
  };
  static Scratch s;
  if (s.path.empty()) {
    std::error_code ec;
    const std::filesystem::path dir = std::filesystem::is_directory("/dev/shm", ec)
                                          ? std::filesystem::path("/dev/shm")
                                          : std::filesystem::temp_directory_path();
    s.path = (dir / ("dbacov_fuzz_" + std::to_string(::getpid()) + "_" + name)).string();
  }
  std::FILE* f = std::fopen(s.path.c_str(), "wb");
  if (!f) __builtin_trap();  // the harness itself failed
  if (size && std::fwrite(data, 1, size, f) != size) __builtin_trap();
  std::fclose(f);
  return s.path;
}

}  // namespace dbacov::fuzz
