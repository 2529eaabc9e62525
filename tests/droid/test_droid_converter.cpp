// The DROID-SLAM side (share/droid) against dbacov_io's snapshot loader. The system python (numpy
// only, no torch) writes dumps in DROID's and the paper's layouts, plus the expected arrays; the
// converter or dbacov_dump.dump_dba_snapshot writes `.npz` snapshots; loadSnapshotNpz must read
// back exactly the expected values, with channel 0 = x (column) checked against the pixel grid
// itself. The real snapshot in ../shared/data goes through pickle → converter → loader unchanged,
// bit for bit.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "app_runner.h"
#include "dbacov/io/npy.h"
#include "dbacov/io/npz.h"
#include "dbacov/io/snapshot_npz.h"
#include "temp_dir.h"

#ifndef DBACOV_PYTHON
#define DBACOV_PYTHON "/usr/bin/python3"
#endif

namespace dbacov::testing {
namespace {

const std::string kDroidDir = std::string(DBACOV_SOURCE_DIR) + "/share/droid";
const std::string kConverter = kDroidDir + "/convert_pickle_dumps.py";
const std::string kRealSnapshot = std::string(DBACOV_SHARED_DATA_DIR) + "/droid_window_0055.npz";

std::string quoted(const std::string& s) {
  return "'" + s + "'";
}

bool haveNumpy() {
  static const bool ok = runCommand(DBACOV_PYTHON " -c 'import numpy'").code == 0;
  return ok;
}

#define DBACOV_REQUIRE_NUMPY() \
  if (!haveNumpy()) GTEST_SKIP() << "needs " DBACOV_PYTHON " with numpy (python3-numpy)"

/// Runs `code` with the system python in `dir` (its cwd), share/droid importable, no bytecode.
AppResult runPython(const TempDir& dir, const std::string& code) {
  const std::string script = dir.file("script.py");
  std::ofstream(script) << "import pickle\nimport numpy as np\n" << code << "\n";
  return runCommand("cd " + quoted(dir.path()) + " && PYTHONPATH=" + quoted(kDroidDir) + " " +
                    DBACOV_PYTHON " -B " + quoted(script));
}

AppResult runConverter(const std::string& args) {
  return runCommand(std::string(DBACOV_PYTHON) + " -B " + quoted(kConverter) + " " + args);
}

/// Element-for-element equality, reporting the first mismatch instead of whole vectors.
template <typename A, typename B>
void expectSameValues(const std::vector<A>& got, const std::vector<B>& want,
                      const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  std::size_t bad = 0, first = 0;
  for (std::size_t k = 0; k < got.size(); ++k)
    if (!(got[k] == static_cast<A>(want[k])) && bad++ == 0) first = k;
  EXPECT_EQ(bad, 0u) << what << ": " << bad << " of " << got.size() << " values differ, first at "
                     << first << ": " << got[first] << " vs " << want[first];
}

template <typename T>
bool sameBits(const T* a, const T* b, std::size_t n) {
  return n == 0 || std::memcmp(a, b, n * sizeof(T)) == 0;
}
template <typename T>
bool sameBits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && sameBits(a.data(), b.data(), a.size());
}

// Synthetic DROID data: N keyframes, E edges on an H×W grid (H != W, neither 2), deterministic.
// Targets are each pixel's own (column, row) plus a flow below 0.4 px, so the loaded channel 0 must
// stay within 0.5 of the column and channel 1 of the row, whatever python's expectations say.
constexpr int kN = 6, kE = 7, kH = 5, kW = 8;
const char* const kSyntheticPy = R"PY(
N, E, H, W = 6, 7, 5, 8
rng = np.random.default_rng(5)
ii = rng.integers(0, N, size=E)
jj = (ii + rng.integers(1, N, size=E)) % N
y, x = np.mgrid[0:H, 0:W].astype(np.float32)
tx = x + rng.uniform(-0.4, 0.4, size=(E, H, W)).astype(np.float32)
ty = y + rng.uniform(-0.4, 0.4, size=(E, H, W)).astype(np.float32)
wx = rng.uniform(0, 1, size=(E, H, W)).astype(np.float32)
wy = rng.uniform(0, 1, size=(E, H, W)).astype(np.float32)
poses = rng.normal(size=(N, 7)).astype(np.float32)
poses[:, 3:] /= np.linalg.norm(poses[:, 3:], axis=1, keepdims=True)
disps = rng.uniform(0.2, 1.5, size=(N, H, W)).astype(np.float32)
K = np.array([40.0, 41.0, 2.5, 1.5], np.float32)
tstamp = np.arange(N, dtype=np.float64) * 3
last = lambda a, b: np.stack([a, b], axis=-1)   # (E,H,W,2), last axis (x, y)
planar = lambda a, b: np.stack([a, b], axis=1)  # (E,2,H,W)
np.save('expected_target.npy', planar(tx, ty))
np.save('expected_weight.npy', planar(wx, wy))
np.save('expected_poses.npy', poses.astype(np.float64))
np.save('expected_disps.npy', disps)
np.save('expected_ii.npy', ii)
np.save('expected_jj.npy', jj)
)PY";

