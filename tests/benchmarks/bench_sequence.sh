#!/usr/bin/env bash
# A long simulated sequence end to end through dba-covariance (issue 8): rawlog in, rawlog + CSV
# out. Prints wall time, snapshots per second and peak resident memory for the first 100 and for
# all 500 snapshots (the peak must not grow with the number of snapshots), on 1 and 2 threads.
#   tests/benchmarks/bench_sequence.sh [BUILD_DIR] [SNAPSHOTS]
set -euo pipefail
build=${1:-build}
total=${2:-500}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$build/bin/simul-dba" -o "$work/seq" --snapshots "$total" --window 25 --height 48 --width 64 \
  --trajectory loop --no-solve -q \
  --edge-radius 3 --weight-scale 4 --seed 3 > /dev/null
mkdir -p "$work/first"
for f in $(ls "$work/seq"/snapshot_*.npz | head -n 100); do ln -s "$f" "$work/first/"; done
"$build/bin/droid2rawlog" -i "$work/first" -o "$work/first.rawlog" -q
"$build/bin/droid2rawlog" -i "$work/seq" -o "$work/all.rawlog" -q
printf '%-10s %-8s %10s %14s %12s\n' snapshots threads wall_s snapshots_per_s peak_MB
for input in first all; do
  n=$([ "$input" = first ] && echo 100 || echo "$total")
  for threads in 1 2; do
    /usr/bin/time -f '%e %M' -o "$work/time" "$build/bin/dba-covariance" -i "$work/$input.rawlog" \
      -o "$work/poses.rawlog" --csv "$work/keyframes.csv" --weight-scale 4 --threads "$threads" -q
    read -r wall kb < "$work/time"
    awk -v n="$n" -v t="$threads" -v w="$wall" -v kb="$kb" \
      'BEGIN { printf "%-10d %-8d %10.2f %14.1f %12.1f\n", n, t, w, n / w, kb / 1024 }'
  done
done
