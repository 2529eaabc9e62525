"""Tests of the DROID-SLAM side (share/droid): dbacov_dump.dump_dba_snapshot with numpy-backed fakes
of DROID's DepthVideo / FactorGraph, and the pickle converter's layouts, errors and exit codes.

Needs numpy only (torch is not used). Run: PYTHONPATH=share/droid python3 -m unittest discover -s
share/droid/tests -v
"""

import contextlib
import os
import pickle
import subprocess
import sys
import tempfile
import types
import unittest
import zipfile

import numpy as np

import convert_pickle_dumps
import dbacov_dump

CONVERTER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                         "convert_pickle_dumps.py")
SPEC = {"poses": np.float32, "disps": np.float32, "intrinsics": np.float32, "ii": np.int64,
        "jj": np.int64, "target": np.float32, "weight": np.float32, "tstamp": np.float64,
        "timestamps_s": np.float64, "id": np.int64, "t0": np.int64, "disps_sens": np.float32,
        "stereo_rig": np.float64}
EXTRA = ("timestamps_s", "t0", "disps_sens", "stereo_rig")  # written only in some cases


class FakeTensor:
    """The part of a torch tensor that the dump uses: indexing, comparisons, &, and
    .detach().cpu().numpy() (which records that it was called)."""

    conversions = 0

    def __init__(self, a):
        self._a = np.asarray(a)

    @staticmethod
    def _raw(x):
        if isinstance(x, tuple):
            return tuple(FakeTensor._raw(v) for v in x)
        return x._a if isinstance(x, FakeTensor) else x

    def __getitem__(self, key):
        return FakeTensor(self._a[self._raw(key)])

    def __ge__(self, other):
        return FakeTensor(self._a >= other)

    def __and__(self, other):
        return FakeTensor(self._a & self._raw(other))

    @property
    def shape(self):
        return self._a.shape

    def detach(self):
        return self

    def cpu(self):
        return self

    def numpy(self):
        FakeTensor.conversions += 1
        return self._a


class FakeVideo:
    """DROID's DepthVideo: buffers larger than the N = counter.value keyframes in use."""

    def __init__(self, n, capacity, h, w, rng, wrap=FakeTensor):
        self.counter = types.SimpleNamespace(value=n)
        poses = rng.normal(size=(capacity, 7)).astype(np.float32)
        poses[:, 3:] /= np.linalg.norm(poses[:, 3:], axis=1, keepdims=True)
        poses[n:] = np.nan  # beyond N: never read
        intr = np.tile(np.array([60.5, 61.25, 3.5, 2.25], np.float32), (capacity, 1))
        intr[n:] = 0  # beyond N: different, must not matter
        self.poses = wrap(poses)
        self.disps = wrap(rng.uniform(0.1, 2.0, size=(capacity, h, w)).astype(np.float32))
        self.intrinsics = wrap(intr)
        tstamp = np.arange(capacity, dtype=np.float32) * 3
        tstamp[n:] = 0  # DROID's buffer is zero beyond what was ever appended
        self.tstamp = wrap(tstamp)
        self.locked = 0

    @contextlib.contextmanager
    def get_lock(self):
        self.locked += 1
        yield


def pixel_planes(e_count, h, w, rng):
    """Targets as (x, y) planes: the pixel's own column/row plus a small flow, and weights."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    tx = x[None] + rng.uniform(-0.4, 0.4, size=(e_count, h, w)).astype(np.float32)
    ty = y[None] + rng.uniform(-0.4, 0.4, size=(e_count, h, w)).astype(np.float32)
    wx = rng.uniform(0, 1, size=(e_count, h, w)).astype(np.float32)
    wy = rng.uniform(0, 1, size=(e_count, h, w)).astype(np.float32)
    return tx, ty, wx, wy


def channel_last(px, py):
    """(E,H,W) planes -> DROID's (1,E,H,W,2), last axis (x, y)."""
    return np.stack([px, py], axis=-1)[None]


class FakeGraph:
    def __init__(self, ii, jj, tx, ty, wx, wy, wrap=FakeTensor):
        self.ii, self.jj = wrap(np.asarray(ii, np.int64)), wrap(np.asarray(jj, np.int64))
        self.target, self.weight = wrap(channel_last(tx, ty)), wrap(channel_last(wx, wy))


