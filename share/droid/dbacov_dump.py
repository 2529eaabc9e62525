"""Dump DROID-SLAM's dense-bundle-adjustment (DBA) factor graph as dbacov snapshots.

One snapshot is the DBA factor graph of one frontend update, written as one `.npz` file in the
interchange format of conventions §1 (dbacov's ``docs/conventions.md``), which
``dba-covariance`` reads:

    poses        float32 (N,7)      T_cw as [tx ty tz qx qy qz qw] (lietorch order)
    disps        float32 (N,H,W)    inverse depth at 1/8 resolution
    intrinsics   float32 (4,)       fx fy cx cy of the H×W grid (already divided by 8)
    ii, jj       int64   (E,)       edge e: source keyframe ii[e] -> target keyframe jj[e]
    target       float32 (E,2,H,W)  predicted pixel coordinates in frame jj[e]; channel 0 = x
    weight       float32 (E,2,H,W)  confidences; channel 0 = x (column), channel 1 = y (row)
    tstamp       float64 (N,)       DROID's keyframe time stamp (image index)
    timestamps_s float64 (N,)       optional: keyframe times in seconds
    id           int64   ()         snapshot counter
    t0           int64   ()         DROID's first optimized pose, max(1, min(ii) + 1)
    disps_sens   float32 (N,H,W)    RGB-D only: sensor inverse depth (1/m), 0 = none
    stereo_rig   float64 (7,)       stereo only: transform of the ii == jj edges (DROID: -0.1 in x)

``tstamp`` is the keyframes' true image index whatever the DROID release (KeyframeRecord corrects
the stale ``video.tstamp`` of releases before 2025 after ``rm_keyframe``).

DROID keeps targets and weights as (1,E,H,W,2) with the last axis (x, y); they are transposed to
(E,2,H,W), never swapped. N is ``video.counter.value``: the keyframes in the buffer.

Where to call it
----------------
In DROID-SLAM's ``droid_slam/droid_frontend.py``, method ``DroidFrontend._update`` (current
DROID-SLAM; ``__update`` in releases before 2025), right after its last DBA, i.e. after the
``if d.item() < ...: / else:`` block that ends with ``self.graph.update(None, None,
use_inactive=True)``, before "set pose for next iteration" (with ``share/droid`` on
``PYTHONPATH``)::

            for itr in range(self.iters2):
                self.graph.update(None, None, use_inactive=True)

        self.dumper(self.video, self.graph, self.count)  # a DbaDumper made in __init__

        # set pose for next itration
        self.video.poses[self.t1] = self.video.poses[self.t1-1]

At that point poses and disparities are the DBA solution, and ``graph.target``/``graph.weight``
are the targets and confidences that DBA used. When the frontend has just dropped a keyframe
(``rm_keyframe``), buffers and edges are already renumbered consistently.

Not dumped, on purpose: DROID's Levenberg-Marquardt damping (``lm``, ``ep``) and its learned
per-pixel depth damping (eta, ``graph.damping``). They are solver aids, not measurements, and are
not part of the information matrix (conventions §2).

Inactive edges: with ``use_inactive=True`` DROID's frontend DBA also uses the stored, no longer
updated edges ``graph.ii_inac``/``jj_inac`` whose keyframes are >= t0 - 3 (t0 = min(ii) + 1). By
default only the active edges ``graph.ii``/``jj`` are dumped; ``include_inactive=True`` adds the
inactive ones with DROID's own selection rule, so that the dump is exactly the factor set of that
DBA call.

DROID's global BA (``DroidBackend``, run twice by ``Droid.terminate``; ``DroidAsyncBackend``):
``install_backend_hook(dumper)`` writes ``global_NNNNNN.npz`` right after each
``FactorGraph.update_lowmem`` of a backend call, before the backend drops its edges; the factor
set is the backend's graph (its proximity edges, plus every inactive edge when update_lowmem is
given ``use_inactive=True``) and ``t0`` is 1, what update_lowmem holds (dump_global_ba).

Forks: GO-SLAM's ``video.timestamp`` is read when there is no ``video.tstamp``. DBA-Fusion's
``tstamp`` holds times in seconds (non-integral values): they are mapped to image indices through
``image_times_s``, and refused without it (KeyframeTimeError saying so), never taken as indices.

Every attribute is checked before use: a missing one, None, a wrong type, dtype or shape is a
ValueError naming it (``video.poses has shape (8, 6), expected (slots, 7)``), never another
exception (``share/droid/tests/fuzz_hook.py`` fuzzes this).

numpy is required; torch is not imported: tensors are read through ``.detach().cpu().numpy()``,
numpy arrays are taken as they are.
"""

import contextlib
import functools
import hashlib
import inspect
import operator
import os
import re
import sys
import tempfile
import threading
import zipfile

import numpy as np

__all__ = ["dump_dba_snapshot", "check_snapshot", "write_snapshot_npz", "to_numpy",
           "KeyframeRecord", "KeyframeTimeError", "DbaDumper", "read_euroc_image_times",
           "snapshot_arrays", "exception_text", "read_real", "keyframe_count",
           "dump_global_ba", "install_backend_hook", "DROID_STEREO_RIG"]

#: The fixed transform DROID-SLAM's BA applies on an edge with ii == jj (droid_kernels.cu: the
#: second camera of the stereo pair sits at tij = (-0.1, 0, 0), no rotation),
#: [tx ty tz qx qy qz qw].
DROID_STEREO_RIG = np.array([-0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])


def exception_text(exc):
    """str(exc), or what can be said of it when its own __str__ fails (a hook must never raise
    while it reports a failure)."""
    try:
        return str(exc)
    except Exception:  # noqa: BLE001 -- any failure of a foreign __str__
        return f"<{type(exc).__name__} whose message cannot be printed: its __str__ raised>"


def to_numpy(x):
    """A private numpy copy of a torch tensor (any device) or of anything np.asarray accepts."""
    if hasattr(x, "detach"):
        x = x.detach().cpu().numpy()
    return np.array(x, copy=True)


