// The zlib streams behind rawlog reading and writing (libs/mrpt/src/gz_streams.h, private to
// dbacov_mrpt; the test includes it directly): round trip against zlib's own gzip format, a
// truncated stream reported as a read error, and a write failure at close reported rather than
// ignored (MRPT's CFileGZOutputStream ignores it).

#include <vector>

#include <gtest/gtest.h>

#include "dbacov/core/errors.h"
#include "gz_members.h"
#include "gz_streams.h"
#include "temp_dir.h"

namespace dbacov {
namespace {

using mrpt_bridge::GzInputStream;
using mrpt_bridge::GzOutputStream;

std::vector<unsigned char> pattern(std::size_t n) {
  std::vector<unsigned char> v(n);
  std::uint32_t x = 12345;
  for (auto& b : v) b = static_cast<unsigned char>((x = x * 1103515245u + 12345u) >> 24);
  return v;
}

std::vector<unsigned char> readAll(GzInputStream& in, bool* error) {
  std::vector<unsigned char> out;
  unsigned char buf[4096];
  *error = false;
  for (;;) {
    const std::size_t n = in.Read(buf, sizeof buf);
    if (n == static_cast<std::size_t>(-1)) {
      *error = true;
      break;
    }
    if (n == 0) break;
    out.insert(out.end(), buf, buf + n);
  }
  return out;
}

TEST(GzStreams, RoundTripIsGzipThatZlibReads) {
  testing::TempDir dir;
  const std::vector<unsigned char> data = pattern(300000);
  GzOutputStream out(dir.file("a.gz"), "a.gz");
  EXPECT_EQ(out.Write(data.data(), data.size()), data.size());
  out.close();
  // zlib's own reader, independently of GzInputStream
  EXPECT_EQ(testing::zlibReadAll(dir.file("a.gz")), data);
  GzInputStream in(dir.file("a.gz"));
  bool error = true;
  EXPECT_EQ(readAll(in, &error), data);
  EXPECT_FALSE(error);
}

TEST(GzStreams, TruncatedCompressedDataIsAReadErrorNotAnEnd) {
  testing::TempDir dir;
  const std::vector<unsigned char> data = pattern(300000);
  {
    GzOutputStream out(dir.file("a.gz"), "a.gz");
    out.Write(data.data(), data.size());
    out.close();
  }
  std::vector<unsigned char> file;
  {
    std::FILE* f = std::fopen(dir.file("a.gz").c_str(), "rb");
    ASSERT_NE(f, nullptr);
    int c;
    while ((c = std::fgetc(f)) != EOF) file.push_back(static_cast<unsigned char>(c));
    std::fclose(f);
  }
  for (const std::size_t keep : {file.size() - 4, file.size() - 8, file.size() / 2}) {
    SCOPED_TRACE(keep);
    std::FILE* f = std::fopen(dir.file("cut.gz").c_str(), "wb");
    std::fwrite(file.data(), 1, keep, f);
    std::fclose(f);
    GzInputStream in(dir.file("cut.gz"));
    bool error = false;
    const std::vector<unsigned char> got = readAll(in, &error);
    EXPECT_TRUE(error);
    EXPECT_LE(got.size(), data.size());
  }
}

TEST(GzStreams, AFailureToFinishTheFileIsReported) {
  // /dev/full accepts the open and fails every write with ENOSPC: the small write stays in
  // zlib's buffer, so the failure comes when close() flushes it.
  const std::vector<unsigned char> data = pattern(100);
  GzOutputStream out("/dev/full", "out.rawlog");
  out.Write(data.data(), data.size());
  try {
    out.close();
    ADD_FAILURE() << "close() did not report the full disk";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "out.rawlog: cannot finish the compressed rawlog: No space left on device");
  }
}

}  // namespace
}  // namespace dbacov