class DumpTest(unittest.TestCase):
    N, CAP, H, W = 5, 8, 4, 6
    II, JJ = [1, 2, 2, 3, 4, 1], [2, 1, 3, 4, 3, 3]

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name
        self.rng = np.random.default_rng(7)
        self.planes = pixel_planes(len(self.II), self.H, self.W, self.rng)

    def tearDown(self):
        self.tmp.cleanup()

    def make(self, wrap=FakeTensor):
        video = FakeVideo(self.N, self.CAP, self.H, self.W, self.rng, wrap)
        return video, FakeGraph(self.II, self.JJ, *self.planes, wrap=wrap)

    def test_writes_exactly_the_spec_keys_dtypes_shapes_and_channel_order(self):
        for wrap in (FakeTensor, np.asarray):
            video, graph = self.make(wrap)
            path = os.path.join(self.dir, "snap.npz")
            before = FakeTensor.conversions
            self.assertEqual(dbacov_dump.dump_dba_snapshot(path, video, graph, 42), path)
            if wrap is FakeTensor:  # every array went through .detach().cpu().numpy()
                self.assertEqual(FakeTensor.conversions - before, 8)
            self.assertEqual(video.locked, 1)
            n, e, h, w = self.N, len(self.II), self.H, self.W
            with np.load(path) as z:
                self.assertEqual(sorted(z.files),
                                 sorted([k for k in SPEC if k not in EXTRA] + ["t0"]))
                for k in z.files:
                    self.assertEqual(z[k].dtype, SPEC[k], k)
                shapes = {"poses": (n, 7), "disps": (n, h, w), "intrinsics": (4,), "ii": (e,),
                          "jj": (e,), "target": (e, 2, h, w), "weight": (e, 2, h, w),
                          "tstamp": (n,), "id": (), "t0": ()}
                self.assertEqual({k: z[k].shape for k in z.files}, shapes)
                src = {k: np.asarray(getattr(video, k)._a if wrap is FakeTensor
                                     else getattr(video, k)) for k in ("poses", "disps", "tstamp")}
                np.testing.assert_array_equal(z["poses"], src["poses"][:n])
                np.testing.assert_array_equal(z["disps"], src["disps"][:n])
                np.testing.assert_array_equal(z["tstamp"], src["tstamp"][:n])
                np.testing.assert_array_equal(z["intrinsics"], [60.5, 61.25, 3.5, 2.25])
                np.testing.assert_array_equal(z["ii"], self.II)
                np.testing.assert_array_equal(z["jj"], self.JJ)
                self.assertEqual(int(z["id"]), 42)
                tx, ty, wx, wy = self.planes
                np.testing.assert_array_equal(z["target"][:, 0], tx)  # channel 0 = x
                np.testing.assert_array_equal(z["target"][:, 1], ty)
                np.testing.assert_array_equal(z["weight"][:, 0], wx)
                np.testing.assert_array_equal(z["weight"][:, 1], wy)
                # Independent of the fixture: channel 0 is near the column, channel 1 the row.
                cols, rows = np.meshgrid(np.arange(w), np.arange(h))
                self.assertLess(np.abs(z["target"][:, 0] - cols).max(), 0.5)
                self.assertLess(np.abs(z["target"][:, 1] - rows).max(), 0.5)
                self.assertTrue(z["target"].flags.c_contiguous)
            self.assertEqual(os.listdir(self.dir), ["snap.npz"])  # no temporary left

    def test_timestamps_and_stored_archive(self):
        video, graph = self.make()
        path = os.path.join(self.dir, "s.npz")
        secs = np.linspace(0.5, 2.5, self.N)
        dbacov_dump.dump_dba_snapshot(path, video, graph, 3, timestamps_s=secs, compressed=False)
        with zipfile.ZipFile(path) as zf:
            self.assertTrue(all(i.compress_type == zipfile.ZIP_STORED for i in zf.infolist()))
        with np.load(path) as z:
            self.assertEqual(z["timestamps_s"].dtype, np.float64)
            np.testing.assert_array_equal(z["timestamps_s"], secs)
        with self.assertRaisesRegex(ValueError, "timestamps_s"):
            dbacov_dump.dump_dba_snapshot(path, video, graph, 3, timestamps_s=secs[:-1])

    def test_inconsistent_intrinsics_raise_and_write_nothing(self):
        video, graph = self.make()
        video.intrinsics._a[3, 2] += 0.5
        path = os.path.join(self.dir, "s.npz")
        with self.assertRaisesRegex(ValueError, r"intrinsics differ.*row 3"):
            dbacov_dump.dump_dba_snapshot(path, video, graph, 1)
        self.assertEqual(os.listdir(self.dir), [])

    def test_edge_beyond_counter_raises(self):
        video, graph = self.make()
        graph.jj._a[2] = self.N  # a keyframe slot beyond counter.value
        with self.assertRaisesRegex(ValueError, r"^graph.jj\[2\] names keyframe 5, outside "
                                                r"\[0, 5\) \(video.counter.value = 5 keyframes\)$"):
            dbacov_dump.dump_dba_snapshot(os.path.join(self.dir, "s.npz"), video, graph, 1)
        self.assertEqual(os.listdir(self.dir), [])

    def test_wrong_graph_layout_raises(self):
        video, graph = self.make()
        graph.weight = FakeTensor(graph.weight._a[0])  # (E,H,W,2): not DROID's layout
        with self.assertRaisesRegex(ValueError, r"graph.weight has shape .*expected \(1,E,H,W,2\)"):
            dbacov_dump.dump_dba_snapshot(os.path.join(self.dir, "s.npz"), video, graph, 1)

    def test_inactive_edges_with_droids_selection(self):
        video, graph = self.make()
        # Active edges all leave keyframe 4: t0 = min(ii) + 1 = 5, and DROID keeps the inactive
        # edges whose keyframes are both >= t0 - 3 = 2, inactive ones first.
        graph.ii._a[:] = [4, 4, 4, 4, 4, 4]
        graph.jj._a[:] = [0, 1, 2, 3, 0, 1]
        rng = np.random.default_rng(3)
        itx, ity, iwx, iwy = pixel_planes(3, self.H, self.W, rng)
        graph.ii_inac = FakeTensor(np.array([0, 2, 3], np.int64))  # (0, 1) is too old
        graph.jj_inac = FakeTensor(np.array([1, 3, 2], np.int64))
        graph.target_inac = FakeTensor(channel_last(itx, ity))
        graph.weight_inac = FakeTensor(channel_last(iwx, iwy))
        path = os.path.join(self.dir, "s.npz")
        dbacov_dump.dump_dba_snapshot(path, video, graph, 1, include_inactive=True)
        with np.load(path) as z:
            np.testing.assert_array_equal(z["ii"], [2, 3, 4, 4, 4, 4, 4, 4])
            np.testing.assert_array_equal(z["jj"], [3, 2, 0, 1, 2, 3, 0, 1])
            np.testing.assert_array_equal(z["target"][:2, 0], itx[1:])
            np.testing.assert_array_equal(z["weight"][:2, 1], iwy[1:])
            np.testing.assert_array_equal(z["target"][2:, 1], self.planes[1])
        dbacov_dump.dump_dba_snapshot(path, video, graph, 1)  # default: active edges only
        with np.load(path) as z:
            self.assertEqual(z["ii"].shape, (6,))

    def test_failed_write_keeps_previous_file_and_leaves_no_temporary(self):
        video, graph = self.make()
        path = os.path.join(self.dir, "s.npz")
        with open(path, "wb") as f:
            f.write(b"previous")
        original = np.lib.format.write_array
        np.lib.format.write_array = lambda *a, **k: (_ for _ in ()).throw(OSError(28, "disk full"))
        try:
            with self.assertRaises(OSError):
                dbacov_dump.dump_dba_snapshot(path, video, graph, 1)
        finally:
            np.lib.format.write_array = original
        with open(path, "rb") as f:
            self.assertEqual(f.read(), b"previous")
        self.assertEqual(os.listdir(self.dir), ["s.npz"])