def _torch_dtype(x):
    """The dtype name of a torch tensor ('float32', 'bfloat16', ...), None for anything else."""
    if not hasattr(x, "detach"):
        return None
    text = str(getattr(x, "dtype", ""))
    return text[len("torch."):] if text.startswith("torch.") else None


def read_real(x, name, integer=False):
    """to_numpy(x), refusing (ValueError naming `name`) what a conversion to the snapshot dtypes
    would silently change: a masked array (its mask), complex values (the imaginary part),
    booleans and non-numeric dtypes; with `integer`, values that are not integers (a float 1.7
    would become 1; integral floats such as 2.0 are accepted) or beyond int64. What cannot be
    read as an array at all (None, a ragged list, an object) is refused the same way."""
    if x is None:
        raise ValueError(f"{name} is None, expected an array of real numbers (a tensor)")
    if isinstance(x, np.ma.MaskedArray):
        raise ValueError(f"{name} is a NumPy masked array: its mask would be ignored; pass a "
                         "plain array")
    dtype = _torch_dtype(x)
    if dtype is not None and dtype.startswith("complex"):  # before .numpy(), which may fail
        raise ValueError(f"{name} has the complex dtype {dtype}: its imaginary part would be "
                         "dropped; expected real numbers")
    if dtype == "bfloat16":  # NumPy has no bfloat16; float32 holds every value exactly
        x = x.detach().float()
    try:
        a = to_numpy(x)
    except (TypeError, ValueError, RuntimeError, OverflowError) as exc:
        raise ValueError(f"{name} cannot be read as an array ({type(x).__name__}): "
                         f"{exception_text(exc)}") from None
    if a.dtype.kind == "c":
        raise ValueError(f"{name} has the complex dtype {a.dtype}: its imaginary part would be "
                         "dropped; expected real numbers")
    if a.dtype.kind not in "iuf":
        raise ValueError(f"{name} has the dtype {a.dtype}, expected real numbers (a float or "
                         "integer dtype)")
    if integer and a.dtype.kind == "f":
        bad = np.flatnonzero(~np.isfinite(a) | (a != np.round(a)))
        if bad.size:
            raise ValueError(f"{name}[{bad[0]}] is {a.reshape(-1)[bad[0]]!r}, not a keyframe "
                             "index: expected integers (integral floats such as 2.0 are "
                             "accepted; a fraction is never rounded)")
    if integer and a.dtype.kind in "fu":
        bad = np.flatnonzero(a.reshape(-1) >= 2.0 ** 63) if a.dtype.kind == "u" else \
            np.flatnonzero(np.abs(a.reshape(-1)) >= 2.0 ** 63)
        if bad.size:
            raise ValueError(f"{name}[{bad[0]}] is {a.reshape(-1)[bad[0]]!r}, beyond the int64 "
                             "range of keyframe indices")
    return a


def _integer(value, name, minimum=None):
    """An integer argument or counter (int, NumPy integer, 0-d integer tensor) as a Python int in
    the int64 range; anything else (a bool, a float, a string, None) is a ValueError naming it."""
    if isinstance(value, (bool, np.bool_)):
        ok = False
    else:
        try:
            value = operator.index(value)
            ok = -2 ** 63 <= value < 2 ** 63
        except TypeError:
            ok = False
    if not ok:
        raise ValueError(f"{name} is {value!r} ({type(value).__name__}), expected an integer "
                         "in the int64 range")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} is {value}, expected at least {minimum}")
    return value


def keyframe_count(video):
    """N, the keyframes in use: DROID's `video.counter.value` (a multiprocessing Value), checked.
    A missing counter, a value that is not an integer, or N < 1 is a ValueError naming it."""
    counter = getattr(video, "counter", None)
    value = getattr(counter, "value", None)
    if value is None:
        raise ValueError("video.counter.value is missing: expected the number of keyframes "
                         "(DROID's DepthVideo.counter, a multiprocessing Value)")
    n = _integer(value, "video.counter.value")
    if n < 1:
        raise ValueError(f"video.counter.value is {n}: the video holds no keyframe (expected at "
                         "least 1)")
    return n


def _shape(x, name):
    """(x, its shape as a tuple of ints): tensors and arrays as they are, anything else
    (a list) read as an array first."""
    if x is None:
        raise ValueError(f"{name} is missing (None or no such attribute)")
    shape = getattr(x, "shape", None)
    if shape is None or not hasattr(x, "__getitem__"):
        x = read_real(x, name)
        shape = x.shape
    try:
        return x, tuple(int(d) for d in shape)
    except (TypeError, ValueError):
        raise ValueError(f"{name} has the shape {shape!r}, which is not a tuple of sizes") from None


def _spelled(shape):
    return "(" + ", ".join(str(d) for d in shape) + ("," if len(shape) == 1 else "") + ")"


def _slots(video, name, n, tail):
    """video.name[:n] of a DROID buffer whose first axis is the keyframe slot, as read by
    read_real; `tail` is the shape of one slot (None = any size). The buffer must hold at least
    the N keyframes."""
    full = f"video.{name}"
    x, shape = _shape(getattr(video, name, None), full)
    if len(shape) != 1 + len(tail) or any(d is not None and d != s
                                          for d, s in zip(tail, shape[1:])):
        expected = ("slots",) + tuple("*" if d is None else d for d in tail)
        raise ValueError(f"{full} has shape {_spelled(shape)}, expected {_spelled(expected)}")
    if shape[0] < n:
        raise ValueError(f"{full} has {shape[0]} slots, fewer than the video.counter.value = "
                         f"{n} keyframes")
    return read_real(x[:n], full)


def _planes(graph, name, edges, like=None):
    """graph.name as DROID keeps it, (1,E,H,W,2), with E = `edges`: (the object, its shape).
    `like` = (other name, its shape): the H x W grid must be the other's."""
    x, shape = _shape(getattr(graph, name, None), f"graph.{name}")
    if len(shape) != 5 or shape[0] != 1 or shape[1] != edges or shape[4] != 2:
        ii = "ii_inac" if name.endswith("_inac") else "ii"
        raise ValueError(f"graph.{name} has shape {_spelled(shape)}, expected (1,E,H,W,2) with "
                         f"E = {edges} (the edges of graph.{ii})")
    if like is not None and shape[2:4] != like[1][2:4]:
        raise ValueError(f"graph.{name} has shape {_spelled(shape)}: its H x W grid "
                         f"{shape[2]} x {shape[3]} is not graph.{like[0]}'s {like[1][2]} x "
                         f"{like[1][3]}")
    return x, shape


