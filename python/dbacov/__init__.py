"""dbacov: consistent pose covariances from DROID-SLAM's dense bundle adjustment (DBA).

    import dbacov
    snap = dbacov.load("snapshot.npz")               # or dbacov.Snapshot(poses=..., ...)
    cov = dbacov.Covariance(snap, preset="droid")    # dba-covariance's options as keywords
    cov.keyframes                                     # graph keyframes
    cov.marginal(k), cov.joint(a, b), cov.relative(a, b)   # numpy, tangent [rho; phi]
    cov.marginals()                                   # (K, 6, 6)
    cov.inverse_depth_sigma(k)                        # (H, W)
    cov.summary()                                     # one line (full=True: every field)
    cov.self_calibration                              # the noise model found: a dict (None when
    cov = dbacov.Covariance(snap, stated_model=True)  # ... the stated model: --stated-model)
    cov.write_pose_rawlog("poses.rawlog", fps=20)     # dba-covariance -o (through the MRPT bridge)
    dbacov.write_pose_rawlog("poses.rawlog", [cov1, cov2], emit="final")
    snap = dbacov.from_droid(video, graph)            # DROID's DepthVideo and FactorGraph

Arrays may be NumPy arrays or torch tensors (any device: read through .detach().cpu()); NumPy
arrays of the snapshot dtypes (float32 disps/target/weight, float64 poses/tstamp, int64 ii/jj),
C-contiguous, are read in place. Errors are dbacov.InputError (a ValueError) and
dbacov.NumericalError (an ArithmeticError) with the messages of the command-line tools.
"""

import difflib
import functools
import inspect
import operator
import os

import numpy as np

from . import _droid
from ._dbacov import Covariance as _Covariance
from ._dbacov import InputError, NumericalError
from ._dbacov import Snapshot as _Snapshot
from ._dbacov import _write_pose_rawlog
from ._dbacov import check_options as _check_options
from ._dbacov import load as _load

__all__ = ["load", "Snapshot", "Covariance", "from_droid", "write_pose_rawlog", "check_options",
           "InputError", "NumericalError"]

_DTYPES = {"poses": np.float64, "disps": np.float32, "intrinsics": np.float64, "ii": np.int64,
           "jj": np.int64, "target": np.float32, "weight": np.float32, "tstamp": np.float64,
           "timestamps_s": np.float64, "disps_sens": np.float32, "stereo_rig": np.float64}

#: Covariance's keywords after the snapshot (dba-covariance's options), in the binding's order.
COVARIANCE_KEYWORDS = ("preset", "weight_scale", "gauge", "gauge_sigma_rot", "gauge_sigma_trans",
                       "near", "far", "min_depth_ratio", "sensor_depth_weight", "solver",
                       "ordering", "threads", "depth_sigma", "stated_model",
                       "self_calibrate_nodes", "self_calibrate_depth_noise", "converge",
                       "converge_iterations")
_WRITE_KEYWORDS = ("emit", "label", "fps", "start_time", "times")


def _unknown_keyword(function, given, valid):
    """TypeError naming the first keyword of `given` not in `valid`, with the valid ones (and the
    closest, when one is close), instead of Python's or pybind11's generic message."""
    for key in given:
        if key not in valid:
            close = difflib.get_close_matches(key, valid, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise TypeError(f"{function}() got an unknown keyword argument {key!r}{hint}; "
                            f"valid keywords: {', '.join(valid)}")


def _keywords(valid=None):
    """Decorator: unknown keywords name themselves and the valid ones (the function's own
    parameters, or `valid` for a function taking **options)."""
    def wrap(f):
        names = valid or tuple(n for n, p in inspect.signature(f).parameters.items()
                               if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY))

        @functools.wraps(f)
        def checked(*args, **kwargs):
            _unknown_keyword(f.__name__, kwargs, names)
            return f(*args, **kwargs)
        return checked
    return wrap


def _path(path):
    """A path argument (str, bytes or os.PathLike) as str; a NUL byte is refused by the module."""
    return os.fsdecode(os.fspath(path))