# --- keyframe times, RGB-D, stereo, the safe hook --------------------------------------------------

class FakeFrontendVideo:
    """A DepthVideo driven as DROID's frontend drives it: append() at counter.value (tstamp, image),
    rm_keyframe() shifting every buffer, with tstamp shifted (current DROID) or not (releases
    before 2025)."""

    def __init__(self, capacity=16, h=3, w=4, shift_tstamp=True, images=True, rgbd=False,
                 stereo=False):
        self.counter = types.SimpleNamespace(value=0)
        self.stereo = stereo  # DepthVideo(stereo=...): DROID's --stereo
        self.shift_tstamp = shift_tstamp
        rng = np.random.default_rng(5)
        poses = np.zeros((capacity, 7), np.float32)
        poses[:, 6] = 1
        poses[:, :3] = rng.normal(size=(capacity, 3))
        self.poses = FakeTensor(poses)
        self.disps = FakeTensor(rng.uniform(0.2, 1.0, size=(capacity, h, w)).astype(np.float32))
        self.intrinsics = FakeTensor(np.tile(np.float32([50, 50, 1.5, 1]), (capacity, 1)))
        self.tstamp = FakeTensor(np.zeros(capacity, np.float32))
        self.images = FakeTensor(np.zeros((capacity, 3, 8, 8), np.uint8)) if images else None
        self.disps_sens = FakeTensor(np.zeros((capacity, h, w), np.float32))
        self.rgbd = rgbd
        self.truth = []  # the frame index of every slot, kept by the test

    @contextlib.contextmanager
    def get_lock(self):
        yield

    def append(self, frame):
        k = self.counter.value
        self.tstamp._a[k] = frame
        if self.images is not None:
            self.images._a[k] = np.random.default_rng(frame).integers(0, 255, (3, 8, 8))
        if self.rgbd:
            self.disps_sens._a[k] = 1.0 / (1.0 + 0.1 * frame)
            self.disps_sens._a[k, 0, 0] = 0  # a pixel without sensor depth
        self.counter.value += 1
        self.truth.append(frame)

    def rm_keyframe(self, ix):
        t = self.counter.value
        names = ["poses", "disps", "intrinsics", "disps_sens"] + \
            (["images"] if self.images is not None else []) + \
            (["tstamp"] if self.shift_tstamp else [])
        for name in names:
            a = getattr(self, name)._a
            a[ix:t - 1] = a[ix + 1:t].copy()
        self.counter.value -= 1
        del self.truth[ix]