def _plane_layout(a, name):
    """(1,E,H,W,2) as DROID stores it -> contiguous (E,2,H,W), channel order (x, y) kept."""
    if a.ndim != 5 or a.shape[0] != 1 or a.shape[4] != 2:
        raise ValueError(f"graph.{name} has shape {tuple(a.shape)}, expected (1,E,H,W,2)")
    return np.ascontiguousarray(a[0].transpose(0, 3, 1, 2))


def _edge_indices(graph, names, n):
    """graph.ii / graph.jj (or their _inac pair) as int64 (E,), checked for the same E and for
    keyframes in [0, n)."""
    out = []
    for name in names:
        x, shape = _shape(getattr(graph, name, None), f"graph.{name}")
        if len(shape) != 1:
            raise ValueError(f"graph.{name} has shape {_spelled(shape)}, expected (E,)")
        a = read_real(x, f"graph.{name}", integer=True).astype(np.int64)
        bad = np.flatnonzero((a < 0) | (a >= n))
        if bad.size:
            raise ValueError(f"graph.{name}[{bad[0]}] names keyframe {a[bad[0]]}, outside [0, {n})"
                             f" (video.counter.value = {n} keyframes)")
        out.append(a)
    if out[0].size != out[1].size:
        raise ValueError(f"graph.{names[1]} has {out[1].size} edges but graph.{names[0]} has "
                         f"{out[0].size}: expected one index pair per edge")
    return out


def _lock(video):
    """video.get_lock(), DROID's lock of the video's buffers, checked to be a context manager."""
    get_lock = getattr(video, "get_lock", None)
    if not callable(get_lock):
        raise ValueError("video.get_lock is missing or not callable: expected DROID's "
                         "DepthVideo.get_lock() (the lock of its buffers)")
    lock = get_lock()
    if not (hasattr(lock, "__enter__") and hasattr(lock, "__exit__")):
        raise ValueError(f"video.get_lock() returned {type(lock).__name__}, expected a lock "
                         "(a context manager)")
    return lock


def _where(key, index):
    """An element of a snapshot array in words, independent of the layout it was converted from."""
    index = [int(i) for i in index]
    if key in ("target", "weight"):
        e, c, y, x = index
        return f"edge {e}, channel {'xy'[c]}, pixel (x={x}, y={y})"
    if key == "disps":
        return f"keyframe {index[0]}, pixel (x={index[2]}, y={index[1]})"
    return "index " + str(tuple(index))


def check_snapshot(arrays, check_values=True, names=None):
    """Checks a dict of conventions §1 arrays; raises ValueError naming the key and what was
    expected.

    Always: shapes agree (N from 'poses', E from 'ii', H,W from 'disps'), ii/jj in [0, N) and
    ii != jj unless a 'stereo_rig' transform is given (a stereo edge). With check_values also:
    every float finite, weights >= 0, quaternions of non-zero norm, positive focal lengths.
    `names` maps keys to the names used in messages.
    """
    def k_(key):
        return "key '" + (names or {}).get(key, key) + "'"

    n = arrays["poses"].shape[0]
    e = arrays["ii"].shape[0]
    h, w = arrays["disps"].shape[1:]
    expected = {"poses": (n, 7), "disps": (n, h, w), "intrinsics": (4,), "ii": (e,), "jj": (e,),
                "target": (e, 2, h, w), "weight": (e, 2, h, w), "tstamp": (n,),
                "timestamps_s": (n,), "id": (), "disps_sens": (n, h, w), "stereo_rig": (7,),
                "t0": ()}
    for key, shape in expected.items():
        if key in arrays and arrays[key].shape != shape:
            raise ValueError(f"{k_(key)} has shape {arrays[key].shape}, expected {shape}")
    for key in ("ii", "jj"):
        bad = np.flatnonzero((arrays[key] < 0) | (arrays[key] >= n))
        if bad.size:
            k = bad[0]
            raise ValueError(f"{k_(key)}: edge {k} names keyframe {arrays[key][k]}, "
                             f"outside [0, {n}) (N = {n} keyframes)")
    if "tstamp" in arrays:
        # dbacov identifies a keyframe by its tstamp (image index): every tool refuses repeats.
        ts = np.asarray(arrays["tstamp"]).reshape(-1)
        order = np.argsort(ts, kind="stable")
        dup = np.flatnonzero(ts[order][1:] == ts[order][:-1])
        if dup.size:
            a, b = sorted((int(order[dup[0]]), int(order[dup[0] + 1])))
            raise ValueError(f"{k_('tstamp')} gives keyframes {a} and {b} the same value "
                             f"{ts[a]:g}: a keyframe is identified by its tstamp (the image "
                             "index), expected distinct values")
    same = np.flatnonzero(arrays["ii"] == arrays["jj"])
    if same.size and "stereo_rig" not in arrays:
        k = same[0]
        raise ValueError(f"{k_('ii')} and {k_('jj')}: edge {k} links keyframe "
                         f"{arrays['ii'][k]} to itself (a stereo edge needs the rig transform "
                         "'stereo_rig')")
    if not check_values:
        return
    for key in ("poses", "disps", "intrinsics", "target", "weight", "tstamp", "timestamps_s",
                "disps_sens", "stereo_rig"):
        if key in arrays:
            bad = np.argwhere(~np.isfinite(arrays[key]))
            if bad.size:
                raise ValueError(f"{k_(key)} has a non-finite value at {_where(key, bad[0])}")
    bad = np.argwhere(arrays["weight"] < 0)
    if bad.size:
        raise ValueError(f"{k_('weight')} has a negative value at {_where('weight', bad[0])}")
    bad = np.flatnonzero(np.linalg.norm(arrays["poses"][:, 3:].astype(np.float64), axis=1) == 0)
    if bad.size:
        raise ValueError(f"{k_('poses')}: keyframe {bad[0]} has a zero quaternion")
    if not (arrays["intrinsics"][:2] > 0).all():
        raise ValueError(f"{k_('intrinsics')}: focal lengths {arrays['intrinsics'][:2]} "
                         "must be positive")


