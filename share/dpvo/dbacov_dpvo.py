"""Dump DPVO's patch-graph bundle adjustment as dbacov snapshots (the DPVO side of dbacov).

DPVO (and DPV-SLAM, its loop-closing version in the same repository) optimizes a *patch graph*:
every frame contributes M patches of P x P pixels (P = 3) at 1/4 of the image resolution, each
with one inverse depth; edge e asks patch kk[e] of frame ii[e] = kk[e] // M to appear at
target[e] in frame jj[e], with confidence weight[e]. One snapshot is that graph right after one
call of DPVO's BA (``fastba.BA``), written as one ``.npz`` file (docs/reference/formats.md,
"Patch-graph snapshots (DPVO)"):

    poses        float32 (N,7)        world-to-camera T_cw [tx ty tz qx qy qz qw] (lietorch order)
    patches      float32 (N,M,3,P,P)  channel 0 = x (column), 1 = y (row) at 1/4 resolution,
                                      2 = inverse depth (DPVO keeps one value per patch)
    intrinsics   float32 (4,)         fx fy cx cy at 1/4 resolution (DPVO stores intrinsics / RES)
    ii, jj, kk   int64   (E,)         edge e: patch kk[e] of frame ii[e] = kk[e] // M -> frame jj[e]
    target       float32 (E,2)        predicted (x, y) of the patch centre in frame jj[e]
    weight       float32 (E,2)        confidences per axis (a sigmoid: in (0, 1), no extra scale)
    t0           int64   ()           frames below t0 are held by the BA
    tstamp       float64 (N,)         DPVO's frame stamps (``tstamps_``: the frame's call counter)
    timestamps_s float64 (N,)         optional: frame times in seconds
    id           int64   ()           snapshot counter
    is_global    uint8   ()           1 for DPV-SLAM's global BA (loop-closure edges), else 0

Frames: by default (``frames="graph"``) the snapshot holds DPVO's frames [f0, n), f0 the lowest
frame that an edge names; ii, jj, kk and t0 are renumbered into them (snapshot frame 0 is DPVO's
frame f0, ``tstamp`` identifies it). ``frames="all"`` keeps [0, n). DPVO's geometry buffers are
not ring buffers (only its network features, ``imap_``/``gmap_``/``fmap*_``, wrap modulo
``pmem``/``mem``): kk indexes ``patches_`` directly.

Where DPVO keeps the graph (the buffers' first axis is the frame slot, BUFFER_SIZE long):
DPV-SLAM's layout holds them in ``dpvo.pg`` (a ``PatchGraph``: ``poses_``, ``patches_``,
``intrinsics_``, ``tstamps_`` a NumPy int64 array, ``ii``, ``jj``, ``kk``, ``n``, ``M``); the
original DPVO holds the same names on the DPVO object itself (``tstamps_`` a torch tensor).
Both call ``fastba.BA(poses, patches, intrinsics, target, weight, lmbda, ii, jj, kk, t0, t1,
...)`` from ``DPVO.update`` with views of those buffers, t1 = n, t0 = max(n - OPTIMIZATION_WINDOW,
1) once initialized (1 before). DPV-SLAM's ``DPVO.__run_global_BA`` calls it with the inactive
edges (``pg.*_inac``) followed by the active ones and t0 = min(pg.ii), after ``pg.normalize()``.

The hook (``install_hook``) wraps the ``BA`` attribute of the ``fastba`` module that DPVO's module
uses, so it sees exactly the target, weight, edges and t0 of each call, and reads the buffers
after the BA has moved the poses and depths. It never raises into DPVO: a failure skips that
snapshot, is reported once per kind (``warnings``, RuntimeWarning) and VO goes on. The BA's own
exceptions pass through unchanged (DPVO catches them itself).

numpy is required; torch is not imported: tensors are read with ``.detach().cpu().numpy()``.
"""

import contextlib
import functools
import operator
import os
import re
import sys
import tempfile
import warnings
import zipfile

import numpy as np

__all__ = ["snapshot_from_dpvo", "save_snapshot", "check_snapshot", "install_hook", "DpvoHook",
           "BA_ARGUMENTS"]

#: The leading parameters shared by every fastba.BA signature (DPVO and DPV-SLAM).
BA_ARGUMENTS = ("poses", "patches", "intrinsics", "target", "weight", "lmbda", "ii", "jj", "kk",
                "t0", "t1")


