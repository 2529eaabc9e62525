"""Tests of the DPVO side (share/dpvo/dbacov_dpvo.py) with fake DPVO objects.

The fakes lay their tensors out as DPVO does (DPV-SLAM's PatchGraph in ``dpvo.pg``, and the
original layout with the buffers on the DPVO object), call a fake ``fastba.BA`` from their
``update`` the way ``DPVO.update`` and ``DPVO.__run_global_BA`` do, and see a static scene: every
target is the exact projection of the patch's world point, so a snapshot taken after the BA
has a zero reprojection residual under the layout's conventions (T_cw, x before y, intrinsics
at the patch resolution) and a large one under any other. Torch CPU tensors are used where
torch is installed, NumPy arrays otherwise; the CUDA test runs only with a GPU.

Run: PYTHONPATH=share/dpvo /usr/bin/python3 -m unittest discover -s share/dpvo/tests -v
"""

import os
import tempfile
import types
import unittest
import warnings

import numpy as np

import dbacov_dpvo

try:
    import torch
except ImportError:  # the fakes then hold NumPy arrays
    torch = None

DEVICE = "cpu"


def tensor(a, integer=False):
    a = np.array(a, dtype=np.int64 if integer else np.float32)
    return torch.from_numpy(a).to(DEVICE) if torch is not None else a


def cat(parts, dim=0):
    return torch.cat(parts, dim) if torch is not None else np.concatenate(parts, dim)


def host(x):
    return x.detach().cpu().numpy() if hasattr(x, "detach") else np.asarray(x)


