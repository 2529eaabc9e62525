"""Dump DROID-SLAM's dense-bundle-adjustment (DBA) factor graph as dbacov snapshots.

One snapshot is the DBA factor graph of one frontend update, written as one `.npz` file in the
interchange format of conventions §1 (dbacov's ``docs/conventions.md``), which ``dba-covariance`` reads:

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
DROID-SLAM; ``__update`` in releases before 2025), right after its last DBA, i.e. after the ``if d.item() < ...: / else:`` block that
ends with ``self.graph.update(None, None, use_inactive=True)``, before "set pose for next
iteration" (with ``share/droid`` on ``PYTHONPATH``)::

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

numpy is required; torch is not imported: tensors are read through ``.detach().cpu().numpy()``,
numpy arrays are taken as they are.
"""

import contextlib
import hashlib
import os
import sys
import tempfile
import zipfile

import numpy as np

__all__ = ["dump_dba_snapshot", "check_snapshot", "write_snapshot_npz", "to_numpy",
           "KeyframeRecord", "KeyframeTimeError", "DbaDumper", "read_euroc_image_times",
           "snapshot_arrays", "exception_text", "read_real",
           "DROID_STEREO_RIG"]

#: The fixed transform DROID-SLAM's BA applies on an edge with ii == jj (droid_kernels.cu: the
#: second camera of the stereo pair sits at tij = (-0.1, 0, 0), no rotation), [tx ty tz qx qy qz qw].
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


def read_real(x, name, integer=False):
    """to_numpy(x), refusing (ValueError naming `name`) what a conversion to the snapshot dtypes
    would silently change: a masked array (its mask), complex values (the imaginary part),
    booleans and non-numeric dtypes; with `integer`, values that are not integers (a float 1.7
    would become 1; integral floats such as 2.0 are accepted)."""
    if isinstance(x, np.ma.MaskedArray):
        raise ValueError(f"{name} is a NumPy masked array: its mask would be ignored; pass a "
                         "plain array")
    a = to_numpy(x)
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
    return a


