"""Dump DROID-SLAM's dense-bundle-adjustment (DBA) factor graph as dbacov snapshots.

One snapshot is the DBA factor graph of one frontend update, written as one `.npz` file in the
interchange format of SPEC §1 (dbacov's ``docs/SPEC.md``), which ``dba-covariance`` reads:

    poses        float32 (N,7)      T_cw as [tx ty tz qx qy qz qw] (lietorch order)
    disps        float32 (N,H,W)    inverse depth at 1/8 resolution
    intrinsics   float32 (4,)       fx fy cx cy of the H×W grid (already divided by 8)
    ii, jj       int64   (E,)       edge e: source keyframe ii[e] -> target keyframe jj[e]
    target       float32 (E,2,H,W)  predicted pixel coordinates in frame jj[e]; channel 0 = x
    weight       float32 (E,2,H,W)  confidences; channel 0 = x (column), channel 1 = y (row)
    tstamp       float64 (N,)       DROID's keyframe time stamp (image index)
    timestamps_s float64 (N,)       optional: keyframe times in seconds
    id           int64   ()         snapshot counter

DROID keeps targets and weights as (1,E,H,W,2) with the last axis (x, y); they are transposed to
(E,2,H,W), never swapped. N is ``video.counter.value``: the keyframes in the buffer.

Where to call it
----------------
In DROID-SLAM's ``droid_slam/droid_frontend.py``, method ``DroidFrontend.__update`` (``_update`` in
newer releases), right after its last DBA, i.e. after the ``if d.item() < ...: / else:`` block that
ends with ``self.graph.update(None, None, use_inactive=True)``, before "set pose for next
iteration" (with ``share/droid`` on ``PYTHONPATH``)::

            for itr in range(self.iters2):
                self.graph.update(None, None, use_inactive=True)

        from dbacov_dump import dump_dba_snapshot
        dump_dba_snapshot(f"{DUMP_DIR}/window_{self.count:06d}.npz",
                          self.video, self.graph, snapshot_id=self.count)

        # set pose for next itration
        self.video.poses[self.t1] = self.video.poses[self.t1-1]

At that point poses and disparities are the DBA solution, and ``graph.target``/``graph.weight``
are the targets and confidences that DBA used. When the frontend has just dropped a keyframe
(``rm_keyframe``), buffers and edges are already renumbered consistently.

Not dumped, on purpose: DROID's Levenberg-Marquardt damping (``lm``, ``ep``) and its learned
per-pixel depth damping (eta, ``graph.damping``). They are solver aids, not measurements, and are
not part of the information matrix (SPEC §2).

Inactive edges: with ``use_inactive=True`` DROID's frontend DBA also uses the stored, no longer
updated edges ``graph.ii_inac``/``jj_inac`` whose keyframes are >= t0 - 3 (t0 = min(ii) + 1). By
default only the active edges ``graph.ii``/``jj`` are dumped; ``include_inactive=True`` adds the
inactive ones with DROID's own selection rule, so that the dump is exactly the factor set of that
DBA call.

numpy is required; torch is not imported: tensors are read through ``.detach().cpu().numpy()``,
numpy arrays are taken as they are.
"""

import contextlib
import os
import tempfile

import numpy as np

__all__ = ["dump_dba_snapshot", "check_snapshot", "write_snapshot_npz", "to_numpy"]


def to_numpy(x):
    """A private numpy copy of a torch tensor (any device) or of anything np.asarray accepts."""
    if hasattr(x, "detach"):
        x = x.detach().cpu().numpy()
    return np.array(x, copy=True)


def _plane_layout(a, name):
    """(1,E,H,W,2) as DROID stores it -> contiguous (E,2,H,W), channel order (x, y) kept."""
    if a.ndim != 5 or a.shape[0] != 1 or a.shape[4] != 2:
        raise ValueError(f"graph.{name} has shape {tuple(a.shape)}, expected (1,E,H,W,2)")
    return np.ascontiguousarray(a[0].transpose(0, 3, 1, 2))


def _where(key, index):
    """An element of a SPEC array in words, independent of the layout it was converted from."""
    index = [int(i) for i in index]
    if key in ("target", "weight"):
        e, c, y, x = index
        return f"edge {e}, channel {'xy'[c]}, pixel (x={x}, y={y})"
    if key == "disps":
        return f"keyframe {index[0]}, pixel (x={index[2]}, y={index[1]})"
    return "index " + str(tuple(index))


