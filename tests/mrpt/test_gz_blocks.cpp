// The gzip members of GzOutputStream (each inflated whole with libdeflate on reading):
// members that carry their size, read back by zlib and by GzInputStream; another writer's member
// after ours read through zlib; damage and a cut between two members are read errors, not ends;
// members that deflate shrinks by less than half are stored blocks.
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

#include <gtest/gtest.h>

#include "gz_members.h"
#include "gz_streams.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

using mrpt_bridge::GzInputStream;
using mrpt_bridge::GzOutputStream;
using testing::fileBytes;
using testing::firstBlockType;
using testing::load32;
using testing::members;
using testing::zlibReadAll;

/// Random bytes of an alphabet of `symbols` letters: deflate leaves ≈ log2(symbols) / 8 of them.
std::vector<unsigned char> randomText(std::size_t n, std::uint32_t seed, unsigned symbols) {
  std::vector<unsigned char> v(n);
  std::uint32_t x = seed;
  for (auto& c : v) {
    x = x * 1103515245u + 12345u;
    c = static_cast<unsigned char>(32 + (x >> 16) % symbols);
  }
  return v;
}

/// Compressible but not trivial: four letters (deflate: ≈ 0.3).
std::vector<unsigned char> letters(std::size_t n, std::uint32_t seed) {
  return randomText(n, seed, 4);
}

void putBytes(const std::string& path, const std::vector<unsigned char>& b) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

/// Everything GzInputStream gives, in reads of odd sizes; *error when a read failed.
std::vector<unsigned char> readAllOf(const std::string& path, bool* error) {
  GzInputStream in(path);
  std::vector<unsigned char> out;
  std::vector<unsigned char> buf(70001);
  *error = false;
  for (;;) {
    const std::size_t n = in.Read(buf.data(), buf.size());
    if (n == static_cast<std::size_t>(-1)) {
      *error = true;
      break;
    }
    if (n == 0) break;
    out.insert(out.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
  }
  EXPECT_EQ(in.getPosition(), out.size());
  return out;
}

std::vector<unsigned char> writeOurs(const std::string& path, std::size_t n) {
  const std::vector<unsigned char> data = letters(n, 99);
  GzOutputStream out(path, path);
  for (std::size_t at = 0; at < n; at += 100000)  // several writes across member boundaries
    out.Write(data.data() + at, std::min<std::size_t>(100000, n - at));
  EXPECT_EQ(out.getPosition(), n);
  out.close();
  return data;
}

TEST(GzBlocks, MembersCarryTheirSizeAndBothReadersReadThem) {
  testing::TempDir dir;
  const std::string path = dir.file("a.gz");
  const std::vector<unsigned char> data = writeOurs(path, 3000000);
  const std::vector<unsigned char> file = fileBytes(path);
  const std::vector<std::size_t> at = members(file);
  // 8, 16, ..., 256 KiB, then 256 KiB members: 3 MB need 16 of them.
  EXPECT_EQ(at.size(), 16u);
  EXPECT_EQ(file[at.back() + 20] & 1, 1) << "the last member is marked";
  EXPECT_EQ(file[at.front() + 20] & 1, 0);
  EXPECT_EQ(zlibReadAll(path), data);
  bool error = true;
  EXPECT_EQ(readAllOf(path, &error), data);
  EXPECT_FALSE(error);
  // An empty output is one (empty, last) member.
  writeOurs(dir.file("empty.gz"), 0);
  EXPECT_TRUE(readAllOf(dir.file("empty.gz"), &error).empty());
  EXPECT_FALSE(error);
}

TEST(GzBlocks, AnotherWritersMemberAfterOursAndOtherFilesGoThroughZlib) {
  testing::TempDir dir;
  const std::string path = dir.file("a.gz");
  std::vector<unsigned char> data = writeOurs(path, 500000);
  const std::vector<unsigned char> tail = letters(200000, 5);
  gzFile gz = gzopen(path.c_str(), "ab");  // zlib appends a member of its own
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, tail.data(), static_cast<unsigned>(tail.size())),
            static_cast<int>(tail.size()));
  ASSERT_EQ(gzclose(gz), Z_OK);
  data.insert(data.end(), tail.begin(), tail.end());
  bool error = true;
  EXPECT_EQ(readAllOf(path, &error), data);
  EXPECT_FALSE(error);
  // zlib's gzip alone, and a plain (uncompressed) file
  gz = gzopen(dir.file("z.gz").c_str(), "wb");
  gzwrite(gz, tail.data(), static_cast<unsigned>(tail.size()));
  gzclose(gz);
  EXPECT_EQ(readAllOf(dir.file("z.gz"), &error), tail);
  EXPECT_FALSE(error);
  putBytes(dir.file("plain"), tail);
  EXPECT_EQ(readAllOf(dir.file("plain"), &error), tail);
  EXPECT_FALSE(error);
}