def _text(exc):
    try:
        return str(exc)
    except Exception:  # noqa: BLE001 -- a foreign __str__ must not break the report
        return f"<{type(exc).__name__} whose message cannot be printed>"


def _spelled(shape):
    return "(" + ", ".join("*" if d is None else str(d) for d in shape) + \
        ("," if len(shape) == 1 else "") + ")"


def _numpy(x, name):
    """A private numpy copy of a tensor (any device) or array of real numbers; anything else
    (None, complex, boolean, object, a masked array) is a ValueError naming `name`."""
    if x is None:
        raise ValueError(f"{name} is missing (None or no such attribute)")
    if isinstance(x, np.ma.MaskedArray):
        raise ValueError(f"{name} is a NumPy masked array: its mask would be ignored")
    if hasattr(x, "detach"):
        dtype = str(getattr(x, "dtype", ""))
        if "complex" in dtype:
            raise ValueError(f"{name} has the complex dtype {dtype}, expected real numbers")
        try:
            if dtype == "torch.bfloat16":  # NumPy has no bfloat16; float32 holds it exactly
                x = x.detach().float()
            x = x.detach().cpu().numpy()
        except (TypeError, ValueError, RuntimeError, AttributeError) as exc:
            raise ValueError(f"{name} cannot be read as an array: {_text(exc)}") from None
    try:
        a = np.array(x, copy=True)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name} cannot be read as an array ({type(x).__name__}): "
                         f"{_text(exc)}") from None
    if a.dtype.kind not in "iuf":
        raise ValueError(f"{name} has the dtype {a.dtype}, expected real numbers")
    return a


def _shape(x, name):
    """(x, its shape) without copying a tensor: its buffer is sliced before it is read."""
    if x is None:
        raise ValueError(f"{name} is missing (None or no such attribute)")
    shape = getattr(x, "shape", None)
    if shape is None or not hasattr(x, "__getitem__"):
        x = _numpy(x, name)
        shape = x.shape
    try:
        return x, tuple(int(d) for d in shape)
    except (TypeError, ValueError):
        raise ValueError(f"{name} has the shape {shape!r}, not a tuple of sizes") from None


def _integer(value, name, minimum=None):
    """An int (Python, NumPy or a 0-d integer tensor) in the int64 range, else a ValueError."""
    ok = not isinstance(value, (bool, np.bool_))
    if ok:
        try:
            value = operator.index(value)
            ok = -2 ** 63 <= value < 2 ** 63
        except TypeError:
            ok = False
    if not ok:
        raise ValueError(f"{name} is {value!r} ({type(value).__name__}), expected an integer")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} is {value}, expected at least {minimum}")
    return value


def _indices(x, name):
    """An (E,) integer tensor as int64; integral floats are accepted, fractions refused."""
    x, shape = _shape(x, name)
    if len(shape) != 1:
        raise ValueError(f"{name} has shape {_spelled(shape)}, expected (E,)")
    a = _numpy(x, name)
    if a.dtype.kind == "f":
        bad = np.flatnonzero(~np.isfinite(a) | (a != np.round(a)))
        if bad.size:
            raise ValueError(f"{name}[{bad[0]}] is {a[bad[0]]!r}, expected an integer index")
    if a.size and (np.abs(a.astype(np.float64)) >= 2.0 ** 63).any():
        raise ValueError(f"{name} holds a value beyond the int64 range")
    return a.astype(np.int64)


def _slots(holder, prefix, attr, n, tail, first):
    """holder.attr[first:n] of a DPVO buffer whose first axis is the frame slot; `tail` is the
    shape of one slot (None = any size). The buffer must hold the n frames."""
    name = f"{prefix}.{attr}"
    x, shape = _shape(getattr(holder, attr, None), name)
    if len(shape) != 1 + len(tail) or any(d is not None and d != s
                                          for d, s in zip(tail, shape[1:])):
        raise ValueError(f"{name} has shape {_spelled(shape)}, expected "
                         f"{_spelled(('slots',) + tail)}")
    if shape[0] < n:
        raise ValueError(f"{name} has {shape[0]} slots, fewer than the n = {n} frames")
    return _numpy(x[first:n], name)


def _planes(x, name, e):
    """DPVO's target / weight, (1,E,2) with the last axis (x, y), as an (E,2) array."""
    x, shape = _shape(x, name)
    if shape != (1, e, 2):
        raise ValueError(f"{name} has shape {_spelled(shape)}, expected (1, {e}, 2) (one "
                         f"(x, y) per edge of ii, E = {e})")
    return _numpy(x, name)[0]


