"""Mutational fuzzer of the dump hook's tensor reader: dbacov_dump.snapshot_arrays and DbaDumper.

Every case starts from a valid pair of fake DROID-SLAM objects holding real torch tensors laid out
as DROID's (a DepthVideo with buffers of `capacity` keyframe slots, a FactorGraph with active and
inactive edges; monocular, stereo or RGB-D) and applies 1 to 3 random mutations: dtypes, shapes,
values, counters, indices, missing attributes, None, Python lists, NumPy arrays, non-contiguous or
requires_grad tensors, zero edges, mismatched intrinsics rows, repeated time stamps, the layouts of
DROID forks. The contract checked on every case:

* snapshot_arrays either returns a dict of conventions §1 arrays with the documented dtypes that
  passes check_snapshot(..., check_values=False), or raises ValueError (KeyframeTimeError is one)
  with a non-empty message. Any other exception is a finding. It never changes DROID's tensors.
* DbaDumper(out_dir)(video, graph, count), called twice, then its global_ba, never raises;
  with the same keywords it writes a snapshot exactly when snapshot_arrays succeeds, with the
  same arrays; it leaves no temporary file in out_dir, and every file it writes loads with NumPy
  (no pickle) and passes check_snapshot. A bad keyword may be refused by DbaDumper(...) itself
  (ValueError), before SLAM.

Usage (the system python, which has numpy and Debian's python3-torch)::

    /usr/bin/python3 share/droid/tests/fuzz_hook.py --seconds 30 [--seed S]
    /usr/bin/python3 share/droid/tests/fuzz_hook.py --seed S --case K      # replays one case
    /usr/bin/python3 share/droid/tests/fuzz_hook.py --seconds 60 --keep-going  # every kind

Prints the cases run, how many were valid and how many refused; on a finding prints the seed, the
case and its mutations, the traceback, and exits with status 1. Case K of seed S is always the
same case (its generator is seeded with (S, K)), so a finding replays exactly.
test_fuzz_hook.py runs a fixed number of cases of a fixed seed in every ctest run.
"""

import argparse
import contextlib
import io
import os
import sys
import tempfile
import threading
import time
import traceback
import types
import warnings

import numpy as np
import torch

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import dbacov_dump  # noqa: E402 -- after the path of share/droid

#: The dtype of every key a snapshot may hold (conventions §1).
SPEC = {"poses": np.float32, "disps": np.float32, "intrinsics": np.float32, "ii": np.int64,
        "jj": np.int64, "target": np.float32, "weight": np.float32, "tstamp": np.float64,
        "timestamps_s": np.float64, "id": np.int64, "t0": np.int64, "disps_sens": np.float32,
        "stereo_rig": np.float64}
REQUIRED = ("poses", "disps", "intrinsics", "ii", "jj", "target", "weight", "tstamp")

VIDEO_TENSORS = ("poses", "disps", "intrinsics", "tstamp", "images", "disps_sens")
GRAPH_TENSORS = ("ii", "jj", "target", "weight", "ii_inac", "jj_inac", "target_inac",
                 "weight_inac")
DTYPES = (torch.float64, torch.float16, torch.bfloat16, torch.int32, torch.int64, torch.uint8,
          torch.bool, torch.complex64, torch.complex128)
FLOAT_VALUES = (float("nan"), float("inf"), -float("inf"), 1e39, -1e39, 1e300, -1e300, -0.0,
                2.0 ** 63, -7.25, 1e-45)
INDEX_VALUES = (-1, -(2 ** 63), 2 ** 63 - 1, 2 ** 40, 5, 6, 7, 8, 9, 1000)


class Finding(Exception):
    """A broken contract; its message says which."""


