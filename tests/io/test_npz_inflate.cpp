// Whole-member inflation (libdeflate) against NumPy's own bytes, damaged deflate streams
// with libzip's messages, the first failure in key order when members inflate in parallel, and
// the block-wise non-finite scan of Snapshot::validate on the real DROID snapshot.
#include <cmath>
#include <filesystem>
#include <limits>

#include <gtest/gtest.h>

#include "dbacov/core/parallel.h"
#include "dbacov/io/npz.h"
#include "dbacov/io/snapshot_npz.h"
#include "io_test_util.h"

namespace dbacov::io::testing {
namespace {

const std::string kDroid = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

TEST(NpzInflate, EveryMemberOfTheSharedSnapshotIsNumpysBytesOnOneAndTwoThreads) {
  DBACOV_REQUIRE_NUMPY();
  if (!std::filesystem::exists(kDroid)) GTEST_SKIP() << "missing " << kDroid;
  TempDir dir;
  ASSERT_EQ(runPython(dir, "z = np.load('" + kDroid +
                               "')\n"
                               "for k in z.files: open(k + '.bin', 'wb').write(z[k].tobytes())\n"),
            0);
  const NpzReader npz(kDroid);
  const std::vector<std::string> keys = npz.keys();
  ASSERT_GE(keys.size(), 8u);
  for (std::size_t threads : {1, 2}) {
    SCOPED_TRACE(threads);
    const ThreadLimit limit(threads);
    const std::vector<NpyArray> all = npz.readAll(keys);
    ASSERT_EQ(all.size(), keys.size());
    for (std::size_t k = 0; k < keys.size(); ++k) {
      SCOPED_TRACE(keys[k]);
      EXPECT_EQ(std::vector<unsigned char>(all[k].data.begin(), all[k].data.end()),
                readBytes(dir.file(keys[k] + ".bin")));
      EXPECT_EQ(npz.read(keys[k]).data, all[k].data);
    }
  }
}

TEST(NpzInflate, DamagedDeflateStreamsKeepLibzipsMessagesAndTheFirstFailureInKeyOrder) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  // Three deflated members of 80 kB; `bad_crc.npz` has a wrong CRC-32 recorded for b, `bad_data`
  // an invalid deflate block type at the start of b, `both` the bad block in b and the bad CRC in
  // c.
  ASSERT_EQ(runPython(dir, R"PY(
rng = np.random.default_rng(7)
arrays = {k: np.round(rng.normal(size=10000), 2) for k in 'abc'}
np.savez_compressed('good.npz', **arrays)
good = open('good.npz', 'rb').read()
z = zipfile.ZipFile('good.npz')
def member(name):
    i = z.getinfo(name)
    h = i.header_offset
    n, m = struct.unpack('<HH', good[h + 26:h + 30])
    return i, h, h + 30 + n + m
def central(b, name):
    cd = b.find(b'PK\x01\x02')
    while cd >= 0:
        n = struct.unpack('<H', b[cd + 28:cd + 30])[0]
        if b[cd + 46:cd + 46 + n] == name.encode(): return cd
        cd = b.find(b'PK\x01\x02', cd + 4)
def bad_crc(b, name):
    i, h, _ = member(name)
    b[h + 14] ^= 0xFF
    b[central(b, name) + 16] ^= 0xFF
def bad_data(b, name):
    b[member(name)[2]] = 0x07  # BFINAL = 1, BTYPE = 3 (reserved)
for out, edits in [('bad_crc.npz', [(bad_crc, 'b.npy')]), ('bad_data.npz', [(bad_data, 'b.npy')]),
                   ('both.npz', [(bad_crc, 'c.npy'), (bad_data, 'b.npy')])]:
    b = bytearray(good)
    for f, name in edits: f(b, name)
    open(out, 'wb').write(bytes(b))
)PY"),
            0);
  for (std::size_t threads : {1, 2}) {
    SCOPED_TRACE(threads);
    const ThreadLimit limit(threads);
    const std::vector<std::string> keys = {"a", "b", "c"};
    EXPECT_EQ(NpzReader(dir.file("good.npz")).readAll(keys).size(), 3u);
    for (const auto& [file, message] : std::vector<std::pair<std::string, std::string>>{
             {"bad_crc.npz", "key 'b': cannot read member: CRC error"},
             {"bad_data.npz", "key 'b': cannot read member: Zlib error: data error"},
             {"both.npz", "key 'b': cannot read member: Zlib error: data error"}}) {
      SCOPED_TRACE(file);
      const NpzReader npz(dir.file(file));
      expectMentions(inputErrorOf([&] { npz.readAll(keys); }), {file, message});
      expectMentions(inputErrorOf([&] { npz.read("b"); }), {file, message});
      EXPECT_EQ(npz.read("a").shape, std::vector<std::size_t>{10000});
    }
    expectMentions(inputErrorOf([&] { NpzReader(dir.file("both.npz")).read("c"); }),
                   {"key 'c': cannot read member: CRC error"});
  }
}

TEST(NpzInflate, ValidationFindsTheFirstNonFiniteValueAtEveryPlaceOfItsBlocks) {
  if (!std::filesystem::exists(kDroid)) GTEST_SKIP() << "missing " << kDroid;
  const Snapshot good = loadSnapshotNpz(kDroid, 0);
  const std::size_t HW = static_cast<std::size_t>(good.H * good.W), n = good.target.size();
  for (std::size_t at : {std::size_t{0}, std::size_t{255}, std::size_t{256}, std::size_t{257},
                         std::size_t{511}, n - 257, n - 1}) {
    for (float bad :
         {std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::infinity()}) {
      SCOPED_TRACE(at);
      Snapshot s = good;
      s.target[at] = bad;
      if (at + 300 < n) s.target[at + 300] = bad;  // a later one must not be the one named
      const std::size_t plane = at / HW, p = at % HW;
      const std::string where =
          "edge " + std::to_string(plane / 2) + " channel " + std::to_string(plane % 2) +
          " pixel (x=" + std::to_string(p % good.W) + ", y=" + std::to_string(p / good.W) + ")";
      expectMentions(inputErrorOf([&] { s.validate(); }),
                     {"key 'target' is non-finite at " + where});
    }
    Snapshot s = good;
    s.weight[at] = -0.5f;
    expectMentions(inputErrorOf([&] { s.validate(); }), {"key 'weight' is negative (-0.5"});
  }
  Snapshot zero = good;
  std::fill(zero.weight.begin(), zero.weight.end(), 0.0f);
  zero.weight.back() = 1e-30f;  // one positive confidence in the last, partial block is enough
  EXPECT_NO_THROW(zero.validate());
  zero.weight.back() = 0.0f;
  expectMentions(inputErrorOf([&] { zero.validate(); }), {"key 'weight' is zero at every pixel"});
}

}  // namespace
}  // namespace dbacov::io::testing