def _array(x, dtype):
    """A NumPy view of x when it is already of that dtype and C-contiguous, else x as NumPy reads
    it (np.asarray, no conversion): the module converts it to the snapshot dtype, refusing what
    would lose information (complex values, fractional indices, masks). torch tensors (CPU or
    CUDA) go through .detach().cpu() (no copy for CPU tensors); masked arrays are passed as they
    are, for the module to refuse."""
    if hasattr(x, "detach"):
        x = x.detach().cpu().numpy()
    if isinstance(x, np.ma.MaskedArray):
        return x
    a = np.asarray(x)
    return np.ascontiguousarray(a) if a.dtype == dtype else a


def _integer(value, name, source):
    """An integer argument (id, t0): an int, a NumPy/torch integer or 0-d array, or a float of
    integral value (2.0, as keyframe indices); a fraction is refused, never truncated."""
    if value is None:
        return None
    try:
        return operator.index(value)
    except TypeError:
        pass
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{source}: {name} is {value!r} ({type(value).__name__}), expected an "
                         "integer") from None
    if not (np.isfinite(f) and f == int(f)):
        raise InputError(f"{source}: {name} is {value!r}, not an integer: expected an integer "
                         "(integral floats such as 2.0 are accepted; a fraction is never "
                         "rounded)")
    return int(f)


@_keywords()
def load(path):
    """Reads one snapshot .npz (conventions §1); errors name the file and the key."""
    return _load(_path(path))


check_options = _keywords(COVARIANCE_KEYWORDS)(_check_options)
check_options.__doc__ = ("Checks Covariance's keywords without a snapshot (the same checks and "
                         "messages as Covariance): raises ValueError (an unknown value) or "
                         "TypeError (an unknown keyword), else returns None. For tools that take "
                         "the options long before the first snapshot (dbacov_online.py).")


@_keywords()
def Snapshot(*, poses, disps, intrinsics, ii, jj, target, weight, tstamp, timestamps_s=None,
             id=None, disps_sens=None, stereo_rig=None, t0=None, source="<python>"):
    """A snapshot from arrays in the layout of conventions §1 (poses T_cw (N,7), disps (N,H,W),
    intrinsics (4,), ii/jj (E,), target/weight (E,2,H,W) x first, tstamp (N,)); optional
    timestamps_s (N,), id, disps_sens (N,H,W) for RGB-D, stereo_rig (7,) for ii == jj edges,
    t0 (DROID's first optimized pose). Checked as the file loader checks a .npz; refused
    (dbacov.InputError naming the key): masked arrays, complex, boolean or non-numeric dtypes,
    and ii/jj/id/t0 values that are not integers (integral floats such as 2.0 are accepted)."""
    kw = {k: v for k, v in dict(poses=poses, disps=disps, intrinsics=intrinsics, ii=ii, jj=jj,
                                target=target, weight=weight, tstamp=tstamp,
                                timestamps_s=timestamps_s, disps_sens=disps_sens,
                                stereo_rig=stereo_rig).items() if v is not None}
    arrays = {k: _array(v, _DTYPES[k]) for k, v in kw.items()}
    if "intrinsics" in arrays and not isinstance(arrays["intrinsics"], np.ma.MaskedArray):
        arrays["intrinsics"] = arrays["intrinsics"].reshape(-1)
    return _Snapshot(**arrays, id=_integer(id, "id", source), t0=_integer(t0, "t0", source),
                     source=source)


