"""Golden outputs compared with tolerances (golden_outputs.sh runs it).

A file's digest holds what a change of compiler, BLAS or optimization level keeps and what a real
change of the numbers does not:
  - text files (.csv, .g2o, .graph, .json): the text with every number replaced by '#' (its
    layout, headers, labels and ids), kept exactly; and the numbers;
  - .npy arrays: dtype and shape exactly; and the values;
  - binary MRPT files (.rawlog, .graphbin): their size exactly. Their numbers are those of their
    text siblings (the pose rawlog holds the CSV's covariances, the .graphbin the .graph's
    edges), which are compared by value.
The numbers of a file are compared through their count (exactly), their sum, sum of absolute
values, sum of squares, minimum, maximum and up to 64 evenly spaced samples, each within
RTOL relative to the file's scale (its largest absolute value, or the sample's own size).

  golden_compare.py digest DIR > golden.json     the digests of every file under DIR
  golden_compare.py check DIR golden.json        exit 1 naming each file and quantity that differs
  golden_compare.py self-test DIR golden.json    a check that must fail: each kind of file under
                                                 DIR perturbed by 1e-4 of a value, and it must be
                                                 caught (exit 1 otherwise)
"""

import hashlib
import json
import os
import re
import shutil
import sys
import tempfile

import numpy as np

RTOL = 1e-6  # Release builds of one source agree to ~1e-12; a real change moves ~1e-3 or more
SAMPLES = 64
NUMBER = re.compile(r"(?<![A-Za-z_0-9.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![A-Za-z_])"
                    r"|(?<![A-Za-z_])(?:nan|inf)(?![A-Za-z_])")
TEXT = (".csv", ".g2o", ".graph", ".json", ".tum")
BINARY = (".rawlog", ".graphbin")


def numbers_digest(values):
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    # Where the values are not finite (-inf log-determinants of held poses, NaN depths), exactly.
    bad = np.flatnonzero(~np.isfinite(v))
    d = {"count": int(v.size),
         "nonfinite": hashlib.sha256(repr([(int(i), repr(v[i])) for i in bad]).encode())
         .hexdigest()}
    v = v[np.isfinite(v)]
    if v.size:
        idx = np.unique(np.linspace(0, v.size - 1, min(SAMPLES, v.size)).round().astype(int))
        d.update(sum=float(v.sum()), abs=float(np.abs(v).sum()), sq=float((v * v).sum()),
                 min=float(v.min()), max=float(v.max()), samples=[float(x) for x in v[idx]])
    return d


def digest(path):
    name = path.lower()
    if name.endswith(BINARY):
        return {"size": os.path.getsize(path)}
    if name.endswith(".npy"):
        a = np.load(path, allow_pickle=False)
        return {"layout": f"{a.dtype.str} {a.shape}", **numbers_digest(a)}
    if name.endswith(TEXT):
        text = open(path, encoding="utf-8").read()
        layout = hashlib.sha256(NUMBER.sub("#", text).encode()).hexdigest()
        return {"layout": layout, **numbers_digest([float(m) for m in NUMBER.findall(text)])}
    raise SystemExit(f"golden_compare: {path}: no digest for this kind of file")


def digest_tree(root):
    out = {}
    for d, _, files in os.walk(root):
        for f in files:
            p = os.path.join(d, f)
            out[os.path.relpath(p, root)] = digest(p)
    return dict(sorted(out.items()))


def differences(now, golden):
    """Lines naming each file and quantity of `now` that is not `golden` within the tolerances."""
    out = []
    for f in sorted(set(now) | set(golden)):
        if f not in golden:
            out.append(f"{f}: a new file (not in the golden outputs)")
            continue
        if f not in now:
            out.append(f"{f}: missing (the golden outputs have it)")
            continue
        a, b = now[f], golden[f]
        for key in ("size", "layout", "count", "nonfinite"):
            if a.get(key) != b.get(key):
                out.append(f"{f}: {key} {a.get(key)} != golden {b.get(key)}")
        if out and out[-1].startswith(f + ":") or "sum" not in b:
            continue
        scale = max(abs(b["min"]), abs(b["max"]), 1e-300)
        for key in ("sum", "abs", "sq", "min", "max"):
            ref = b["abs"] if key == "sum" else (b[key] if key != "min" else scale)
            if abs(a[key] - b[key]) > RTOL * max(abs(ref), abs(b[key]), 1e-300):
                out.append(f"{f}: {key} {a[key]!r} != golden {b[key]!r}")
        for i, (x, y) in enumerate(zip(a["samples"], b["samples"])):
            if not (x == y or abs(x - y) <= RTOL * max(abs(y), 1e-3 * scale)):
                out.append(f"{f}: sample {i} {x!r} != golden {y!r}")
                break
    return out


def check(root, golden_path, quiet=False):
    with open(golden_path, encoding="utf-8") as f:
        golden = json.load(f)
    diff = differences(digest_tree(root), golden)
    for line in [] if quiet else diff:
        print("golden outputs: " + line, file=sys.stderr)
    return diff


def perturb(path):
    """Moves one value of `path` by 1e-4 of itself (or of the file's scale): a small real change."""
    name = path.lower()
    if name.endswith(".npy"):
        a = np.load(path)
        k = int(np.argmax(np.abs(a)))
        a.flat[k] *= 1 + 1e-4
        np.save(path, a)
        return True
    if name.endswith(TEXT):
        text = open(path, encoding="utf-8").read()
        finite = [m for m in NUMBER.finditer(text) if np.isfinite(float(m.group()))]
        best = max(finite, key=lambda m: abs(float(m.group())), default=None)
        if best is None or float(best.group()) == 0:
            return False
        x = float(best.group()) * (1 + 1e-4)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text[:best.start()] + repr(x) + text[best.end():])
        return True
    if name.endswith(BINARY):
        with open(path, "ab") as f:
            f.write(b"\0")
        return True
    return False


def self_test(root, golden_path):
    """Each kind of file perturbed alone must fail the check (and the untouched tree pass)."""
    if check(root, golden_path):
        print("golden self-test: the untouched outputs already differ", file=sys.stderr)
        return 1
    kinds = {}
    for f in sorted(digest_tree(root)):
        kinds.setdefault(os.path.splitext(f)[1], f)
    missed = []
    for ext, f in kinds.items():
        with tempfile.TemporaryDirectory() as tmp:
            copy = os.path.join(tmp, "t")
            shutil.copytree(root, copy)
            if perturb(os.path.join(copy, f)) and not check(copy, golden_path, quiet=True):
                missed.append(f)
    if missed:
        print("golden self-test: a perturbation of 1e-4 was not caught in " + ", ".join(missed),
              file=sys.stderr)
        return 1
    print(f"golden self-test: a 1e-4 change is caught in each of {len(kinds)} kinds of file")
    return 0


def main(argv):
    if len(argv) == 2 and argv[0] == "digest":
        json.dump(digest_tree(argv[1]), sys.stdout, indent=1, sort_keys=True)
        print()
        return 0
    if len(argv) == 3 and argv[0] == "check":
        return 1 if check(argv[1], argv[2]) else 0
    if len(argv) == 3 and argv[0] == "self-test":
        return self_test(argv[1], argv[2])
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