def frontend_graph(video, stereo=False):
    n = video.counter.value
    ii = [k for k in range(max(0, n - 4), n) for j in range(max(0, n - 4), n) if j != k]
    jj = [j for k in range(max(0, n - 4), n) for j in range(max(0, n - 4), n) if j != k]
    if stereo:
        ii, jj = ii + list(range(max(0, n - 4), n)), jj + list(range(max(0, n - 4), n))
    h, w = video.disps.shape[1:]
    tx, ty, wx, wy = pixel_planes(len(ii), h, w, np.random.default_rng(n))
    graph = FakeGraph(ii, jj, tx, ty, wx, wy)
    graph.ii_inac = graph.jj_inac = FakeTensor(np.zeros(0, np.int64))  # as DROID starts
    graph.target_inac = graph.weight_inac = FakeTensor(np.zeros((1, 0, h, w, 2), np.float32))
    return graph


class KeyframeTimesTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def run_frontend(self, video, removal_slot, steps=10, **dump_kw):
        """Frames 0, 3, 6, ...; the first 4 are the initialization; every third update removes
        `removal_slot(t1)` (t1 = counter after the append) as DROID's frontend does. Returns the
        dumped tstamp and the truth of every update."""
        record = dbacov_dump.KeyframeRecord()
        frame, out = 0, []
        for _ in range(4):
            video.append(frame)
            frame += 3
        for step in range(steps):
            video.append(frame)
            frame += 3
            if step % 3 == 1:
                video.rm_keyframe(removal_slot(video.counter.value))
            path = os.path.join(self.dir, f"s{step}.npz")
            dbacov_dump.dump_dba_snapshot(path, video, frontend_graph(video), step,
                                          record=record, **dump_kw)
            with np.load(path) as z:
                out.append((z["tstamp"].astype(int).tolist(), list(video.truth),
                            z["timestamps_s"] if "timestamps_s" in z.files else None))
        return record, out

    def test_current_droid_shifted_tstamp_is_kept(self):
        video = FakeFrontendVideo(shift_tstamp=True)
        record, out = self.run_frontend(video, lambda t1: t1 - 3)
        for got, truth, _ in out:
            self.assertEqual(got, truth)
        self.assertEqual(record.stale_corrections, 0)

    def test_old_droid_stale_tstamp_is_corrected(self):
        # DROID 2022: rm_keyframe(t1 - 2) without shifting tstamp. The raw buffer goes wrong
        # (checked below), the dump stays right, with and without images to locate the removal.
        for images in (True, False):
            with self.subTest(images=images):
                video = FakeFrontendVideo(shift_tstamp=False, images=images)
                record, out = self.run_frontend(video, lambda t1: t1 - 2)
                for got, truth, _ in out:
                    self.assertEqual(got, truth)
                self.assertEqual(record.stale_corrections, 3)
                n = video.counter.value
                self.assertNotEqual(video.tstamp._a[:n].astype(int).tolist(), video.truth)

    def test_old_droid_removing_another_slot_is_located_by_images(self):
        video = FakeFrontendVideo(shift_tstamp=False, images=True)
        record, out = self.run_frontend(video, lambda t1: t1 - 3)
        for got, truth, _ in out:
            self.assertEqual(got, truth)

    def test_old_droid_without_record_still_corrects_this_updates_removal(self):
        video = FakeFrontendVideo(shift_tstamp=False, images=False)
        for f in range(0, 15, 3):
            video.append(f)
        video.rm_keyframe(video.counter.value - 2)
        path = os.path.join(self.dir, "s.npz")
        dbacov_dump.dump_dba_snapshot(path, video, frontend_graph(video), 1)
        with np.load(path) as z:
            self.assertEqual(z["tstamp"].astype(int).tolist(), video.truth)

    def test_image_times_give_timestamps_s(self):
        times = 1403636579.76 + 0.05 * np.arange(100)
        video = FakeFrontendVideo(shift_tstamp=False)
        _, out = self.run_frontend(video, lambda t1: t1 - 2, image_times_s=times)
        for _, truth, secs in out:
            np.testing.assert_array_equal(secs, times[truth])
        csv = os.path.join(self.dir, "data.csv")
        with open(csv, "w") as f:
            f.write("#timestamp [ns],filename\n")
            f.writelines(f"{1403636579763555584 + 50000000 * k},{k}.png\n" for k in range(5))
        np.testing.assert_allclose(dbacov_dump.read_euroc_image_times(csv),
                                   1403636579.763555584 + 0.05 * np.arange(5), rtol=0, atol=1e-6)
        with self.assertRaisesRegex(dbacov_dump.KeyframeTimeError, "beyond the 10 image times"):
            self.run_frontend(FakeFrontendVideo(), lambda t1: t1 - 3, image_times_s=times[:10])

    def test_inconsistent_history_is_refused(self):
        video = FakeFrontendVideo()
        record = dbacov_dump.KeyframeRecord()
        for f in (0, 3, 6, 9):
            video.append(f)
        record.update(video)
        video.append(12)
        video.append(15)  # two keyframes between calls
        with self.assertRaisesRegex(dbacov_dump.KeyframeTimeError, "went from 4 to 6"):
            record.update(video)
        video = FakeFrontendVideo()
        for f in (0, 3, 3):
            video.append(f)
        with self.assertRaisesRegex(dbacov_dump.KeyframeTimeError, "not increasing: slot 1 = 3"):
            dbacov_dump.KeyframeRecord().update(video)

    def test_rgbd_and_stereo_keys_and_t0(self):
        video = FakeFrontendVideo(rgbd=True, stereo=True)
        for f in range(0, 18, 3):
            video.append(f)
        path = os.path.join(self.dir, "s.npz")
        dbacov_dump.dump_dba_snapshot(path, video, frontend_graph(video, stereo=True), 1)
        with np.load(path) as z:
            np.testing.assert_array_equal(z["disps_sens"], video.disps_sens._a[:6])
            self.assertEqual(z["disps_sens"].dtype, np.float32)
            np.testing.assert_array_equal(z["stereo_rig"], [-0.1, 0, 0, 0, 0, 0, 1])
            self.assertEqual(z["stereo_rig"].dtype, np.float64)
            self.assertEqual(int(z["t0"]), 3)  # min(ii) = 2 -> DROID's t0 = 3
            self.assertTrue((z["ii"] == z["jj"]).any())
        mono = FakeFrontendVideo()
        for f in range(0, 18, 3):
            mono.append(f)
        dbacov_dump.dump_dba_snapshot(path, mono, frontend_graph(mono), 1)
        with np.load(path) as z:
            self.assertNotIn("disps_sens", z.files)  # all zero: not RGB-D
            self.assertNotIn("stereo_rig", z.files)

    def test_safe_hook_never_raises_and_reports_each_kind_once(self):
        import io
        video = FakeFrontendVideo()
        for f in range(0, 15, 3):
            video.append(f)
        stream = io.StringIO()
        dumper = dbacov_dump.DbaDumper(os.path.join(self.dir, "out"), stream=stream)
        self.assertTrue(dumper(video, frontend_graph(video), 1).endswith("window_000001.npz"))
        broken = frontend_graph(video)
        broken.weight = FakeTensor(broken.weight._a[0])
        for count in (2, 3, 4):
            self.assertIsNone(dumper(video, broken, count))
        self.assertIsNone(dumper(video, None, 5))  # no graph: refused, naming what is missing

        class Failing:  # a failure of DROID's own objects (a CUDA error, a bug)
            @property
            def ii(self):
                raise RuntimeError("CUDA error: an illegal memory access was encountered")

        self.assertIsNone(dumper(video, Failing(), 6))
        self.assertEqual((dumper.written, dumper.failures), (1, 5))
        lines = stream.getvalue().splitlines()
        self.assertEqual(len(lines), 3, lines)
        self.assertRegex(lines[0], r"snapshot 2 not written \(ValueError: ")
        self.assertIn("DROID-SLAM goes on", lines[0])
        self.assertRegex(lines[1], r"snapshot 5 not written \(ValueError: graph.ii is missing")
        self.assertRegex(lines[2], r"snapshot 6 not written \(RuntimeError: CUDA error")
        self.assertEqual(sorted(os.listdir(os.path.join(self.dir, "out"))), ["window_000001.npz"])


