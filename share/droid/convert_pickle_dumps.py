#!/usr/bin/env python3
"""Convert the pickled DBA dumps of the paper's published code to dbacov snapshot `.npz` files.

The code published with the paper (github.com/jpsnir/droid_slam_covariance_models) stores one DBA
factor graph per pickle: a dict with keys id, intrinsics, graph_data {ii, jj}, disps, c_map,
predicted, poses, tstamp (torch tensors or numpy arrays). This tool writes each as the `.npz` of
conventions §1 ('predicted' -> 'target', 'c_map' -> 'weight', graph_data.ii/jj -> 'ii'/'jj'), validated,
atomically, one output per input with the same stem. See --help.
"""

import argparse
import os
import pickle
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dbacov_dump import check_snapshot, to_numpy, write_snapshot_npz  # noqa: E402

PROG = "convert_pickle_dumps.py"
# Names of the snapshot keys in the pickles, for messages.
SOURCE_NAMES = {"target": "predicted", "weight": "c_map", "ii": "graph_data.ii",
                "jj": "graph_data.jj"}
PICKLE_SUFFIXES = (".pkl", ".pickle")

DESCRIPTION = """\
Convert pickled DBA dumps of the paper's code (github.com/jpsnir/droid_slam_covariance_models) to
dbacov snapshot .npz files (conventions §1): 'predicted' -> 'target', 'c_map' -> 'weight',
graph_data['ii'/'jj'] -> 'ii'/'jj'; 'poses', 'disps', 'intrinsics', 'tstamp' and (if present) 'id'
are kept. foo.pkl becomes OUT_DIR/foo.npz.

Accepted layouts (E edges from graph_data.ii, N keyframes from poses, H,W from disps):
  predicted, c_map   (E,2,H,W) (E,H,W,2) (1,E,H,W,2) (1,E,2,H,W); written as (E,2,H,W) float32,
                     channel 0 = x (column), 1 = y (row): channel order is kept, never swapped
  disps              (N,H,W) or (1,N,H,W)          poses  (N,7) or (1,N,7), T_cw [t, qx qy qz qw]
  intrinsics         (4,), (N,4) or (1,N,4) with equal rows     tstamp (N,)    id  integer scalar
Ambiguous or inconsistent shapes are refused. Checked: ii/jj in [0,N) and ii != jj, finite values,
weights >= 0. Exit status: 0 all converted, 1 some file failed (one error line each; the others
are still written), 2 bad usage.

Pickles holding torch tensors need PyTorch installed to be read (the CPU build is enough)."""

EPILOG = """\
SECURITY: unpickling runs code chosen by whoever wrote the file. Only convert pickles you trust
(e.g. that you produced yourself); never run this on files from an untrusted source."""


class ConversionError(Exception):
    """A bad input file; the message names the key, the shape found and what was expected."""


def _shape(shape):
    return "(" + ",".join(str(d) for d in shape) + ("," if len(shape) == 1 else "") + ")"


def _pick_layout(a, key, layouts, dims):
    """Returns `a` rearranged by the one layout whose concrete shape matches a.shape.

    layouts: (pattern, rearrange) pairs; a pattern is a tuple of dim names ("E", "N", "H", "W")
    and literal sizes. dims: the values of the names. Zero or several matches raise."""
    concrete = [(p, tuple(dims.get(d, d) for d in p), f) for p, f in layouts]
    hits = [(p, f) for p, c, f in concrete if c == a.shape]
    if len(hits) == 1:
        return hits[0][1](a)
    names = ", ".join(f"({','.join(str(d) for d in p)})={_shape(c)}" for p, c, _ in concrete)
    if not hits:
        raise ConversionError(f"key '{key}' has shape {_shape(a.shape)}, expected one of "
                              f"{names} (E from graph_data.ii, N from poses, H,W from disps)")
    matched = " and ".join("(" + ",".join(map(str, p)) + ")" for p, _ in hits)
    raise ConversionError(f"key '{key}' has shape {_shape(a.shape)}, which is ambiguous: it "
                          f"matches {matched}; expected one of {names}")