class FakeVideo:
    """DROID's DepthVideo: counter (a multiprocessing Value's .value), buffers of `capacity` slots,
    get_lock()."""

    def __init__(self, rng, n, capacity, h, w, stereo=False, rgbd=False):
        self.counter = types.SimpleNamespace(value=n)
        poses = np.zeros((capacity, 7), np.float32)
        poses[:, :3] = rng.normal(size=(capacity, 3))
        q = rng.normal(size=(capacity, 4))
        poses[:, 3:] = q / np.linalg.norm(q, axis=1, keepdims=True)
        self.poses = torch.from_numpy(poses)
        self.disps = torch.from_numpy(rng.uniform(0.1, 2.0, (capacity, h, w)).astype(np.float32))
        intr = np.tile(np.float32([40.5, 41.0, w / 2 - 0.5, h / 2 - 0.5]), (capacity, 1))
        self.intrinsics = torch.from_numpy(intr)
        frames = np.cumsum(rng.integers(1, 4, capacity)).astype(np.float32)
        frames[n:] = 0  # DROID's buffer: zero beyond what was ever appended
        self.tstamp = torch.from_numpy(frames)
        self.images = torch.from_numpy(rng.integers(0, 256, (capacity, 3, 8 * h, 8 * w),
                                                    dtype=np.uint8))
        sens = np.zeros((capacity, h, w), np.float32)
        if rgbd:
            sens[:n] = rng.uniform(0.0, 2.0, (n, h, w)) * (rng.uniform(size=(n, h, w)) > 0.2)
        self.disps_sens = torch.from_numpy(sens)
        self.stereo = stereo
        self._lock = threading.RLock()

    def get_lock(self):
        return self._lock


class FakeGraph:
    """DROID's FactorGraph: ii/jj long (E,), target/weight (1,E,H,W,2) float, last axis (x, y),
    and the inactive edges ii_inac/jj_inac/target_inac/weight_inac."""

    def __init__(self, rng, n, h, w, edges, inactive, stereo=False):
        pairs = [(i, j) for i in range(n) for j in range(n) if abs(i - j) in (1, 2)]
        pick = rng.choice(len(pairs), size=min(edges, len(pairs)), replace=False)
        ii = [pairs[k][0] for k in pick]
        jj = [pairs[k][1] for k in pick]
        if stereo:
            ii, jj = ii + [n - 1], jj + [n - 1]
        self.ii = torch.tensor(ii, dtype=torch.long)
        self.jj = torch.tensor(jj, dtype=torch.long)
        self.target, self.weight = self._planes(rng, len(ii), h, w)
        ii_inac = rng.integers(0, n, inactive)
        jj_inac = (ii_inac + rng.integers(1, n, inactive)) % n
        self.ii_inac = torch.from_numpy(ii_inac.astype(np.int64))
        self.jj_inac = torch.from_numpy(jj_inac.astype(np.int64))
        self.target_inac, self.weight_inac = self._planes(rng, inactive, h, w)

    @staticmethod
    def _planes(rng, e, h, w):
        y, x = np.mgrid[0:h, 0:w].astype(np.float32)
        flow = rng.uniform(-0.5, 0.5, (1, e, h, w, 2)).astype(np.float32)
        target = np.stack([x, y], axis=-1)[None, None] + flow
        weight = rng.uniform(0, 1, (1, e, h, w, 2)).astype(np.float32)
        return torch.from_numpy(np.ascontiguousarray(target)), torch.from_numpy(weight)