def check_snapshot(arrays, check_values=True, names=None):
    """Checks a dict of SPEC §1 arrays; raises ValueError naming the key and what was expected.

    Always: shapes agree (N from 'poses', E from 'ii', H,W from 'disps'), ii/jj in [0, N) and
    ii != jj. With check_values also: every float finite, weights >= 0, quaternions of non-zero
    norm, positive focal lengths. `names` maps keys to the names used in messages.
    """
    def k_(key):
        return "key '" + (names or {}).get(key, key) + "'"

    n = arrays["poses"].shape[0]
    e = arrays["ii"].shape[0]
    h, w = arrays["disps"].shape[1:]
    expected = {"poses": (n, 7), "disps": (n, h, w), "intrinsics": (4,), "ii": (e,), "jj": (e,),
                "target": (e, 2, h, w), "weight": (e, 2, h, w), "tstamp": (n,),
                "timestamps_s": (n,), "id": ()}
    for key, shape in expected.items():
        if key in arrays and arrays[key].shape != shape:
            raise ValueError(f"{k_(key)} has shape {arrays[key].shape}, expected {shape}")
    for key in ("ii", "jj"):
        bad = np.flatnonzero((arrays[key] < 0) | (arrays[key] >= n))
        if bad.size:
            k = bad[0]
            raise ValueError(f"{k_(key)}: edge {k} names keyframe {arrays[key][k]}, "
                             f"outside [0, {n}) (N = {n} keyframes)")
    same = np.flatnonzero(arrays["ii"] == arrays["jj"])
    if same.size:
        k = same[0]
        raise ValueError(f"{k_('ii')} and {k_('jj')}: edge {k} links keyframe "
                         f"{arrays['ii'][k]} to itself (a stereo edge? dbacov models monocular "
                         "DBA only)")
    if not check_values:
        return
    for key in ("poses", "disps", "intrinsics", "target", "weight", "tstamp", "timestamps_s"):
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
            (np.savez_compressed if compressed else np.savez)(f, **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, _file_mode())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def dump_dba_snapshot(path, video, graph, snapshot_id, timestamps_s=None, compressed=True,
                      include_inactive=False):
    """Writes the current DBA factor graph of DROID-SLAM to `path` (SPEC §1 `.npz`, atomically).

    video         DROID's DepthVideo: poses (≥N,7) T_cw, disps (≥N,H,W), intrinsics (≥N,4),
                  tstamp (≥N,), counter.value = N, get_lock().
    graph         DROID's FactorGraph: ii, jj (E,), target, weight (1,E,H,W,2), last axis (x, y).
    snapshot_id   stored as 'id' (int64 scalar); None leaves 'id' out.
    timestamps_s  optional keyframe times in seconds, N values (e.g. your image times indexed by
                  video.tstamp[:N]); stored as float64 'timestamps_s'.
    compressed    np.savez_compressed (default) or np.savez.
    include_inactive  also dump the inactive edges that DROID's DBA used (see the module doc).

    Raises ValueError, before writing anything, when the intrinsics of the N keyframes differ,
    when an edge names a keyframe outside [0, N) or itself, or when shapes are inconsistent.
    Returns `path`.
    """
    with video.get_lock():
        n = int(video.counter.value)
        poses = to_numpy(video.poses[:n])
        disps = to_numpy(video.disps[:n])
        intrinsics = to_numpy(video.intrinsics[:n])
        tstamp = to_numpy(video.tstamp[:n])
        ii, jj = to_numpy(graph.ii), to_numpy(graph.jj)
        target, weight = to_numpy(graph.target), to_numpy(graph.weight)
        if include_inactive and ii.size:
            # DROID's FactorGraph.update(use_inactive=True): inactive edges first, then active.
            t0 = max(1, int(ii.min()) + 1)
            m = (graph.ii_inac >= t0 - 3) & (graph.jj_inac >= t0 - 3)
            ii = np.concatenate([to_numpy(graph.ii_inac[m]), ii])
            jj = np.concatenate([to_numpy(graph.jj_inac[m]), jj])
            target = np.concatenate([to_numpy(graph.target_inac[:, m]), target], axis=1)
            weight = np.concatenate([to_numpy(graph.weight_inac[:, m]), weight], axis=1)

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
    arrays = {
        "poses": poses.astype(np.float32),
        "disps": disps.astype(np.float32),
        "intrinsics": intrinsics[0].astype(np.float32),
        "ii": ii.astype(np.int64).reshape(-1),
        "jj": jj.astype(np.int64).reshape(-1),
        "target": _plane_layout(target, "target").astype(np.float32, copy=False),
        "weight": _plane_layout(weight, "weight").astype(np.float32, copy=False),
        "tstamp": tstamp.astype(np.float64).reshape(-1),
    }
    if timestamps_s is not None:
        arrays["timestamps_s"] = to_numpy(timestamps_s).astype(np.float64)
    if snapshot_id is not None:
        arrays["id"] = np.array(int(snapshot_id), dtype=np.int64)
    check_snapshot(arrays, check_values=False)
    write_snapshot_npz(path, arrays, compressed)
    return path