def _keep(a):
    return a


def _first(a):
    return a[0]


PLANE_LAYOUTS = [
    (("E", 2, "H", "W"), _keep),
    (("E", "H", "W", 2), lambda a: a.transpose(0, 3, 1, 2)),
    ((1, "E", "H", "W", 2), lambda a: a[0].transpose(0, 3, 1, 2)),
    ((1, "E", 2, "H", "W"), _first),
]


def _numeric(dump, key, path=None):
    """The value of `key` (or of the nested `path`) as a numpy array of numbers."""
    value = dump
    for k in path or (key,):
        if not isinstance(value, dict) or k not in value:
            raise ConversionError(f"missing key '{key}'")
        value = value[k]
    try:
        a = to_numpy(value)
    except Exception as e:  # an object that is no array at all
        raise ConversionError(f"key '{key}' is not an array ({type(value).__name__}): {e}")
    if a.dtype.kind not in "biuf":
        raise ConversionError(f"key '{key}' has dtype {a.dtype}, expected numbers")
    return a


def _indices(dump, key):
    a = _numeric(dump, f"graph_data.{key}", ("graph_data", key))
    if a.dtype.kind not in "iu":
        raise ConversionError(f"key 'graph_data.{key}' has dtype {a.dtype}, expected integers")
    if a.ndim != 1:
        raise ConversionError(f"key 'graph_data.{key}' has shape {_shape(a.shape)}, expected (E,)")
    return a.astype(np.int64)


def convert_dump(dump):
    """The conventions §1 arrays of one unpickled dump (a dict); raises ConversionError."""
    if not isinstance(dump, dict):
        raise ConversionError(f"the pickle holds a {type(dump).__name__}, expected a dict")
    ii, jj = _indices(dump, "ii"), _indices(dump, "jj")
    if ii.shape != jj.shape:
        raise ConversionError(f"keys 'graph_data.ii' and 'graph_data.jj' have shapes "
                              f"{_shape(ii.shape)} and {_shape(jj.shape)}, expected the same (E,)")
    poses = _numeric(dump, "poses")
    if poses.ndim not in (2, 3) or poses.shape[-1] != 7:
        raise ConversionError(f"key 'poses' has shape {_shape(poses.shape)}, "
                              "expected (N,7) or (1,N,7)")
    n = poses.shape[-2]
    poses = _pick_layout(poses, "poses", [(("N", 7), _keep), ((1, "N", 7), _first)], {"N": n})
    disps = _numeric(dump, "disps")
    if disps.ndim not in (3, 4):
        raise ConversionError(f"key 'disps' has shape {_shape(disps.shape)}, "
                              f"expected (N,H,W) or (1,N,H,W) with N={n} from poses")
    h, w = disps.shape[-2:]
    dims = {"E": ii.shape[0], "N": n, "H": h, "W": w}
    disps = _pick_layout(disps, "disps", [(("N", "H", "W"), _keep), ((1, "N", "H", "W"), _first)],
                         dims)
    intr = _pick_layout(_numeric(dump, "intrinsics"), "intrinsics",
                        [((4,), lambda a: a[None]), (("N", 4), _keep), ((1, "N", 4), _first)], dims)
    differs = np.flatnonzero((intr != intr[0]).any(axis=1))
    if differs.size:
        raise ConversionError(f"key 'intrinsics': row {differs[0]} = {intr[differs[0]]} differs "
                              f"from row 0 = {intr[0]}; expected one camera for all keyframes")
    arrays = {
        "poses": poses.astype(np.float64 if poses.dtype == np.float64 else np.float32),
        "disps": disps.astype(np.float32),
        "intrinsics": intr[0].astype(np.float32),
        "ii": ii,
        "jj": jj,
        "target": _pick_layout(_numeric(dump, "predicted"), "predicted", PLANE_LAYOUTS, dims),
        "weight": _pick_layout(_numeric(dump, "c_map"), "c_map", PLANE_LAYOUTS, dims),
        "tstamp": _pick_layout(_numeric(dump, "tstamp"), "tstamp", [(("N",), _keep)], dims),
    }
    for key in ("target", "weight"):
        arrays[key] = np.ascontiguousarray(arrays[key], dtype=np.float32)
    arrays["tstamp"] = arrays["tstamp"].astype(np.float64)
    if "id" in dump:
        sid = _numeric(dump, "id")
        if sid.dtype.kind not in "iu" or sid.size != 1 or sid.ndim > 1:
            raise ConversionError(f"key 'id' is {sid.dtype} {_shape(sid.shape)}, "
                                  "expected one integer")
        arrays["id"] = np.array(sid.reshape(-1)[0], dtype=np.int64)
    try:
        check_snapshot(arrays, check_values=True, names=SOURCE_NAMES)
    except ValueError as e:
        raise ConversionError(str(e)) from None
    return arrays


