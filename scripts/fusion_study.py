#!/usr/bin/python3
"""Monte Carlo study of the fused sequence graph: is dba-posegraph's fused result consistent?

For each scenario and run: simul-dba (24x32, weight scale 256, white noise matching the
confidences), dba-covariance --graph with each --graph-edges choice, extra constraints drawn with
their own noise from the ground truth (loop closures, absolute priors), dba-posegraph, and
dba-evaluate --rawlog against the ground truth. Pools the NEES of the optimized poses over every
node but the two gauge keyframes (held at the truth by the simulator) and prints ANEES, its 95 %
region for N = runs, and the RMS position error.

  scripts/fusion_study.py [--build build] [--runs 20] [--scenarios line,loop,priors] [--out DIR]
      [--methods snapshot-marginals-not-fusable,chain,covisibility] [--persistence snapshot|edge]

--persistence edge draws each edge's flows once and shares them among the snapshots that hold it
(simul-dba --noise-persistence edge), as DROID's overlapping windows share their flows; the
default redraws them per snapshot. --gauge-hold estimate holds each snapshot's gauge keyframes at
the previous snapshot's estimates (DROID's frontend) instead of the truth (simul-dba
--gauge-hold): the snapshots then no longer hand the pose graph the true frame and scale of
every window. Keyframes 0 and 1 stay at the truth either way.
"""
import argparse, csv, math, os, random, subprocess, sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENARIOS = {
    # name: (config, extra-constraint kind)
    "line": ("share/sim/sliding_window_line.json", None),
    "loop": ("share/sim/loop_room_boxes.json", "loop"),
    "priors": ("share/sim/sliding_window_line.json", "priors"),
}
METHODS = ["snapshot-marginals-not-fusable", "chain", "covisibility"]


def quat_to_R(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def R_to_quat(R):
    w = math.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    return [x, y, z, w]


def exp_se3(xi):
    rho, phi = np.asarray(xi[:3]), np.asarray(xi[3:])
    th = np.linalg.norm(phi)
    K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    if th < 1e-12:
        R, V = np.eye(3) + K, np.eye(3) + K / 2
    else:
        R = np.eye(3) + math.sin(th) / th * K + (1 - math.cos(th)) / th**2 * K @ K
        V = np.eye(3) + (1 - math.cos(th)) / th**2 * K + (th - math.sin(th)) / th**3 * K @ K
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, V @ rho
    return T


def read_tum(path):
    poses = []
    for line in open(path):
        v = [float(x) for x in line.split()]
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = quat_to_R(v[4:8]), v[1:4]
        poses.append((v[0], T))
    return poses


def pose_text(T):
    return " ".join("%.17g" % v for v in list(T[:3, 3]) + R_to_quat(T[:3, :3]))


def extra_constraints(kind, truth, rng, path):
    lines = []
    if kind == "loop":  # loop closures between a keyframe and its revisit one lap later
        st, sr = 0.01, 0.005
        for a in range(0, len(truth) - 30, 3):
            b = a + 30
            Z = np.linalg.inv(truth[a][1]) @ truth[b][1]
            Z = Z @ exp_se3([rng.gauss(0, st) for _ in range(3)] + [rng.gauss(0, sr) for _ in range(3)])
            lines.append("relative %d %d %s %g %g" % (a, b, pose_text(Z), st, sr))
    elif kind == "priors":  # GPS-like absolute priors on every 6th keyframe
        st, sr = 0.02, 0.01
        for k in range(6, len(truth), 6):
            T = truth[k][1] @ exp_se3([rng.gauss(0, st) for _ in range(3)] + [rng.gauss(0, sr) for _ in range(3)])
            lines.append("absolute %d %s %g %g" % (k, pose_text(T), st, sr))
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr))
    return r.stderr


def region(runs, dof=6):
    k, z = dof * runs, 1.959963984540054
    q = lambda s: k * (1 - 2 / (9 * k) + s * z * math.sqrt(2 / (9 * k))) ** 3 / runs
    return q(-1), q(1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--scenarios", default="line,loop,priors")
    ap.add_argument("--out", default="/tmp/dbacov_fusion_study")
    ap.add_argument("--persistence", default="snapshot", choices=["snapshot", "edge"],
                    help="simul-dba --noise-persistence")
    ap.add_argument("--gauge-hold", default="truth", choices=["truth", "estimate"],
                    help="simul-dba --gauge-hold")
    ap.add_argument("--methods", default=",".join(METHODS), help="--graph-edges values to compare")
    a = ap.parse_args()
    methods = a.methods.split(",")
    b = os.path.join(a.build, "bin")
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for name in a.scenarios.split(","):
        config, kind = SCENARIOS[name]
        stats = {m: {"nees": 0.0, "n": 0, "pos2": 0.0} for m in methods}
        for r in range(a.runs):
            d = os.path.join(a.out, "%s_%d" % (name, r))
            run([b + "/simul-dba", "-o", d, "--config", os.path.join(ROOT, config), "--height", "24",
                 "--width", "32", "--weight-scale", "256", "--run", str(r), "-q",
                 "--noise-persistence", a.persistence, "--gauge-hold", a.gauge_hold])
            truth = read_tum(os.path.join(d, "groundtruth.tum"))
            extra = []
            if kind:
                extra_constraints(kind, truth, random.Random(1000 * r + 7), d + "/extra.txt")
                extra = ["--extra", d + "/extra.txt"]
            gauge_time = truth[1][0] + 1e-6  # nodes 0 and 1: the gauge, held at the truth
            for m in methods:
                run([b + "/dba-covariance", "-i", d, "--weight-scale", "256", "--graph", d + "/g_" + m,
                     "--graph-edges", m, "-q"])
                run([b + "/dba-posegraph", "-g", d + "/g_" + m + ".graphbin", "-o", d + "/pg.rawlog", "-q"] + extra)
                run([b + "/dba-evaluate", "--rawlog", d + "/pg.rawlog", "--gt", d + "/groundtruth.tum",
                     "--samples-csv", d + "/s.csv"])
                for row in csv.DictReader(open(d + "/s.csv")):
                    if float(row["group"][1:]) <= gauge_time:
                        continue
                    s = stats[m]
                    s["nees"] += float(row["nees"])
                    s["n"] += 1
                    s["pos2"] += sum(float(row["e_%d" % i]) ** 2 for i in range(3))
            print("%s run %d done" % (name, r), file=sys.stderr)
        lo, hi = region(a.runs)
        for m in methods:
            s = stats[m]
            anees = s["nees"] / s["n"]
            rows.append((name, m, a.runs, anees, lo, hi, lo <= anees <= hi, math.sqrt(s["pos2"] / s["n"])))
    print("gauge_hold,persistence,scenario,graph_edges,runs,anees,region_lo,region_hi,inside,rms_position")
    for row in rows:
        print("%s,%s,%s,%s,%d,%.3f,%.2f,%.2f,%s,%.5f" % ((a.gauge_hold, a.persistence) + row))


if __name__ == "__main__":
    main()
