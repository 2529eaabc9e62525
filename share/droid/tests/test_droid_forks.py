"""DROID forks and DROID's global BA in the dump hook (share/droid/dbacov_dump.py), with fakes of
their DepthVideo / FactorGraph / backend (NumPy arrays; the method names and call order are the
real ones):

* GO-SLAM names the keyframe time stamps `video.timestamp` (image indices);
* DBA-Fusion keeps `video.tstamp` as float64 seconds: mapped to image indices through
  image_times_s, refused without (once per run by the hook, never a silent skip);
* DROID's DroidBackend / DroidAsyncBackend: install_backend_hook dumps the graph of each global
  BA (FactorGraph.update_lowmem) before the backend drops its edges, with t0 = 1.

Needs numpy only. Run: PYTHONPATH=share/droid python3 -m unittest discover -s share/droid/tests -v
"""

import contextlib
import io
import os
import sys
import tempfile
import types
import unittest

import numpy as np

import dbacov_dump

START_S = 1403636579.763555584  # EuRoC MH_01's first image, in seconds
PERIOD_S = 0.05


def image_times(count):
    """EuRoC-like image times as read_euroc_image_times gives them (ns * 1e-9)."""
    ns = 1403636579763555584 + 50000000 * np.arange(count, dtype=np.int64)
    return ns * 1e-9


class ForkVideo:
    """A DepthVideo as a fork's frontend drives it: append() at counter.value, rm_keyframe()
    shifting every buffer, the time stamps under `stamps` ('tstamp' or GO-SLAM's 'timestamp'),
    as image indices or (DBA-Fusion) as float64 seconds."""

    def __init__(self, stamps="tstamp", seconds=False, capacity=16, h=3, w=4):
        self.counter = types.SimpleNamespace(value=0)
        self.stereo = False
        self.stamps, self.seconds = stamps, seconds
        rng = np.random.default_rng(3)
        self.poses = np.zeros((capacity, 7), np.float32)
        self.poses[:, 6] = 1
        self.poses[:, :3] = rng.normal(size=(capacity, 3))
        self.disps = rng.uniform(0.2, 1.0, (capacity, h, w)).astype(np.float32)
        self.intrinsics = np.tile(np.float32([50, 50, 1.5, 1]), (capacity, 1))
        self.images = np.zeros((capacity, 3, 8 * h, 8 * w), np.uint8)
        self.disps_sens = np.zeros((capacity, h, w), np.float32)
        setattr(self, stamps, np.zeros(capacity, np.float64 if seconds else np.float32))
        self.truth = []

    def get_lock(self):
        return contextlib.nullcontext()

    def append(self, frame):
        k = self.counter.value
        getattr(self, self.stamps)[k] = image_times(frame + 1)[frame] if self.seconds else frame
        self.images[k] = np.random.default_rng(frame).integers(0, 255, self.images.shape[1:])
        self.counter.value += 1
        self.truth.append(frame)

    def rm_keyframe(self, ix):
        t = self.counter.value
        for name in ("poses", "disps", "intrinsics", "images", "disps_sens", self.stamps):
            a = getattr(self, name)
            a[ix:t - 1] = a[ix + 1:t].copy()
        self.counter.value -= 1
        del self.truth[ix]


def window_graph(video, h=3, w=4):
    """Edges between the newest 4 keyframes, in DROID's layout."""
    n = video.counter.value
    pairs = [(i, j) for i in range(max(0, n - 4), n) for j in range(max(0, n - 4), n) if i != j]
    return planes_graph([p[0] for p in pairs], [p[1] for p in pairs], h, w)