def _file_mode():
    """0666 minus the umask, read without os.umask (which is not thread-safe)."""
    with contextlib.suppress(OSError, ValueError):
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    return 0o644


def write_snapshot_npz(path, arrays, compressed=True):
    """Writes `arrays` to `path` atomically: a hidden temporary file in the same directory, then
    os.replace. On failure the previous file is untouched and no temporary is left behind."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp",
                               dir=directory)
    try:
        with os.fdopen(fd, "wb") as f:
            # np.savez's layout (one NAME.npy member per array, zip64), but with the archive
            # closed on every path: np.savez leaves its ZipFile open when a write fails (a full
            # disk), and its __del__ then prints a traceback at every update.
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


class KeyframeTimeError(ValueError):
    """The keyframes' frame indices cannot be established (the dump refuses to guess)."""


def _fingerprint(image):
    """A short digest of one keyframe image (subsampled), to recognise a slot after a shift."""
    a = read_real(image, "video.images")
    return hashlib.blake2b(np.ascontiguousarray(a[..., ::4, ::4]).tobytes(),
                           digest_size=16).digest()


#: Two times closer than this (seconds) are the same image's: far below any camera's frame period,
#: far above the rounding of a time in seconds since 1970 held in float64 (about 2e-7 s).
IMAGE_TIME_TOLERANCE_S = 1e-4


def _time_stamps(video):
    """(name, buffer) of the keyframes' time stamps: DROID's `video.tstamp`, or GO-SLAM's
    `video.timestamp` when the video has no `tstamp`."""
    for name in ("tstamp", "timestamp"):
        x = getattr(video, name, None)
        if x is not None:
            return name, x
    raise ValueError("video.tstamp is missing (None or no such attribute), and so is "
                     "video.timestamp (GO-SLAM's name): expected the keyframes' time stamps")


def _image_times(image_times_s):
    """image_times_s as float64 (M,), checked."""
    times = read_real(image_times_s, "image_times_s").astype(np.float64)
    if times.ndim != 1:
        raise ValueError(f"image_times_s has shape {_spelled(times.shape)}, expected (images,): "
                         "the time in seconds of every input image, by image index")
    return times


def _indices_of_times(stamps, times, name):
    """The image index whose time (image_times_s) is within IMAGE_TIME_TOLERANCE_S of each stamp
    (seconds), as int64; a stamp that matches no image time raises KeyframeTimeError."""
    if times.size == 0:
        raise KeyframeTimeError(f"{name} holds times in seconds but image_times_s is empty: "
                                "expected the time of every input image")
    order = np.argsort(times, kind="stable")
    sorted_times = times[order]
    right = np.clip(np.searchsorted(sorted_times, stamps), 0, times.size - 1)
    left = np.clip(right - 1, 0, times.size - 1)
    near = np.where(np.abs(sorted_times[left] - stamps) <= np.abs(sorted_times[right] - stamps),
                    left, right)
    gap = np.abs(sorted_times[near] - stamps)
    bad = np.flatnonzero(~(gap <= IMAGE_TIME_TOLERANCE_S))
    if bad.size:
        k = int(bad[0])
        raise KeyframeTimeError(f"{name}[{k}] = {stamps[k]:.6f} s matches no image time: the "
                                f"nearest is image {int(order[near[k]])} at "
                                f"{sorted_times[near[k]]:.6f} s (tolerance "
                                f"{IMAGE_TIME_TOLERANCE_S:g} s); image_times_s must be the times "
                                "of the images DROID was fed")
    return order[near].astype(np.int64)