class Case:
    """One fuzz case: the objects, the keywords of snapshot_arrays, and what was done to them."""

    def __init__(self, seed, index):
        self.seed, self.index = seed, index
        self.rng = np.random.default_rng([seed, index])
        rng = self.rng
        self.n = int(rng.integers(4, 7))
        self.capacity = self.n + int(rng.integers(1, 4))
        self.h, self.w = 6, 8
        mode = rng.choice(["mono", "mono", "stereo", "rgbd"])
        self.video = FakeVideo(rng, self.n, self.capacity, self.h, self.w,
                               stereo=mode == "stereo", rgbd=mode == "rgbd")
        self.graph = FakeGraph(rng, self.n, self.h, self.w, int(rng.integers(3, 9)),
                               int(rng.integers(0, 4)), stereo=mode == "stereo")
        self.kwargs = {"include_inactive": bool(rng.integers(0, 2))}
        if rng.integers(0, 4) == 0:
            self.kwargs["t0"] = 1  # DROID's global BA (update_lowmem)
        if rng.integers(0, 3) == 0:
            frames = int(self.video.tstamp.max()) + 1
            self.kwargs["image_times_s"] = 1403636579.76 + 0.05 * np.arange(frames)
        self.snapshot_id = int(rng.integers(0, 1000))
        self.mutations = [f"base: {mode}, N={self.n}, capacity={self.capacity}, "
                          f"E={self.graph.ii.numel()}, inactive={self.graph.ii_inac.numel()}, "
                          f"keywords={sorted(self.kwargs)}"]
        for _ in range(int(rng.integers(1, 4))):
            name = MUTATION_NAMES[int(rng.integers(0, len(MUTATION_NAMES)))]
            try:
                what = MUTATIONS[name](self)
            except Exception as exc:  # noqa: BLE001 -- an earlier mutation removed its object
                what = f"not applicable ({type(exc).__name__}: {exc})"
            self.mutations.append(name + ": " + what)

    def owner(self, name):
        return self.video if name in VIDEO_TENSORS or name == "timestamp" else self.graph

    def pick(self, names):
        """A random attribute of `names` that exists and holds a tensor, or None."""
        names = [nm for nm in names if isinstance(getattr(self.owner(nm), nm, None), torch.Tensor)]
        return names[int(self.rng.integers(0, len(names)))] if names else None

    def tensor_names(self):
        return VIDEO_TENSORS + GRAPH_TENSORS + ("timestamp",)


def qualified(case, name):
    return ("video." if case.owner(name) is case.video else "graph.") + name


# --- mutations: each changes the case and returns what it did -------------------------------------

def on_a_tensor(names=None):
    """A mutation of one tensor, picked among `names` (default: every tensor of the case) and
    passed by name; "nothing to change" when none of them is there."""
    def wrap(mutate):
        def run(case):
            name = case.pick(case.tensor_names() if names is None else names)
            return "nothing to change" if name is None else mutate(case, name)
        run.__name__ = mutate.__name__
        return run
    return wrap


@on_a_tensor()
def m_dtype(case, name):
    dtype = DTYPES[int(case.rng.integers(0, len(DTYPES)))]
    setattr(case.owner(name), name, getattr(case.owner(name), name).to(dtype))
    return f"{qualified(case, name)} to {dtype}"


@on_a_tensor()
def m_shape(case, name):
    t = getattr(case.owner(name), name)
    rng = case.rng
    kind = ["drop", "add", "permute", "narrow", "grow"][int(rng.integers(0, 5))]
    if t.dim() == 0:
        kind = "add"
    dim = int(rng.integers(0, max(t.dim(), 1)))
    if kind == "drop":
        t = t.select(dim, 0) if t.shape[dim] > 0 else t.sum(dim)
    elif kind == "add":
        t = t.unsqueeze(int(rng.integers(0, t.dim() + 1)))
    elif kind == "permute":
        t = t.permute(*[int(d) for d in rng.permutation(t.dim())])
    elif kind == "narrow":
        size = int(rng.integers(0, max(t.shape[dim], 1)))
        t = t.narrow(dim, 0, size)
    else:
        t = torch.cat([t, t.narrow(dim, 0, min(t.shape[dim], int(rng.integers(1, 3))))], dim)
    setattr(case.owner(name), name, t)
    return f"{qualified(case, name)} {kind} dim {dim}: shape {tuple(t.shape)}"


@on_a_tensor(("target", "weight", "target_inac", "weight_inac"))
def m_last_axis(case, name):
    t = getattr(case.owner(name), name)
    t = t[..., :1] if case.rng.integers(0, 2) else torch.cat([t, t[..., :1]], -1)
    setattr(case.owner(name), name, t)
    return f"{qualified(case, name)} last axis {t.shape[-1]}"


@on_a_tensor(("ii", "jj", "target", "weight", "ii_inac", "jj_inac", "target_inac",
             "weight_inac"))
def m_edge_count(case, name):
    g, rng = case.graph, case.rng
    t = getattr(g, name)
    axis = 1 if name.startswith(("target", "weight")) else 0
    if t.dim() <= axis:
        return f"{name} has no edge axis"
    if rng.integers(0, 2) and t.shape[axis] > 0:
        t = t.narrow(axis, 0, t.shape[axis] - 1)
    else:
        t = torch.cat([t, t.narrow(axis, 0, min(1, t.shape[axis]))], axis)
    setattr(g, name, t)
    return f"graph.{name} now {t.shape[axis]} edges"