def _plane_layout(a, name):
    """(1,E,H,W,2) as DROID stores it -> contiguous (E,2,H,W), channel order (x, y) kept."""
    if a.ndim != 5 or a.shape[0] != 1 or a.shape[4] != 2:
        raise ValueError(f"graph.{name} has shape {tuple(a.shape)}, expected (1,E,H,W,2)")
    return np.ascontiguousarray(a[0].transpose(0, 3, 1, 2))


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
    """Checks a dict of conventions §1 arrays; raises ValueError naming the key and what was expected.

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
    a = to_numpy(image)
    return hashlib.blake2b(np.ascontiguousarray(a[..., ::4, ::4]).tobytes(), digest_size=16).digest()


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
        if getattr(video, "images", None) is None:
            return {}
        return {k: _fingerprint(video.images[k]) for k in range(max(0, n - self.window), n)}

    def update(self, video):
        """The frame index of keyframe slots 0..N-1 now (np.int64), updating the record."""
        n = int(video.counter.value)
        ts = read_real(video.tstamp[:n + 1], "video.tstamp").astype(np.float64).reshape(-1)
        if n < 1 or ts.size < n or not np.isfinite(ts[:n]).all() or \
                (ts[:n] != np.round(ts[:n])).any():
            raise KeyframeTimeError(f"video.tstamp[:{n}] does not hold integer image indices "
                                    f"(counter.value = {n})")
        view = ts[:n].astype(np.int64)
        ghost = int(ts[n]) if ts.size > n and np.isfinite(ts[n]) else None
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
                raise KeyframeTimeError(self._disagree(prev, view))
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
                raise KeyframeTimeError(self._disagree(prev, view))
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
    def _disagree(prev, view):
        k = int(np.flatnonzero(view[:prev.size] != prev[:view.size])[0])
        return (f"video.tstamp[{k}] = {view[k]} but the record says frame {prev[k]}: keyframes "
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
                      include_inactive=False, record=None, image_times_s=None, stereo_rig=None):
    arrays = snapshot_arrays(video, graph, snapshot_id, timestamps_s=timestamps_s,
                             include_inactive=include_inactive, record=record,
                             image_times_s=image_times_s, stereo_rig=stereo_rig)
    write_snapshot_npz(path, arrays, compressed)
    return path


dump_dba_snapshot.__doc__ = None  # set below, shared with snapshot_arrays


def snapshot_arrays(video, graph, snapshot_id=None, timestamps_s=None, include_inactive=False,
                    record=None, image_times_s=None, stereo_rig=None):
    """Writes the current DBA factor graph of DROID-SLAM to `path` (conventions §1 `.npz`, atomically).

    video         DROID's DepthVideo: poses (≥N,7) T_cw, disps (≥N,H,W), intrinsics (≥N,4),
                  tstamp (≥N,), counter.value = N, get_lock(); optional disps_sens (≥N,H,W)
                  (RGB-D), images (to locate removed keyframes), stereo.
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

    Extra keys: 't0' (int64, DROID's first optimized pose of this update, max(1, min(ii) + 1)
    over the active edges), 'disps_sens' (float32 (N,H,W), only when some value is > 0) and
    'stereo_rig' (float64 (7,), only with ii == jj edges).

    Raises ValueError, before writing anything, when the intrinsics of the N keyframes differ,
    when an edge names a keyframe outside [0, N), when shapes are inconsistent, and
    KeyframeTimeError when the keyframe frame indices cannot be established. Returns `path`.
    """
    with video.get_lock():
        n = int(video.counter.value)
        poses = read_real(video.poses[:n], "video.poses")
        disps = read_real(video.disps[:n], "video.disps")
        intrinsics = read_real(video.intrinsics[:n], "video.intrinsics")
        frames = (record if record is not None else KeyframeRecord()).update(video)
        sens = getattr(video, "disps_sens", None)
        sens = read_real(sens[:n], "video.disps_sens") if sens is not None else None
        ii = read_real(graph.ii, "graph.ii", integer=True)
        jj = read_real(graph.jj, "graph.jj", integer=True)
        target = read_real(graph.target, "graph.target")
        weight = read_real(graph.weight, "graph.weight")
        t0 = max(1, int(ii.min()) + 1) if ii.size else None
        if include_inactive and ii.size:
            # DROID's FactorGraph.update(use_inactive=True): inactive edges first, then active.
            m = (graph.ii_inac >= t0 - 3) & (graph.jj_inac >= t0 - 3)
            ii = np.concatenate([read_real(graph.ii_inac[m], "graph.ii_inac", integer=True), ii])
            jj = np.concatenate([read_real(graph.jj_inac[m], "graph.jj_inac", integer=True), jj])
            target = np.concatenate([read_real(graph.target_inac[:, m], "graph.target_inac"),
                                     target], axis=1)
            weight = np.concatenate([read_real(graph.weight_inac[:, m], "graph.weight_inac"),
                                     weight], axis=1)

    if n < 1 or intrinsics.shape != (n, 4):
        raise ValueError(f"video.intrinsics[:{n}] has shape {intrinsics.shape}, expected ({n}, 4)")
    differs = np.flatnonzero((intrinsics != intrinsics[0]).any(axis=1))
    if differs.size:
        k = differs[0]
        raise ValueError(f"video.intrinsics differ between keyframes: row {k} = {intrinsics[k]} "
                         f"but row 0 = {intrinsics[0]}; a snapshot has one camera (fx fy cx cy)")
    if poses.ndim != 2 or disps.ndim != 3:
        raise ValueError(f"video.poses[:{n}] / video.disps[:{n}] have shapes {poses.shape} / "
                         f"{disps.shape}, expected ({n}, 7) / ({n}, H, W)")
    # A value beyond float32 becomes inf here, refused by position by the checks, not a warning.
    with np.errstate(over="ignore", invalid="ignore"):
        arrays = {
            "poses": poses.astype(np.float32),
            "disps": disps.astype(np.float32),
            "intrinsics": intrinsics[0].astype(np.float32),
            "ii": ii.astype(np.int64).reshape(-1),
            "jj": jj.astype(np.int64).reshape(-1),
            "target": _plane_layout(target, "target").astype(np.float32, copy=False),
            "weight": _plane_layout(weight, "weight").astype(np.float32, copy=False),
            "tstamp": frames.astype(np.float64),
        }
    if t0 is not None:
        arrays["t0"] = np.array(t0, dtype=np.int64)
    if sens is not None and (sens > 0).any():
        arrays["disps_sens"] = np.where(sens > 0, sens, 0).astype(np.float32)
    if (arrays["ii"] == arrays["jj"]).any():
        if stereo_rig is None and not getattr(video, "stereo", False):
            e = int(np.flatnonzero(arrays["ii"] == arrays["jj"])[0])
            raise ValueError(f"graph edge {e} links keyframe {int(arrays['ii'][e])} to itself "
                             "(ii == jj), a stereo edge, but the video is not stereo "
                             f"(video.stereo = {getattr(video, 'stereo', None)!r}): run DROID-SLAM "
                             "with --stereo (DepthVideo(stereo=True)), or give the rig "
                             "transform as stereo_rig= [tx ty tz qx qy qz qw] (DROID's: "
                             "dbacov_dump.DROID_STEREO_RIG)")
        rig = DROID_STEREO_RIG if stereo_rig is None else read_real(stereo_rig, "stereo_rig")
        arrays["stereo_rig"] = np.asarray(rig, dtype=np.float64).reshape(-1)
    if image_times_s is not None:
        times = read_real(image_times_s, "image_times_s").astype(np.float64).reshape(-1)
        if frames.size and (frames.min() < 0 or frames.max() >= times.size):
            raise KeyframeTimeError(f"keyframe frame index {int(frames.max())} is beyond the "
                                    f"{times.size} image times given (image_times_s)")
        arrays["timestamps_s"] = times[frames]
    if timestamps_s is not None:
        arrays["timestamps_s"] = read_real(timestamps_s, "timestamps_s").astype(np.float64)
    if snapshot_id is not None:
        arrays["id"] = np.array(int(snapshot_id), dtype=np.int64)
    check_snapshot(arrays, check_values=False)
    return arrays


dump_dba_snapshot.__doc__ = snapshot_arrays.__doc__
snapshot_arrays.__doc__ = ("The conventions §1 arrays of DROID's current DBA (a dict), as "
                           "dump_dba_snapshot writes them.\n" + (snapshot_arrays.__doc__ or ""))


class DbaDumper:
    """The hook to put in DROID's frontend: one call per update, and it never stops SLAM.

        dumper = DbaDumper(out_dir, image_times_s=read_euroc_image_times(".../cam0/data.csv"))
        ...
        dumper(self.video, self.graph, self.count)       # in DroidFrontend._update / __update

    Every failure (bad tensors, a disk error, keyframe times it cannot establish, a bug) is caught:
    the first of each kind is reported once on stderr (`stream`), the update's snapshot is skipped,
    and DROID goes on. `failures` counts them, `written` the snapshots written.
    """

    def __init__(self, out_dir, image_times_s=None, include_inactive=True, compressed=True,
                 stereo_rig=None, pattern="window_{:06d}.npz", stream=None):
        self.out_dir = os.fspath(out_dir)
        self.image_times_s = None if image_times_s is None else to_numpy(image_times_s)
        self.include_inactive, self.compressed = include_inactive, compressed
        self.stereo_rig, self.pattern = stereo_rig, pattern
        self.stream = stream
        self.record = KeyframeRecord()
        self.written, self.failures = 0, 0
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
            self.failures += 1
            if isinstance(exc, KeyframeTimeError):
                self.record = KeyframeRecord()  # start afresh at the next update
            text = exception_text(exc)
            kind = (type(exc).__name__, text.split(":")[0])
            if kind not in self._reported:
                self._reported.add(kind)
                with contextlib.suppress(Exception):
                    print(f"dbacov_dump: snapshot {count} not written ({type(exc).__name__}: "
                          f"{text}); DROID-SLAM goes on, further failures of this kind are not "
                          "reported", file=self.stream or sys.stderr, flush=True)
            return None
