// .npy parser and writer against NumPy (byte-identical output, values both ways) and against
// hand-made broken inputs, with the largest allocation measured for hostile headers.
#include <cmath>
#include <cstring>
#include <limits>

#include <gtest/gtest.h>

#include "dbacov/io/npy.h"
#include "io_test_util.h"

namespace dbacov::io::testing {
namespace {

using DType = NpyArray::DType;

struct Case {
  std::string descr;
  std::vector<std::size_t> shape;
};
const std::vector<Case> kCases = {
    {"<f4", {2, 3}},
    {"<f8", {5}},
    {"<i4", {}},
    {"<i8", {0}},
    {"|u1", {4, 1}},
    {"|b1", {7}},
    {"<f8", {2, 0, 3}},
    {"<i8", {3, 1, 2, 2}},
    {"<f4", {}},
    {"<i4", {1000}},
    {"<f8", {12345678901, 0}},
    {"<f4", {0, 12345678901}},
    // Header text + NumPy's growth padding is exactly 64k - 11 bytes: the alignment pad is 64.
    {"<f4", {2, 100, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}}};

std::string pyCaseList() {
  std::string s = "cases = [";
  for (const Case& c : kCases) s += "('" + c.descr + "', " + pyTuple(c.shape) + "), ";
  return s + "]\n";
}

/// An .npy byte stream with a hand-written header (no padding rules applied).
template <typename Bytes>
std::vector<unsigned char> craft(const std::string& dict, const Bytes& data,
                                 unsigned char major = 1) {
  std::vector<unsigned char> out = {0x93, 'N', 'U', 'M', 'P', 'Y', major, 0};
  const std::size_t n = dict.size();
  out.push_back(static_cast<unsigned char>(n & 0xff));
  out.push_back(static_cast<unsigned char>((n >> 8) & 0xff));
  if (major != 1) out.insert(out.end(), {0, 0});
  out.insert(out.end(), dict.begin(), dict.end());
  out.insert(out.end(), data.begin(), data.end());
  return out;
}
const ByteVector kFiveFloats = referenceArray("<f4", {5}).data;

TEST(Npy, SerializationIsByteIdenticalToNumpySave) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  ASSERT_EQ(runPython(dir, std::string(kPyReference) + pyCaseList() +
                               "for k, (dt, shape) in enumerate(cases):\n"
                               "    np.save(f'ref_{k}.npy', ref_values(dt, shape))\n"),
            0);
  for (std::size_t k = 0; k < kCases.size(); ++k) {
    SCOPED_TRACE(kCases[k].descr + " " + pyTuple(kCases[k].shape));
    const std::vector<unsigned char> ours =
        serializeNpy(referenceArray(kCases[k].descr, kCases[k].shape));
    EXPECT_EQ(ours, readBytes(dir.file("ref_" + std::to_string(k) + ".npy")));
    EXPECT_EQ((ours[8] + 256 * ours[9] + 10) % 64, 0u);
  }
}

TEST(Npy, ReadsNumpyFilesOfEveryVersion) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  ASSERT_EQ(
      runPython(dir, std::string(kPyReference) + pyCaseList() +
                         "for k, (dt, shape) in enumerate(cases):\n"
                         "    for v in [(1, 0), (2, 0), (3, 0)]:\n"
                         "        with open(f'ref_{k}_{v[0]}.npy', 'wb') as f:\n"
                         "            np.lib.format.write_array(f, ref_values(dt, shape), v)\n"),
      0);
  for (std::size_t k = 0; k < kCases.size(); ++k) {
    const NpyArray expected = referenceArray(kCases[k].descr, kCases[k].shape);
    for (int v = 1; v <= 3; ++v) {
      SCOPED_TRACE(kCases[k].descr + " " + pyTuple(kCases[k].shape) + " v" + std::to_string(v));
      const NpyArray a =
          readNpyFile(dir.file("ref_" + std::to_string(k) + "_" + std::to_string(v) + ".npy"));
      EXPECT_EQ(a.dtype, expected.dtype);
      EXPECT_EQ(a.shape, expected.shape);
      EXPECT_EQ(a.data, expected.data);
    }
  }
  // Values, decoded: the first float32 case and the int64 case.
  const std::vector<double> f = npyToDoubles(readNpyFile(dir.file("ref_0_1.npy")), "f4");
  EXPECT_EQ(f, (std::vector<double>{-0.75, -0.5, -0.25, 0, 0.25, 0.5}));
  const std::vector<std::int64_t> i = npyToInt64s(readNpyFile(dir.file("ref_7_2.npy")), "i8");
  ASSERT_EQ(i.size(), 12u);
  EXPECT_EQ(i[0], -3000000000000LL + 5);
  EXPECT_EQ(i[11], 8000000000000LL + 5);
  const std::vector<std::int64_t> s = npyToInt64s(readNpyFile(dir.file("ref_2_3.npy")), "i4");
  EXPECT_EQ(s, (std::vector<std::int64_t>{-300007}));
}