def load_pickle(path):
    """Unpickles `path`; explains a missing torch. Raises ConversionError."""
    try:
        with open(path, "rb") as f:
            return pickle.load(f)
    except ModuleNotFoundError as e:
        if (e.name or "").split(".")[0] == "torch":
            raise ConversionError("the pickle holds torch tensors and PyTorch is not installed: "
                                  "install torch (the CPU build is enough) to read it") from None
        raise ConversionError(f"cannot unpickle: needs Python module '{e.name}'") from None
    except OSError as e:
        raise ConversionError(f"cannot read: {e.strerror or e}") from None
    except Exception as e:
        raise ConversionError(f"cannot unpickle: {type(e).__name__}: {e}") from None


def expand_inputs(inputs):
    """(path, error) pairs: a directory gives its .pkl/.pickle files in name order."""
    out = []
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            files = sorted((f for f in p.iterdir()
                            if f.suffix.lower() in PICKLE_SUFFIXES and f.is_file()),
                           key=lambda f: f.name)
            out += [(f, None) for f in files] or [(p, "directory holds no .pkl/.pickle file")]
        elif p.is_file():
            out.append((p, None))
        else:
            out.append((p, "no such file or directory"))
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(prog=PROG, description=DESCRIPTION, epilog=EPILOG,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("inputs", nargs="+", metavar="INPUT",
                        help="a .pkl/.pickle dump, or a directory of them (name order)")
    parser.add_argument("-o", "--output-dir", required=True, metavar="OUT_DIR",
                        help="directory for the .npz files (created if missing)")
    parser.add_argument("--uncompressed", action="store_true",
                        help="store the arrays (np.savez) instead of deflating them")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="print errors only (no per-file lines, no summary)")
    args = parser.parse_args(argv)

    out_dir = Path(args.output_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        print(f"{PROG}: error: cannot create output directory {out_dir}: {e.strerror or e}",
              file=sys.stderr)
        return 1
    written = {}
    failed = 0
    inputs = expand_inputs(args.inputs)
    for path, error in inputs:
        out = out_dir / (path.stem + ".npz")
        try:
            if error:
                raise ConversionError(error)
            if out in written:
                raise ConversionError(f"output {out} is already written from {written[out]}")
            arrays = convert_dump(load_pickle(path))
            try:
                write_snapshot_npz(out, arrays, compressed=not args.uncompressed)
            except OSError as e:
                raise ConversionError(f"cannot write {out}: {e.strerror or e}") from None
            written[out] = path
            if not args.quiet:
                print(f"{path} -> {out}")
        except ConversionError as e:
            failed += 1
            print(f"{PROG}: error: {path}: " + " ".join(str(e).split()), file=sys.stderr)
    if not args.quiet:
        print(f"{len(inputs) - failed} of {len(inputs)} files converted, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