class KeyframeRecord:
    """The true image (frame) index of every keyframe slot of one DepthVideo, kept by the hook.

    DROID's `video.tstamp[k]` is the image index of keyframe slot k, written when the frame is
    appended. `FactorGraph.rm_keyframe(ix)` shifts every buffer down by one slot above ix. DROID
    releases before 2025 do not shift `tstamp` (checked on the 2022 release: its frontend calls
    `rm_keyframe(t1 - 2)`), so from then on the kept keyframes carry the removed ones' time stamps;
    current DROID shifts it (and removes `t1 - 3`). The record tells the two apart at every call:

    * the slot beyond the counter still holds the last appended keyframe's time stamp after a
      removal: equal to `tstamp[N-1]` when DROID shifted it, larger when it did not (stale);
    * the record of the previous call: unchanged slots must keep their frame index, the new one is
      larger than every recorded one;
    * with `video.images` (every DROID release), a digest of the newest `window` images locates
      the removed slot exactly; without images the 2022 release's rule (the removed slot is the
      second newest, `t1 - 2`) is used.

    A stale shift is corrected; anything inconsistent raises KeyframeTimeError (never a silent
    wrong match against ground truth). One record per DepthVideo, called once per frontend update.
    """

    def __init__(self, window=8):
        self.window = int(window)
        self.frames = None  # np.int64 (N,): the truth at the previous call
        self.prints = {}    # slot -> image digest at the previous call (newest `window` slots)
        self.stale = False  # DROID's tstamp went stale (unshifted removal seen)
        self.stale_corrections = 0

    def _digests(self, video, n):
        images = getattr(video, "images", None)
        if images is None:
            return {}
        images, shape = _shape(images, "video.images")
        if len(shape) < 3 or shape[0] < n:
            raise ValueError(f"video.images has shape {_spelled(shape)}, expected (slots, 3, 8H, "
                             f"8W) with at least the video.counter.value = {n} slots")
        return {k: _fingerprint(images[k]) for k in range(max(0, n - self.window), n)}

    def update(self, video, image_times_s=None):
        """The frame index of keyframe slots 0..N-1 now (np.int64), updating the record.

        The time stamps are `video.tstamp` (DROID), or `video.timestamp` (GO-SLAM) when there is
        no `tstamp`. Stamps that are not integers are times in seconds (DBA-Fusion's `tstamp`):
        they are mapped to image indices through `image_times_s` (the time of every input image,
        by index), and refused (KeyframeTimeError naming the fork) without it."""
        n = keyframe_count(video)
        name, buffer = _time_stamps(video)
        buffer, shape = _shape(buffer, f"video.{name}")
        if len(shape) != 1:
            raise KeyframeTimeError(f"video.{name} has shape {_spelled(shape)}, expected "
                                    "(slots,): one time stamp per keyframe slot")
        if shape[0] < n:
            raise KeyframeTimeError(f"video.{name} has {shape[0]} slots, fewer than the "
                                    f"video.counter.value = {n} keyframes")
        ts = read_real(buffer[:n + 1], f"video.{name}").astype(np.float64)
        bad = np.flatnonzero(~np.isfinite(ts[:n]))
        if bad.size:
            raise KeyframeTimeError(f"video.{name}[{bad[0]}] is {ts[bad[0]]!r}: expected the "
                                    "keyframe's image index, a finite number")
        ghost = ts[n] if ts.size > n and np.isfinite(ts[n]) else None
        fraction = np.flatnonzero(ts[:n] != np.round(ts[:n]))
        if fraction.size:
            k = int(fraction[0])
            if image_times_s is None:
                raise KeyframeTimeError(
                    f"video.{name} holds times in seconds, not image indices: keyframe {k} has "
                    f"{ts[k]:.6f}, not an integer; this looks like DBA-Fusion, whose tstamp is "
                    "in seconds; pass image_times_s= (the time of every input image, by index, "
                    "e.g. read_euroc_image_times('cam0/data.csv')) so that the keyframes' image "
                    "indices can be found")
            times = _image_times(image_times_s)
            view = _indices_of_times(ts[:n], times, f"video.{name}")
            if ghost is not None:  # beyond the counter: an image's time, or left over (None)
                try:
                    ghost = int(_indices_of_times(np.array([ghost]), times, "")[0])
                except KeyframeTimeError:
                    ghost = None
        else:
            big = np.flatnonzero(np.abs(ts[:n]) >= 2.0 ** 53)
            if big.size:
                raise KeyframeTimeError(f"video.{name}[{big[0]}] is {ts[big[0]]:g}, beyond the "
                                        "integers that a float64 holds exactly (2**53): not an "
                                        "image index")
            view = ts[:n].astype(np.int64)
            ghost = int(ghost) if ghost is not None and ghost == np.round(ghost) and \
                abs(ghost) < 2.0 ** 53 else None
        prints = self._digests(video, n)
        prev = self.frames
        if prev is None:
            if ghost is not None and ghost > view[-1]:
                # A removal in this very update left DROID's tstamp unshifted (pre-2025).
                frames = np.delete(np.append(view, ghost), self._removed_slot(n, prints))
                self.stale, self.stale_corrections = True, self.stale_corrections + 1
            else:
                frames = view
        elif n == prev.size + 1:  # one keyframe appended: its tstamp is fresh in every release
            frames = np.append(prev, view[-1])
            if not self.stale and not np.array_equal(view[:-1], prev):
                raise KeyframeTimeError(self._disagree(prev, view, name))
        elif n == prev.size and ghost is not None and ghost > prev[-1]:
            # A keyframe appended (its index survives beyond the counter) and one removed.
            shifted = None
            if not self.stale:
                k = int(np.flatnonzero(np.append(view[:-1] != prev[:-1], True))[0])
                if np.array_equal(view, np.append(np.delete(prev, k), ghost)):
                    shifted = view  # current DROID shifted tstamp: it is the truth
            if shifted is not None:
                frames = shifted
            else:
                frames = np.append(np.delete(prev, self._removed_slot(n, prints)), ghost)
                self.stale, self.stale_corrections = True, self.stale_corrections + 1
        elif n == prev.size:  # called again without a new keyframe
            frames = prev
            if not self.stale and not np.array_equal(view, prev):
                raise KeyframeTimeError(self._disagree(prev, view, name))
        else:
            raise KeyframeTimeError(f"the keyframe count went from {prev.size} to {n} between "
                                    "two calls: call the hook once per frontend update")
        frames = np.asarray(frames, dtype=np.int64)
        if n > 1 and (np.diff(frames) <= 0).any():
            k = int(np.flatnonzero(np.diff(frames) <= 0)[0])
            raise KeyframeTimeError(f"keyframe frame indices are not increasing: slot {k} = "
                                    f"{frames[k]}, slot {k + 1} = {frames[k + 1]}")
        self.frames, self.prints = frames, prints
        return frames.copy()

    @staticmethod
    def _disagree(prev, view, name="tstamp"):
        k = int(np.flatnonzero(view[:prev.size] != prev[:view.size])[0])
        return (f"video.{name}[{k}] = {view[k]} but the record says frame {prev[k]}: keyframes "
                "changed outside the frontend update (one record per DepthVideo)")

    def _removed_slot(self, n, prints):
        """Slot (old numbering) that rm_keyframe removed in this update, for an unshifted tstamp."""
        if prints and self.prints:
            for k in sorted(prints):
                if k in self.prints and prints[k] != self.prints[k]:
                    return k
            raise KeyframeTimeError("a keyframe was removed but no keyframe image changed: "
                                    "cannot locate it to correct DROID's unshifted tstamp")
        return n - 1  # DROID 2022 frontend: rm_keyframe(t1 - 2), the newest slot before


def read_euroc_image_times(csv_path):
    """Image times in seconds, in image order, from a EuRoC `cam0/data.csv` (ns,filename rows;
    '#' comments). Frame index k of DROID's EuRoC reader is row k."""
    times = []
    with open(csv_path) as f:
        for line_no, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            try:
                times.append(int(line.split(",")[0]) * 1e-9)
            except ValueError:
                raise ValueError(f"{csv_path}:{line_no}: expected 'timestamp_ns,filename', "
                                 f"got {line!r}") from None
    return np.asarray(times, dtype=np.float64)


