#!/usr/bin/env bash
# The outputs of dba-covariance on the shared DROID snapshot and on the demo sequence, compared
# with the golden ones within tolerances (golden_compare.py: layouts and counts exactly, numbers to
# 1e-6 of the scale of their column or line position), so that another compiler or BLAS passes
# and a real change of the numbers does not. ctest runs it with --check (GoldenOutputs), which
# also checks that small changes of one value are caught in each kind of file (the comparison can
# fail).
# The stated model's outputs (--stated-model) at the top level, the CSV tables' last column
# (noise_model) taken off; the default (self-calibrated) outputs in calibrated/.
#   tests/app/golden_outputs.sh BUILD_DIR WORK_DIR           prints the digests
#   tests/app/golden_outputs.sh BUILD_DIR WORK_DIR --check   compares them with golden/outputs.json
# A deliberate change of an output: regenerate with
#   tests/app/golden_outputs.sh build /tmp/golden > tests/app/golden/outputs.json
# and say in the commit which output changed and why. Exit 77 (skipped) without ../shared.
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
rm -rf demo/*.npz demo/snapshots.rawlog demo/groundtruth.tum
compare=(/usr/bin/python3 "$here/golden_compare.py")
if [ "${3:-}" = "--check" ]; then
  if "${compare[@]}" check "$top" "$here/golden/outputs.json"; then
    echo "golden outputs: $(find . -type f | wc -l) files within the tolerances"
  else
    echo "golden outputs differ (above): see tests/app/golden_outputs.sh" >&2
    exit 1
  fi
  "${compare[@]}" self-test "$top" "$here/golden/outputs.json"
else
  "${compare[@]}" digest "$top"
fi
