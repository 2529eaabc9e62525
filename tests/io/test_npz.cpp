// .npz reading/writing against NumPy (savez, savez_compressed, np.load), damaged archives, and the
// real DROID snapshot of ../shared/data.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "dbacov/io/npz.h"
#include "dbacov/io/snapshot_npz.h"
#include "io_test_util.h"

namespace dbacov::io::testing {
namespace {

const std::vector<std::pair<std::string, std::vector<std::size_t>>> kArrays = {
    {"<f4", {2, 3}}, {"<f8", {5}}, {"<i4", {}},     {"<i8", {0}},      {"|u1", {4}},
    {"|b1", {3}},    {"<f8", {}},  {"<f4", {0, 2}}, {"<i8", {2, 2, 2}}};

/// "a0" → ref_values('<f4', (2, 3)), ...: the Python statement that saves kArrays with `fn`.
std::string pySaveArrays(const std::string& fn, const std::string& file) {
  std::string s = std::string(kPyReference) + fn + "('" + file + "'";
  for (std::size_t k = 0; k < kArrays.size(); ++k)
    s += ", a" + std::to_string(k) + "=ref_values('" + kArrays[k].first + "', " +
         pyTuple(kArrays[k].second) + ")";
  return s + ")\n";
}

TEST(Npz, ReadsNumpySavezAndSavezCompressed) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  ASSERT_EQ(runPython(dir, pySaveArrays("np.savez", "stored.npz") +
                               pySaveArrays("np.savez_compressed", "deflated.npz") +
                               "np.savez('empty.npz')\n"),
            0);
  for (const char* name : {"stored.npz", "deflated.npz"}) {
    SCOPED_TRACE(name);
    const NpzReader npz(dir.file(name));
    std::vector<std::string> expected_keys;
    for (std::size_t k = 0; k < kArrays.size(); ++k)
      expected_keys.push_back("a" + std::to_string(k));
    EXPECT_EQ(npz.keys(), expected_keys);
    EXPECT_TRUE(npz.has("a0"));
    EXPECT_FALSE(npz.has("a0.npy"));
    EXPECT_FALSE(npz.has("nothere"));
    for (std::size_t k = 0; k < kArrays.size(); ++k) {
      const NpyArray a = npz.read("a" + std::to_string(k));
      const NpyArray e = referenceArray(kArrays[k].first, kArrays[k].second);
      EXPECT_EQ(a.dtype, e.dtype) << k;
      EXPECT_EQ(a.shape, e.shape) << k;
      EXPECT_EQ(a.data, e.data) << k;
    }
    EXPECT_EQ(npyToDoubles(npz.read("a1"), "a1"),
              (std::vector<double>{-0.75, -0.5, -0.25, 0, 0.25}));
  }
  EXPECT_TRUE(NpzReader(dir.file("empty.npz")).keys().empty());
}

TEST(Npz, NumpyReadsWhatWeWrite) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  for (bool compressed : {false, true}) {
    NpzWriter w(dir.file(compressed ? "deflated.npz" : "stored.npz"), compressed);
    for (std::size_t k = 0; k < kArrays.size(); ++k)
      w.add("a" + std::to_string(k), referenceArray(kArrays[k].first, kArrays[k].second));
    EXPECT_THROW(w.add("a0", referenceArray("<f4", {1})), std::invalid_argument);
    w.commit();
    EXPECT_THROW(w.commit(), std::logic_error);
  }
  NpzWriter(dir.file("empty.npz")).commit();
  std::string script = std::string(kPyReference) + "cases = [";
  for (const auto& [dt, shape] : kArrays) script += "('" + dt + "', " + pyTuple(shape) + "), ";
  script += R"PY(]
for name, method in [('stored.npz', zipfile.ZIP_STORED), ('deflated.npz', zipfile.ZIP_DEFLATED)]:
    with zipfile.ZipFile(name) as z:
        assert z.testzip() is None, name
        assert all(i.compress_type == method for i in z.infolist()), name
        assert all(i.date_time == (1980, 1, 1, 0, 0, 0) for i in z.infolist()), name
    d = np.load(name)
    assert d.files == ['a%d' % k for k in range(len(cases))], d.files
    for k, (dt, shape) in enumerate(cases):
        a, e = d['a%d' % k], ref_values(dt, shape)
        assert a.dtype == e.dtype and a.shape == e.shape and np.array_equal(a, e), (name, k)
assert np.load('empty.npz').files == []
)PY";
  EXPECT_EQ(runPython(dir, script), 0);
}

