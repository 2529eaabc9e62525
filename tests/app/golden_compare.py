"""Golden outputs compared with tolerances (golden_outputs.sh runs it).

A file's digest holds what a change of compiler, BLAS or optimization level keeps and what a real
change of the numbers does not:
  - text files (.csv, .g2o, .graph, .json): the text with every number replaced by '#' (its
    layout, headers, labels and ids), kept exactly; and the numbers, grouped by where they stand
    (a group: the numbers at one position of the lines of one layout, e.g. a CSV column or the
    third number of every EDGE_SE3:QUAT line);
  - .npy arrays: dtype and shape exactly; and the values (one group);
  - binary MRPT files (.rawlog, .graphbin): their size exactly. Their numbers are those of their
    text siblings (the pose rawlog holds the CSV's covariances, the .graphbin the .graph's
    edges), which are compared by value.
Each group is compared through its count and the positions of its non-finite values (exactly),
its sum and sum of absolute values (within RTOL of the latter), its minimum and maximum (RTOL of
the group's largest magnitude) and the sum of log|x| over its values above 1e-6 of that magnitude
(within RTOL per value: every value's relative change counts alike). So a change of sign, a
column scaled by 1 + 1e-3, or one value of a group of n moved by more than n·1e-6 of itself is
caught, whatever the magnitudes of the file's other groups; values below 1e-6 of their group's
largest (an information matrix's rounding noise beside entries of 1e15) are guarded only through
the sums.

  golden_compare.py digest DIR > golden.json     the digests of every file under DIR
  golden_compare.py check DIR golden.json        exit 1 naming each file, group and quantity
                                                 that differs
  golden_compare.py self-test DIR golden.json    checks that must fail: in each kind of file
                                                 under DIR, its largest value moved by 1e-4 and
                                                 a guarded value of median magnitude by 1e-2,
                                                 one at a time (exit 1 when one is not caught)
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
NUMBER = re.compile(r"(?<![A-Za-z_0-9.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![A-Za-z_])"
                    r"|(?<![A-Za-z_])(?:nan|inf)(?![A-Za-z_])")
TEXT = (".csv", ".g2o", ".graph", ".json", ".tum")
BINARY = (".rawlog", ".graphbin")


def numbers_digest(values):
    """The digest of one group of numbers (floats rounded to 12 digits: RTOL is far coarser)."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    # Where the values are not finite (-inf log-determinants of held poses), exactly.
    bad = np.flatnonzero(~np.isfinite(v))
    d = {"count": int(v.size),
         "nonfinite": [[int(i), repr(float(v[i]))] for i in bad[:8]] + ([int(bad.size)]
                                                                         if bad.size > 8 else [])}
    v = v[np.isfinite(v)]
    if v.size:
        r = lambda x: float(f"{x:.12g}")
        scale = np.abs(v).max()
        # Σ log|x| over the values that are not rounding noise: every value's relative change
        # counts alike, whatever its magnitude beside the others.
        big = np.abs(v)[np.abs(v) > 1e-6 * scale]
        d.update(sum=r(v.sum()), abs=r(np.abs(v).sum()), min=r(v.min()), max=r(v.max()),
                 nlog=int(big.size), log=r(np.log(big).sum()))
    return d


def text_numbers(text):
    """[(match, group key)] of every number of `text`: a group is one position of the lines of
    one layout."""
    out = []
    for line_start, line in line_spans(text):
        key = hashlib.sha256(NUMBER.sub("#", line).encode()).hexdigest()[:8]
        for k, m in enumerate(NUMBER.finditer(line)):
            out.append((line_start + m.start(), line_start + m.end(), m.group(), f"{key}.{k}"))
    return out


def line_spans(text):
    start = 0
    for line in text.split("\n"):
        yield start, line
        start += len(line) + 1


def text_groups(text):
    """{group key: numbers}."""
    groups = {}
    for _, _, number, key in text_numbers(text):
        groups.setdefault(key, []).append(float(number))
    return groups


def digest(path):
    name = path.lower()
    if name.endswith(BINARY):
        return {"size": os.path.getsize(path)}
    if name.endswith(".npy"):
        a = np.load(path, allow_pickle=False)
        return {"layout": f"{a.dtype.str} {a.shape}", "groups": {"values": numbers_digest(a)}}
    if name.endswith(TEXT):
        text = open(path, encoding="utf-8").read()
        layout = hashlib.sha256(NUMBER.sub("#", text).encode()).hexdigest()
        return {"layout": layout,
                "groups": {k: numbers_digest(v) for k, v in text_groups(text).items()}}
    raise SystemExit(f"golden_compare: {path}: no digest for this kind of file")