def _float(a):
    """float64 kept as it is, every other real dtype as float32 (what DPVO holds)."""
    return a if a.dtype == np.float64 else a.astype(np.float32)


def _graph(dpvo):
    """(the object holding DPVO's buffers and edges, its name in messages)."""
    pg = getattr(dpvo, "pg", None)
    return (pg, "dpvo.pg") if pg is not None else (dpvo, "dpvo")


def snapshot_from_dpvo(dpvo, target, weight, t0, ii=None, jj=None, kk=None, n=None,
                       frames="graph", snapshot_id=None, is_global=False, image_times_s=None):
    """The snapshot arrays (a dict, the layout of this module's docstring) of `dpvo`'s patch
    graph, for a BA that used `target`, `weight` (DPVO's (1,E,2)) and held the frames below `t0`.

    ii, jj, kk  the BA's edges (default: the graph's active edges, ``pg.ii`` etc.); the global
                BA passes the inactive edges followed by the active ones.
    n           the BA's t1, the frames in use (default: the graph's ``n``).
    frames      "graph": frames [f0, n), f0 the lowest frame an edge names (indices renumbered);
                "all": frames [0, n).
    image_times_s  optional: the time in seconds of every frame given to DPVO, indexed by its
                ``tstamps_`` value (DPVO's call counter); written as 'timestamps_s'.

    Every missing or malformed tensor is a ValueError naming it. Call it after the BA: the poses
    and depths are read from DPVO's buffers as they are."""
    g, prefix = _graph(dpvo)
    n = _integer(getattr(g, "n", None) if n is None else n,
                 f"{prefix}.n" if n is None else "n (the BA's t1)", minimum=1)
    m = _integer(getattr(g, "M", None), f"{prefix}.M", minimum=1)
    edges = {}
    for key, given in (("ii", ii), ("jj", jj), ("kk", kk)):
        edges[key] = _indices(getattr(g, key, None) if given is None else given,
                              f"{prefix}.{key}" if given is None else key)
    ii, jj, kk = edges["ii"], edges["jj"], edges["kk"]
    e = ii.size
    if e == 0:
        raise ValueError("ii is empty: the BA has no edges, there is no graph to dump")
    for key in ("jj", "kk"):
        if edges[key].size != e:
            raise ValueError(f"{key} has {edges[key].size} edges but ii has {e}")
    for key, a, hi in (("kk", kk, n * m), ("jj", jj, n), ("ii", ii, n)):
        bad = np.flatnonzero((a < 0) | (a >= hi))
        if bad.size:
            raise ValueError(f"{key}[{bad[0]}] is {a[bad[0]]}, outside [0, {hi}) (n = {n} "
                             f"frames, M = {m} patches per frame)")
    bad = np.flatnonzero(ii != kk // m)
    if bad.size:
        k = bad[0]
        raise ValueError(f"ii[{k}] is {ii[k]} but patch kk[{k}] = {kk[k]} belongs to frame "
                         f"{kk[k] // m} (kk // M, M = {m}): the edges are inconsistent")
    t0 = _integer(t0, "t0")
    if not 0 <= t0 <= n:
        raise ValueError(f"t0 is {t0}, expected 0 <= t0 <= n = {n}")
    if frames not in ("graph", "all"):
        raise ValueError(f"frames is {frames!r}, expected 'graph' or 'all'")
    f0 = int(min(ii.min(), jj.min())) if frames == "graph" else 0

    poses = _slots(g, prefix, "poses_", n, (7,), f0)
    patches = _slots(g, prefix, "patches_", n, (m, 3, None, None), f0)
    p = patches.shape[3]
    if patches.shape[4] != p or p % 2 == 0:
        raise ValueError(f"{prefix}.patches_ has patches of {patches.shape[3]} x "
                         f"{patches.shape[4]} pixels, expected square patches of odd size")
    intrinsics = _slots(g, prefix, "intrinsics_", n, (4,), 0)
    differs = np.flatnonzero((intrinsics != intrinsics[0]).any(axis=1))
    if differs.size:
        raise ValueError(f"{prefix}.intrinsics_ differ between frames: row {differs[0]} = "
                         f"{intrinsics[differs[0]]} but row 0 = {intrinsics[0]}; DPVO's BA uses "
                         "row 0 for every frame, a snapshot has one camera")
    tstamp = _slots(g, prefix, "tstamps_", n, (), f0).astype(np.float64)
    arrays = {
        "poses": _float(poses),
        "patches": _float(patches),
        "intrinsics": _float(intrinsics[0]),
        "ii": ii - f0,
        "jj": jj - f0,
        "kk": kk - f0 * m,
        "target": _float(_planes(target, "target", e)),
        "weight": _float(_planes(weight, "weight", e)),
        "t0": np.array(max(t0 - f0, 0), dtype=np.int64),
        "tstamp": tstamp,
        "is_global": np.array(1 if is_global else 0, dtype=np.uint8),
    }
    if snapshot_id is not None:
        arrays["id"] = np.array(_integer(snapshot_id, "snapshot_id"), dtype=np.int64)
    if image_times_s is not None:
        times = _numpy(image_times_s, "image_times_s").astype(np.float64).reshape(-1)
        if (tstamp != np.round(tstamp)).any() or tstamp.min() < 0 or tstamp.max() >= times.size:
            raise ValueError(f"{prefix}.tstamps_ {tstamp.tolist()} cannot index the "
                             f"{times.size} image_times_s given")
        arrays["timestamps_s"] = times[tstamp.astype(np.int64)]
    check_snapshot(arrays, check_values=False)
    return arrays


def check_snapshot(arrays, check_values=True):
    """Checks a dict of patch-graph snapshot arrays; raises ValueError naming the key.

    Always: required keys, shapes (N, M, P from 'patches', E from 'ii'), dtypes, ii/jj in [0, N),
    kk in [0, N*M), ii == kk // M, 0 <= t0 <= N, distinct tstamp values. With check_values also:
    every float finite, weights >= 0, non-zero quaternions, positive focal lengths, positive
    inverse depths at the centre of every patch that an edge names."""
    for key in ("poses", "patches", "intrinsics", "ii", "jj", "kk", "target", "weight", "t0",
                "tstamp"):
        if key not in arrays:
            raise ValueError(f"key '{key}' is missing")
    if np.ndim(arrays["patches"]) != 5:
        raise ValueError(f"key 'patches' has shape {np.shape(arrays['patches'])}, expected "
                         "(N, M, 3, P, P)")
    n, m, _, p, _ = arrays["patches"].shape
    e = np.shape(arrays["ii"])[0] if np.ndim(arrays["ii"]) == 1 else -1
    expected = {"poses": (n, 7), "patches": (n, m, 3, p, p), "intrinsics": (4,), "ii": (e,),
                "jj": (e,), "kk": (e,), "target": (e, 2), "weight": (e, 2), "t0": (),
                "tstamp": (n,), "timestamps_s": (n,), "id": (), "is_global": ()}
    for key, shape in expected.items():
        if key in arrays and np.shape(arrays[key]) != shape:
            raise ValueError(f"key '{key}' has shape {np.shape(arrays[key])}, expected {shape}")
        if key in arrays:
            kind = np.asarray(arrays[key]).dtype.kind
            want = "iu" if key in ("ii", "jj", "kk", "t0", "id", "is_global") else "f"
            if kind not in want:
                raise ValueError(f"key '{key}' has the dtype {np.asarray(arrays[key]).dtype}")
    ii, jj, kk = arrays["ii"], arrays["jj"], arrays["kk"]
    for key, a, hi in (("ii", ii, n), ("jj", jj, n), ("kk", kk, n * m)):
        bad = np.flatnonzero((a < 0) | (a >= hi))
        if bad.size:
            raise ValueError(f"key '{key}': edge {bad[0]} names {a[bad[0]]}, outside [0, {hi})")
    bad = np.flatnonzero(ii != kk // max(m, 1))
    if bad.size:
        raise ValueError(f"key 'ii': edge {bad[0]} has ii = {ii[bad[0]]} but kk // M = "
                         f"{kk[bad[0]] // m}")
    if not 0 <= int(arrays["t0"]) <= n:
        raise ValueError(f"key 't0' is {int(arrays['t0'])}, expected 0 <= t0 <= N = {n}")
    ts = np.sort(np.asarray(arrays["tstamp"]))
    if (ts[1:] == ts[:-1]).any():
        raise ValueError("key 'tstamp' repeats a value: a frame is identified by its tstamp")
    if not check_values:
        return
    for key in ("poses", "patches", "intrinsics", "target", "weight", "tstamp", "timestamps_s"):
        if key in arrays:
            bad = np.argwhere(~np.isfinite(arrays[key]))
            if bad.size:
                raise ValueError(f"key '{key}' has a non-finite value at {tuple(bad[0])}")
    if (arrays["weight"] < 0).any():
        raise ValueError("key 'weight' has a negative value")
    if (np.linalg.norm(arrays["poses"][:, 3:].astype(np.float64), axis=1) == 0).any():
        raise ValueError("key 'poses' has a zero quaternion")
    if not (arrays["intrinsics"][:2] > 0).all():
        raise ValueError(f"key 'intrinsics': focal lengths {arrays['intrinsics'][:2]} must be "
                         "positive")
    d = arrays["patches"].reshape(n * m, 3, p, p)[kk, 2, p // 2, p // 2]
    if e and not (d > 0).all():
        raise ValueError(f"key 'patches': patch {kk[np.flatnonzero(~(d > 0))[0]]} has an "
                         "inverse depth <= 0")


def _file_mode():
    """0666 minus the umask, read without os.umask (which is not thread-safe)."""
    with contextlib.suppress(OSError, ValueError):
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    return 0o644


def save_snapshot(path, arrays, compressed=True):
    """Writes `arrays` to `path` (np.savez's layout) atomically: a hidden temporary file in the
    same directory, then os.replace. On any failure the previous file at `path` is untouched and
    no temporary is left behind."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp",
                               dir=directory)
    try:
        with os.fdopen(fd, "wb") as f:
            method = zipfile.ZIP_DEFLATED if compressed else zipfile.ZIP_STORED
            with zipfile.ZipFile(f, mode="w", compression=method, allowZip64=True) as z:
                for key, value in arrays.items():
                    with z.open(key + ".npy", "w", force_zip64=True) as member:
                        np.lib.format.write_array(member, np.asanyarray(value),
                                                  allow_pickle=False)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, _file_mode())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def _address(x):
    """The address of a tensor's or array's first element, None when it cannot be told."""
    with contextlib.suppress(Exception):
        if callable(getattr(x, "data_ptr", None)):
            return int(x.data_ptr())
        if isinstance(x, np.ndarray):
            return int(x.__array_interface__["data"][0])
    return None


class DpvoHook:
    """What install_hook returns: the wrapper of one DPVO object's BA calls.

    written, failures, skipped  snapshots written; BA calls whose snapshot failed; BA calls on
                                other buffers (DPV-SLAM's structure-only BA of its classic loop
                                closure, another DPVO object), passed through untouched
    last_path                   the last file written
    remove()                    restores fastba.BA and the global-BA method."""

    def __init__(self, dpvo, fastba, out_dir, every, pattern, global_pattern, frames,
                 image_times_s, compressed):
        self.dpvo, self.fastba, self.out_dir = dpvo, fastba, os.fspath(out_dir)
        self.every = _integer(every, "every", minimum=1)
        self.pattern, self.global_pattern = pattern, global_pattern
        self.frames, self.compressed = frames, compressed
        self.image_times_s = None if image_times_s is None else \
            _numpy(image_times_s, "image_times_s").astype(np.float64).reshape(-1)
        self.local_calls = self.global_calls = 0
        self.written = self.failures = self.skipped = 0
        self.last_path = None
        self._global_depth = 0
        self._reported = set()
        self._active = True
        self._original = fastba.BA

        @functools.wraps(self._original)
        def ba(*args, **kwargs):
            result = self._original(*args, **kwargs)  # its exceptions reach DPVO unchanged
            if self._active:
                self._after_ba(args, kwargs)
            return result

        self._wrapper = ba
        fastba.BA = ba
        # DPV-SLAM's global BA is the private DPVO.__run_global_BA (``_DPVO__run_global_BA``
        # once name-mangled); an instance attribute of that name is what ``self.__run_global_BA``
        # finds first, so marking the calls made inside it needs no change to the class.
        self._global_name = "_DPVO__run_global_BA"
        method = getattr(dpvo, self._global_name, None)
        self._global_wrapped = callable(method)
        self._global_wrapper = None
        if self._global_wrapped:
            @functools.wraps(method)
            def run_global_ba(*args, **kwargs):
                self._global_depth += 1
                try:
                    return method(*args, **kwargs)
                finally:
                    self._global_depth -= 1

            self._global_wrapper = run_global_ba
            setattr(dpvo, self._global_name, run_global_ba)

    def remove(self):
        """Stops writing and restores what install_hook replaced (when nothing has wrapped it
        since; otherwise the wrapper stays in place and passes every call through)."""
        self._active = False
        if getattr(self.fastba, "BA", None) is self._wrapper:
            self.fastba.BA = self._original
        if self._global_wrapped:
            with contextlib.suppress(Exception):
                if vars(self.dpvo).get(self._global_name) is self._global_wrapper:
                    del vars(self.dpvo)[self._global_name]

    def _after_ba(self, args, kwargs):
        """Writes the snapshot of one BA call; never raises."""
        sid = None
        try:
            bound = dict(zip(BA_ARGUMENTS, args))
            bound.update((k, v) for k, v in kwargs.items() if k in BA_ARGUMENTS)
            missing = [k for k in BA_ARGUMENTS if k not in bound]
            if missing:
                raise ValueError(f"the BA call has no {', '.join(missing)}")
            g = _graph(self.dpvo)[0]
            mine, theirs = _address(bound["poses"]), _address(getattr(g, "poses_", None))
            if mine is not None and theirs is not None and mine != theirs:
                self.skipped += 1
                return
            is_global = self._global_depth > 0
            if is_global:
                self.global_calls += 1
                sid, pattern = self.global_calls, self.global_pattern
            else:
                self.local_calls += 1
                sid, pattern = self.local_calls, self.pattern
                if (sid - 1) % self.every:
                    return
            arrays = snapshot_from_dpvo(
                self.dpvo, bound["target"], bound["weight"], bound["t0"], ii=bound["ii"],
                jj=bound["jj"], kk=bound["kk"], n=bound["t1"], frames=self.frames,
                snapshot_id=sid, is_global=is_global, image_times_s=self.image_times_s)
            os.makedirs(self.out_dir, exist_ok=True)
            path = os.path.join(self.out_dir, pattern.format(sid))
            self.last_path = save_snapshot(path, arrays, compressed=self.compressed)
            self.written += 1
        except Exception as exc:  # noqa: BLE001 -- the hook must never stop DPVO
            self.failures += 1
            text = _text(exc)
            kind = (type(exc).__name__, re.sub(r"[0-9]+", "#", text.split(":")[0]))
            if kind not in self._reported:
                self._reported.add(kind)
                with contextlib.suppress(Exception):
                    warnings.warn(f"dbacov_dpvo: snapshot {sid} not written "
                                  f"({type(exc).__name__}: {text}); DPVO goes on, further "
                                  "failures of this kind are not reported", RuntimeWarning,
                                  stacklevel=3)


def install_hook(dpvo, out_dir, every=1, fastba=None, pattern="dpvo_{:06d}.npz",
                 global_pattern="dpvo_global_{:06d}.npz", frames="graph", image_times_s=None,
                 compressed=True):
    """Writes a snapshot after every `every`-th BA of `dpvo`'s VO (``pattern``: local BA number
    1, 1 + every, ...) and after every global BA of DPV-SLAM (``global_pattern``, numbered on
    their own), into `out_dir`. Returns a DpvoHook (``.remove()``).

    fastba   the module whose ``BA`` DPVO calls (default: the ``fastba`` that the module defining
             type(dpvo) imported, i.e. ``dpvo.fastba``). Its BA is replaced by a wrapper that runs
             the BA, then writes snapshot_from_dpvo of that call's arguments.
    frames, image_times_s  as snapshot_from_dpvo.

    Install it once the DPVO object exists (in DPVO's demo.py, right after ``DPVO(cfg, ...)``).
    A bad argument is a ValueError here; afterwards nothing reaches DPVO but the BA's own
    results."""
    if fastba is None:
        module = sys.modules.get(type(dpvo).__module__)
        fastba = getattr(module, "fastba", None)
    if not callable(getattr(fastba, "BA", None)):
        raise ValueError(f"no fastba module with a BA function found for {type(dpvo).__name__} "
                         f"(module {type(dpvo).__module__}): pass fastba=")
    if frames not in ("graph", "all"):
        raise ValueError(f"frames is {frames!r}, expected 'graph' or 'all'")
    for name, value in (("pattern", pattern), ("global_pattern", global_pattern)):
        try:
            value.format(1)
        except (AttributeError, IndexError, KeyError, ValueError):
            raise ValueError(f"{name} is {value!r}, expected a format with one field") from None
    return DpvoHook(dpvo, fastba, out_dir, every, pattern, global_pattern, frames,
                    image_times_s, compressed)