TEST(Npz, ArchiveLevelErrorsNameTheFile) {
  TempDir dir;
  expectMentions(inputErrorOf([&] { NpzReader r(dir.file("nope.npz")); }),
                 {"nope.npz", "cannot open"});
  std::ofstream(dir.file("text.npz")) << "this is not a zip archive\n";
  expectMentions(inputErrorOf([&] { NpzReader r(dir.file("text.npz")); }), {"text.npz", "zip"});
  expectMentions(inputErrorOf([&] { NpzReader r(dir.path()); }), {dir.path(), "regular file"});
  NpzWriter w(dir.file("ok.npz"), false);
  w.add("x", referenceArray("<f8", {1000}));
  w.commit();
  std::vector<unsigned char> bytes = readBytes(dir.file("ok.npz"));
  bytes.resize(bytes.size() / 2);
  writeBytes(dir.file("truncated.npz"), bytes);
  expectMentions(inputErrorOf([&] { NpzReader(dir.file("truncated.npz")).read("x"); }),
                 {"truncated.npz"});
  expectMentions(inputErrorOf([&] { NpzReader(dir.file("ok.npz")).read("y"); }),
                 {"ok.npz", "missing key 'y'"});
  expectMentions(inputErrorOf([&] { NpzReader(dir.file("ok.npz"), 4000).read("x"); }),
                 {"ok.npz: key 'x'", "exceeds the limit of 4000 bytes"});
}

TEST(Npz, DamagedMembersNameFileAndKey) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  ASSERT_EQ(runPython(dir, R"PY(
def npy(header, data):
    h = header.encode()
    return b'\x93NUMPY\x01\x00' + struct.pack('<H', len(h)) + h + data
a = np.arange(100.0)
np.savez('crc.npz', a=a)
b = bytearray(open('crc.npz', 'rb').read())
b[b.find(a.tobytes()) + 100] ^= 0x40
open('crc.npz', 'wb').write(bytes(b))
with zipfile.ZipFile('huge.npz', 'w') as z:
    z.writestr('a.npy', npy("{'descr': '<f8', 'fortran_order': False, 'shape': (1099511627776, 1024), }", bytes(64)))
with zipfile.ZipFile('header.npz', 'w') as z:
    z.writestr('a.npy', npy("{'descx': '<f8', 'fortran_order': False, 'shape': (2,), }", bytes(16)))
with zipfile.ZipFile('bzip2.npz', 'w', zipfile.ZIP_BZIP2) as z:
    z.writestr('a.npy', npy("{'descr': '<f8', 'fortran_order': False, 'shape': (2,), }", bytes(16)))
for name, method in [('liar_stored.npz', zipfile.ZIP_STORED), ('liar_deflated.npz', zipfile.ZIP_DEFLATED)]:
    with zipfile.ZipFile(name, 'w', method) as z:
        z.writestr('a.npy', npy("{'descr': '<f8', 'fortran_order': False, 'shape': (2,), }", bytes(16)))
    b = bytearray(open(name, 'rb').read())
    cd = b.find(b'PK\x01\x02')
    struct.pack_into('<I', b, cd + 24, 0xF0000000)  # uncompressed size in the central directory
    open(name, 'wb').write(bytes(b))
)PY"),
            0);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"crc.npz", "CRC"},
      {"huge.npz", "(1099511627776,1024)"},
      {"header.npz", "unexpected key 'descx'"},
      {"bzip2.npz", "compression method 12 is not supported"},
      {"liar_stored.npz", "inconsistent sizes"},
      {"liar_deflated.npz", "claims 4026531840 bytes"},
  };
  for (const auto& [name, what] : cases) {
    SCOPED_TRACE(name);
    std::string message;
    const std::string file = name;  // a structured binding is not capturable before C++20
    const std::size_t largest = largestAllocationDuring(
        [&] { message = inputErrorOf([&] { NpzReader(dir.file(file)).read("a"); }); });
    expectMentions(message, {name + ": key 'a'", what});
    EXPECT_LT(largest, std::size_t{1} << 20) << "allocated " << largest << " bytes";
  }
}

TEST(Npz, ListsNpzFilesSortedByName) {
  TempDir dir;
  for (const char* name : {"b_0002.npz", "a_0010.npz", "a_0009.npz", "notes.txt", "x.npz.tmp"})
    std::ofstream(dir.file(name)) << "x";
  std::filesystem::create_directory(dir.file("sub.npz"));
  EXPECT_EQ(listNpzFiles(dir.path()),
            (std::vector<std::string>{dir.file("a_0009.npz"), dir.file("a_0010.npz"),
                                      dir.file("b_0002.npz")}));
  expectMentions(inputErrorOf([&] { listNpzFiles(dir.file("missing")); }), {dir.file("missing")});
  expectMentions(inputErrorOf([&] { listNpzFiles(dir.file("notes.txt")); }),
                 {"notes.txt", "not a directory"});
}

}  // namespace
}  // namespace dbacov::io::testing
