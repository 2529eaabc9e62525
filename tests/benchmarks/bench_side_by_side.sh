#!/usr/bin/env bash
# dba-covariance against the Ceres peer, as whole processes on the same input in one
# run: one copy of the shared DROID snapshot, then COPIES copies (one process each time). Both on
# one thread (`taskset -c 1` when the machine has a second core), CSV out. Prints for each tool the
# median wall time and CPU time (user+sys) over REPEATS runs, the ratio peer / dbacov, and the
# largest ‖Σ_ceres − Σ_dbacov‖ / ‖Σ_dbacov‖ over every keyframe of every snapshot; first, the
# start-up alone (`dba-covariance --help`).
#   tests/benchmarks/bench_side_by_side.sh [BUILD_DIR] [COPIES] [REPEATS]
set -euo pipefail
build=${1:-build}
copies=${2:-20}
repeats=${3:-3}
here=$(cd "$(dirname "$0")" && pwd)
snapshot=${DBACOV_SNAPSHOT:-$here/../../../shared/data/droid_window_0055.npz}
[ -f "$snapshot" ] || snapshot=/work/shared/data/droid_window_0055.npz
[ -f "$snapshot" ] || { echo "bench_side_by_side: no shared snapshot (set DBACOV_SNAPSHOT)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/one" "$work/many"
ln -s "$snapshot" "$work/one/s0001.npz"
for n in $(seq -w 1 "$copies"); do ln -s "$snapshot" "$work/many/s$n.npz"; done
pin=()
if [ "$(nproc)" -ge 2 ] && command -v taskset > /dev/null; then pin=(taskset -c 1); fi

# run CMD...: REPEATS runs; prints "median_wall median_cpu" in seconds (proc_time.py: CPU time
# from the kernel's rusage to the microsecond, not /usr/bin/time's 10 ms steps).
run() { /usr/bin/python3 "$here/proc_time.py" "$repeats" "${pin[@]}" "$@"; }

printf '%-10s %-14s %10s %10s\n' snapshots tool wall_s cpu_s
# Start-up alone: what every run pays before the first snapshot.
read -r hw hc < <(run "$build/bin/dba-covariance" --help)
printf '%-10s %-14s %10.4f %10.4f\n' 0 "--help" "$hw" "$hc"
for input in one many; do
  n=$([ "$input" = one ] && echo 1 || echo "$copies")
  read -r dw dc < <(run "$build/bin/dba-covariance" -i "$work/$input" --csv "$work/dbacov.csv" \
    --threads 1 -q)
  read -r cw cc < <(run "$build/bin/peer_ceres_covariance" -i "$work/$input" --csv "$work/ceres.csv")
  printf '%-10d %-14s %10.4f %10.4f\n' "$n" dba-covariance "$dw" "$dc"
  printf '%-10d %-14s %10.4f %10.4f\n' "$n" ceres-peer "$cw" "$cc"
  awk -v n="$n" -v dw="$dw" -v dc="$dc" -v cw="$cw" -v cc="$cc" 'BEGIN {
    printf "%-10d %-14s %9.1fx %9.1fx   (per snapshot: dbacov %.1f ms wall, ceres %.0f ms)\n",
      n, "ratio", cw / dw, cc / dc, 1000 * dw / n, 1000 * cw / n }'
  /usr/bin/python3 - "$work/dbacov.csv" "$work/ceres.csv" << 'PY'
import csv, sys
import numpy as np
d = {}
with open(sys.argv[1]) as f:
    rows = list(csv.DictReader(f))
snaps = sorted({r['snapshot'] for r in rows}, key=int)  # dba-covariance names the snapshot id
for r in rows:
    c = np.zeros((6, 6))
    for i in range(6):
        for j in range(i, 6):
            c[i, j] = c[j, i] = float(r['cov_%d%d' % (i, j)])
    d[(r['snapshot'], int(r['keyframe']))] = c
worst, n = 0.0, 0
with open(sys.argv[2]) as f:
    for r in csv.DictReader(f):
        c = np.array([float(r['c%d%d' % (i, j)]) for i in range(6) for j in range(6)]).reshape(6, 6)
        ref = d[(snaps[0], int(r['keyframe']))]
        worst = max(worst, np.linalg.norm(c - ref) / np.linalg.norm(ref))
        n += 1
print('           max ||S_ceres - S_dbacov|| / ||S_dbacov|| over %d marginals: %.1e' % (n, worst))
PY
done