def rotation(q):
    """3x3 rotation of a unit quaternion [qx qy qz qw] (lietorch order)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def matrix(pose):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rotation(pose[3:] / np.linalg.norm(pose[3:])), pose[:3]
    return T


def random_pose(rng, k):
    """T_cw of a camera near (0.15 k, 0, 0) looking along +z, slightly rotated."""
    q = np.append(rng.normal(scale=0.03, size=3), 1.0)
    q /= np.linalg.norm(q)
    c = np.array([0.15 * k, 0.03 * np.sin(k), 0.02 * k])  # camera centre in the world
    R = rotation(q)
    return np.concatenate([-R @ c, q])


fastba = types.ModuleType("fastba")  # what DPVO's module imports: `from . import fastba`
fastba_v1 = types.ModuleType("fastba_v1")  # the original DPVO's, older BA signature


class Scene:
    """True poses, patch centres and world points; exact targets for any edge."""

    def __init__(self, frames, m, seed=5):
        rng = np.random.default_rng(seed)
        self.fx, self.fy, self.cx, self.cy = 40.0, 42.0, 20.0, 15.0  # 1/4 resolution
        self.poses = np.array([random_pose(rng, k) for k in range(frames)])
        self.xy = np.stack([rng.uniform(2, 38, (frames, m)), rng.uniform(2, 28, (frames, m))], -1)
        depth = rng.uniform(2.0, 5.0, (frames, m))
        self.d = 1.0 / depth
        ray = np.stack([(self.xy[..., 0] - self.cx) / self.fx, (self.xy[..., 1] - self.cy) /
                        self.fy, np.ones_like(depth)], -1) * depth[..., None]
        self.world = np.empty_like(ray)
        for i in range(frames):  # X_w = T_cw_i^-1 X_c
            T = np.linalg.inv(matrix(self.poses[i]))
            self.world[i] = ray[i] @ T[:3, :3].T + T[:3, 3]

    def project(self, frame, j, p):
        """(x, y) at 1/4 resolution of patch p of true frame `frame` in true frame j."""
        T = matrix(self.poses[j])
        X = T[:3, :3] @ self.world[frame, p] + T[:3, 3]
        return [self.fx * X[0] / X[2] + self.cx, self.fy * X[1] / X[2] + self.cy]


class Buffers:
    """The geometry buffers and edges DPVO keeps (PatchGraph in DPV-SLAM, DPVO before it)."""

    def init_buffers(self, slots, m, p=3, numpy_tstamps=True):
        self.n, self.m, self.M, self.N = 0, 0, m, slots
        self.tstamps_ = np.zeros(slots, np.int64) if numpy_tstamps else \
            tensor(np.zeros(slots), integer=True)
        poses = np.zeros((slots, 7))
        poses[:, 6] = 1
        self.poses_ = tensor(poses)
        self.patches_ = tensor(np.zeros((slots, m, 3, p, p)))
        self.intrinsics_ = tensor(np.zeros((slots, 4)))
        self.index_ = tensor(np.zeros((slots, m)), integer=True)
        self.ii = self.jj = self.kk = tensor([], integer=True)
        self.ii_inac = self.jj_inac = self.kk_inac = tensor([], integer=True)
        self.target_inac = self.weight_inac = tensor(np.zeros((1, 0, 2)))

    @property
    def poses(self):
        return self.poses_.reshape(1, self.N, 7)

    @property
    def patches(self):
        return self.patches_.reshape(1, self.N * self.M, 3, 3, 3)

    @property
    def intrinsics(self):
        return self.intrinsics_.reshape(1, self.N, 4)


class PatchGraph(Buffers):
    def __init__(self, slots, m):
        self.init_buffers(slots, m)


class FakeBase:
    """DPVO's frame intake, edges, keyframe removal and update, on the scene's truth."""

    OPTIMIZATION_WINDOW, REMOVAL_WINDOW, PATCH_LIFETIME, RES = 5, 7, 4, 4

    def setup(self, scene, g):
        self.scene, self.g = scene, g
        self.is_initialized, self.counter, self.true_frame = False, 0, []
        self.ba_failures, self.mutate, self.corrupt, self.saved = 0, None, None, None
        self.pmem = self.mem = 36  # the network features' ring buffers; geometry is not one
        self.rng = np.random.default_rng(11)

    def add_frame(self, skip=0):
        g, s = self.g, self.scene
        self.counter += skip  # frames DPVO saw but did not keep (motion probe)
        f, n = len(self.true_frame), g.n
        self.true_frame.append(f)
        g.tstamps_[n] = self.counter
        full = np.array([s.fx, s.fy, s.cx, s.cy]) * self.RES  # the calibration of the image
        g.intrinsics_[n] = tensor(full) / self.RES  # DPVO: intrinsics / self.RES
        g.index_[n] = n
        pose = s.poses[f].copy()
        if n > 0:
            pose[:3] += self.rng.normal(scale=0.05, size=3)  # the motion model's guess
        g.poses_[n] = tensor(pose)
        off = np.arange(3) - 1.0
        patches = np.zeros((g.M, 3, 3, 3))
        patches[:, 0] = s.xy[f, :, 0, None, None] + off[None, None, :]
        patches[:, 1] = s.xy[f, :, 1, None, None] + off[None, :, None]
        patches[:, 2] = 0.5  # DPVO's initial depth guess
        g.patches_[n] = tensor(patches)
        self.counter += 1
        g.n, g.m = n + 1, g.m + g.M
        n, r = g.n, self.PATCH_LIFETIME
        forw = [(k, n - 1) for k in range(g.M * max(n - r, 0), g.M * (n - 1))]
        back = [(k, j) for k in range(g.M * (n - 1), g.M * n) for j in range(max(n - r, 0), n)]
        self.append(forw + back)

    def append(self, pairs):
        g = self.g
        kk = tensor([k for k, _ in pairs], integer=True)
        g.kk, g.jj = cat([g.kk, kk]), cat([g.jj, tensor([j for _, j in pairs], integer=True)])
        g.ii = cat([g.ii, g.index_.reshape(-1)[kk]])

    def predict(self):
        """The network's targets (exact here) and sigmoid confidences, (1,E,2) each."""
        g, ii, jj, kk = self.g, host(self.g.ii), host(self.g.jj), host(self.g.kk)
        t = [self.scene.project(self.true_frame[i], self.true_frame[j], k % g.M)
             for i, j, k in zip(ii, jj, kk)]
        return tensor([t]), tensor(self.rng.uniform(0.05, 0.95, (1, len(t), 2)))

    def solve(self, poses, patches, t0, t1, kk):
        """What the fake BA does: poses [t0, t1) and the depths of patches kk become the truth."""
        g = self.g
        truth = np.array([self.scene.poses[self.true_frame[i]] for i in range(t0, t1)])
        poses.reshape(-1, 7)[t0:t1] = tensor(truth.reshape(-1, 7))
        for k in np.unique(host(kk)):
            patches.reshape(-1, 3, 3, 3)[k, 2] = float(self.scene.d[self.true_frame[k // g.M],
                                                                     k % g.M])

    def local_ba(self, args):
        t0 = max(self.g.n - self.OPTIMIZATION_WINDOW if self.is_initialized else 1, 1)
        self.call_ba(t0=t0, **args)

    def update(self):
        """DPVO.update from the network's output on: the BA (local or global) in a try."""
        target, weight = self.predict()
        self.g.target, self.g.weight = target, weight
        args = dict(target=target, weight=weight, ii=self.g.ii, jj=self.g.jj, kk=self.g.kk)
        if self.mutate:  # a defect in what DPVO hands to the BA
            args = self.mutate(args)
        try:
            self.run_ba(args)
        except Exception:  # noqa: BLE001 -- DPVO.update: print("Warning BA failed...")
            self.ba_failures += 1
        finally:
            if self.saved:  # undo a defect that FakeBA made for the hook to read
                setattr(self.g, *self.saved)
                self.saved = None

    def drop_keyframe(self, k):
        """DPVO.keyframe's removal of frame k: edges, indices and buffers shift down."""
        g = self.g
        keep = ~((host(g.ii) == k) | (host(g.jj) == k))
        idx = tensor(np.flatnonzero(keep), integer=True)
        g.ii, g.jj, g.kk = g.ii[idx], g.jj[idx], g.kk[idx]
        above = g.ii > k
        g.kk[above] -= g.M
        g.ii[above] -= 1
        g.jj[g.jj > k] -= 1
        for i in range(k, g.n - 1):
            for name in ("tstamps_", "poses_", "patches_", "intrinsics_"):
                getattr(g, name)[i] = getattr(g, name)[i + 1]
        del self.true_frame[k]
        g.n, g.m = g.n - 1, g.m - g.M

    def retire_old_edges(self):
        """DPVO.keyframe's removal of edges out of the window (stored as inactive)."""
        g = self.g
        old = host(g.ii) < g.n - self.REMOVAL_WINDOW
        o, a = (tensor(np.flatnonzero(m), integer=True) for m in (old, ~old))
        g.ii_inac, g.jj_inac = cat([g.ii_inac, g.ii[o]]), cat([g.jj_inac, g.jj[o]])
        g.kk_inac = cat([g.kk_inac, g.kk[o]])
        g.target_inac = cat([g.target_inac, g.target[:, o]], 1)
        g.weight_inac = cat([g.weight_inac, g.weight[:, o]], 1)
        g.ii, g.jj, g.kk = g.ii[a], g.jj[a], g.kk[a]


class DPVO(FakeBase):
    """DPV-SLAM's layout: buffers and edges in self.pg, fastba.BA(..., M=, iterations=,
    eff_impl=) and the private global BA over the inactive and active edges."""

    def __init__(self, scene, slots=32, m=6):
        self.M, self.N = m, slots
        self.pg = PatchGraph(slots, m)
        self.setup(scene, self.pg)

    @property
    def n(self):
        return self.pg.n

    def call_ba(self, target, weight, ii, jj, kk, t0):
        fastba.BA(self.pg.poses, self.pg.patches, self.pg.intrinsics, target, weight,
                  tensor([1e-4]), ii, jj, kk, t0, self.n, M=self.M, iterations=2, eff_impl=False)

    def run_ba(self, args):
        if (host(self.pg.ii) < self.n - self.REMOVAL_WINDOW - 1).any():
            self.__run_global_BA()
        else:
            self.local_ba(args)

    def __run_global_BA(self):
        pg = self.pg
        full_target = cat([pg.target_inac, pg.target], 1)
        full_weight = cat([pg.weight_inac, pg.weight], 1)
        t0 = pg.ii.min().item()
        fastba.BA(self.pg.poses, self.pg.patches, self.pg.intrinsics, full_target, full_weight,
                  tensor([1e-4]), cat([pg.ii_inac, pg.ii]), cat([pg.jj_inac, pg.jj]),
                  cat([pg.kk_inac, pg.kk]), t0, self.n, M=self.M, iterations=2, eff_impl=True)

    def structure_only_ba(self):
        """DPV-SLAM's classic loop closure: a BA on a cloned three-frame mini graph."""
        poses = self.pg.poses[:, 0:3] * 1.0
        fastba.BA(poses, self.pg.patches[:, :self.M] * 1.0, self.pg.intrinsics[:, 0:3] * 4,
                  tensor(np.zeros((1, 2, 2))), tensor(np.ones((1, 2, 2))), tensor([1e-3]),
                  tensor([1, 1], integer=True), tensor([0, 2], integer=True),
                  tensor([0, 1], integer=True), 3, 3, M=-1, iterations=6, eff_impl=False)


class OldDPVO(FakeBase, Buffers):
    """The original DPVO: the same buffers on the object itself, tstamps_ a tensor, and
    fastba.BA(poses, ..., t0, t1, iterations) with the iterations positional."""

    def __init__(self, scene, slots=32, m=6):
        self.init_buffers(slots, m, numpy_tstamps=False)
        self.setup(scene, self)

    def call_ba(self, target, weight, ii, jj, kk, t0):
        fastba_v1.BA(self.poses, self.patches, self.intrinsics, target, weight, tensor([1e-4]),
                     ii, jj, kk, t0, self.n, 2)

    def run_ba(self, args):
        self.local_ba(args)


class FakeBA:
    """fastba.BA: records each call and moves the poses and depths to the truth in place."""

    def __init__(self):
        self.calls, self.raise_next, self.owner = [], None, None

    def __call__(self, poses, patches, intrinsics, target, weight, lmbda, ii, jj, kk, t0, t1,
                 *rest, **kwargs):
        self.calls.append(dict(t0=t0, t1=t1, edges=len(ii), kwargs=kwargs))
        if self.raise_next is not None:
            exc, self.raise_next = self.raise_next, None
            raise exc
        if self.owner is not None and t1 > t0 and poses.reshape(-1).shape[0] == \
                self.owner.g.N * 7:
            self.owner.solve(poses, patches, t0, t1, kk)
        owner = self.owner
        if owner is not None and owner.corrupt:  # a defect for the hook to read after the BA
            attr, value_of = owner.corrupt
            owner.saved = (attr, getattr(owner.g, attr))
            setattr(owner.g, attr, value_of(owner))


def step(dpvo):
    """One more frame and its update, without DPVO.keyframe's edge removal afterwards: the
    graph is then the one the last BA used."""
    dpvo.add_frame()
    dpvo.update()


def run(dpvo, frames, skip=()):
    """DPVO.__call__ for `frames` frames: initialized at n == 4, one update per frame after."""
    for f in range(frames):
        dpvo.add_frame(skip=1 if f in skip else 0)
        if dpvo.g.n == 4 and not dpvo.is_initialized:
            dpvo.is_initialized = True
            for _ in range(3):
                dpvo.update()
        elif dpvo.is_initialized:
            dpvo.update()
            dpvo.retire_old_edges()


def residuals(s, poses=None, swap=False, scale=1.0):
    """Conventions section 2 at the patch centres, in NumPy, from a loaded snapshot."""
    poses = s["poses"] if poses is None else poses
    fx, fy, cx, cy = s["intrinsics"].astype(np.float64) * scale
    p = s["patches"].shape[3]
    c = s["patches"].reshape(-1, 3, p, p)[s["kk"], :, p // 2, p // 2].astype(np.float64)
    x, y = (c[:, 1], c[:, 0]) if swap else (c[:, 0], c[:, 1])
    target = s["target"][:, ::-1] if swap else s["target"]
    out = []
    for e, (i, j) in enumerate(zip(s["ii"], s["jj"])):
        X = np.array([(x[e] - cx) / fx, (y[e] - cy) / fy, 1.0, c[e, 2]])
        Y = matrix(poses[j]) @ np.linalg.inv(matrix(poses[i])) @ X
        out.append(target[e] - [fx * Y[0] / Y[2] + cx, fy * Y[1] / Y[2] + cy])
    return np.array(out)


class Case(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.out = self.tmp.name
        self.scene = Scene(frames=20, m=6)
        for module in (fastba, fastba_v1):
            module.BA = FakeBA()
        self.hooks = []

    def tearDown(self):
        for hook in self.hooks:
            hook.remove()
        self.tmp.cleanup()

    def make(self, cls=DPVO, hook=True, **kwargs):
        dpvo = cls(self.scene)
        fastba.BA.owner = fastba_v1.BA.owner = dpvo
        if not hook:
            return dpvo, None
        self.hooks.append(dbacov_dpvo.install_hook(dpvo, self.out, **kwargs))
        return dpvo, self.hooks[-1]

    def load(self, name):
        with np.load(os.path.join(self.out, name)) as z:
            return {k: z[k] for k in z.files}

    def files(self):
        return sorted(os.listdir(self.out))


SPEC = {"poses": np.float32, "patches": np.float32, "intrinsics": np.float32, "ii": np.int64,
        "jj": np.int64, "kk": np.int64, "target": np.float32, "weight": np.float32,
        "t0": np.int64, "tstamp": np.float64, "id": np.int64, "is_global": np.uint8}


class SnapshotLayout(Case):
    def test_each_update_writes_a_snapshot_that_round_trips(self):
        dpvo, hook = self.make()
        run(dpvo, 11, skip=(5,))
        step(dpvo)
        # Initialization (3 updates at n = 4), then one update per frame: 3 + 8 BA calls.
        self.assertEqual(self.files(), [f"dpvo_{i:06d}.npz" for i in range(1, 12)])
        self.assertEqual((hook.written, hook.failures, hook.skipped), (11, 0, 0))
        s = self.load("dpvo_000011.npz")
        self.assertEqual(set(s), set(SPEC))
        for key, dtype in SPEC.items():
            self.assertEqual(s[key].dtype, dtype, key)
        pg, m = dpvo.pg, dpvo.M
        n, f0 = pg.n, int(min(host(pg.ii).min(), host(pg.jj).min()))
        self.assertGreater(f0, 0)  # frames="graph": the window the edges name
        self.assertEqual(s["poses"].shape, (n - f0, 7))
        self.assertEqual(s["patches"].shape, (n - f0, m, 3, 3, 3))
        np.testing.assert_array_equal(s["poses"], host(pg.poses_)[f0:n])
        np.testing.assert_array_equal(s["patches"], host(pg.patches_)[f0:n])
        np.testing.assert_array_equal(s["intrinsics"], host(pg.intrinsics_)[0])
        np.testing.assert_array_equal(s["ii"], host(pg.ii) - f0)
        np.testing.assert_array_equal(s["jj"], host(pg.jj) - f0)
        np.testing.assert_array_equal(s["kk"], host(pg.kk) - f0 * m)
        np.testing.assert_array_equal(s["ii"], s["kk"] // m)
        np.testing.assert_array_equal(s["target"], host(pg.target)[0])
        np.testing.assert_array_equal(s["weight"], host(pg.weight)[0])
        np.testing.assert_array_equal(s["tstamp"], pg.tstamps_[f0:n])
        self.assertEqual(s["tstamp"][-1], 12)  # 12 frames kept, one skipped before: counter 12
        self.assertEqual((int(s["id"]), int(s["is_global"])), (11, 0))
        self.assertEqual(int(s["t0"]), n - DPVO.OPTIMIZATION_WINDOW - f0)
        dbacov_dpvo.check_snapshot(s)

    def test_frames_all_keeps_every_frame_and_dpvo_indices(self):
        dpvo, _ = self.make(frames="all")
        run(dpvo, 11)
        step(dpvo)
        s, pg = self.load(self.files()[-1]), dpvo.pg
        self.assertEqual(s["poses"].shape[0], pg.n)
        np.testing.assert_array_equal(s["kk"], host(pg.kk))
        np.testing.assert_array_equal(s["ii"], host(pg.ii))
        self.assertEqual(int(s["t0"]), pg.n - DPVO.OPTIMIZATION_WINDOW)

    def test_t0_of_the_local_ba(self):
        dpvo, _ = self.make(frames="all")
        run(dpvo, 8)
        t0 = [int(self.load(f)["t0"]) for f in self.files()]
        # Initialization holds frame 0 only; then max(n - OPTIMIZATION_WINDOW, 1), n = 5, 6, ...
        self.assertEqual(t0, [1, 1, 1, 1, 1, 2, 3])
        self.assertEqual([c["t0"] for c in fastba.BA.calls], t0)

    def test_the_global_ba_is_a_separate_snapshot_with_every_edge(self):
        dpvo, hook = self.make()
        run(dpvo, 12)
        m = dpvo.M
        dpvo.add_frame()
        dpvo.append([(k, dpvo.n - 1) for k in range(2 * m, 3 * m)])  # a loop edge: 2 -> newest
        dpvo.update()
        self.assertEqual(fastba.BA.calls[-1]["kwargs"]["eff_impl"], True)
        self.assertIn("dpvo_global_000001.npz", self.files())
        s, pg = self.load("dpvo_global_000001.npz"), dpvo.pg
        self.assertEqual((int(s["is_global"]), int(s["id"])), (1, 1))
        e_inac, e = len(host(pg.ii_inac)), len(host(pg.ii))
        self.assertEqual(len(s["ii"]), e_inac + e)
        f0 = int(min(host(pg.ii_inac).min(), host(pg.jj_inac).min()))
        np.testing.assert_array_equal(s["kk"], np.concatenate([host(pg.kk_inac),
                                                               host(pg.kk)]) - f0 * m)
        np.testing.assert_array_equal(s["ii"], s["kk"] // m)
        self.assertEqual(int(s["t0"]), 2 - f0)  # DPV-SLAM: t0 = min(pg.ii), the loop edge's 2
        np.testing.assert_array_equal(s["target"][:e_inac], host(pg.target_inac)[0])
        self.assertLess(np.abs(residuals(s)).max(), 2e-3)
        dpvo.retire_old_edges()
        run_more = hook.written
        step(dpvo)  # local again: the next local number
        self.assertEqual(hook.written, run_more + 1)
        self.assertIn(f"dpvo_{hook.local_calls:06d}.npz", self.files())

    def test_original_dpvo_layout(self):
        dpvo, hook = self.make(OldDPVO, fastba=fastba_v1)
        run(dpvo, 8, skip=(2,))
        self.assertEqual(hook.written, 7)
        s = self.load("dpvo_000007.npz")
        np.testing.assert_array_equal(s["tstamp"][-1], host(dpvo.tstamps_)[dpvo.n - 1])
        np.testing.assert_array_equal(s["ii"], s["kk"] // dpvo.M)
        self.assertLess(np.abs(residuals(s)).max(), 2e-3)

    def test_keyframe_removal_renumbers_consistently(self):
        dpvo, _ = self.make()
        run(dpvo, 9)
        dropped = dpvo.g.tstamps_[dpvo.n - 4]
        dpvo.drop_keyframe(dpvo.n - 4)  # DPVO.keyframe drops n - KEYFRAME_INDEX
        dpvo.update()
        s = self.load(self.files()[-1])
        self.assertEqual(len(np.unique(s["tstamp"])), len(s["tstamp"]))
        self.assertNotIn(float(dropped), s["tstamp"])
        self.assertEqual(len(np.flatnonzero(np.diff(s["tstamp"]) == 2)), 1)  # the gap
        self.assertLess(np.abs(residuals(s)).max(), 2e-3)

    def test_every_and_remove(self):
        dpvo, hook = self.make(every=3)
        run(dpvo, 8)
        self.assertEqual(self.files(), ["dpvo_000001.npz", "dpvo_000004.npz", "dpvo_000007.npz"])
        wrapper = fastba.BA
        hook.remove()
        self.assertIsNot(fastba.BA, wrapper)
        self.assertIsInstance(fastba.BA, FakeBA)
        self.assertNotIn("_DPVO__run_global_BA", vars(dpvo))
        run(dpvo, 2)
        self.assertEqual(len(self.files()), 3)

    def test_image_times(self):
        times = 1000.0 + 0.05 * np.arange(40)
        dpvo, _ = self.make(image_times_s=times)
        run(dpvo, 7, skip=(3,))
        s = self.load(self.files()[-1])
        np.testing.assert_array_equal(s["timestamps_s"], times[s["tstamp"].astype(int)])

    def test_foreign_ba_calls_are_passed_through(self):
        dpvo, hook = self.make()
        run(dpvo, 5)
        written = hook.written
        dpvo.structure_only_ba()
        self.assertEqual((hook.written, hook.skipped, hook.failures), (written, 1, 0))

    @unittest.skipUnless(torch is not None and torch.cuda.is_available(), "needs a CUDA GPU")
    def test_cuda_tensors(self):
        global DEVICE
        DEVICE = "cuda"
        try:
            dpvo, hook = self.make()
            run(dpvo, 6)
        finally:
            DEVICE = "cpu"
        self.assertEqual(hook.failures, 0)
        self.assertLess(np.abs(residuals(self.load(self.files()[-1]))).max(), 2e-3)


class Conventions(Case):
    """The world-point scene makes exact targets; the layout's conventions give ~0 residual."""

    def test_reprojection_residual_is_zero_under_the_conventions(self):
        dpvo, _ = self.make()
        run(dpvo, 12, skip=(4, 7))
        for name in self.files():
            s = self.load(name)
            self.assertLess(np.abs(residuals(s)).max(), 2e-3, name)
            inverted = np.array([np.concatenate([np.linalg.inv(matrix(p))[:3, 3],
                                                 p[3:] * [-1, -1, -1, 1]]) for p in s["poses"]])
            self.assertGreater(np.median(np.abs(residuals(s, poses=inverted))), 0.05, name)
            self.assertGreater(np.median(np.abs(residuals(s, swap=True))), 0.5, name)
            self.assertGreater(np.median(np.abs(residuals(s, scale=4.0))), 0.5, name)

    def test_the_snapshot_is_taken_after_the_ba(self):
        dpvo, _ = self.make()
        run(dpvo, 6)
        s = self.load(self.files()[-1])
        self.assertLess(np.abs(residuals(s)).max(), 2e-3)
        guess = s["poses"].copy()
        guess[-1, :3] += 0.05  # the motion model's guess the BA started from
        self.assertGreater(np.abs(residuals(s, poses=guess)).max(), 0.1)


# Defects in what the hook reads after the BA: (attribute of dpvo.pg, its bad value, the text
# the warning must hold).
CORRUPT = {
    "tstamps missing": ("tstamps_", lambda d: None, "dpvo.pg.tstamps_ is missing"),
    "tstamps short": ("tstamps_", lambda d: d.pg.tstamps_[:3], "fewer than the n"),
    "tstamps repeated": ("tstamps_", lambda d: np.zeros(d.N, np.int64), "'tstamp' repeats"),
    "poses 6 wide": ("poses_", lambda d: d.pg.poses_[:, :6], "dpvo.pg.poses_ has shape"),
    "patches ragged": ("patches_", lambda d: [[1, 2], [3]], "dpvo.pg.patches_"),
    "wrong M": ("M", lambda d: d.M + 1, "M = 7"),
    "M a float": ("M", lambda d: 6.0, "dpvo.pg.M is 6.0"),
    "two cameras": ("intrinsics_", lambda d: d.pg.intrinsics_ * tensor(
        np.r_[np.ones(3), 2 * np.ones(d.N - 3)][:, None]), "differ between frames"),
}
# Defects in what DPVO hands to the BA: a change of its arguments, the warning's text.
BAD_ARGUMENTS = {
    "flat target": (lambda a: dict(a, target=a["target"][0]), "target has shape"),
    "weight 3 wide": (lambda a: dict(a, weight=cat([a["weight"]] * 2, 2)), "weight has shape"),
    "weight None": (lambda a: dict(a, weight=None), "weight is missing"),
    "ii shifted": (lambda a: dict(a, ii=a["ii"] + 1), "ii["),
    "jj short": (lambda a: dict(a, jj=a["jj"][:-1]), "jj has"),
}
if torch is not None:
    BAD_ARGUMENTS["complex weight"] = (lambda a: dict(a, weight=a["weight"].to(torch.complex64)),
                                       "complex")


class Malformed(Case):
    """Every malformed tensor is a ValueError naming it; the hook warns once and VO goes on."""

    def check_survives(self, label, set_defect, text):
        for f in os.listdir(self.out):
            os.unlink(os.path.join(self.out, f))
        dpvo, hook = self.make()
        try:
            self.survives(dpvo, hook, label, set_defect, text)
        finally:
            hook.remove()

    def survives(self, dpvo, hook, label, set_defect, text):
        run(dpvo, 5)
        last = self.files()[-1]
        with open(os.path.join(self.out, last), "rb") as f:
            before = f.read()
        set_defect(dpvo)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for _ in range(2):
                step(dpvo)
        self.assertEqual(dpvo.ba_failures, 0, label)  # DPVO never saw a failure
        self.assertEqual(hook.failures, 2, label)
        self.assertEqual(len(caught), 1, [str(w.message) for w in caught])  # once per kind
        self.assertIs(caught[0].category, RuntimeWarning)
        self.assertIn(text, str(caught[0].message))
        self.assertEqual(self.files()[-1], last)
        with open(os.path.join(self.out, last), "rb") as f:
            self.assertEqual(f.read(), before)
        self.assertFalse([f for f in os.listdir(self.out) if f.endswith(".tmp")])
        # The defect gone, the next update is written again.
        dpvo.corrupt = dpvo.mutate = None
        step(dpvo)
        self.assertEqual(hook.failures, 2)
        self.assertNotEqual(self.files()[-1], last, label)

    def test_the_hook_survives_bad_buffers(self):
        for label, (attr, value_of, text) in CORRUPT.items():
            with self.subTest(label):
                self.check_survives(label, lambda d: setattr(d, "corrupt", (attr, value_of)),
                                    text)

    def test_the_hook_survives_bad_ba_arguments(self):
        for label, (change, text) in BAD_ARGUMENTS.items():
            with self.subTest(label):
                self.check_survives(label, lambda d: setattr(d, "mutate", change), text)

    def test_the_bas_own_failure_reaches_dpvo_and_nothing_is_written(self):
        dpvo, hook = self.make()
        run(dpvo, 5)
        files = self.files()
        fastba.BA.__wrapped__.raise_next = RuntimeError("cholesky failed")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            step(dpvo)
        self.assertEqual((dpvo.ba_failures, hook.failures, len(caught)), (1, 0, 0))
        self.assertEqual(self.files(), files)

    def test_an_unwritable_directory_is_reported_not_raised(self):
        path = os.path.join(self.out, "a_file")
        open(path, "w").close()
        dpvo = DPVO(self.scene)
        fastba.BA.owner = dpvo
        hook = dbacov_dpvo.install_hook(dpvo, os.path.join(path, "sub"))
        self.hooks.append(hook)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            run(dpvo, 6)
        self.assertEqual((hook.written, hook.failures, len(caught)), (0, 5, 1))

    def test_snapshot_from_dpvo_names_the_tensor(self):
        dpvo, _ = self.make(hook=False)
        run(dpvo, 5)
        t, w = dpvo.predict()
        good = dbacov_dpvo.snapshot_from_dpvo(dpvo, t, w, 1)
        self.assertEqual(good["ii"].shape, (len(host(dpvo.pg.ii)),))
        for kwargs, text in (({"t0": 99}, "t0 is 99"), ({"t0": 1.5}, "t0 is 1.5"),
                             ({"frames": "window"}, "frames"),
                             ({"kk": dpvo.pg.kk[:-1]}, "kk has"),
                             ({"jj": dpvo.pg.jj + 50}, "jj["),
                             ({"n": 0}, "n (the BA's t1)"),
                             ({"image_times_s": np.arange(3.0)}, "image_times_s")):
            with self.subTest(kwargs=list(kwargs)):
                args = dict(target=t, weight=w, t0=1)
                args.update(kwargs)
                with self.assertRaises(ValueError) as ctx:
                    dbacov_dpvo.snapshot_from_dpvo(dpvo, **args)
                self.assertIn(text, str(ctx.exception))

    def test_install_refuses_bad_arguments(self):
        dpvo = DPVO(self.scene)
        for kwargs, text in (({"every": 0}, "every"), ({"frames": "x"}, "frames"),
                             ({"pattern": "fixed.npz{"}, "pattern"),
                             ({"fastba": types.ModuleType("empty")}, "fastba")):
            with self.subTest(kwargs=list(kwargs)):
                with self.assertRaises(ValueError) as ctx:
                    dbacov_dpvo.install_hook(dpvo, self.out, **kwargs)
                self.assertIn(text, str(ctx.exception))
        self.assertIsInstance(fastba.BA, FakeBA)


class AtomicWrite(Case):
    def test_a_failed_write_leaves_the_previous_file_untouched(self):
        path = os.path.join(self.out, "dpvo_000001.npz")
        dbacov_dpvo.save_snapshot(path, {"a": np.arange(3)})
        with open(path, "rb") as f:
            before = f.read()
        with self.assertRaises(ValueError):  # object arrays are refused (allow_pickle=False)
            dbacov_dpvo.save_snapshot(path, {"a": np.arange(4), "b": np.array([{}, 1])})
        with open(path, "rb") as f:
            self.assertEqual(f.read(), before)
        self.assertEqual(self.files(), ["dpvo_000001.npz"])

    def test_check_snapshot_values(self):
        dpvo, _ = self.make()
        run(dpvo, 5)
        s = self.load(self.files()[-1])
        for key, change, text in (("weight", lambda a: -a, "negative"),
                                  ("poses", lambda a: a * np.nan, "non-finite"),
                                  ("patches", lambda a: a * 0, "inverse depth"),
                                  ("ii", lambda a: (a + 1) % 3, "kk // M")):
            with self.subTest(key):
                bad = dict(s)
                bad[key] = change(s[key])
                with self.assertRaises(ValueError) as ctx:
                    dbacov_dpvo.check_snapshot(bad)
                self.assertIn(text, str(ctx.exception))


if __name__ == "__main__":
    unittest.main()