def dump_dba_snapshot(path, video, graph, snapshot_id, timestamps_s=None, compressed=True,
                      include_inactive=False, record=None, image_times_s=None, stereo_rig=None,
                      t0=None):
    arrays = snapshot_arrays(video, graph, snapshot_id, timestamps_s=timestamps_s,
                             include_inactive=include_inactive, record=record,
                             image_times_s=image_times_s, stereo_rig=stereo_rig, t0=t0)
    write_snapshot_npz(path, arrays, compressed)
    return path


dump_dba_snapshot.__doc__ = None  # set below, shared with snapshot_arrays


def snapshot_arrays(video, graph, snapshot_id=None, timestamps_s=None, include_inactive=False,
                    record=None, image_times_s=None, stereo_rig=None, t0=None):
    """Writes the current DBA factor graph of DROID-SLAM to `path` (conventions §1 `.npz`,
    atomically).

    video         DROID's DepthVideo: poses (≥N,7) T_cw, disps (≥N,H,W), intrinsics (≥N,4),
                  tstamp (≥N,), counter.value = N, get_lock(); optional disps_sens (≥N,H,W)
                  (RGB-D), images (to locate removed keyframes), stereo. GO-SLAM's
                  `timestamp` is read when there is no `tstamp`; a `tstamp` in seconds
                  (DBA-Fusion's) needs `image_times_s`.
    graph         DROID's FactorGraph: ii, jj (E,), target, weight (1,E,H,W,2), last axis (x, y).
    snapshot_id   stored as 'id' (int64 scalar); None leaves 'id' out.
    timestamps_s  optional keyframe times in seconds, N values; stored as float64 'timestamps_s'.
    image_times_s optional time in seconds of every input image, indexed by image (frame) index
                  (for EuRoC: read_euroc_image_times("cam0/data.csv")); gives 'timestamps_s'.
    record        a KeyframeRecord kept across calls (one per video): corrects the stale `tstamp`
                  of pre-2025 DROID after rm_keyframe. Without one, a fresh record still detects
                  (and corrects) a removal in this very update.
    stereo_rig    the transform of edges with ii == jj, [tx ty tz qx qy qz qw]; default DROID's
                  DROID_STEREO_RIG when the video is stereo (video.stereo), written only when
                  such edges exist. Such edges on a video that is not stereo, without stereo_rig,
                  are refused (ValueError) rather than given DROID's rig.
    compressed    np.savez_compressed (default) or np.savez.
    include_inactive  also dump the inactive edges that DROID's DBA used (see the module doc).
    t0            the first pose the BA optimized (it held every pose below); None = the
                  frontend's rule, max(1, min(ii) + 1) over the active edges. DROID's global BA
                  (FactorGraph.update_lowmem) uses 1: see dump_global_ba.

    Extra keys: 't0' (int64, DROID's first optimized pose of this update, max(1, min(ii) + 1)
    over the active edges unless given), 'disps_sens' (float32 (N,H,W), only when some value is
    > 0) and 'stereo_rig' (float64 (7,), only with ii == jj edges).

    Raises ValueError, before writing anything, when an attribute is missing or has the wrong
    type, dtype or shape (naming it), when the intrinsics of the N keyframes differ, when an edge
    names a keyframe outside [0, N), and KeyframeTimeError when the keyframe frame indices cannot
    be established. Returns `path`.
    """
    times = None if image_times_s is None else _image_times(image_times_s)
    sid = None if snapshot_id is None else _integer(snapshot_id, "snapshot_id")
    fixed_t0 = None if t0 is None else _integer(t0, "t0", minimum=0)
    with _lock(video):
        n = keyframe_count(video)
        poses = _slots(video, "poses", n, (7,))
        disps = _slots(video, "disps", n, (None, None))
        intrinsics = _slots(video, "intrinsics", n, (4,))
        frames = (record if record is not None else KeyframeRecord()).update(
            video, image_times_s=times)
        sens = None
        if getattr(video, "disps_sens", None) is not None:
            sens = _slots(video, "disps_sens", n, disps.shape[1:])
        ii, jj = _edge_indices(graph, ("ii", "jj"), n)
        target, shape = _planes(graph, "target", ii.size)
        weight, _ = _planes(graph, "weight", ii.size, like=("target", shape))
        if shape[2:4] != disps.shape[1:]:
            raise ValueError(f"graph.target has shape {_spelled(shape)}: its H x W grid "
                             f"{shape[2]} x {shape[3]} is not video.disps' {disps.shape[1]} x "
                             f"{disps.shape[2]}")
        target = read_real(target, "graph.target")
        weight = read_real(weight, "graph.weight")
        t0 = fixed_t0 if fixed_t0 is not None else \
            (max(1, int(ii.min()) + 1) if ii.size else None)
        if include_inactive and t0 is not None:
            # DROID's FactorGraph.update(use_inactive=True): inactive edges first, then active,
            # those whose keyframes are both >= t0 - 3 (with t0 = 1, update_lowmem's: all).
            ii_inac, jj_inac = _edge_indices(graph, ("ii_inac", "jj_inac"), n)
            keep = np.flatnonzero((ii_inac >= t0 - 3) & (jj_inac >= t0 - 3))
            planes = []
            for name in ("target_inac", "weight_inac"):
                like = ("target", (1, ii_inac.size) + shape[2:])
                x, _ = _planes(graph, name, ii_inac.size, like=like)
                planes.append(read_real(x[:, keep], f"graph.{name}"))
            ii = np.concatenate([ii_inac[keep], ii])
            jj = np.concatenate([jj_inac[keep], jj])
            target = np.concatenate([planes[0], target], axis=1)
            weight = np.concatenate([planes[1], weight], axis=1)

    same = (intrinsics == intrinsics[0]) | (np.isnan(intrinsics) & np.isnan(intrinsics[0]))
    differs = np.flatnonzero(~same.all(axis=1))
    if differs.size:
        k = differs[0]
        raise ValueError(f"video.intrinsics differ between keyframes: row {k} = {intrinsics[k]} "
                         f"but row 0 = {intrinsics[0]}; a snapshot has one camera (fx fy cx cy)")
    # A value beyond float32 becomes inf here, refused by position by the checks, not a warning.
    with np.errstate(over="ignore", invalid="ignore"):
        arrays = {
            "poses": poses.astype(np.float32),
            "disps": disps.astype(np.float32),
            "intrinsics": intrinsics[0].astype(np.float32),
            "ii": ii.astype(np.int64),
            "jj": jj.astype(np.int64),
            "target": _plane_layout(target, "target").astype(np.float32, copy=False),
            "weight": _plane_layout(weight, "weight").astype(np.float32, copy=False),
            "tstamp": frames.astype(np.float64),
        }
        if sens is not None and (sens > 0).any():
            arrays["disps_sens"] = np.where(sens > 0, sens, 0).astype(np.float32)
    if t0 is not None:
        arrays["t0"] = np.array(t0, dtype=np.int64)
    if (arrays["ii"] == arrays["jj"]).any():
        stereo = getattr(video, "stereo", None)
        if stereo is not None and not isinstance(stereo, (bool, np.bool_)):
            raise ValueError(f"video.stereo is {stereo!r} ({type(stereo).__name__}), expected "
                             "True or False (DepthVideo(stereo=...))")
        if stereo_rig is None and not stereo:
            e = int(np.flatnonzero(arrays["ii"] == arrays["jj"])[0])
            raise ValueError(f"graph edge {e} links keyframe {int(arrays['ii'][e])} to itself "
                             "(ii == jj), a stereo edge, but the video is not stereo "
                             f"(video.stereo = {stereo!r}): run DROID-SLAM "
                             "with --stereo (DepthVideo(stereo=True)), or give the rig "
                             "transform as stereo_rig= [tx ty tz qx qy qz qw] (DROID's: "
                             "dbacov_dump.DROID_STEREO_RIG)")
        rig = DROID_STEREO_RIG if stereo_rig is None else read_real(stereo_rig, "stereo_rig")
        arrays["stereo_rig"] = np.asarray(rig, dtype=np.float64)
    if times is not None:
        if frames.min() < 0 or frames.max() >= times.size:
            k = int(np.flatnonzero((frames < 0) | (frames >= times.size))[0])
            raise KeyframeTimeError(f"keyframe {k}'s frame index {int(frames[k])} is beyond the "
                                    f"{times.size} image times given (image_times_s)")
        arrays["timestamps_s"] = times[frames]
    if timestamps_s is not None:
        arrays["timestamps_s"] = read_real(timestamps_s, "timestamps_s").astype(np.float64)
    if sid is not None:
        arrays["id"] = np.array(sid, dtype=np.int64)
    check_snapshot(arrays, check_values=False)
    return arrays