@on_a_tensor()
def m_value(case, name):
    t = getattr(case.owner(name), name)
    if t.numel() == 0:
        return f"{qualified(case, name)} is empty"
    flat = t.detach().reshape(-1).clone()
    k = int(case.rng.integers(0, flat.numel()))
    if t.is_floating_point() or t.is_complex():
        v = FLOAT_VALUES[int(case.rng.integers(0, len(FLOAT_VALUES)))]
        big = torch.finfo(t.dtype).max
        if np.isfinite(v) and abs(v) > big:  # beyond the dtype: what a cast would give
            v = float("inf") if v > 0 else -float("inf")
    elif t.dtype == torch.bool:
        v = True
    else:
        info = torch.iinfo(t.dtype)
        v = int(min(max(INDEX_VALUES[int(case.rng.integers(0, len(INDEX_VALUES)))], info.min),
                    info.max))
    flat[k] = v
    setattr(case.owner(name), name, flat.reshape(t.shape))
    return f"{qualified(case, name)} flat [{k}] = {v!r}"


@on_a_tensor(("ii", "jj", "ii_inac", "jj_inac"))
def m_index(case, name):
    g, rng = case.graph, case.rng
    t = getattr(g, name).clone()
    if t.dim() != 1 or t.numel() == 0:
        return f"graph.{name} has shape {tuple(t.shape)}"
    k = int(rng.integers(0, t.numel()))
    kind = ["value", "fraction", "self"][int(rng.integers(0, 3))]
    if kind == "value":
        v = [-1, -2, case.n, case.n + 1, case.capacity, 2 ** 40][int(rng.integers(0, 6))]
        t[k] = v
        setattr(g, name, t)
        return f"graph.{name}[{k}] = {v}"
    if kind == "fraction":
        t = t.to(torch.float64)
        t[k] += 0.5
        setattr(g, name, t)
        return f"graph.{name}[{k}] += 0.5 (float64)"
    other = {"ii": "jj", "jj": "ii", "ii_inac": "jj_inac", "jj_inac": "ii_inac"}[name]
    o = getattr(g, other)
    if not isinstance(o, torch.Tensor) or o.shape != t.shape:
        return f"graph.{other} is not comparable"
    t[k] = o[k]
    setattr(g, name, t)
    return f"graph.{name}[{k}] = graph.{other}[{k}] (a self edge)"


def m_counter(case):
    rng = case.rng
    values = [0, -3, 1, case.n - 1, case.n + 1, case.capacity, case.capacity + 5, 10 ** 6,
              float(case.n), case.n - 0.5, str(case.n), None, True, np.int64(case.n),
              torch.tensor(case.n), float("nan"), 2 ** 70]
    v = values[int(rng.integers(0, len(values)))]
    kind = int(rng.integers(0, 8))
    if kind == 0:
        del case.video.counter
        return "video.counter deleted"
    if kind == 1:
        case.video.counter = None
        return "video.counter = None"
    if kind == 2:
        case.video.counter = types.SimpleNamespace()
        return "video.counter has no value"
    case.video.counter.value = v
    return f"video.counter.value = {v!r}"


def m_missing(case):
    names = case.tensor_names() + ("stereo", "counter", "get_lock")
    names = [nm for nm in names if hasattr(case.owner(nm), nm)]
    name = names[int(case.rng.integers(0, len(names)))]
    if name == "get_lock":
        case.video.get_lock = None
        return "video.get_lock = None"
    delattr(case.owner(name), name)
    return f"{qualified(case, name)} deleted"


@on_a_tensor()
def m_none(case, name):
    setattr(case.owner(name), name, None)
    return f"{qualified(case, name)} = None"


@on_a_tensor()
def m_container(case, name):
    t = getattr(case.owner(name), name)
    kind = ["list", "numpy", "scalar", "string", "object"][int(case.rng.integers(0, 5))]
    value = {"list": lambda: t.tolist(), "numpy": lambda: t.numpy(),
             "scalar": lambda: float(t.reshape(-1)[0]) if t.numel() and not t.is_complex()
             else 1.5,
             "string": lambda: "not a tensor", "object": lambda: {"a": 1}}[kind]()
    setattr(case.owner(name), name, value)
    return f"{qualified(case, name)} as a {kind}"


