#!/usr/bin/env bash
# Sets everything up (packages + Release build), simulates a short DROID-like sequence of DBA
# snapshots and computes their pose covariances. Outputs land in build/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
# Only what the demo runs: the three programs and the MRPT plugin that writes the rawlogs, the
# scene and the pictures (not the test suite).
scripts/setup.sh simul-dba droid2rawlog dba-covariance dbacov_mrpt
out=build/demo
rm -rf "$out"
build/bin/simul-dba -o "$out" --snapshots 5 --seed 1
build/bin/droid2rawlog -i "$out" -o "$out/snapshots.rawlog"
build/bin/dba-covariance -i "$out/snapshots.rawlog" --weight-scale 4 \
  -o "$out/poses.rawlog" --emit final --csv "$out/covariances.csv" --relative-csv "$out/relative.csv" \
  --scene "$out/scene.3Dscene" --snapshot "$out/scene.png" --plots "$out/plots"
echo "demo: $(($(wc -l < "$out/covariances.csv") - 1)) keyframe covariances in $out/covariances.csv,"
echo "      MRPT poses with covariance in $out/poses.rawlog (rawlog-edit --info -i $out/poses.rawlog)"
echo "      pictures: $out/scene.png (SceneViewer3D $out/scene.3Dscene) and $out/plots/*.png"