def planes_graph(ii, jj, h=3, w=4, seed=0):
    rng = np.random.default_rng(seed)
    e = len(ii)
    g = types.SimpleNamespace()
    g.ii, g.jj = np.asarray(ii, np.int64), np.asarray(jj, np.int64)
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    g.target = (np.stack([x, y], -1)[None, None] + rng.uniform(-0.3, 0.3, (1, e, h, w, 2))
                ).astype(np.float32)
    g.weight = rng.uniform(0, 1, (1, e, h, w, 2)).astype(np.float32)
    g.ii_inac = g.jj_inac = np.zeros(0, np.int64)
    g.target_inac = g.weight_inac = np.zeros((1, 0, h, w, 2), np.float32)
    return g


def run_fork_frontend(video, dumper, updates=9):
    """Frames 0, 2, 4, ...: 4 keyframes, then one per update; every third update removes the
    second newest (rm_keyframe(t1 - 2), as GO-SLAM's and DBA-Fusion's frontends do)."""
    frame = 0
    for _ in range(4):
        video.append(frame)
        frame += 2
    paths = []
    for step in range(updates):
        video.append(frame)
        frame += 2
        if step % 3 == 2:
            video.rm_keyframe(video.counter.value - 2)
        paths.append((dumper(video, window_graph(video), step), list(video.truth)))
    return paths


class ForkTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def test_go_slam_timestamp_is_read_when_there_is_no_tstamp(self):
        video = ForkVideo(stamps="timestamp")
        self.assertFalse(hasattr(video, "tstamp"))
        times = image_times(100)
        dumper = dbacov_dump.DbaDumper(self.dir, image_times_s=times, stream=io.StringIO())
        for path, truth in run_fork_frontend(video, dumper):
            with np.load(path) as z:
                self.assertEqual(z["tstamp"].astype(int).tolist(), truth)
                np.testing.assert_array_equal(z["timestamps_s"], times[truth])
        self.assertEqual((dumper.failures, dumper.record.stale_corrections), (0, 0))
        # A stamp that went wrong is named under GO-SLAM's name.
        video.timestamp[1] = np.nan
        with self.assertRaisesRegex(dbacov_dump.KeyframeTimeError,
                                    r"^video.timestamp\[1\] is nan: expected the keyframe's "
                                    "image index, a finite number$"):
            dbacov_dump.snapshot_arrays(video, window_graph(video))

    def test_dba_fusion_seconds_are_mapped_to_image_indices(self):
        video = ForkVideo(seconds=True)
        times = image_times(100)
        dumper = dbacov_dump.DbaDumper(self.dir, image_times_s=times, stream=io.StringIO())
        for path, truth in run_fork_frontend(video, dumper):
            with np.load(path) as z:
                self.assertEqual(z["tstamp"].dtype, np.float64)
                self.assertEqual(z["tstamp"].astype(int).tolist(), truth)  # image indices
                # The fork's own seconds, within the rounding of ns * 1e-9.
                np.testing.assert_allclose(z["timestamps_s"], times[truth], rtol=0, atol=1e-6)
        self.assertEqual(dumper.failures, 0)
        self.assertEqual(dumper.written, 9)
        # A stamp that is no image's time is refused, naming it and the nearest image.
        video.tstamp[2] += 0.02
        with self.assertRaises(dbacov_dump.KeyframeTimeError) as e:
            dbacov_dump.snapshot_arrays(video, window_graph(video), image_times_s=times)
        self.assertEqual(str(e.exception), "video.tstamp[2] = 1403636579.983556 s matches no "
                         "image time: the nearest is image 4 at 1403636579.963556 s (tolerance "
                         "0.0001 s); image_times_s must be the times of the images DROID was fed")

    def test_dba_fusion_seconds_without_image_times_are_refused_and_reported_once(self):
        video = ForkVideo(seconds=True)
        stream = io.StringIO()
        dumper = dbacov_dump.DbaDumper(self.dir, stream=stream)
        for path, _ in run_fork_frontend(video, dumper):
            self.assertIsNone(path)
        self.assertEqual((dumper.written, dumper.failures), (0, 9))
        self.assertEqual(os.listdir(self.dir), [])
        lines = stream.getvalue().splitlines()
        self.assertEqual(len(lines), 1, lines)  # reported, once, never a silent no-op
        self.assertEqual(
            lines[0],
            "dbacov_dump: snapshot 0 not written (KeyframeTimeError: video.tstamp holds times in "
            "seconds, not image indices: keyframe 0 has 1403636579.763556, not an integer; this "
            "looks like DBA-Fusion, whose tstamp is in seconds; pass image_times_s= (the time of "
            "every input image, by index, e.g. read_euroc_image_times('cam0/data.csv')) so that "
            "the keyframes' image indices can be found); DROID-SLAM goes on, further failures of "
            "this kind are not reported")
        with self.assertRaises(dbacov_dump.KeyframeTimeError):
            dbacov_dump.KeyframeRecord().update(video)

    def test_droid_image_indices_are_unchanged_by_the_fork_support(self):
        video = ForkVideo()
        dumper = dbacov_dump.DbaDumper(self.dir, stream=io.StringIO())
        for path, truth in run_fork_frontend(video, dumper):
            with np.load(path) as z:
                self.assertEqual(z["tstamp"].astype(int).tolist(), truth)
                self.assertNotIn("timestamps_s", z.files)