@on_a_tensor()
def m_layout(case, name):
    t = getattr(case.owner(name), name)
    if case.rng.integers(0, 2) and t.dim() > 0:
        t = torch.stack([t, t], dim=-1).select(-1, 0)  # same values, not contiguous
        assert t.numel() <= 1 or not t.is_contiguous()
        what = "non-contiguous"
    elif t.is_floating_point() or t.is_complex():
        t = t.clone().requires_grad_(True)
        what = "requires_grad"
    else:
        t = t.expand(*t.shape)  # a view
        what = "an expanded view"
    setattr(case.owner(name), name, t)
    return f"{qualified(case, name)} {what}"


def m_zero_edges(case):
    g = case.graph
    for name in ("ii", "jj"):
        t = getattr(g, name, None)
        if isinstance(t, torch.Tensor) and t.dim() >= 1:
            setattr(g, name, t[:0])
    for name in ("target", "weight"):
        t = getattr(g, name, None)
        if isinstance(t, torch.Tensor) and t.dim() >= 2:
            setattr(g, name, t[:, :0])
    return "every active edge removed"


def m_intrinsics_row(case):
    t = case.video.intrinsics
    if not isinstance(t, torch.Tensor) or t.dim() != 2 or t.shape[0] == 0:
        return "video.intrinsics is not (slots, 4)"
    t = t.clone()
    k = int(case.rng.integers(0, t.shape[0]))
    t[k, int(case.rng.integers(0, t.shape[1]))] += 0.5
    case.video.intrinsics = t
    return f"video.intrinsics row {k} changed"


def m_dup_tstamp(case):
    t = case.video.tstamp
    if not isinstance(t, torch.Tensor) or t.dim() != 1 or t.shape[0] < 2:
        return "video.tstamp is not (slots,)"
    t = t.clone()
    k = int(case.rng.integers(1, t.shape[0]))
    t[k] = t[k - 1]
    case.video.tstamp = t
    return f"video.tstamp[{k}] = video.tstamp[{k - 1}]"


def m_stereo(case):
    values = [True, False, None, 1, "yes", np.bool_(True), torch.tensor([True, False]),
              torch.tensor(True)]
    v = values[int(case.rng.integers(0, len(values)))]
    case.video.stereo = v
    return f"video.stereo = {v!r}"


def m_images(case):
    t = case.video.images
    if not isinstance(t, torch.Tensor) or t.dim() < 1:
        return "video.images is not a buffer"
    kind = int(case.rng.integers(0, 4))
    if kind == 0:
        t = t[:max(0, case.n - 2)]
        what = f"only {t.shape[0]} slots"
    elif kind == 1:
        t = t[:, 0, 0]
        what = "(slots, 8W)"
    elif kind == 2:
        t = t.float() / 255
        what = "float in [0, 1]"
    else:
        t = t[..., :3, :3]
        what = "3x3 images"
    case.video.images = t
    return f"video.images {what}"


def m_fork(case):
    """The layouts of DROID forks: GO-SLAM's video.timestamp, DBA-Fusion's tstamp in seconds."""
    v, rng = case.video, case.rng
    t = getattr(v, "tstamp", None)
    if not isinstance(t, torch.Tensor) or t.dim() != 1:
        return "video.tstamp is not (slots,)"
    if rng.integers(0, 2):
        del v.tstamp
        v.timestamp = t
        return "GO-SLAM: video.tstamp renamed video.timestamp"
    frames = t.to(torch.float64)
    if not bool(torch.isfinite(frames).all()) or float(frames.abs().max()) > 10 ** 5:
        return "video.tstamp holds no small image indices"
    start = 1403636579.763555584
    seconds = torch.where(frames > 0, start + 0.05 * frames, torch.zeros_like(frames))
    seconds[0] = start + 0.05 * frames[0]
    v.tstamp = seconds
    what = "DBA-Fusion: video.tstamp in seconds (float64)"
    if rng.integers(0, 3):
        count = int(frames.max()) + 1 + int(rng.integers(-2, 3))
        case.kwargs["image_times_s"] = start + 0.05 * np.arange(max(count, 0))
        what += f", image_times_s of {max(count, 0)} images"
    else:
        case.kwargs.pop("image_times_s", None)
    return what


