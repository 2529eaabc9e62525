#!/usr/bin/env bash
# The cost of the default (self-calibrated) covariance against the stated model (--stated-model)
# on the shared DROID snapshot: one snapshot per process, and 20 copies of it in one process
# (start-up paid once), on 1 and 2 threads. Prints the median wall time of 5 runs of each and the
# ratio default / stated.
#   tests/benchmarks/bench_default_cost.sh [BUILD_DIR] [SNAPSHOT.npz]
set -euo pipefail
build=${1:-build}
snapshot=${2:-$(dirname "$0")/../../../shared/data/droid_window_0055.npz}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir "$work/twenty"
for i in $(seq -w 1 20); do ln -s "$(realpath "$snapshot")" "$work/twenty/copy_$i.npz"; done
median() { sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
wall() {  # median wall seconds of 5 runs (after one warm-up) of dba-covariance ARGS
  "$build/bin/dba-covariance" -q "$@" --csv "$work/out.csv"
  for _ in 1 2 3 4 5; do
    /usr/bin/time -f '%e' -o "$work/t" "$build/bin/dba-covariance" -q "$@" --csv "$work/out.csv"
    cat "$work/t"
  done | median
}
printf '%-22s %-8s %12s %12s %8s\n' input threads stated_s default_s ratio
for input in one twenty; do
  src=$([ "$input" = one ] && echo "$snapshot" || echo "$work/twenty")
  for threads in 1 2; do
    s=$(wall -i "$src" --threads "$threads" --stated-model)
    d=$(wall -i "$src" --threads "$threads")
    awk -v i="$input" -v t="$threads" -v s="$s" -v d="$d" \
      'BEGIN { printf "%-22s %-8d %12.3f %12.3f %8.2f\n", i, t, s, d, d / s }'
  done
done
