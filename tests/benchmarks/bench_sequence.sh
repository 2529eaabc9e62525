#!/usr/bin/env bash
# A long simulated sequence end to end through dba-covariance: rawlog in, rawlog + CSV
# out. Prints wall time, snapshots per second and peak resident memory for the last 100 and for
# all 500 snapshots, on 1 and 2 threads. Like DROID-SLAM's dumps, snapshot s holds every keyframe
# so far in 'poses'/'disps' (its graph covers the last 25), so snapshots grow along the sequence:
# the last 100 are the largest, and the peak over all 500 must equal theirs (nothing accumulates).
#   tests/benchmarks/bench_sequence.sh [BUILD_DIR] [SNAPSHOTS]
set -euo pipefail
build=${1:-build}
total=${2:-500}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$build/bin/simul-dba" -o "$work/seq" --snapshots "$total" --window 25 --height 48 --width 64 \
  --trajectory loop --no-solve -q \
  --edge-radius 3 --weight-scale 4 --seed 3 > /dev/null
mkdir -p "$work/last"
for f in $(ls "$work/seq"/snapshot_*.npz | tail -n 100); do ln -s "$f" "$work/last/"; done
"$build/bin/droid2rawlog" -i "$work/last" -o "$work/last.rawlog" -q
"$build/bin/droid2rawlog" -i "$work/seq" -o "$work/all.rawlog" -q
printf '%-10s %-8s %10s %14s %12s\n' snapshots threads wall_s snapshots_per_s peak_MB
for input in last all; do
  n=$([ "$input" = last ] && echo 100 || echo "$total")
  for threads in 1 2; do
    /usr/bin/time -f '%e %M' -o "$work/time" "$build/bin/dba-covariance" -i "$work/$input.rawlog" \
      -o "$work/poses.rawlog" --csv "$work/keyframes.csv" --weight-scale 4 --threads "$threads" -q
    read -r wall kb < "$work/time"
    awk -v n="$n" -v t="$threads" -v w="$wall" -v kb="$kb" \
      'BEGIN { printf "%-10d %-8d %10.2f %14.1f %12.1f\n", n, t, w, n / w, kb / 1024 }'
  done
done