dump_dba_snapshot.__doc__ = snapshot_arrays.__doc__
snapshot_arrays.__doc__ = ("The conventions §1 arrays of DROID's current DBA (a dict), as "
                           "dump_dba_snapshot writes them.\n" + (snapshot_arrays.__doc__ or ""))


def dump_global_ba(path, video, graph, snapshot_id=None, include_inactive=False, record=None,
                   image_times_s=None, stereo_rig=None, compressed=True, t0=1):
    """Writes the factor graph of DROID's global BA to `path`: call it right after
    `FactorGraph.update_lowmem` returns, before the backend drops the edges (`clear_edges`,
    `rm_factors`); install_backend_hook does it for DROID's backends.

    update_lowmem ends each of its steps with `video.ba(target, weight, damping, ii, jj, 1, t)`:
    it holds pose 0 only (t0 = 1, whatever t0 it is given) and optimizes every other keyframe,
    over the graph's active edges (DroidBackend: the proximity graph it has just built,
    `use_inactive=False`) and, with `use_inactive=True` (DroidAsyncBackend), every inactive edge
    too: pass the same as `include_inactive` (DROID's selection >= t0 - 3 keeps them all with
    t0 = 1). The snapshot's 't0' is 1 (`--gauge droid` holds keyframe 0 only: in monocular mode
    the scale is then free, held in DROID by its damping alone; use `--gauge two-pose` there).
    A fork whose global BA holds more (GO-SLAM's loop BA: update_lowmem(t0=...)) passes its t0.
    The other arguments are dump_dba_snapshot's. Returns `path`."""
    return dump_dba_snapshot(path, video, graph, snapshot_id, compressed=compressed,
                             include_inactive=include_inactive, record=record,
                             image_times_s=image_times_s, stereo_rig=stereo_rig, t0=t0)


def _failure_kind(exc, text):
    """What makes two failures 'the same kind' for a report once: the exception's type and its
    message up to the first colon, numbers left out (a keyframe count changes at every update)."""
    return type(exc).__name__, re.sub(r"[0-9]+", "#", text.split(":")[0])


