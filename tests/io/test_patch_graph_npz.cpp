// Patch-graph snapshots (DPVO): files written by NumPy (np.savez, the layout of formats.md) are
// read value by value; malformed ones are refused with messages that name the key, edge or patch.
#include <cstdlib>

#include <gtest/gtest.h>

#include "dbacov/io/patch_graph_npz.h"
#include "dbacov/io/snapshot_npz.h"
#include "io_test_util.h"

namespace dbacov::io::testing {
namespace {

// A valid graph of N = 4 frames, M = 3 patches of 3×3 pixels: patch (f, m) has its centre at
// (5 + 2m + f, 4 + m) and inverse depth 0.5 + 0.1 m + 0.01 f; every patch is seen in the two next
// frames (mod N) and in its own frame (a self-edge). `edit` runs before the file is written.
std::string writeGraph(const TempDir& dir, const std::string& edit = "",
                       const std::string& name = "pg.npz") {
  const std::string script = R"PY(
N, M, P = 4, 3, 3
poses = np.zeros((N, 7)); poses[:, 6] = 1; poses[:, 0] = 0.1 * np.arange(N)
patches = np.zeros((N, M, 3, P, P), np.float32)
for f in range(N):
    for m in range(M):
        patches[f, m, 0] = 5 + 2 * m + f + (np.arange(P)[None, :] - 1)
        patches[f, m, 1] = 4 + m + (np.arange(P)[:, None] - 1)
        patches[f, m, 2] = 0.5 + 0.1 * m + 0.01 * f
ii, jj, kk = [], [], []
for f in range(N):
    for m in range(M):
        for j in (f, (f + 1) % N, (f + 2) % N):
            ii.append(f); jj.append(j); kk.append(f * M + m)
E = len(ii)
a = dict(poses=poses.astype(np.float32), patches=patches,
         intrinsics=np.array([40., 41., 16., 12.], np.float32),
         ii=np.array(ii, np.int64), jj=np.array(jj, np.int64), kk=np.array(kk, np.int64),
         target=(np.arange(2 * E, dtype=np.float32).reshape(E, 2) * 0.5),
         weight=np.full((E, 2), 0.75, np.float32), t0=np.int64(1),
         tstamp=np.arange(N, dtype=np.float64) + 10, id=np.int64(7), is_global=np.uint8(1))
)PY" + edit + "\nnp.savez('" +
                             name + "', **a)\n";
  EXPECT_EQ(runPython(dir, script), 0);
  return dir.file(name);
}

TEST(PatchGraphNpz, ReadsTheCentresIndicesAndLabelsNumPyWrote) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  const std::string path = writeGraph(dir);
  EXPECT_TRUE(isPatchGraphNpz(path));
  const PatchGraph g = loadPatchGraphNpz(path, 2);
  EXPECT_EQ(g.source, path);
  EXPECT_EQ(g.index, 2);
  ASSERT_EQ(g.numFrames(), 4);
  ASSERT_EQ(g.M, 3);
  ASSERT_EQ(g.numPatches(), 12);
  ASSERT_EQ(g.numEdges(), 36);
  for (int f = 0; f < 4; ++f)
    for (int m = 0; m < 3; ++m) {
      const int p = f * 3 + m;
      EXPECT_EQ(g.patch_x[p], 5 + 2 * m + f) << p;  // the centre, not a corner
      EXPECT_EQ(g.patch_y[p], 4 + m) << p;
      EXPECT_NEAR(g.patch_d[p], 0.5 + 0.1 * m + 0.01 * f, 1e-7) << p;
    }
  EXPECT_EQ(g.ii[4], 0);
  EXPECT_EQ(g.jj[4], 1);
  EXPECT_EQ(g.kk[4], 1);
  EXPECT_EQ(g.target[9], 4.5);
  EXPECT_EQ(g.weight[9], 0.75);
  EXPECT_EQ(g.t0, 1);
  EXPECT_EQ(g.tstamp[3], 13);
  EXPECT_EQ(g.intrinsics[3], 12);
  EXPECT_DOUBLE_EQ(g.poses_cw(2, 0), static_cast<double>(0.2f));
  ASSERT_TRUE(g.id.has_value());
  EXPECT_EQ(*g.id, 7);
  EXPECT_TRUE(g.is_global);
  EXPECT_FALSE(g.timestamps_s.has_value());
  EXPECT_EQ(g.graphFrames(), (std::vector<int>{0, 1, 2, 3}));
}

TEST(PatchGraphNpz, DenseSnapshotsAreNotPatchGraphs) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  const std::string path = writeGraph(dir, "del a['kk']");
  EXPECT_FALSE(isPatchGraphNpz(path));
  expectMentions(inputErrorOf([&] { loadPatchGraphNpz(path, 0); }), {"missing", "'kk'"});
  expectMentions(inputErrorOf([&] { isPatchGraphNpz(dir.file("absent.npz")); }), {"absent.npz"});
}

