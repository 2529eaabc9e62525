#!/usr/bin/python3
"""The per-edge self-calibration of a snapshot against the edge's mean confidence and flow
magnitude (docs/studies/real-snapshot.md), as an SVG with two panels.

    scripts/edge_figure.py [--snapshot ../shared/data/droid_window_0055.npz]
                           [--build build] [--out docs/self_calibration_edges.svg] [-- ARGS...]

Runs `dba-covariance -i SNAPSHOT --edge-csv ...` (extra ARGS go to it, e.g.
`--self-calibrate-nodes 0`), then plots per edge the white-noise inflation c_e (filled)
and c_e times the field's share, `correlation` (open: the edge's whole error variance over the
confidences' claim), on a log axis, against the mean confidence of the edge's pixels with w > 0
and their mean flow magnitude |target - pixel| (grid pixels). Prints the Spearman rank
correlations. Needs only NumPy (no plotting library: the SVG is written directly).
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile

import numpy as np


def spearman(x, y):
    rx = np.argsort(np.argsort(x)).astype(float)
    ry = np.argsort(np.argsort(y)).astype(float)
    if rx.std() == 0 or ry.std() == 0:
        return 0.0
    return float(np.corrcoef(rx, ry)[0, 1])


def edge_features(path):
    z = np.load(path)
    target, weight = z["target"].astype(float), z["weight"].astype(float)
    E, _, H, W = target.shape
    ys, xs = np.mgrid[0:H, 0:W]
    conf, flow = np.zeros(E), np.zeros(E)
    for e in range(E):
        used = (weight[e, 0] > 0) | (weight[e, 1] > 0)
        if not used.any():
            conf[e] = flow[e] = float("nan")
            continue
        w = 0.5 * (weight[e, 0] + weight[e, 1])
        conf[e] = w[used].mean()
        mag = np.hypot(target[e, 0] - xs, target[e, 1] - ys)
        flow[e] = mag[used].mean()
    return conf, flow


def panel(x0, y0, w, h, xs, series, xlabel, ylabel):
    """One scatter panel at (x0, y0) of size w × h; series = [(values, filled, label)], log y."""
    out = []
    ok = np.isfinite(xs)
    allv = np.concatenate([v[ok & (v > 0)] for v, _, _ in series])
    lo, hi = math.floor(math.log10(allv.min())), math.ceil(math.log10(allv.max()))
    hi = max(hi, lo + 1)
    xmin, xmax = float(np.nanmin(xs)), float(np.nanmax(xs))
    pad = 0.05 * (xmax - xmin or 1.0)
    xmin, xmax = xmin - pad, xmax + pad

    def px(x):
        return x0 + (x - xmin) / (xmax - xmin) * w

    def py(v):
        return y0 + h - (math.log10(v) - lo) / (hi - lo) * h

    out.append(f'<rect x="{x0}" y="{y0}" width="{w}" height="{h}" fill="none" stroke="#444"/>')
    for d in range(lo, hi + 1):
        y = py(10.0 ** d)
        out.append(f'<line x1="{x0}" x2="{x0 + w}" y1="{y:.1f}" y2="{y:.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{x0 - 6}" y="{y + 4:.1f}" text-anchor="end" font-size="11">'
                   f'1e{d}</text>')
    for k in range(5):
        x = xmin + (xmax - xmin) * (k + 0.5) / 5
        out.append(f'<text x="{px(x):.1f}" y="{y0 + h + 16}" text-anchor="middle" '
                   f'font-size="11">{x:.3g}</text>')
    out.append(f'<text x="{x0 + w / 2}" y="{y0 + h + 34}" text-anchor="middle" '
               f'font-size="12">{xlabel}</text>')
    out.append(f'<text x="{x0 - 48}" y="{y0 + h / 2}" text-anchor="middle" font-size="12" '
               f'transform="rotate(-90 {x0 - 48} {y0 + h / 2})">{ylabel}</text>')
    for values, filled, _ in series:
        for x, v in zip(xs, values):
            if not (np.isfinite(x) and v > 0):
                continue
            style = 'fill="#1f5fa8"' if filled else 'fill="none" stroke="#c0392b"'
            out.append(f'<circle cx="{px(x):.1f}" cy="{py(v):.1f}" r="3.2" {style}/>')
    return out


def main():
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1:]
        argv = argv[:argv.index("--")]
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--snapshot", default="../shared/data/droid_window_0055.npz")
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="docs/self_calibration_edges.svg")
    a = ap.parse_args(argv)
    exe = os.path.join(a.build, "bin", "dba-covariance")
    if not os.path.exists(a.snapshot):
        sys.exit(f"edge_figure: {a.snapshot}: no such snapshot")
    with tempfile.TemporaryDirectory() as tmp:
        edges_csv = os.path.join(tmp, "edges.csv")
        cmd = [exe, "-i", a.snapshot, "--csv", os.path.join(tmp, "k.csv"), "-q",
               "--edge-csv", edges_csv] + extra
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"edge_figure: {' '.join(cmd)} failed:\n{r.stderr}")
        rows = list(csv.DictReader(open(edges_csv)))
    conf, flow = edge_features(a.snapshot)
    if len(rows) != len(conf):
        sys.exit(f"edge_figure: {len(rows)} edge rows for {len(conf)} edges")
    infl = np.array([float(r["inflation"]) for r in rows])
    whole = infl * np.array([float(r["correlation"]) for r in rows])
    method = rows[0]["method"] if rows else "?"
    series = [(infl, True, "white inflation c_e"), (whole, False, "c_e x correlation")]
    W, H = 900, 400
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
           f'font-family="sans-serif">', f'<rect width="{W}" height="{H}" fill="white"/>',
           f'<text x="{W / 2}" y="20" text-anchor="middle" font-size="14">'
           f'{os.path.basename(a.snapshot)}: per-edge self-calibration ({method}), '
           f'{len(rows)} edges</text>']
    svg += panel(90, 50, 330, 280, conf, series, "mean confidence of the edge's pixels",
                 "variance factor")
    svg += panel(540, 50, 330, 280, flow, series, "mean flow magnitude (grid px)",
                 "variance factor")
    svg.append(f'<circle cx="100" cy="{H - 14}" r="3.2" fill="#1f5fa8"/>'
               f'<text x="108" y="{H - 10}" font-size="11">{series[0][2]}</text>'
               f'<circle cx="300" cy="{H - 14}" r="3.2" fill="none" stroke="#c0392b"/>'
               f'<text x="308" y="{H - 10}" font-size="11">{series[1][2]} (the whole error '
               f'variance over the confidences\' claim)</text>')
    svg.append("</svg>")
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    with open(a.out + ".tmp", "w") as f:
        f.write("\n".join(svg) + "\n")
    os.replace(a.out + ".tmp", a.out)
    ok = np.isfinite(conf)
    print(f"{a.out}: {len(rows)} edges, method {method}")
    for name, v in (("inflation", infl), ("inflation x correlation", whole)):
        print(f"  Spearman({name}, mean confidence) = {spearman(v[ok], conf[ok]):+.2f}, "
              f"(…, flow magnitude) = {spearman(v[ok], flow[ok]):+.2f}, "
              f"range {v.min():.3g} .. {v.max():.3g}")


if __name__ == "__main__":
    main()