def digest_tree(root):
    out = {}
    for d, _, files in os.walk(root):
        for f in files:
            p = os.path.join(d, f)
            out[os.path.relpath(p, root)] = digest(p)
    return dict(sorted(out.items()))


def group_differences(where, a, b):
    """Lines for the quantities of group digest `a` that are not golden `b` within RTOL."""
    for key in ("count", "nonfinite", "nlog"):
        if a.get(key) != b.get(key):
            return [f"{where}: {key} {a.get(key)} != golden {b.get(key)}"]
    if "sum" not in b:
        return []
    scale = max(abs(b["min"]), abs(b["max"]))
    out = []
    for key in ("sum", "abs", "min", "max", "log"):
        ref = {"sum": b["abs"], "abs": b["abs"], "log": b["nlog"]}.get(key, scale)
        if abs(a[key] - b[key]) > RTOL * ref:
            out.append(f"{where}: {key} {a[key]!r} != golden {b[key]!r}")
    return out


def differences(now, golden):
    """Lines naming each file, group and quantity of `now` that is not `golden`."""
    out = []
    for f in sorted(set(now) | set(golden)):
        if f not in golden:
            out.append(f"{f}: a new file (not in the golden outputs)")
            continue
        if f not in now:
            out.append(f"{f}: missing (the golden outputs have it)")
            continue
        a, b = now[f], golden[f]
        wrong = [f"{f}: {key} {a.get(key)} != golden {b.get(key)}" for key in ("size", "layout")
                 if a.get(key) != b.get(key)]
        if wrong:
            out += wrong
            continue
        for g in sorted(b.get("groups", {})):
            out += group_differences(f"{f} [{g}]", a["groups"].get(g, {}), b["groups"][g])
    return out


def check(root, golden_path, quiet=False):
    with open(golden_path, encoding="utf-8") as f:
        golden = json.load(f)
    diff = differences(digest_tree(root), golden)
    for line in [] if quiet else diff:
        print("golden outputs: " + line, file=sys.stderr)
    return diff


def perturb(path, which):
    """Moves one value of `path`: the largest ("largest", by 1e-4 of itself) or one of median
    magnitude among those that the comparison guards, above 1e-6 of their group's largest
    ("median", by 1e-2): small real changes. False when the file has no such value."""
    name = path.lower()
    factor = 1 + (1e-4 if which == "largest" else 1e-2)

    def pick(values, groups):
        top = {}
        for x, g in zip(values, groups):
            if np.isfinite(x):
                top[g] = max(top.get(g, 0.0), abs(x))
        ok = [i for i, (x, g) in enumerate(zip(values, groups))
              if np.isfinite(x) and x != 0 and abs(x) > 1e-6 * top[g]]
        if not ok:
            return None
        order = sorted(ok, key=lambda i: abs(values[i]))
        return order[-1] if which == "largest" else order[len(order) // 2]

    if name.endswith(".npy"):
        a = np.load(path)
        values = a.reshape(-1).tolist()
        k = pick(values, [0] * len(values))
        if k is None:
            return False
        a.flat[k] *= factor
        np.save(path, a)
        return True
    if name.endswith(TEXT):
        text = open(path, encoding="utf-8").read()
        numbers = text_numbers(text)
        k = pick([float(n[2]) for n in numbers], [n[3] for n in numbers])
        if k is None:
            return False
        start, end, number, _ = numbers[k]
        with open(path, "w", encoding="utf-8") as f:
            f.write(text[:start] + repr(float(number) * factor) + text[end:])
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
        for which in ("largest", "median"):
            with tempfile.TemporaryDirectory() as tmp:
                copy = os.path.join(tmp, "t")
                shutil.copytree(root, copy)
                if perturb(os.path.join(copy, f), which) and not check(copy, golden_path, True):
                    missed.append(f"{f} ({which} value)")
    if missed:
        print("golden self-test: a small change was not caught in " + ", ".join(missed),
              file=sys.stderr)
        return 1
    print(f"golden self-test: a change of the largest value by 1e-4 and of a median one by 1e-2 "
          f"is caught in each of {len(kinds)} kinds of file")
    return 0


def main(argv):
    if len(argv) == 2 and argv[0] == "digest":
        json.dump(digest_tree(argv[1]), sys.stdout, indent=0, sort_keys=True, separators=(",", ":"))
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
