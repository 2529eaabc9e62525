// Snapshot files (conventions §1): the real DROID snapshot in ../shared/data, checked against
// NumPy; shape/dtype/missing-key errors; save → load round trips that NumPy can read.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "dbacov/io/npz.h"
#include "dbacov/io/snapshot_npz.h"
#include "io_test_util.h"
#include "snapshot_compare.h"

namespace dbacov::io::testing {
namespace {

const std::string kDroid = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

#define DBACOV_REQUIRE_DROID()                                                              \
  do {                                                                                      \
    if (!std::filesystem::exists(kDroid)) GTEST_SKIP() << "missing shared data " << kDroid; \
  } while (0)

using ::dbacov::testing::expectSameSnapshot;

TEST(SnapshotNpz, RealDroidSnapshotKeysShapesAndDtypes) {
  DBACOV_REQUIRE_DROID();
  const NpzReader npz(kDroid);
  const std::vector<std::string> keys = npz.keys();
  for (const char* k :
       {"poses", "disps", "intrinsics", "ii", "jj", "target", "weight", "tstamp", "id"})
    EXPECT_NE(std::find(keys.begin(), keys.end(), k), keys.end()) << k;
  using S = std::vector<std::size_t>;
  using DType = NpyArray::DType;
  const std::vector<std::tuple<const char*, DType, S>> expected = {
      {"poses", DType::Float32, S{11, 7}},
      {"disps", DType::Float32, S{11, 49, 61}},
      {"intrinsics", DType::Float32, S{4}},
      {"ii", DType::Int64, S{58}},
      {"jj", DType::Int64, S{58}},
      {"target", DType::Float32, S{58, 2, 49, 61}},
      {"weight", DType::Float32, S{58, 2, 49, 61}},
      {"tstamp", DType::Float64, S{11}},
      {"id", DType::Int64, S{}}};
  for (const auto& [key, dtype, shape] : expected) {
    const NpyArray a = npz.read(key);
    EXPECT_EQ(a.dtype, dtype) << key;
    EXPECT_EQ(a.shape, shape) << key;
  }
}

TEST(SnapshotNpz, RealDroidSnapshotValues) {
  DBACOV_REQUIRE_DROID();
  const Snapshot s = loadSnapshotNpz(kDroid, 3);
  EXPECT_EQ(s.source, kDroid);
  EXPECT_EQ(s.index, 3);
  ASSERT_EQ(s.numKeyframes(), 11);
  ASSERT_EQ(s.numEdges(), 58);
  EXPECT_EQ(s.H, 49);
  EXPECT_EQ(s.W, 61);
  ASSERT_TRUE(s.id.has_value());
  EXPECT_EQ(*s.id, 55);
  EXPECT_EQ(s.label(), 55);
  EXPECT_FALSE(s.timestamps_s.has_value());
  const float pose1[7] = {-0.01736303f, -0.00630309f, -0.02361806f, 0.00340959f,
                          -0.00392949f, 0.00255851f,  0.9999833f};
  // The reference values are NumPy's printout (8 decimals or the shortest float32 form).
  for (int c = 0; c < 7; ++c) EXPECT_NEAR(s.poses_cw(1, c), pose1[c], 5e-8) << c;
  const float k[4] = {78.31055f, 78.4314f, 31.50211f, 26.21228f};
  for (int c = 0; c < 4; ++c) EXPECT_FLOAT_EQ(static_cast<float>(s.intrinsics[c]), k[c]) << c;
  EXPECT_EQ(s.ii.front(), 1);
  EXPECT_EQ(s.jj.front(), 2);
  EXPECT_EQ(s.tstamp.back(), 55.0);

  // Sums and single values computed by NumPy.
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  ASSERT_EQ(runPython(dir, "d = np.load('" + kDroid + R"PY(')
v = [d['disps'].astype(np.float64).sum(), d['target'].astype(np.float64).sum(),
     d['weight'].astype(np.float64).sum(), d['poses'].astype(np.float64).sum(),
     d['tstamp'].sum(), d['ii'].sum(), d['jj'].sum(),
     d['target'][57, 1, 48, 60], d['target'][3, 0, 10, 20], d['weight'][13, 0, 20, 30],
     d['disps'][10, 48, 0]]
open('ref.txt', 'w').write('\n'.join(repr(float(x)) for x in v))
)PY"),
            0);
  std::istringstream in(readText(dir.file("ref.txt")));
  std::vector<double> ref(11);
  for (double& r : ref) in >> r;
  auto sum = [](const auto& v) {
    double t = 0;
    for (auto x : v) t += static_cast<double>(x);
    return t;
  };
  const double poses_sum = s.poses_cw.sum();
  const double sums[] = {sum(s.disps),  sum(s.target), sum(s.weight), poses_sum,
                         sum(s.tstamp), sum(s.ii),     sum(s.jj)};
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(sums[i], ref[i], 1e-9 * (1 + std::fabs(ref[i]))) << i;
  EXPECT_EQ(s.targetPlane(57, 1)[48 * 61 + 60], static_cast<float>(ref[7]));
  EXPECT_EQ(s.targetPlane(3, 0)[10 * 61 + 20], static_cast<float>(ref[8]));
  EXPECT_EQ(s.weightPlane(13, 0)[20 * 61 + 30], static_cast<float>(ref[9]));
  EXPECT_EQ(s.disp(10, 48, 0), static_cast<float>(ref[10]));
}

TEST(SnapshotNpz, ErrorsNameFileKeyAndExpectedShape) {
  DBACOV_REQUIRE_DROID();
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  ASSERT_EQ(runPython(dir, "d = dict(np.load('" + kDroid + R"PY('))
def save(name, **changes):
    e = dict(d)
    e.update(changes)
    np.savez(name, **{k: v for k, v in e.items() if v is not None})
save('missing_weight.npz', weight=None)
save('target_w.npz', target=d['target'][..., :60])
save('ii_float.npz', ii=d['ii'].astype(np.float32))
save('jj_short.npz', jj=d['jj'][:57])
save('poses_6.npz', poses=d['poses'][:, :6])
save('poses_1d.npz', poses=d['poses'].ravel())
save('poses_fortran.npz', poses=np.asfortranarray(d['poses']))
save('id_vec.npz', id=np.array([1, 2]))
save('ii_range.npz', ii=np.where(np.arange(58) == 5, 99, d['ii']))
save('tstamp_len.npz', tstamp=d['tstamp'][:10])
save('disps_2d.npz', disps=d['disps'][0])
save('weight_h.npz', weight=d['weight'][:, :, :48, :])
save('stamps_len.npz', timestamps_s=np.zeros(3))
save('nan_weight.npz', weight=np.where(np.arange(61) == 7, np.nan, d['weight']).astype(np.float32))
)PY"),
            0);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"missing_weight.npz", "missing required key 'weight'"},
      {"target_w.npz",
       "key 'target' has shape (58,2,49,60), expected (58,2,49,61) "
       "(E,2,H,W from 'ii' and 'disps')"},
      {"weight_h.npz", "key 'weight' has shape (58,2,48,61), expected (58,2,49,61)"},
      {"ii_float.npz", "key 'ii' has dtype float32, expected int32 or int64"},
      {"jj_short.npz", "key 'jj' has shape (57,), expected (58,) (E from 'ii')"},
      {"poses_6.npz", "key 'poses' has shape (11,6), expected (11,7)"},
      {"poses_1d.npz", "key 'poses' has shape (77,), expected (N,7)"},
      {"poses_fortran.npz", "key 'poses': Fortran-order"},
      {"id_vec.npz", "key 'id' has shape (2,), expected () or (1,)"},
      {"ii_range.npz", "'ii' edge 5 names keyframe 99"},
      {"tstamp_len.npz", "key 'tstamp' has shape (10,), expected (11,) (N from 'poses')"},
      {"disps_2d.npz", "key 'disps' has shape (49,61), expected (11,H,W) (N from 'poses')"},
      {"stamps_len.npz", "key 'timestamps_s' has shape (3,), expected (11,)"},
      {"nan_weight.npz", "key 'weight' is non-finite"},
  };
  for (const auto& [name, what] : cases) {
    SCOPED_TRACE(name);
    const std::string file = name;  // a structured binding is not capturable before C++20
    expectMentions(inputErrorOf([&] { loadSnapshotNpz(dir.file(file), 0); }), {name + ": ", what});
  }
}