# --- converter ------------------------------------------------------------------------------------

def make_dump(rng, n=4, e=5, h=3, w=5, planes="(1,E,H,W,2)", disps="(N,H,W)", poses="(N,7)",
              intrinsics="(4,)"):
    """A consistent dump as the paper's code writes it, in the given layouts. Also returns the
    expected SPEC arrays, built from the (x, y) planes, not from the dump's arrays."""
    ii = rng.integers(0, n, size=e)
    jj = (ii + rng.integers(1, n, size=e)) % n
    tx, ty, wx, wy = pixel_planes(e, h, w, rng)
    p = rng.normal(size=(n, 7)).astype(np.float32)
    d = rng.uniform(0.2, 1.5, size=(n, h, w)).astype(np.float32)
    k = np.array([40.0, 41.0, 2.5, 1.5], np.float32)
    expected = {"poses": p, "disps": d, "intrinsics": k, "ii": ii, "jj": jj,
                "target": np.stack([tx, ty], axis=1), "weight": np.stack([wx, wy], axis=1),
                "tstamp": np.arange(n, dtype=np.float64) * 2, "id": np.int64(17)}
    layout = {"(E,2,H,W)": lambda a, b: np.stack([a, b], axis=1),
              "(E,H,W,2)": lambda a, b: np.stack([a, b], axis=-1),
              "(1,E,H,W,2)": lambda a, b: np.stack([a, b], axis=-1)[None],
              "(1,E,2,H,W)": lambda a, b: np.stack([a, b], axis=1)[None]}[planes]
    dump = {"id": 17, "graph_data": {"ii": ii, "jj": jj}, "predicted": layout(tx, ty),
            "c_map": layout(wx, wy), "tstamp": expected["tstamp"].copy(),
            "poses": p[None] if poses == "(1,N,7)" else p,
            "disps": d[None] if disps == "(1,N,H,W)" else d,
            "intrinsics": {"(4,)": k, "(N,4)": np.tile(k, (n, 1)),
                           "(1,N,4)": np.tile(k, (1, n, 1))}[intrinsics]}
    return dump, expected