# --- DROID's global BA ---------------------------------------------------------------------------

def make_droid_backend_module(name="droid_backend"):
    """A module shaped as DROID-SLAM's droid_slam/droid_backend.py: FactorGraph (the methods the
    backends call, in DROID's order and with its signatures), DroidBackend and DroidAsyncBackend.
    update_lowmem runs DROID's BA as `ba(target, weight, damping, ii, jj, 1, t)`: the fake moves
    every pose but pose 0 and records the edges it used."""
    module = types.ModuleType(name)

    class FactorGraph:
        ba_calls = []

        def __init__(self, video, update_op, device="cuda", corr_impl="volume", max_factors=-1,
                     upsample=False):
            self.video = video
            h, w = video.disps.shape[1:]
            empty = planes_graph([], [], h, w)
            for key, value in vars(empty).items():
                setattr(self, key, value)
            self.age = np.zeros(0, np.int64)

        def add_proximity_factors(self, t0=0, t1=0, rad=2, nms=2, beta=0.25, thresh=16.0,
                                  remove=False):
            t = self.video.counter.value
            pairs = [(i, j) for i in range(t0, t) for j in range(t1, t) if 0 < abs(i - j) <= 3]
            new = planes_graph([p[0] for p in pairs], [p[1] for p in pairs],
                               *self.video.disps.shape[1:], seed=t)
            for key in ("ii", "jj"):
                setattr(self, key, np.concatenate([getattr(self, key), getattr(new, key)]))
            for key in ("target", "weight"):
                setattr(self, key, np.concatenate([getattr(self, key), getattr(new, key)], 1))
            self.age = np.concatenate([self.age, np.zeros(len(pairs), np.int64)])

        def update_lowmem(self, t0=None, t1=None, itrs=2, use_inactive=False, EP=1e-7, steps=8):
            t = self.video.counter.value
            for _ in range(steps):
                ii, jj = self.ii, self.jj
                if use_inactive:
                    ii = np.concatenate([self.ii_inac, self.ii])
                    jj = np.concatenate([self.jj_inac, self.jj])
                self.video.poses[1:t, :3] += 0.001  # the BA moves every pose but pose 0
                self.age += 1
            FactorGraph.ba_calls.append((list(zip(ii.tolist(), jj.tolist())), 1, t))

        def rm_factors(self, mask, store=False):
            if store:
                self.ii_inac = np.concatenate([self.ii_inac, self.ii[mask]])
                self.jj_inac = np.concatenate([self.jj_inac, self.jj[mask]])
                self.target_inac = np.concatenate([self.target_inac, self.target[:, mask]], 1)
                self.weight_inac = np.concatenate([self.weight_inac, self.weight[:, mask]], 1)
            self.ii, self.jj, self.age = self.ii[~mask], self.jj[~mask], self.age[~mask]
            self.target, self.weight = self.target[:, ~mask], self.weight[:, ~mask]

        def clear_edges(self):
            self.rm_factors(self.ii >= 0)

    class DroidBackend:
        def __init__(self, net, video, args):
            self.video = video
            self.backend_radius, self.backend_nms = 2, 3
            self.backend_thresh, self.beta = 22.0, 0.3
            self.graphs = []

        def __call__(self, steps=12, normalize=True):
            t = self.video.counter.value
            graph = FactorGraph(self.video, None, corr_impl="alt", max_factors=16 * t)
            graph.add_proximity_factors(rad=self.backend_radius, nms=self.backend_nms,
                                        thresh=self.backend_thresh, beta=self.beta)
            graph.update_lowmem(steps=steps)
            graph.clear_edges()
            self.graphs.append(graph)

    class DroidAsyncBackend:
        def __init__(self, net, video, args, max_age=7):
            self.video, self.max_age = video, max_age
            self.graph = FactorGraph(video, None, corr_impl="alt", max_factors=-1)

        def __call__(self, steps=12, normalize=True):
            self.graph.add_proximity_factors(rad=2, nms=3, thresh=22.0, beta=0.3)
            self.graph.update_lowmem(steps=steps, use_inactive=True)
            self.graph.rm_factors(self.graph.age > self.max_age, store=True)

    for cls in (FactorGraph, DroidBackend, DroidAsyncBackend):
        cls.__module__ = name
        setattr(module, cls.__name__, cls)
    return module


class GlobalBaTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name
        self.module = make_droid_backend_module()
        sys.modules["droid_backend"] = self.module  # found as DROID's demo.py puts it on the path

    def tearDown(self):
        sys.modules.pop("droid_backend", None)
        self.tmp.cleanup()

    def frontend_run(self, dumper, frames=10):
        """A DROID video after its frontend: `frames` keyframes, the last update dumped by the
        same dumper (its record follows the video), inactive frontend edges left in no graph."""
        video = ForkVideo()
        for f in range(0, 3 * frames, 3):
            video.append(f)
        self.assertIsNotNone(dumper(video, window_graph(video), 0))
        return video

    def test_droid_backend_dumps_each_global_ba_before_clear_edges_with_t0_1(self):
        stream = io.StringIO()
        dumper = dbacov_dump.DbaDumper(self.dir, stream=stream)
        video = self.frontend_run(dumper)
        installed = dbacov_dump.install_backend_hook(dumper)  # DROID's droid_backend module
        self.assertEqual([c.__name__ for c in installed], ["DroidBackend", "DroidAsyncBackend"])
        backend = self.module.DroidBackend(None, video, None)
        backend(7)   # Droid.terminate: 7 steps, then 12
        before = video.poses.copy()
        backend(12)
        self.assertEqual(stream.getvalue(), "")
        self.assertEqual(sorted(os.listdir(self.dir)),
                         ["global_000001.npz", "global_000002.npz", "window_000000.npz"])
        for k, graph in enumerate(backend.graphs):
            self.assertEqual(graph.ii.size, 0)  # clear_edges ran after the dump
            used, t0, t1 = self.module.FactorGraph.ba_calls[k]
            with np.load(os.path.join(self.dir, f"global_{k + 1:06d}.npz")) as z:
                self.assertEqual(int(z["t0"]), 1)  # update_lowmem's ba(..., 1, t)
                self.assertEqual(int(z["id"]), k + 1)
                self.assertEqual(list(zip(z["ii"].tolist(), z["jj"].tolist())), used)
                self.assertEqual(z["poses"].shape[0], t1)
                self.assertEqual(z["tstamp"].astype(int).tolist(), video.truth)
        with np.load(os.path.join(self.dir, "global_000002.npz")) as z:
            np.testing.assert_array_equal(z["poses"], video.poses[:10])  # after the BA
            self.assertFalse(np.array_equal(z["poses"], before[:10]))
            np.testing.assert_array_equal(z["poses"][0], before[0])  # pose 0 held

    def test_async_backend_dumps_its_inactive_edges_too(self):
        dumper = dbacov_dump.DbaDumper(self.dir, stream=io.StringIO())
        video = self.frontend_run(dumper)
        dbacov_dump.install_backend_hook(dumper, backend_class=self.module.DroidAsyncBackend)
        backend = self.module.DroidAsyncBackend(None, video, None, max_age=10)
        backend(8)   # ages 8: all stay active
        backend(8)   # ages 16 and 8: the first edges become inactive, stored
        self.assertGreater(backend.graph.ii_inac.size, 0)
        backend(8)   # use_inactive=True: the inactive edges are in this BA, keyframe 0's too
        used, _, _ = self.module.FactorGraph.ba_calls[-1]
        with np.load(os.path.join(self.dir, "global_000003.npz")) as z:
            self.assertEqual(list(zip(z["ii"].tolist(), z["jj"].tolist())), used)
            self.assertIn(0, z["ii"][:backend.graph.ii_inac.size])
            self.assertEqual(int(z["t0"]), 1)

    def test_update_lowmem_outside_a_backend_call_is_not_dumped(self):
        dumper = dbacov_dump.DbaDumper(self.dir, stream=io.StringIO())
        video = self.frontend_run(dumper)
        dbacov_dump.install_backend_hook(dumper)
        graph = self.module.FactorGraph(video, None)
        graph.add_proximity_factors()
        graph.update_lowmem(steps=1)
        self.assertEqual(os.listdir(self.dir), ["window_000000.npz"])

    def test_a_failing_hook_never_stops_the_backend(self):
        class Broken:
            def global_ba(self, *args, **kwargs):
                raise RuntimeError("a hook that raises")

        video = self.frontend_run(dbacov_dump.DbaDumper(self.dir, stream=io.StringIO()))
        dbacov_dump.install_backend_hook(Broken())
        backend = self.module.DroidBackend(None, video, None)
        backend(3)
        self.assertEqual(backend.graphs[0].ii.size, 0)  # the backend went on to clear_edges
        # A DbaDumper reports its own failures once and goes on.
        stream = io.StringIO()
        dumper = dbacov_dump.DbaDumper(self.dir, stream=stream)
        dbacov_dump.install_backend_hook(dumper)  # installed again: replaces the hook
        video.intrinsics = None
        backend(3)
        backend(3)
        self.assertEqual(dumper.failures, 2)
        self.assertEqual(stream.getvalue().splitlines(), [
            "dbacov_dump: global BA snapshot 1 not written (ValueError: video.intrinsics is "
            "missing (None or no such attribute)); DROID-SLAM goes on, further failures of this "
            "kind are not reported"])
        self.assertEqual(len(self.module.FactorGraph.ba_calls), 3)  # wrapped once, not twice

    def test_dump_global_ba_directly_and_a_forks_t0(self):
        video = ForkVideo()
        for f in range(0, 30, 3):
            video.append(f)
        graph = planes_graph([0, 1, 2, 5, 6], [1, 0, 3, 6, 5])
        path = os.path.join(self.dir, "g.npz")
        dbacov_dump.dump_global_ba(path, video, graph, snapshot_id=4)
        with np.load(path) as z:
            self.assertEqual((int(z["t0"]), int(z["id"])), (1, 4))
        dbacov_dump.dump_global_ba(path, video, graph, t0=6)  # GO-SLAM's loop BA holds more
        with np.load(path) as z:
            self.assertEqual(int(z["t0"]), 6)
            self.assertNotIn("id", z.files)
        with self.assertRaisesRegex(ValueError, r"^t0 is -1, expected at least 0$"):
            dbacov_dump.dump_global_ba(path, video, graph, t0=-1)


if __name__ == "__main__":
    unittest.main()