struct Expected {
  std::vector<float> target, weight, disps;
  std::vector<double> poses;
  std::vector<std::int64_t> ii, jj;

  explicit Expected(const TempDir& dir) {
    auto load = [&](const std::string& name) { return io::readNpyFile(dir.file(name)); };
    target = io::npyToFloats(load("expected_target.npy"), "target");
    weight = io::npyToFloats(load("expected_weight.npy"), "weight");
    disps = io::npyToFloats(load("expected_disps.npy"), "disps");
    poses = io::npyToDoubles(load("expected_poses.npy"), "poses");
    ii = io::npyToInt64s(load("expected_ii.npy"), "ii");
    jj = io::npyToInt64s(load("expected_jj.npy"), "jj");
  }

  void check(const Snapshot& s, const std::string& what) const {
    SCOPED_TRACE(what);
    ASSERT_EQ(s.numKeyframes(), kN);
    ASSERT_EQ(s.numEdges(), kE);
    ASSERT_EQ(s.H, kH);
    ASSERT_EQ(s.W, kW);
    expectSameValues(s.target, target, "target");
    expectSameValues(s.weight, weight, "weight");
    expectSameValues(s.disps, disps, "disps");
    expectSameValues(std::vector<double>(s.poses_cw.data(), s.poses_cw.data() + 7 * kN), poses,
                     "poses");
    expectSameValues(s.ii, ii, "ii");
    expectSameValues(s.jj, jj, "jj");
    EXPECT_TRUE(s.intrinsics == Eigen::Vector4d(40.0, 41.0, 2.5, 1.5)) << s.intrinsics.transpose();
    expectSameValues(s.tstamp, std::vector<double>{0, 3, 6, 9, 12, 15}, "tstamp");
    // Independent of python's expectations: channel 0 follows the column x, channel 1 the row y.
    double dx = 0, dy = 0;
    for (int e = 0; e < kE; ++e)
      for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
          dx = std::max(dx, std::fabs(double{s.targetPlane(e, 0)[y * kW + x]} - x));
          dy = std::max(dy, std::fabs(double{s.targetPlane(e, 1)[y * kW + x]} - y));
        }
    EXPECT_LT(dx, 0.5);
    EXPECT_LT(dy, 0.5);
  }
};

TEST(droid_converter, SyntheticPicklesInEveryLayoutLoadAsExpected) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  const AppResult py = runPython(dir, std::string(kSyntheticPy) + R"PY(
import os
os.makedirs('in')
def dump(name, target, weight, **layout):
    d = {'graph_data': {'ii': ii, 'jj': jj}, 'predicted': target, 'c_map': weight,
         'poses': poses, 'disps': disps, 'intrinsics': K, 'tstamp': tstamp}
    d.update(layout)
    with open(os.path.join('in', name), 'wb') as f:
        pickle.dump(d, f)
# DROID's own layout: everything with a leading batch axis, intrinsics per keyframe.
dump('a_droid.pkl', last(tx, ty)[None], last(wx, wy)[None], id=9, poses=poses[None],
     disps=disps[None], intrinsics=np.tile(K, (1, N, 1)))
dump('b_channel_last.pkl', last(tx, ty), last(wx, wy), poses=poses.astype(np.float64),
     intrinsics=np.tile(K, (N, 1)), tstamp=tstamp.astype(np.float32))
dump('c_planar.pickle', planar(tx, ty)[None], planar(wx, wy), id=np.int64(11))
)PY");
  ASSERT_EQ(py.code, 0) << py.out;
  const Expected expected(dir);

  const AppResult r = runConverter(quoted(dir.file("in")) + " -o " + quoted(dir.file("out")));
  ASSERT_EQ(r.code, 0) << r.out;
  const struct {
    const char* name;
    std::optional<std::int64_t> id;
  } outputs[] = {{"a_droid.npz", 9}, {"b_channel_last.npz", std::nullopt}, {"c_planar.npz", 11}};
  for (const auto& o : outputs) {
    const Snapshot s = io::loadSnapshotNpz(dir.file("out/") + o.name, 0);
    expected.check(s, o.name);
    EXPECT_EQ(s.id, o.id) << o.name;
  }
  // The dtypes of conventions §1, whatever the input held (float64 poses stay float64, as §1
  // allows).
  const io::NpzReader b(dir.file("out/b_channel_last.npz"));
  EXPECT_EQ(b.read("poses").dtype, io::NpyArray::DType::Float64);
  EXPECT_EQ(b.read("tstamp").dtype, io::NpyArray::DType::Float64);
  EXPECT_EQ(b.read("target").shape, (std::vector<std::size_t>{kE, 2, kH, kW}));
  const io::NpzReader a(dir.file("out/a_droid.npz"));
  EXPECT_EQ(a.read("poses").dtype, io::NpyArray::DType::Float32);
  EXPECT_EQ(a.read("intrinsics").shape, (std::vector<std::size_t>{4}));
  EXPECT_EQ(a.read("ii").dtype, io::NpyArray::DType::Int64);
}