TEST(Npy, NumpyReadsWhatWeWrite) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  for (std::size_t k = 0; k < kCases.size(); ++k)
    writeNpyFileAtomically(dir.file("ours_" + std::to_string(k) + ".npy"),
                           referenceArray(kCases[k].descr, kCases[k].shape));
  EXPECT_EQ(
      runPython(dir,
                std::string(kPyReference) + pyCaseList() +
                    "for k, (dt, shape) in enumerate(cases):\n"
                    "    a = np.load(f'ours_{k}.npy')\n"
                    "    e = ref_values(dt, shape)\n"
                    "    if a.dtype != e.dtype or a.shape != e.shape or not np.array_equal(a, e):\n"
                    "        print('mismatch in case', k, a.dtype, a.shape); sys.exit(1)\n"),
      0);
}

TEST(Npy, RejectsWhatNumpyCanWriteButWeDoNotSupport) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  ASSERT_EQ(runPython(dir,
                      "a = np.arange(6.0).reshape(2, 3)\n"
                      "np.save('fortran.npy', np.asfortranarray(a))\n"
                      "np.save('big.npy', a.astype('>f8'))\n"
                      "np.save('object.npy', np.array([1, 'x'], dtype=object), allow_pickle=True)\n"
                      "np.save('struct.npy', np.zeros(3, dtype=[('a', '<f4'), ('b', '<i4')]))\n"
                      "np.save('complex.npy', np.zeros(2, dtype=np.complex128))\n"
                      "np.save('half.npy', np.zeros(2, dtype=np.float16))\n"
                      "np.save('u16.npy', np.zeros(2, dtype=np.uint16))\n"),
            0);
  const std::pair<const char*, const char*> expected[] = {
      {"fortran.npy", "Fortran"}, {"big.npy", "big-endian"},
      {"object.npy", "object"},   {"struct.npy", "structured"},
      {"complex.npy", "<c16"},    {"half.npy", "<f2"},
      {"u16.npy", "<u2"}};
  // Structured bindings are captured by name only from C++20: the lambdas take plain copies.
  for (const auto& [name, what] : expected) {
    const std::string file = name;
    expectMentions(inputErrorOf([&] { readNpyFile(dir.file(file)); }), {name, what});
  }
}

TEST(Npy, HeaderParsingIsTolerantOfLayout) {
  const std::vector<std::string> dicts = {
      "{'shape': (5,), 'fortran_order': False, 'descr': '<f4'}",
      "{ 'descr' : '<f4' ,'fortran_order':False,'shape':( 5 , ) , }   \n",
      "{\"descr\": \"<f4\", \"fortran_order\": False, \"shape\": (5)}\n",
      "{'descr': '<f4', 'fortran_order': False, 'shape': (5L,), }",
  };
  for (const std::string& d : dicts) {
    SCOPED_TRACE(d);
    for (unsigned char major : {1, 2, 3}) {
      const NpyArray a = parseNpy(craft(d, kFiveFloats, major), "ctx");
      EXPECT_EQ(a.dtype, DType::Float32);
      EXPECT_EQ(a.shape, std::vector<std::size_t>{5});
      EXPECT_EQ(npyToFloats(a, "ctx"), (std::vector<float>{-0.75f, -0.5f, -0.25f, 0.f, 0.25f}));
    }
  }
  const NpyArray scalar = parseNpy(craft("{'descr': '<f8', 'fortran_order': False, 'shape': ()}",
                                         referenceArray("<f8", {}).data),
                                   "ctx");
  EXPECT_TRUE(scalar.shape.empty());
  EXPECT_EQ(npyToDoubles(scalar, "ctx"), std::vector<double>{-0.75});
}