def run_converter(*args, env=None):
    r = subprocess.run([sys.executable, "-B", CONVERTER, *args], capture_output=True, text=True,
                       env=env)
    return r.returncode, r.stdout, r.stderr


class ConverterTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name
        self.rng = np.random.default_rng(11)

    def tearDown(self):
        self.tmp.cleanup()

    def save(self, name, obj):
        path = os.path.join(self.dir, "in", name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            pickle.dump(obj, f)
        return path

    def test_every_layout_is_normalized_to_spec(self):
        combos = [("(E,2,H,W)", "(N,H,W)", "(N,7)", "(4,)"),
                  ("(E,H,W,2)", "(1,N,H,W)", "(1,N,7)", "(N,4)"),
                  ("(1,E,H,W,2)", "(N,H,W)", "(N,7)", "(1,N,4)"),
                  ("(1,E,2,H,W)", "(1,N,H,W)", "(N,7)", "(4,)")]
        for combo in combos:
            with self.subTest(combo=combo):
                names = ("planes", "disps", "poses", "intrinsics")
                dump, exp = make_dump(self.rng, **dict(zip(names, combo)))
                got = convert_pickle_dumps.convert_dump(dump)
                self.assertEqual(sorted(got), sorted(exp))
                for k, v in exp.items():
                    self.assertEqual(got[k].dtype, SPEC[k], k)
                    self.assertEqual(got[k].shape, np.shape(v), k)
                    np.testing.assert_array_equal(got[k], v, err_msg=k)

    def test_float64_poses_kept_and_square_grid(self):
        dump, exp = make_dump(self.rng, h=5, w=5, planes="(E,H,W,2)")
        dump["poses"] = dump["poses"].astype(np.float64)
        got = convert_pickle_dumps.convert_dump(dump)
        self.assertEqual(got["poses"].dtype, np.float64)
        np.testing.assert_array_equal(got["target"], exp["target"])

    def test_shape_errors_name_key_found_and_expected(self):
        cases = [
            ("predicted", lambda d: d["predicted"][..., :1], r"key 'predicted' has shape "
             r"\(1,5,3,5,1\), expected one of \(E,2,H,W\)=\(5,2,3,5\), \(E,H,W,2\)=\(5,3,5,2\), "
             r"\(1,E,H,W,2\)=\(1,5,3,5,2\), \(1,E,2,H,W\)=\(1,5,2,3,5\)"),
            ("c_map", lambda d: d["c_map"][:, :, :, :4], r"key 'c_map' has shape \(1,5,3,4,2\)"),
            ("disps", lambda d: d["disps"][:3], r"key 'disps' has shape \(3,3,5\), expected one "
             r"of \(N,H,W\)=\(4,3,5\), \(1,N,H,W\)=\(1,4,3,5\)"),
            ("intrinsics", lambda d: np.zeros(5), r"key 'intrinsics' has shape \(5,\)"),
            ("tstamp", lambda d: d["tstamp"][None], r"key 'tstamp' has shape \(1,4\), expected "
             r"one of \(N\)=\(4,\)"),
            ("poses", lambda d: d["poses"][:, :6], r"key 'poses' has shape \(4,6\)"),
        ]
        for key, change, pattern in cases:
            with self.subTest(key=key):
                dump, _ = make_dump(self.rng)
                dump[key] = change(dump)
                with self.assertRaisesRegex(convert_pickle_dumps.ConversionError, pattern):
                    convert_pickle_dumps.convert_dump(dump)

    def test_ambiguous_layout_is_refused(self):
        dump, _ = make_dump(self.rng, h=2, w=2, planes="(E,2,H,W)")
        with self.assertRaisesRegex(convert_pickle_dumps.ConversionError,
                                    r"'predicted' has shape \(5,2,2,2\), which is ambiguous: it "
                                    r"matches \(E,2,H,W\) and \(E,H,W,2\)"):
            convert_pickle_dumps.convert_dump(dump)

    def test_intrinsics_rows_must_agree(self):
        dump, _ = make_dump(self.rng, intrinsics="(N,4)")
        dump["intrinsics"][2, 0] += 1
        with self.assertRaisesRegex(convert_pickle_dumps.ConversionError,
                                    "key 'intrinsics': row 2 .* differs from row 0"):
            convert_pickle_dumps.convert_dump(dump)

    def test_bad_files_reported_one_line_each_good_files_still_written(self):
        good, exp = make_dump(self.rng)
        bad = {}
        d, _ = make_dump(self.rng)
        del d["c_map"]
        bad["b_missing_key.pkl"] = (d, "missing key 'c_map'")
        d, _ = make_dump(self.rng)
        d["predicted"] = d["predicted"][0].transpose(0, 1, 3, 2)  # (E,H,2,W)
        bad["c_wrong_layout.pkl"] = (d, r"key 'predicted' has shape \(5,3,2,5\), expected one of")
        d, _ = make_dump(self.rng)
        d["graph_data"]["ii"] = d["graph_data"]["ii"].copy()
        d["graph_data"]["ii"][3] = 4
        bad["d_out_of_range.pkl"] = (d, r"key 'graph_data.ii': edge 3 names keyframe 4, "
                                        r"outside \[0, 4\)")
        d, _ = make_dump(self.rng)
        d["c_map"][0, 2, 1, 3, 1] = -0.5
        bad["e_negative_weight.pkl"] = (d, r"key 'c_map' has a negative value at edge 2, "
                                           r"channel y, pixel \(x=3, y=1\)")
        d, _ = make_dump(self.rng)
        d["poses"][1, 4] = np.inf
        bad["f_nonfinite_pose.pkl"] = (d, r"key 'poses' has a non-finite value at index \(1, 4\)")
        d, _ = make_dump(self.rng)
        d["graph_data"]["jj"] = d["graph_data"]["ii"]
        bad["g_self_edge.pickle"] = (d, r"key 'graph_data.ii' and key 'graph_data.jj': edge 0 "
                                      r"links keyframe \d+ to itself")
        bad["h_not_a_dict.pkl"] = ([1, 2], "the pickle holds a list, expected a dict")
        self.save("a_good.pkl", good)
        for name, (obj, _) in bad.items():
            self.save(name, obj)
        self.save("z_good.pickle", good)
        with open(os.path.join(self.dir, "in", "notes.txt"), "w") as f:
            f.write("not a pickle, ignored in a directory")
        with open(os.path.join(self.dir, "in", "i_truncated.pkl"), "wb") as f:
            f.write(pickle.dumps(good)[:100])
        bad["i_truncated.pkl"] = (None, "cannot unpickle: ")

        out = os.path.join(self.dir, "out")
        code, stdout, stderr = run_converter(os.path.join(self.dir, "in"), "-o", out)
        self.assertEqual(code, 1, stderr)
        lines = stderr.splitlines()
        self.assertEqual(len(lines), len(bad), stderr)
        for line, (name, (_, pattern)) in zip(lines, sorted(bad.items())):
            self.assertRegex(line, f"^convert_pickle_dumps.py: error: .*/in/{name}: {pattern}")
        self.assertEqual(sorted(os.listdir(out)), ["a_good.npz", "z_good.npz"])
        self.assertIn("2 of 10 files converted, 8 failed", stdout)
        self.assertLess(stdout.index("a_good.pkl"), stdout.index("z_good.pickle"))  # name order
        for name in ("a_good.npz", "z_good.npz"):
            with np.load(os.path.join(out, name)) as z:
                self.assertEqual(sorted(z.files), sorted(exp))
                for k, v in exp.items():
                    self.assertEqual(z[k].dtype, SPEC[k], k)
                    np.testing.assert_array_equal(z[k], v, err_msg=k)

    def test_torch_pickle_without_torch_says_so(self):
        fake = types.ModuleType("torch")

        class Tensor:  # pickled by reference as torch.Tensor
            pass

        Tensor.__module__, Tensor.__qualname__ = "torch", "Tensor"
        fake.Tensor = Tensor
        real = sys.modules.get("torch")  # another suite of this run may have imported torch
        sys.modules["torch"] = fake
        try:
            path = self.save("t.pkl", {"poses": Tensor()})
        finally:
            if real is None:
                del sys.modules["torch"]
            else:
                sys.modules["torch"] = real
        # Whether or not torch is installed here: a 'torch' that cannot be imported shadows it.
        shadow = os.path.join(self.dir, "no_torch", "torch")
        os.makedirs(shadow)
        with open(os.path.join(shadow, "__init__.py"), "w") as f:
            f.write("raise ModuleNotFoundError(\"No module named 'torch'\", name='torch')\n")
        env = dict(os.environ, PYTHONPATH=os.path.dirname(shadow))
        code, _, stderr = run_converter(path, "-o", os.path.join(self.dir, "out"), env=env)
        self.assertEqual(code, 1)
        self.assertRegex(stderr, r"t\.pkl: the pickle holds torch tensors and PyTorch is not "
                                 r"installed: install torch")

    def test_usage_and_inputs(self):
        code, out, _ = run_converter("--help")
        self.assertEqual(code, 0)
        self.assertIn("INPUT", out)
        self.assertIn("-o OUT_DIR", out)
        self.assertIn("SECURITY: unpickling runs code", out)
        self.assertIn("Only convert pickles you trust", out)
        for args in ([], ["x.pkl"], ["-o", self.dir], ["x.pkl", "-o", self.dir, "--bogus"]):
            code, _, err = run_converter(*args)
            self.assertEqual(code, 2, args)
            self.assertIn("usage:", err)
        good, _ = make_dump(self.rng)
        a = self.save("a.pkl", good)
        os.makedirs(os.path.join(self.dir, "empty"))
        out = os.path.join(self.dir, "new", "out")  # created on demand
        code, _, err = run_converter(a, os.path.join(self.dir, "missing.pkl"),
                                     os.path.join(self.dir, "empty"), a, "-o", out, "-q")
        self.assertEqual(code, 1)
        lines = err.splitlines()
        self.assertEqual(len(lines), 3, err)
        self.assertRegex(lines[0], r"missing\.pkl: no such file or directory$")
        self.assertRegex(lines[1], r"empty: directory holds no \.pkl/\.pickle file$")
        self.assertRegex(lines[2], r"a\.pkl: output .*a\.npz is already written from .*a\.pkl$")
        self.assertEqual(os.listdir(out), ["a.npz"])


if __name__ == "__main__":
    unittest.main()