TEST(droid_converter, DumpFunctionWithFakeDroidObjectsLoadsAsExpected) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  const AppResult py = runPython(dir, std::string(kSyntheticPy) + R"PY(
import contextlib, types
from dbacov_dump import dump_dba_snapshot
# DROID's DepthVideo and FactorGraph as plain numpy: buffers longer than counter.value, with junk
# (NaN poses, other intrinsics) beyond it that must not be read.
video = types.SimpleNamespace(
    counter=types.SimpleNamespace(value=N), get_lock=contextlib.nullcontext,
    poses=np.concatenate([poses, np.full((3, 7), np.nan, np.float32)]),
    disps=np.concatenate([disps, np.zeros((3, H, W), np.float32)]),
    intrinsics=np.concatenate([np.tile(K, (N, 1)), np.zeros((3, 4), np.float32)]),
    tstamp=np.concatenate([tstamp, [0, 0, 0]]).astype(np.float32))  # DROID zero-initializes the buffer; a larger value there means a removal
graph = types.SimpleNamespace(ii=ii, jj=jj, target=last(tx, ty)[None], weight=last(wx, wy)[None])
dump_dba_snapshot('dumped.npz', video, graph, snapshot_id=4, timestamps_s=tstamp / 30)
)PY");
  ASSERT_EQ(py.code, 0) << py.out;
  const Snapshot s = io::loadSnapshotNpz(dir.file("dumped.npz"), 0);
  Expected(dir).check(s, "dumped.npz");
  EXPECT_EQ(s.id, 4);
  ASSERT_TRUE(s.timestamps_s.has_value());
  for (int k = 0; k < kN; ++k) EXPECT_EQ((*s.timestamps_s)[k], 3.0 * k / 30) << k;
}

TEST(droid_converter, RealSnapshotSurvivesPickleRoundTripBitForBit) {
  if (!std::filesystem::exists(kRealSnapshot)) GTEST_SKIP() << "missing " << kRealSnapshot;
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  // The paper's dump layout: channel-last planes under 'predicted'/'c_map', edges in graph_data.
  const AppResult py = runPython(dir, "d = np.load(" + quoted(kRealSnapshot) + R"PY()
dump = {'id': int(d['id']), 'intrinsics': d['intrinsics'], 'poses': d['poses'],
        'disps': d['disps'], 'tstamp': d['tstamp'],
        'graph_data': {'ii': d['ii'], 'jj': d['jj']},
        'predicted': np.ascontiguousarray(d['target'].transpose(0, 2, 3, 1)),
        'c_map': np.ascontiguousarray(d['weight'].transpose(0, 2, 3, 1))[None]}
assert dump['predicted'].shape == (58, 49, 61, 2)
with open('window_0055.pkl', 'wb') as f:
    pickle.dump(dump, f)
)PY");
  ASSERT_EQ(py.code, 0) << py.out;
  const AppResult r =
      runConverter(quoted(dir.file("window_0055.pkl")) + " -o " + quoted(dir.path()));
  ASSERT_EQ(r.code, 0) << r.out;

  const Snapshot a = io::loadSnapshotNpz(kRealSnapshot, 0);
  const Snapshot b = io::loadSnapshotNpz(dir.file("window_0055.npz"), 0);
  ASSERT_EQ(b.numKeyframes(), 11);
  ASSERT_EQ(b.numEdges(), 58);
  EXPECT_EQ(b.H, 49);
  EXPECT_EQ(b.W, 61);
  EXPECT_EQ(b.id, a.id);
  ASSERT_EQ(b.poses_cw.size(), a.poses_cw.size());
  EXPECT_TRUE(sameBits(b.poses_cw.data(), a.poses_cw.data(), a.poses_cw.size()));
  EXPECT_TRUE(sameBits(b.intrinsics.data(), a.intrinsics.data(), 4));
  EXPECT_TRUE(sameBits(b.disps, a.disps));
  EXPECT_TRUE(sameBits(b.target, a.target));
  EXPECT_TRUE(sameBits(b.weight, a.weight));
  EXPECT_TRUE(sameBits(b.tstamp, a.tstamp));
  EXPECT_EQ(b.ii, a.ii);
  EXPECT_EQ(b.jj, a.jj);
  EXPECT_EQ(b.timestamps_s, a.timestamps_s);

  // Same keys, dtypes and shapes as the original file.
  const io::NpzReader za(kRealSnapshot), zb(dir.file("window_0055.npz"));
  std::vector<std::string> ka = za.keys(), kb = zb.keys();
  std::sort(ka.begin(), ka.end());
  std::sort(kb.begin(), kb.end());
  ASSERT_EQ(kb, ka);
  for (const auto& key : ka) {
    const io::NpyArray x = za.read(key), y = zb.read(key);
    EXPECT_EQ(y.dtype, x.dtype) << key;
    EXPECT_EQ(y.shape, x.shape) << key;
    EXPECT_TRUE(y.data == x.data) << key;
  }
}

}  // namespace
}  // namespace dbacov::testing