def m_keywords(case):
    rng = case.rng
    kind = int(rng.integers(0, 6))
    if kind == 0:
        case.kwargs["image_times_s"] = 0.05 * np.arange(int(rng.integers(0, 4)))
        return "image_times_s too short"
    if kind == 1:
        case.kwargs["image_times_s"] = np.zeros((3, 4))
        return "image_times_s 2-D"
    if kind == 2:
        case.kwargs["stereo_rig"] = [-0.1, 0, 0][:int(rng.integers(0, 4))]
        return f"stereo_rig = {case.kwargs['stereo_rig']}"
    if kind == 3:
        case.kwargs["timestamps_s"] = np.arange(int(rng.integers(0, 8)), dtype=float)
        return f"timestamps_s of {case.kwargs['timestamps_s'].size}"
    if kind == 4:
        case.snapshot_id = [None, 2.5, "x", -1, 2 ** 70, np.int32(4)][int(rng.integers(0, 6))]
        return f"snapshot_id = {case.snapshot_id!r}"
    case.kwargs["include_inactive"] = not case.kwargs["include_inactive"]
    return f"include_inactive = {case.kwargs['include_inactive']}"


MUTATIONS = {"dtype": m_dtype, "shape": m_shape, "last_axis": m_last_axis,
             "edge_count": m_edge_count, "value": m_value, "index": m_index,
             "counter": m_counter, "missing": m_missing, "none": m_none,
             "container": m_container, "layout": m_layout, "zero_edges": m_zero_edges,
             "intrinsics_row": m_intrinsics_row, "dup_tstamp": m_dup_tstamp, "stereo": m_stereo,
             "images": m_images, "keywords": m_keywords, "fork": m_fork}
MUTATION_NAMES = sorted(MUTATIONS)


# --- the contract --------------------------------------------------------------------------------

def state(case):
    """Bytes of every tensor of the objects, to check that the reader changes none (NaN too)."""
    out = {}
    for name in case.tensor_names():
        t = getattr(case.owner(name), name, None)
        if isinstance(t, torch.Tensor):
            raw = t.detach().clone(memory_format=torch.contiguous_format).reshape(-1)
            out[name] = (id(t), t.dtype, tuple(t.shape), raw.view(torch.uint8).clone())
    return out


def same_state(a, b):
    return a.keys() == b.keys() and all(a[k][:3] == b[k][:3] and torch.equal(a[k][3], b[k][3])
                                        for k in a)


def check_arrays(arrays, where):
    """The returned (or written) arrays: the spec's keys and dtypes, and check_snapshot."""
    if not isinstance(arrays, dict):
        raise Finding(f"{where}: returned {type(arrays).__name__}, expected a dict")
    unknown = sorted(set(arrays) - set(SPEC))
    missing = [k for k in REQUIRED if k not in arrays]
    if unknown or missing:
        raise Finding(f"{where}: unknown keys {unknown}, missing keys {missing}")
    for k, v in arrays.items():
        if not isinstance(v, np.ndarray) or v.dtype != SPEC[k]:
            raise Finding(f"{where}: key '{k}' is {type(v).__name__} "
                          f"{getattr(v, 'dtype', None)}, expected {np.dtype(SPEC[k])}")
    try:
        dbacov_dump.check_snapshot(arrays, check_values=False)
    except Exception as exc:  # noqa: BLE001 -- anything is a finding here
        raise Finding(f"{where}: the arrays fail check_snapshot: {type(exc).__name__}: "
                      f"{dbacov_dump.exception_text(exc)}") from exc