TEST(PatchGraphNpz, MalformedFilesNameTheKeyAndTheItem) {
  DBACOV_REQUIRE_NUMPY();
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"del a['t0']", {"missing required key 't0'"}},
      {"a['target'] = a['target'][:, :1]", {"'target'", "(36,1)", "(36,2)"}},
      {"a['patches'] = a['patches'][:, :, :, :, 0]", {"'patches'", "(N,M,3,P,P)"}},
      {"a['poses'] = a['poses'][:3]", {"'patches'", "N from 'poses'"}},
      {"a['kk'] = a['kk'][:-1]", {"'kk'", "(36,)", "E from 'ii'"}},
      {"a['ii'] = a['ii'].astype(np.float32)", {"'ii'", "float32"}},
      {"a['kk'][5] = 4", {"'ii' edge 5", "kk = 4", "frame kk / M = 1"}},
      {"a['jj'][7] = 4", {"'jj' edge 7", "names 4", "0..3"}},
      {"a['kk'][8] = -1", {"'kk' edge 8", "-1"}},
      {"a['target'][3, 1] = np.nan", {"'target'", "non-finite", "edge 3 channel 1"}},
      {"a['weight'][6, 0] = -0.5", {"'weight'", "negative", "edge 6 channel 0"}},
      {"a['patches'][1, 2, 2] = 0", {"'patches'", "patch 5", "frame 1, patch 2", "inverse depth"}},
      {"a['patches'][2, 0, 0, 1, 1] = np.inf", {"'patches' channel 0 (x)", "patch 6"}},
      {"a['poses'][1, 3:] = 0", {"'poses' frame 1", "zero quaternion"}},
      {"a['intrinsics'][0] = 0", {"'intrinsics'", "fx, fy > 0"}},
      {"a['t0'] = np.int64(5)", {"'t0' is 5", "t0 <= N = 4"}},
      {"a['tstamp'][2] = 10", {"'tstamp'", "frames 0 and 2"}},
      {"a['jj'] = a['ii'].copy()", {"ii == jj", "no information"}},
      {"a['weight'][a['ii'] != a['jj']] = 0", {"'weight' is zero on every edge"}},
      {"a['id'] = np.zeros(2, np.int64)", {"'id'", "(2,)", "() or (1,)"}},
  };
  TempDir dir;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const std::string path = writeGraph(dir, cases[i].first, "bad" + std::to_string(i) + ".npz");
    const std::string message = inputErrorOf([&] { loadPatchGraphNpz(path, 0); });
    SCOPED_TRACE(cases[i].first);
    expectMentions(message, {path});
    for (const std::string& part : cases[i].second) expectMentions(message, {part});
  }
}

TEST(PatchGraphNpz, SelfEdgesNeedNoPositiveDepthButOtherEdgesDo) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  // Frame 3's patch 0 keeps its self-edge only: its depth is not used and may be anything.
  const std::string path = writeGraph(dir, R"PY(
keep = ~((a['kk'] == 9) & (a['ii'] != a['jj']))
for k in ('ii', 'jj', 'kk', 'target', 'weight'):
    a[k] = a[k][keep]
a['patches'][3, 0, 2] = -1
)PY");
  const PatchGraph g = loadPatchGraphNpz(path, 0);
  EXPECT_EQ(g.numEdges(), 34);
}

TEST(PatchGraphNpz, TheMemoryBudgetCoversTheArraysTogether) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  const std::string path = writeGraph(dir);
  ::setenv("DBACOV_MEMORY_BUDGET", "1K", 1);
  const std::string message = inputErrorOf([&] { loadPatchGraphNpz(path, 0); });
  ::unsetenv("DBACOV_MEMORY_BUDGET");
  expectMentions(message, {path, "memory budget", "DBACOV_MEMORY_BUDGET"});
}

TEST(PatchGraphNpz, ReadsFromMemoryAndFloat64Arrays) {
  DBACOV_REQUIRE_NUMPY();
  TempDir dir;
  const std::string path = writeGraph(
      dir,
      "for k in ('poses', 'patches', 'target', 'weight'): a[k] = a[k].astype(np.float64)\n"
      "a['ii'] = a['ii'].astype(np.int32)\na['timestamps_s'] = a['tstamp'] / 30");
  const PatchGraph g = loadPatchGraphNpzFromMemory("mem.npz", readBytes(path), 0);
  EXPECT_EQ(g.source, "mem.npz");
  ASSERT_TRUE(g.timestamps_s.has_value());
  EXPECT_DOUBLE_EQ((*g.timestamps_s)[1], 11.0 / 30);
  EXPECT_EQ(g.poses_cw(2, 0), static_cast<double>(0.2f));  // float32 in the dict, then float64
}

}  // namespace
}  // namespace dbacov::io::testing