TEST(Npy, MalformedInputsNameTheContextAndTheProblem) {
  const std::string ok = "{'descr': '<f4', 'fortran_order': False, 'shape': (5,), }";
  auto bytes = [&](std::string dict) { return craft(std::move(dict), kFiveFloats); };
  std::vector<unsigned char> bad_magic = bytes(ok);
  bad_magic[1] = 'X';
  std::vector<unsigned char> version4 = bytes(ok);
  version4[6] = 4;
  const std::vector<unsigned char> full = bytes(ok);
  const std::vector<std::pair<std::vector<unsigned char>, std::string>> cases = {
      {bad_magic, "magic"},
      {version4, "version 4.0"},
      {std::vector<unsigned char>(full.begin(), full.begin() + 9), "truncated .npy preamble"},
      {std::vector<unsigned char>(full.begin(), full.begin() + 30), "truncated .npy header"},
      {std::vector<unsigned char>(full.begin(), full.end() - 1), "needs 20 data bytes, but 19"},
      {[&] {
         auto v = full;
         v.push_back(0);
         return v;
       }(),
       "needs 20 data bytes, but 21"},
      {bytes("{'descr': '<f4', 'shape': (5,)}"), "must contain the keys"},
      {bytes("{'descr': '<f4', 'descr': '<f4', 'fortran_order': False, 'shape': (5,)}"),
       "duplicate key 'descr'"},
      {bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (5,), 'x': 1}"),
       "unexpected key 'x'"},
      {bytes("{'descr': '<f4', 'fortran_order': Nope, 'shape': (5,)}"), "True or False"},
      {bytes("{'descr': '<f4, 'fortran_order': False, 'shape': (5,)}"), "malformed"},
      {bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (5,)} junk"), "after the closing"},
      {bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (-5,)}"), "negative"},
      {bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (5,"), "malformed"},
      {bytes("{'descr': '<f4', 'fortran_order': True, 'shape': (5,)}"), "Fortran"},
      {bytes("{'descr': '<O', 'fortran_order': False, 'shape': (5,)}"), "object"},
      {bytes("{'descr': '|f4', 'fortran_order': False, 'shape': (5,)}"), "byte order"},
      {bytes("{'descr': '=f4', 'fortran_order': False, 'shape': (5,)}"), "byte order"},
      {bytes("{'descr': [('a', '<f4')], 'fortran_order': False, 'shape': (5,)}"), "structured"},
      {bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (99999999999999999999,)}"),
       "overflows 64 bits"},
      {bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (4294967296, 4294967296)}"),
       "overflows"},
  };
  for (const auto& [input, what] : cases) {
    SCOPED_TRACE(what);
    const auto& bytes_in = input;
    expectMentions(inputErrorOf([&] { parseNpy(bytes_in, "file.npz: key 'target'"); }),
                   {"file.npz: key 'target'", what});
  }
  // A v2 header that declares 4 GiB of header text.
  std::vector<unsigned char> long_header = craft(ok, kFiveFloats, 2);
  long_header[8] = long_header[9] = long_header[10] = long_header[11] = 0xff;
  expectMentions(inputErrorOf([&] { parseNpy(long_header, "ctx"); }), {"ctx", "longer than"});
}