def run_case(case, out_dir):
    """Checks the contract on one case; returns 'valid' or 'refused', raises Finding."""
    before = state(case)
    outcome = None
    try:
        with contextlib.redirect_stderr(io.StringIO()):
            arrays = dbacov_dump.snapshot_arrays(case.video, case.graph, case.snapshot_id,
                                                 **case.kwargs)
    except ValueError as exc:
        if not dbacov_dump.exception_text(exc).strip():
            raise Finding(f"snapshot_arrays raised {type(exc).__name__} with an empty "
                          "message") from exc
        outcome = "refused"
    except Exception as exc:  # noqa: BLE001 -- the finding itself
        raise Finding(f"snapshot_arrays raised {type(exc).__name__}: "
                      f"{dbacov_dump.exception_text(exc)}") from exc
    else:
        check_arrays(arrays, "snapshot_arrays")
        outcome = "valid"
    if not same_state(before, state(case)):
        raise Finding("snapshot_arrays changed DROID's tensors")

    stream = io.StringIO()
    try:
        dumper = dbacov_dump.DbaDumper(out_dir, stream=stream,
                                       include_inactive=case.kwargs["include_inactive"],
                                       image_times_s=case.kwargs.get("image_times_s"),
                                       stereo_rig=case.kwargs.get("stereo_rig"))
    except ValueError as exc:  # a bad keyword is refused when the hook is made, before SLAM
        if not dbacov_dump.exception_text(exc).strip():
            raise Finding("DbaDumper(...) raised ValueError with an empty message") from exc
        return outcome
    except Exception as exc:  # noqa: BLE001 -- the finding itself
        raise Finding(f"DbaDumper(...) raised {type(exc).__name__}: "
                      f"{dbacov_dump.exception_text(exc)}") from exc
    # The dumper's count is the snapshot id; the same outcome is expected when it is a plain one.
    plain = isinstance(case.snapshot_id, int) and 0 <= case.snapshot_id < 10 ** 6 and \
        set(case.kwargs) <= {"include_inactive", "image_times_s", "stereo_rig", "t0"}
    count = case.snapshot_id if plain else case.index
    expect = {"window": plain and "t0" not in case.kwargs, "global": plain and "t0" in case.kwargs}
    for call, (kind, number) in enumerate([("window", count), ("window", count + 1),
                                           ("global", None)]):
        try:
            with contextlib.redirect_stderr(io.StringIO()):
                if kind == "window":
                    path = dumper(case.video, case.graph, number)
                else:  # the backend's hook, on the same objects
                    path = dumper.global_ba(case.video, case.graph,
                                            include_inactive=case.kwargs["include_inactive"])
        except BaseException as exc:  # noqa: BLE001 -- the hook must never raise
            raise Finding(f"DbaDumper{'.global_ba' if kind == 'global' else ''} raised "
                          f"{type(exc).__name__}: {dbacov_dump.exception_text(exc)}") from exc
        if call != 1 and expect[kind]:  # the same keywords as snapshot_arrays': the same result
            if (path is not None) != (outcome == "valid"):
                raise Finding(f"DbaDumper ({kind}) {'wrote' if path else 'refused'} what "
                              f"snapshot_arrays {'accepted' if outcome == 'valid' else 'refused'}"
                              f": {stream.getvalue().strip()}")
            if path is not None:
                with np.load(path, allow_pickle=False) as z:
                    got = {k: z[k] for k in z.files if k != "id"}
                want = {k: v for k, v in arrays.items() if k != "id"}
                if got.keys() != want.keys() or not all(
                        np.array_equal(got[k], want[k], equal_nan=True) for k in want):
                    raise Finding(f"DbaDumper ({kind}) wrote other arrays than snapshot_arrays "
                                  "returned")
    if not same_state(before, state(case)):
        raise Finding("DbaDumper changed DROID's tensors")
    lines = stream.getvalue().splitlines()
    if len(lines) > dumper.failures or (dumper.failures and not lines):
        raise Finding(f"DbaDumper reported {len(lines)} lines for {dumper.failures} failures")
    names = sorted(os.listdir(out_dir)) if os.path.isdir(out_dir) else []
    for name in names:
        path = os.path.join(out_dir, name)
        if not (name.startswith(("window_", "global_")) and name.endswith(".npz")):
            raise Finding(f"DbaDumper left {name!r} in out_dir")
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
        except Exception as exc:  # noqa: BLE001 -- an unreadable file is the finding
            raise Finding(f"DbaDumper wrote {name} that NumPy cannot load: "
                          f"{dbacov_dump.exception_text(exc)}") from exc
        check_arrays(arrays, f"DbaDumper's {name}")
        os.unlink(path)
    return outcome