class DbaDumper:
    """The hook to put in DROID's frontend: one call per update, and it never stops SLAM.

        dumper = DbaDumper(out_dir, image_times_s=read_euroc_image_times(".../cam0/data.csv"))
        ...
        dumper(self.video, self.graph, self.count)       # in DroidFrontend._update / __update

    Every failure (bad tensors, a disk error, keyframe times it cannot establish, a bug) is caught:
    the first of each kind is reported once on stderr (`stream`), the update's snapshot is skipped,
    and DROID goes on. `failures` counts them, `written` the snapshots written. `global_ba` is the
    same hook for DROID's global BA (install_backend_hook calls it), written as
    `global_pattern`. A bad `image_times_s` is refused here (ValueError), before SLAM starts.
    """

    def __init__(self, out_dir, image_times_s=None, include_inactive=True, compressed=True,
                 stereo_rig=None, pattern="window_{:06d}.npz", stream=None,
                 global_pattern="global_{:06d}.npz"):
        self.out_dir = os.fspath(out_dir)
        self.image_times_s = None if image_times_s is None else _image_times(image_times_s)
        self.include_inactive, self.compressed = include_inactive, compressed
        self.stereo_rig, self.pattern = stereo_rig, pattern
        self.global_pattern = global_pattern
        self.stream = stream
        self.record = KeyframeRecord()
        self.written, self.failures, self.global_calls = 0, 0, 0
        self._reported = set()

    def __call__(self, video, graph, count):
        try:
            os.makedirs(self.out_dir, exist_ok=True)
            path = os.path.join(self.out_dir, self.pattern.format(int(count)))
            dump_dba_snapshot(path, video, graph, count, compressed=self.compressed,
                              include_inactive=self.include_inactive, record=self.record,
                              image_times_s=self.image_times_s, stereo_rig=self.stereo_rig)
            self.written += 1
            return path
        except Exception as exc:  # noqa: BLE001 -- the hook must never stop SLAM
            if isinstance(exc, KeyframeTimeError):
                self.record = KeyframeRecord()  # start afresh at the next update
            self._failed(exc, f"snapshot {count}")
            return None

    def global_ba(self, video, graph, count=None, include_inactive=False):
        """The hook right after DROID's global BA (FactorGraph.update_lowmem), before the backend
        drops its edges: writes dump_global_ba's snapshot as `global_pattern` with `count`
        (default: 1, 2, ... for the global BAs seen so far; DROID runs two at the end, 7 and 12
        steps). `include_inactive` is the update_lowmem call's `use_inactive`. The keyframes'
        frame indices come from the frontend's record when it has followed this video up to now
        (the same DbaDumper as the frontend's: with DROID releases before 2025 its record
        corrects their stale tstamp), else from the video's stamps alone (right for current
        DROID, which keeps them exact; the only one with DroidAsyncBackend). Never raises."""
        self.global_calls += 1
        count = self.global_calls if count is None else count
        try:
            os.makedirs(self.out_dir, exist_ok=True)
            path = os.path.join(self.out_dir, self.global_pattern.format(int(count)))
            n = keyframe_count(video)
            shared = self.record.frames is not None and self.record.frames.size == n
            dump_global_ba(path, video, graph, count, include_inactive=include_inactive,
                           record=self.record if shared else KeyframeRecord(),
                           image_times_s=self.image_times_s, stereo_rig=self.stereo_rig,
                           compressed=self.compressed)
            self.written += 1
            return path
        except Exception as exc:  # noqa: BLE001 -- the hook must never stop SLAM
            self._failed(exc, f"global BA snapshot {count}")
            return None

    def _failed(self, exc, what):
        self.failures += 1
        text = exception_text(exc)
        kind = _failure_kind(exc, text)
        if kind not in self._reported:
            self._reported.add(kind)
            with contextlib.suppress(Exception):
                print(f"dbacov_dump: {what} not written ({type(exc).__name__}: {text}); "
                      "DROID-SLAM goes on, further failures of this kind are not reported",
                      file=self.stream or sys.stderr, flush=True)


_backend_calls = threading.local()  # how deep this thread is inside a wrapped backend call


def _counted_backend_call(original):
    """A backend's __call__ that marks the thread as inside a backend call while it runs."""
    @functools.wraps(original)
    def call(self, *args, **kwargs):
        _backend_calls.depth = getattr(_backend_calls, "depth", 0) + 1
        try:
            return original(self, *args, **kwargs)
        finally:
            _backend_calls.depth -= 1

    call._dbacov_backend = True
    return call


def install_backend_hook(dumper, backend_class=None, graph_class=None):
    """Dumps DROID's global BA: `dumper.global_ba(graph.video, graph,
    include_inactive=use_inactive)` runs right after every `FactorGraph.update_lowmem` that a
    backend call makes, i.e. after the global BA and before the backend drops its edges
    (DroidBackend: `graph.clear_edges()`; DroidAsyncBackend: `rm_factors`). `dumper` is a
    DbaDumper (or anything with that global_ba method); its failures never propagate.

    backend_class  DROID's DroidBackend and DroidAsyncBackend (droid_slam/droid_backend.py) by
                   default, whichever exist; or a class, or a tuple of classes, whose __call__
                   runs the global BA.
    graph_class    the FactorGraph those backends use (default: the one of their module).

    Call it before DROID's backend runs (Droid.terminate runs DroidBackend twice). With
    DroidAsyncBackend the backend runs in its own process (droid_async.backend_process): call it
    there, with a DbaDumper of that process. Installing again replaces the hook. Returns the
    wrapped classes."""
    if backend_class is None:
        try:  # DROID-SLAM's droid_slam/ on sys.path, as its demo.py puts it
            import droid_backend as module
        except ImportError:  # droid_slam installed as a package
            from droid_slam import droid_backend as module
        classes = tuple(getattr(module, name) for name in ("DroidBackend", "DroidAsyncBackend")
                        if hasattr(module, name))
    else:
        classes = tuple(backend_class) if isinstance(backend_class, (tuple, list)) \
            else (backend_class,)
    if not classes:
        raise ValueError("no backend class to wrap: droid_backend has neither DroidBackend nor "
                         "DroidAsyncBackend; pass backend_class=")
    if graph_class is None:
        graph_class = getattr(sys.modules[classes[0].__module__], "FactorGraph", None)
        if graph_class is None:
            raise ValueError(f"{classes[0].__module__} has no FactorGraph: pass graph_class=")
    for cls in classes:
        original = cls.__call__
        if getattr(original, "_dbacov_backend", False):
            original = original.__wrapped__  # installed twice
        cls.__call__ = _counted_backend_call(original)

    original = graph_class.update_lowmem
    if getattr(original, "_dbacov_hook", None) is not None:
        original = original.__wrapped__  # installed twice: replace the hook
    try:
        signature = inspect.signature(original)
    except (TypeError, ValueError):
        signature = None

    @functools.wraps(original)
    def update_lowmem(self, *args, **kwargs):
        result = original(self, *args, **kwargs)
        if getattr(_backend_calls, "depth", 0) > 0:
            with contextlib.suppress(Exception):
                use_inactive = kwargs.get("use_inactive", False)
                if signature is not None:
                    bound = signature.bind(self, *args, **kwargs)
                    bound.apply_defaults()
                    use_inactive = bound.arguments.get("use_inactive", False)
                dumper.global_ba(self.video, self, include_inactive=bool(use_inactive))
        return result

    update_lowmem._dbacov_hook = dumper
    graph_class.update_lowmem = update_lowmem
    return classes