TEST(Npy, HugeDeclaredShapeThrowsWithoutAllocating) {
  TempDir dir;
  const std::vector<unsigned char> huge =
      craft("{'descr': '<f8', 'fortran_order': False, 'shape': (1099511627776, 1024), }",
            std::vector<unsigned char>(64, 0));
  writeBytes(dir.file("huge.npy"), huge);
  std::string from_memory, from_file;
  const std::size_t largest = largestAllocationDuring([&] {
    from_memory = inputErrorOf([&] { parseNpy(huge, "mem"); });
    from_file = inputErrorOf([&] { readNpyFile(dir.file("huge.npy")); });
  });
  EXPECT_LT(largest, std::size_t{1} << 20);
  // The tracker itself works: a 4 MiB buffer is seen.
  volatile unsigned char sink = 0;
  EXPECT_GE(largestAllocationDuring([&] {
              std::vector<unsigned char> v(std::size_t{4} << 20, 1);
              sink = v[v.size() / 2];
            }),
            std::size_t{4} << 20);
  EXPECT_EQ(sink, 1);
  expectMentions(from_memory, {"mem", "(1099511627776,1024)", "9007199254740992 data bytes"});
  expectMentions(from_file, {"huge.npy", "(1099511627776,1024)", "but 64 are present"});
}

TEST(Npy, ConversionsAreStrictAboutDtypes) {
  const NpyArray f4 = referenceArray("<f4", {3}), i4 = referenceArray("<i4", {3});
  expectMentions(inputErrorOf([&] { npyToInt64s(f4, "x.npz: key 'ii'"); }),
                 {"x.npz: key 'ii'", "float32", "expected int32 or int64"});
  expectMentions(inputErrorOf([&] { npyToDoubles(i4, "x.npz: key 'poses'"); }),
                 {"x.npz: key 'poses'", "int32", "expected float32 or float64"});
  expectMentions(inputErrorOf([&] { npyToFloats(referenceArray("|b1", {3}), "k"); }), {"bool"});
  const NpyArray too_big = makeNpy(std::vector<double>{1.0, 1e300}, {2});
  expectMentions(inputErrorOf([&] { npyToFloats(too_big, "k"); }),
                 {"k", "float32 range", "index 1"});
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(npyToFloats(makeNpy(std::vector<double>{-inf}, {1}), "k")[0],
            -std::numeric_limits<float>::infinity());
  EXPECT_EQ(npyToInt64s(i4, "k"), (std::vector<std::int64_t>{-300007, -200007, -100007}));
  EXPECT_THROW(makeNpy(std::vector<float>(5), {2, 3}), std::invalid_argument);
  NpyArray inconsistent = f4;
  inconsistent.data.pop_back();
  EXPECT_THROW(serializeNpy(inconsistent), std::invalid_argument);
}

TEST(Npy, ByteVectorKeepsEveryValueItIsGiven) {
  // ByteVector only skips the zeroing of resize(n) / vector(n) (npy.h asserts at compile time
  // that its allocator survives rebinding); every explicit value still lands.
  ByteVector v(4, 7);
  EXPECT_EQ(std::vector<unsigned char>(v.begin(), v.end()),
            (std::vector<unsigned char>{7, 7, 7, 7}));
  v.resize(6, 9);
  v.insert(v.begin() + 1, {1, 2});
  EXPECT_EQ(std::vector<unsigned char>(v.begin(), v.end()),
            (std::vector<unsigned char>{7, 1, 2, 7, 7, 7, 9, 9}));
  const ByteVector copy = v;
  EXPECT_EQ(copy, v);
  // Every conversion builds its vector straight from the bytes (ElementReader): same values as an
  // element-by-element decode, for the same type (float32 → float) and for widening ones.
  const float specials[] = {-0.0f, 1e-40f, std::numeric_limits<float>::max(), -3.5f, 0.25f};
  const NpyArray f4 = makeNpy(std::vector<float>(std::begin(specials), std::end(specials)), {5});
  const std::vector<float> as_floats = npyToFloats(f4, "k");
  const std::vector<double> as_doubles = npyToDoubles(f4, "k");
  ASSERT_EQ(as_floats.size(), 5u);
  ASSERT_EQ(as_doubles.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(std::memcmp(&as_floats[i], &specials[i], sizeof(float)), 0) << i;  // -0 kept
    EXPECT_EQ(as_doubles[i], static_cast<double>(specials[i])) << i;
  }
  EXPECT_TRUE(std::signbit(as_doubles[0]));
  EXPECT_TRUE(npyToFloats(makeNpy(std::vector<float>{}, {0}), "k").empty());
}

}  // namespace
}  // namespace dbacov::io::testing
