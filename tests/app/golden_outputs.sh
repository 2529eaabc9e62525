#!/usr/bin/env bash
# The outputs of dba-covariance on the shared DROID snapshot and on the demo sequence, as SHA-256
# sums: a refactor must leave every byte unchanged. ctest runs it with --check (GoldenOutputs).
# The stated model's outputs (--stated-model) at the top level: their sums are those from before
# the self-calibration became the default, the CSV tables' new last column (noise_model) taken
# off before hashing; the default (self-calibrated) outputs in calibrated/.
#   tests/app/golden_outputs.sh BUILD_DIR WORK_DIR           prints the sums
#   tests/app/golden_outputs.sh BUILD_DIR WORK_DIR --check   compares them with golden/outputs.sha256
# A deliberate change of an output: regenerate with
#   tests/app/golden_outputs.sh build /tmp/golden > tests/app/golden/outputs.sha256
# and say in the commit which output changed and why. The sums hold for the Release build with
# Debian 12's compiler and default BLAS (ctest runs the check in Release builds only); exit 77
# (skipped) without ../shared.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bin=$(cd "$1" && pwd)/bin
work=$2
shared=$here/../../../shared/data/droid_window_0055.npz
if [ ! -f "$shared" ]; then
  echo "golden outputs: $shared not found (../shared beside the checkout): skipped"
  exit 77
fi
rm -rf "$work" && mkdir -p "$work" && cd "$work"
top=$PWD

# The demo sequence (scripts/demo.sh without the pictures).
"$bin/simul-dba" -o demo --snapshots 5 --seed 1 > /dev/null 2>&1
"$bin/droid2rawlog" -i demo -o demo/snapshots.rawlog > /dev/null 2>&1
outputs() {
  run() { "$bin/dba-covariance" -q "$@" "${model[@]}"; }
  # The shared snapshot: every table, the depth maps, the graph files and a pose rawlog.
  run -i "$shared" --csv droid.csv --relative-csv droid_rel.csv --depth-sigma droid_depth \
    --graph droid_graph --fps 30 -o droid_poses.rawlog --emit all
  run -i "$shared" --preset paper --csv paper.csv --relative-csv paper_rel.csv
  run -i "$shared" --gauge minimal --solver dense --csv minimal_dense.csv
  run -i "$top/demo/snapshots.rawlog" --weight-scale 4 -o demo_poses.rawlog --emit final \
    --csv demo.csv --relative-csv demo_rel.csv --graph demo_graph
}
model=(--stated-model)
outputs
for f in *.csv; do
  sed -i -e '1s/,noise_model$//' -e 's/,stated$//' "$f"
done
mkdir calibrated
model=()
(cd calibrated && outputs)

# The simulated snapshots (zip members carry times) are left out; the scenario file is the
# simulator's (the schema's writer).
sums=$({ find . -path ./demo -prune -o -type f -print; echo ./demo/scenario.json; } | LC_ALL=C sort |
  xargs sha256sum)
if [ "${3:-}" = "--check" ]; then
  if diff <(echo "$sums") "$here/golden/outputs.sha256"; then
    echo "golden outputs: $(echo "$sums" | wc -l) files identical"
  else
    echo "golden outputs differ (< now, > golden): see tests/app/golden_outputs.sh" >&2
    exit 1
  fi
else
  echo "$sums"
fi