def describe(case, exc):
    lines = [f"fuzz_hook: FINDING in case {case.index} of seed {case.seed}: {exc}",
             "mutations:"] + [f"  {m}" for m in case.mutations]
    lines.append(f"reproduce: /usr/bin/python3 {os.path.relpath(__file__)} --seed {case.seed} "
                 f"--case {case.index}")
    cause = exc.__cause__ or exc
    lines.append("".join(traceback.format_exception(type(cause), cause, cause.__traceback__)))
    return "\n".join(lines)


def signature(exc):
    """A finding's kind: the exception type and the line of dbacov_dump that raised it."""
    cause = exc.__cause__ or exc
    frames = [f for f in traceback.extract_tb(cause.__traceback__)
              if f.filename.endswith("dbacov_dump.py")]
    where = f"dbacov_dump.py:{frames[-1].lineno} ({frames[-1].name})" if frames else "fuzz_hook"
    return f"{type(cause).__name__} at {where}"


def fuzz(seed, cases=None, seconds=None, first=0, keep_going=False):
    """Runs cases first, first+1, ... of `seed` until `cases` are done or `seconds` are up.
    Returns (counts, findings): the first finding's text, or with keep_going the first of each
    class (signature)."""
    counts = {"cases": 0, "valid": 0, "refused": 0}
    findings = {}
    start = time.monotonic()
    # In memory when the system has /dev/shm: the dumper's fsync then costs nothing.
    shm = "/dev/shm" if os.access("/dev/shm", os.W_OK) else None
    with tempfile.TemporaryDirectory(prefix="dbacov_fuzz_hook.", dir=shm) as tmp:
        out_dir = os.path.join(tmp, "out")
        index = first
        while (cases is None or counts["cases"] < cases) and \
                (seconds is None or time.monotonic() - start < seconds):
            with warnings.catch_warnings():  # torch's, on casts the mutations make on purpose
                warnings.simplefilter("ignore")
                case = Case(seed, index)
            index += 1
            counts["cases"] += 1
            try:
                counts[run_case(case, out_dir)] += 1
            except Finding as exc:
                findings.setdefault(signature(exc), describe(case, exc))
                if not keep_going:
                    break
                if os.path.isdir(out_dir):
                    for name in os.listdir(out_dir):
                        os.unlink(os.path.join(out_dir, name))
    return counts, list(findings.values())


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seconds", type=float, default=10.0, help="fuzzing time (default 10)")
    p.add_argument("--seed", type=int, help="the run's seed (default: from the clock)")
    p.add_argument("--case", type=int, help="replay case CASE of --seed only")
    p.add_argument("--keep-going", action="store_true",
                   help="go on after a finding; print the first case of each kind of finding")
    p.add_argument("--memory-mb", type=int, default=4096,
                   help="address-space limit (default 4096): an allocation beyond it is a "
                        "MemoryError, a finding, not the machine's out-of-memory killer")
    o = p.parse_args(argv)
    if o.memory_mb > 0:
        import resource
        limit = o.memory_mb * 2 ** 20
        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        if hard != resource.RLIM_INFINITY:
            limit = min(limit, hard)
        resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    if o.case is not None and o.seed is None:
        p.error("--case needs --seed")
    seed = o.seed if o.seed is not None else int(time.time() * 1000) % 2 ** 31
    start = time.monotonic()
    if o.case is not None:
        counts, findings = fuzz(seed, cases=1, first=o.case)
    else:
        counts, findings = fuzz(seed, seconds=o.seconds, keep_going=o.keep_going)
    elapsed = time.monotonic() - start
    print(f"fuzz_hook: seed {seed}: {counts['cases']} cases in {elapsed:.1f} s "
          f"({counts['cases'] / max(elapsed, 1e-9):.0f}/s), {counts['valid']} valid, "
          f"{counts['refused']} refused, {counts['cases'] - counts['valid'] - counts['refused']} "
          "findings", flush=True)
    for finding in findings:
        print(finding, file=sys.stderr, flush=True)
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