TEST(SnapshotNpz, AcceptsFloat64AndInt32Variants) {
  DBACOV_REQUIRE_DROID();
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  ASSERT_EQ(runPython(dir, "d = dict(np.load('" + kDroid + R"PY('))
e = {k: (v.astype(np.float64) if v.dtype == np.float32 else v) for k, v in d.items()}
e['ii'], e['jj'], e['id'] = d['ii'].astype(np.int32), d['jj'].astype(np.int32), np.array([55])
e['timestamps_s'] = d['tstamp'] * 0.05
np.savez_compressed('variant.npz', **e)
)PY"),
            0);
  Snapshot expected = loadSnapshotNpz(kDroid, 0);
  expected.timestamps_s = expected.tstamp;
  for (double& t : *expected.timestamps_s) t *= 0.05;
  expectSameSnapshot(loadSnapshotNpz(dir.file("variant.npz"), 0), expected);
}

TEST(SnapshotNpz, SaveLoadRoundTripIsExactAndNumpyReadable) {
  DBACOV_REQUIRE_DROID();
  TempDir dir;
  Snapshot s = loadSnapshotNpz(kDroid, 0);
  for (bool compressed : {true, false}) {
    const std::string path = dir.file(compressed ? "deflated.npz" : "stored.npz");
    saveSnapshotNpz(path, s, compressed);
    expectSameSnapshot(loadSnapshotNpz(path, 0), s);
  }
  // With the optional keys, and deterministic bytes.
  s.timestamps_s = std::vector<double>(11, 0.0);
  for (int k = 0; k < 11; ++k) (*s.timestamps_s)[k] = 1.5e9 + 0.05 * k;
  s.id = 7;
  saveSnapshotNpz(dir.file("full.npz"), s);
  saveSnapshotNpz(dir.file("full2.npz"), s);
  expectSameSnapshot(loadSnapshotNpz(dir.file("full.npz"), 0), s);
  EXPECT_EQ(readBytes(dir.file("full.npz")), readBytes(dir.file("full2.npz")));
  s.weight[0] = -1.0f;  // invalid: nothing is written
  expectMentions(inputErrorOf([&] { saveSnapshotNpz(dir.file("bad.npz"), s); }), {"weight"});
  EXPECT_FALSE(std::filesystem::exists(dir.file("bad.npz")));

  DBACOV_REQUIRE_NUMPY();
  EXPECT_EQ(runPython(dir, "o = np.load('" + kDroid + R"PY(')
dtypes = dict(poses='float64', disps='float32', intrinsics='float32', ii='int64', jj='int64',
              target='float32', weight='float32', tstamp='float64', timestamps_s='float64', id='int64')
for name in ['deflated.npz', 'stored.npz', 'full.npz']:
    d = np.load(name)
    for k in d.files:
        assert d[k].dtype == dtypes[k], (name, k, d[k].dtype)
        if k in o.files and not (name == 'full.npz' and k == 'id'):
            assert d[k].shape == o[k].shape and np.array_equal(d[k], o[k].astype(d[k].dtype)), (name, k)
f = np.load('full.npz')
assert f['id'].shape == () and int(f['id']) == 7
assert np.array_equal(f['timestamps_s'], 1.5e9 + 0.05 * np.arange(11))
)PY"),
            0);
}

}  // namespace
}  // namespace dbacov::io::testing