@_keywords(("snapshot",) + COVARIANCE_KEYWORDS)
def Covariance(snapshot, preset="droid", **options):
    """The covariance engine on `snapshot` (a Snapshot or a path). Keywords mirror dba-covariance:
    weight_scale, gauge ("two-pose" | "minimal" | "droid"), gauge_sigma_rot, gauge_sigma_trans,
    near, far, min_depth_ratio, sensor_depth_weight, solver ("sparse" | "dense"), ordering,
    threads; depth_sigma=True keeps what inverse_depth_sigma needs.
    The noise model is self-calibrated from the snapshot's residuals by default (dba-covariance's
    default: a per-edge flow-error field, the white scale and the depths' second-order term);
    stated_model=True gives the covariance of the noise the snapshot states (confidences times
    weight_scale), as --stated-model. self_calibrate_nodes (the field: 0 = affine, 2..8 = affine
    + G x G spline, default 4) and self_calibrate_depth_noise (True (default) | False) tune the
    calibration. converge=True solves the snapshot's DBA first (on a copy; .snapshot is then the
    solved one; converge_iterations, 1..100000, default 200, caps that solve and implies
    converge=True); self-calibrated, stereo edges and RGB-D readings are re-weighted at their
    calibrated variance ratio to the flow and the DBA re-solved until the ratios settle
    (.reweighting: None or a dict of solves, settled, last_ratio, unmeasured, sensor_depth_factor,
    edge_factors, failed_solve: None or the summary of a re-solve that did not converge, after
    which the last converged state is kept).
    The result's .self_calibration is None or a dict (method, global_scale, passes, optimum,
    sensor_depth_scale and sensor_depth_rows (RGB-D: the readings' variance factor, 1 without),
    depth_noise (applied or not), depth_noise_share (what it adds to the trace of the method's own covariance, a fraction),
    depth_noise_kurtosis (the residuals' excess kurtosis the term used),
    depth_noise_cross_kurtosis (the two flow axes' joint fourth cumulant it used),
    edge_scale_spread and poor_fit (the noise-model fit check: the CLI's "fits the residuals
    poorly" warning, whose sigmas are lower bounds),
    edges: one array per --edge-csv column, field_sigma, field_fine_sigma (px) and field_params);
    None with stated_model=True."""
    if snapshot is not None and not isinstance(snapshot, _Snapshot):
        snapshot = load(snapshot)
    return _Covariance(snapshot, preset=preset, **options)


@_keywords()
def write_pose_rawlog(path, covariances, emit="latest", label=None, fps=None,
                      start_time=0.0):
    """dba-covariance -o over several snapshots' covariances (in input order): a gz-compressed
    rawlog of CObservationRobotPose (CPose3DPDFGaussian), emit "latest" | "all" | "final", label
    (default DBA_COVARIANCE_CALIBRATED, or DBA_COVARIANCE for stated-model covariances), the
    keyframe times from the snapshots' timestamps_s or, without them, start_time + tstamp / fps.
    Written atomically through the MRPT bridge (libdbacov_mrpt.so, loaded on the first call); the
    same bytes as the command-line tool. Errors: dbacov.InputError with the CLI's messages."""
    if isinstance(covariances, _Covariance):
        covariances = [covariances]
    _write_pose_rawlog(_path(path), list(covariances), emit=emit, label=label,
                       fps=None if fps is None else float(fps), start_time=float(start_time))


def _write_pose_rawlog_method(self, path, **options):
    _unknown_keyword("write_pose_rawlog", options, _WRITE_KEYWORDS)
    _write_one(self, _path(path), **options)


_write_one = _Covariance.write_pose_rawlog
_write_pose_rawlog_method.__doc__ = _write_one.__doc__
_Covariance.write_pose_rawlog = _write_pose_rawlog_method  # paths as str or os.PathLike


@_keywords()
def from_droid(video, graph, include_inactive=True, record=None, image_times_s=None,
               stereo_rig=None, snapshot_id=None):
    """The current DBA factor graph of DROID-SLAM (its DepthVideo and FactorGraph, CPU or CUDA
    tensors) as a Snapshot, exactly as share/droid/dbacov_dump.py would write it: true keyframe
    frame indices (pass one `record`, a KeyframeRecord, across calls), t0, disps_sens for RGB-D,
    stereo_rig for stereo edges, timestamps_s from `image_times_s`."""
    arrays = _droid.snapshot_arrays(video, graph, snapshot_id, include_inactive=include_inactive,
                                    record=record, image_times_s=image_times_s,
                                    stereo_rig=stereo_rig)
    t0 = arrays.pop("t0", None)
    sid = arrays.pop("id", None)
    return Snapshot(**arrays, id=sid, t0=t0, source="<droid>")


KeyframeRecord = _droid.KeyframeRecord
read_euroc_image_times = _droid.read_euroc_image_times