TEST(GzBlocks, DamageAndACutBetweenMembersAreReadErrors) {
  testing::TempDir dir;
  const std::string path = dir.file("a.gz");
  const std::vector<unsigned char> data = writeOurs(path, 1000000);
  const std::vector<unsigned char> file = fileBytes(path);
  const std::vector<std::size_t> at = members(file);
  ASSERT_GE(at.size(), 4u);
  struct Case {
    const char* name;
    std::vector<unsigned char> bytes;
  };
  std::vector<Case> cases;
  cases.push_back({"cut after the third member", {file.begin(), file.begin() + at[3]}});
  cases.push_back({"cut inside the third member", {file.begin(), file.begin() + at[2] + 1000}});
  cases.push_back({"cut inside a header", {file.begin(), file.begin() + at[3] + 10}});
  std::vector<unsigned char> flipped = file;
  flipped[at[2] + 3000] ^= 0x10;
  cases.push_back({"a flipped byte in the third member", flipped});
  std::vector<unsigned char> crc = file;
  crc[at[3] - 8] ^= 0x01;  // the third member's CRC-32
  cases.push_back({"a wrong CRC-32", crc});
  std::vector<unsigned char> size = file;
  size[at[2] + 16] ^= 0x01;  // the third member's recorded size
  cases.push_back({"a wrong member size", size});
  const std::size_t before_third = 8192 + 16384;  // uncompressed bytes of the first two members
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    putBytes(dir.file("bad.gz"), c.bytes);
    bool error = false;
    const std::vector<unsigned char> got = readAllOf(dir.file("bad.gz"), &error);
    EXPECT_TRUE(error);
    ASSERT_GE(got.size(), before_third);
    EXPECT_TRUE(std::equal(got.begin(), got.end(), data.begin())) << "what was read is the data";
  }
}

/// Float32 noise, as a snapshot's flows and depth maps: deflate barely shrinks it.
std::vector<unsigned char> floatNoise(std::size_t floats, std::uint32_t seed) {
  std::vector<float> f(floats);
  std::uint32_t x = seed;
  for (float& v : f) {
    x = x * 1103515245u + 12345u;
    v = 20.0f + static_cast<float>(x >> 8) * 1e-6f;
  }
  std::vector<unsigned char> b(floats * sizeof(float));
  std::memcpy(b.data(), f.data(), b.size());
  return b;
}

TEST(GzBlocks, MembersDeflateShrinksByLessThanHalfAreStored) {
  testing::TempDir dir;
  const std::string path = dir.file("a.gz");
  // A compressible stretch, float noise across several members, then compressible again.
  std::vector<unsigned char> data = letters(300000, 7);
  const std::vector<unsigned char> noise = floatNoise(250000, 3);
  data.insert(data.end(), noise.begin(), noise.end());
  const std::vector<unsigned char> tail = letters(600000, 8);
  data.insert(data.end(), tail.begin(), tail.end());
  {
    GzOutputStream out(path, path);
    out.Write(data.data(), data.size());
    out.close();
  }
  const std::vector<unsigned char> file = fileBytes(path);
  const std::vector<std::size_t> at = members(file);
  // Uncompressed extents of the members: 8, 16, ..., 128 KiB, then 256 KiB each.
  std::size_t begin = 0, stored = 0, compressed = 0;
  for (std::size_t m = 0; m < at.size(); ++m) {
    const std::size_t end = m + 1 < at.size() ? at[m + 1] : file.size();
    const std::size_t isize = load32(file, end - 4);
    const bool all_noise = begin >= 300000 && begin + isize <= 1300000;
    const bool no_noise = begin + isize <= 300000 || begin >= 1300000;
    SCOPED_TRACE("member " + std::to_string(m) + " at " + std::to_string(begin));
    if (all_noise) {
      EXPECT_EQ(firstBlockType(file, at[m]), 0) << "float noise is stored";
      EXPECT_LT(end - at[m], isize + isize / 1000 + 64) << "stored costs a few bytes";
      ++stored;
    } else if (no_noise) {
      EXPECT_NE(firstBlockType(file, at[m]), 0) << "compressible data is compressed";
      EXPECT_LT(2 * (end - at[m]), isize);
      ++compressed;
    }
    begin += isize;
  }
  EXPECT_EQ(begin, data.size());
  EXPECT_GE(stored, 2u);
  EXPECT_GE(compressed, 4u);
  // zlib and GzInputStream read the mix back.
  EXPECT_EQ(zlibReadAll(path), data);
  bool error = true;
  EXPECT_EQ(readAllOf(path, &error), data);
  EXPECT_FALSE(error);
  // On either side of the threshold (half): 8 letters (zlib level 1: 0.46) stay deflated; 14
  // (0.56) and 100 (0.84) are stored.
  for (const auto& [symbols, expect_stored] :
       {std::pair<unsigned, bool>{8, false}, {14, true}, {100, true}}) {
    SCOPED_TRACE(std::to_string(symbols) + " letters");
    const std::vector<unsigned char> text = randomText(200000, symbols, symbols);
    {
      GzOutputStream out(dir.file("t.gz"), "t.gz");
      out.Write(text.data(), text.size());
      out.close();
    }
    const std::vector<unsigned char> t = fileBytes(dir.file("t.gz"));
    const std::vector<std::size_t> t_at = members(t);
    ASSERT_GE(t_at.size(), 5u);
    for (std::size_t m = 0; m < t_at.size(); ++m)
      EXPECT_EQ(firstBlockType(t, t_at[m]) == 0, expect_stored) << "member " << m;
    EXPECT_EQ(readAllOf(dir.file("t.gz"), &error), text);
    EXPECT_FALSE(error);
  }
  // A flipped byte inside a stored member is caught by its CRC-32: a read error.
  std::size_t victim = 0;
  for (std::size_t m = 0; m < at.size() && !victim; ++m)
    if (firstBlockType(file, at[m]) == 0) victim = at[m] + 24 + 5 + 1000;
  ASSERT_GT(victim, 0u);
  std::vector<unsigned char> flipped = file;
  flipped[victim] ^= 0x10;
  putBytes(dir.file("bad.gz"), flipped);
  readAllOf(dir.file("bad.gz"), &error);
  EXPECT_TRUE(error);
}

}  // namespace
}  // namespace dbacov
