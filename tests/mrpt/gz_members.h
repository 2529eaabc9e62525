// What the gzip tests read from GzOutputStream's files, independently of GzInputStream: the raw
// bytes, the members (each with the 'DB' size subfield: member size at byte 16, flags at 20,
// the deflate data from 24, ISIZE in its last 4 bytes), and the data as zlib's own gzread sees it.
#pragma once

#include <zlib.h>

#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace dbacov::testing {

inline std::vector<unsigned char> fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), {});
}

/// The little-endian 32-bit value at byte `at`.
inline std::size_t load32(const std::vector<unsigned char>& b, std::size_t at) {
  return b[at] | b[at + 1] << 8 | b[at + 2] << 16 | std::size_t{b[at + 3]} << 24;
}

/// Offsets of the members in `file` (each must start with the 'DB' size subfield).
inline std::vector<std::size_t> members(const std::vector<unsigned char>& file) {
  std::vector<std::size_t> at;
  for (std::size_t p = 0; p + 24 <= file.size();) {
    EXPECT_EQ(file[p], 0x1f);
    EXPECT_EQ(file[p + 12], 'D');
    EXPECT_EQ(file[p + 13], 'B');
    at.push_back(p);
    const std::size_t size = load32(file, p + 16);
    if (size < 32) {
      ADD_FAILURE() << "a member of " << size << " bytes at " << p;
      break;
    }
    p += size;
  }
  return at;
}

/// BTYPE of the first deflate block of the member at `at` (0 = stored, 1 fixed, 2 dynamic).
inline int firstBlockType(const std::vector<unsigned char>& file, std::size_t at) {
  return (file[at + 24] >> 1) & 3;
}

/// Everything zlib's gzread gives for `path` (a failure is a test failure).
inline std::vector<unsigned char> zlibReadAll(const std::string& path) {
  std::vector<unsigned char> out;
  gzFile gz = gzopen(path.c_str(), "rb");
  if (!gz) {
    ADD_FAILURE() << "gzopen " << path;
    return out;
  }
  std::vector<unsigned char> buf(1 << 16);
  for (;;) {
    const int n = gzread(gz, buf.data(), static_cast<unsigned>(buf.size()));
    if (n < 0) ADD_FAILURE() << "gzread " << path << " failed";
    if (n <= 0) break;
    out.insert(out.end(), buf.begin(), buf.begin() + n);
  }
  gzclose(gz);
  return out;
}

}  // namespace dbacov::testing
