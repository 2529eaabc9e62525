"""Shared fixtures of the `import dbacov` suite: paths from ctest's environment, fake DROID-SLAM
objects (DepthVideo, FactorGraph) holding torch tensors shaped and typed as DROID's."""

import os
import subprocess
import types

import numpy as np
import pytest

SHARED = os.environ.get("DBACOV_SHARED_SNAPSHOT", "")
CLI = os.environ.get("DBACOV_COVARIANCE", "")


@pytest.fixture
def shared_path():
    if not os.path.exists(SHARED):
        pytest.skip(f"the shared DROID snapshot is missing: {SHARED!r} (DBACOV_SHARED_SNAPSHOT)")
    return SHARED


def run_cli(*args):
    if not os.path.exists(CLI):
        pytest.fail(f"dba-covariance not found: {CLI!r} (DBACOV_COVARIANCE)")
    return subprocess.run([CLI, *args], capture_output=True, text=True)


def cli_marginals(npz, tmp_path, *options):
    """{keyframe: 6x6} from dba-covariance --csv (full precision)."""
    out = tmp_path / "cli.csv"
    r = run_cli("-i", str(npz), "--csv", str(out), "-q", *options)
    assert r.returncode == 0, r.stderr
    lines = out.read_text().splitlines()
    head = lines[0].split(",")
    first = head.index("cov_00")
    res = {}
    for line in lines[1:]:
        v = line.split(",")
        m = np.zeros((6, 6))
        m[np.triu_indices(6)] = [float(x) for x in v[first:first + 21]]
        res[int(v[1])] = m + np.triu(m, 1).T
    return res


class FakeVideo:
    """DROID's DepthVideo as torch tensors: buffers of `capacity` slots, counter.value in use."""

    def __init__(self, torch, arrays, capacity=16, device="cpu"):
        n, h, w = arrays["disps"].shape
        t = lambda a, dt: torch.as_tensor(np.ascontiguousarray(a), dtype=dt, device=device)
        self.counter = types.SimpleNamespace(value=n)
        self.stereo = "stereo_rig" in arrays

        def buf(a, shape, dt):
            b = np.zeros((capacity,) + shape, np.float32)
            b[:n] = a
            return t(b, dt)

        self.poses = buf(arrays["poses"], (7,), torch.float)
        self.disps = buf(arrays["disps"], (h, w), torch.float)
        self.intrinsics = buf(np.tile(arrays["intrinsics"], (n, 1)), (4,), torch.float)
        self.tstamp = buf(arrays["tstamp"], (), torch.float)
        self.disps_sens = buf(arrays.get("disps_sens", np.zeros((n, h, w))), (h, w), torch.float)
        rng = np.random.default_rng(1)
        self.images = t(rng.integers(0, 255, (capacity, 3, 8 * h, 8 * w)), torch.uint8)

    def get_lock(self):
        import contextlib
        return contextlib.nullcontext()


class FakeGraph:
    """DROID's FactorGraph: ii/jj long, target/weight (1,E,H,W,2) float, no inactive edges yet."""

    def __init__(self, torch, arrays, device="cpu"):
        _, h, w = arrays["disps"].shape
        t = lambda a, dt: torch.as_tensor(np.ascontiguousarray(a), dtype=dt, device=device)
        self.ii = t(arrays["ii"], torch.long)
        self.jj = t(arrays["jj"], torch.long)
        self.target = t(arrays["target"].transpose(0, 2, 3, 1)[None], torch.float)
        self.weight = t(arrays["weight"].transpose(0, 2, 3, 1)[None], torch.float)
        self.ii_inac = t(np.zeros(0), torch.long)
        self.jj_inac = t(np.zeros(0), torch.long)
        self.target_inac = t(np.zeros((1, 0, h, w, 2)), torch.float)
        self.weight_inac = t(np.zeros((1, 0, h, w, 2)), torch.float)


def stereo_arrays(arrays, rig=(-0.1, 0, 0, 0, 0, 0, 1), seed=2):
    """The shared snapshot plus one ii == jj edge per source keyframe: targets the projection of
    the pixel through the rig (DROID's -0.1 baseline) plus 0.3 px noise, weights of another edge."""
    a = dict(arrays)
    fx, fy, cx, cy = a["intrinsics"].astype(np.float64)
    n, h, w = a["disps"].shape
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    rng = np.random.default_rng(seed)
    src = np.unique(a["ii"])
    tgt, wgt = [], []
    for k in src:
        d = a["disps"][k].astype(np.float64)
        X = np.stack([(x - cx) / fx, (y - cy) / fy, np.ones_like(x)])
        Y = X + np.asarray(rig[:3])[:, None, None] * d
        tgt.append(np.stack([fx * Y[0] / Y[2] + cx, fy * Y[1] / Y[2] + cy])
                   + rng.normal(0, 0.3, (2, h, w)))
        wgt.append(a["weight"][np.flatnonzero(a["ii"] == k)[0]])
    a["ii"] = np.concatenate([a["ii"], src])
    a["jj"] = np.concatenate([a["jj"], src])
    a["target"] = np.concatenate([a["target"], np.asarray(tgt, np.float32)])
    a["weight"] = np.concatenate([a["weight"], np.asarray(wgt, np.float32)])
    a["stereo_rig"] = np.asarray(rig, np.float64)
    return a


def rgbd_arrays(arrays, seed=3):
    """The shared snapshot plus a sensor inverse depth on 80 % of the pixels (1 % noise)."""
    a = dict(arrays)
    rng = np.random.default_rng(seed)
    d = a["disps"]
    sens = d * (1 + 0.01 * rng.normal(size=d.shape))
    sens[rng.uniform(size=d.shape) > 0.8] = 0
    a["disps_sens"] = np.maximum(sens, 0).astype(np.float32)
    return a
