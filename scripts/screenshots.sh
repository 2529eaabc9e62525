#!/usr/bin/env bash
# Screenshots of MRPT's own viewers on dbacov's outputs of the shared DROID snapshot, taken under
# Xvfb (no display needed): SceneViewer3D on the .3Dscene, RawLogViewer on the snapshot rawlog
# (through the plugin, -l) and on the pose rawlog. Writes docs/images/{sceneviewer3d,
# rawlogviewer_snapshots,rawlogviewer_poses}.png (docs/getting-started.md shows them).
#
# Needs the built project (scripts/setup.sh) and, beyond setup.sh's packages (not needed by the
# tests): apt-get install xvfb xdotool imagemagick.
# Usage: scripts/screenshots.sh [SNAPSHOT.npz]   (default ../shared/data/droid_window_0055.npz)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=${DBACOV_BUILD_DIR:-build}
snapshot=${1:-../shared/data/droid_window_0055.npz}
for tool in Xvfb xdotool import convert SceneViewer3D RawLogViewer; do
  command -v "$tool" >/dev/null || {
    echo "screenshots.sh: $tool missing (apt-get install xvfb xdotool imagemagick mrpt-apps)" >&2
    exit 2
  }
done

work=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT

# The outputs a user makes first (the shared snapshot has no keyframe times: --fps).
"$build/bin/dba-covariance" -i "$snapshot" --fps 20 --scene "$work/scene.3Dscene" \
  -o "$work/poses.rawlog" --emit all -q
"$build/bin/droid2rawlog" -i "$snapshot" --fps 20 -o "$work/snapshots.rawlog" 2>/dev/null

# A virtual X server on a free display number.
display=90
while [ -e "/tmp/.X11-unix/X$display" ] || [ -e "/tmp/.X$display-lock" ]; do display=$((display + 1)); done
Xvfb ":$display" -screen 0 1280x800x24 -nolisten tcp >/dev/null 2>&1 &
pids+=($!)
export DISPLAY=":$display"
for _ in $(seq 50); do xdotool getmouselocation >/dev/null 2>&1 && break; sleep 0.2; done

# Waits for a window whose name matches $1; prints its id.
window() {
  for _ in $(seq 100); do
    if w=$(xdotool search --name "$1" 2>/dev/null | head -1) && [ -n "$w" ]; then
      echo "$w"
      return
    fi
    sleep 0.2
  done
  echo "screenshots.sh: no window '$1'" >&2
  return 1
}
# Places window $1 at the top left with size $2 x $3 and lets it redraw.
place() {
  xdotool windowmove "$1" 0 0 windowsize "$1" "$2" "$3"
  sleep 3
}
# Writes window $1 to docs/images/$2.png (palette PNG: small in the repository).
shoot() {
  timeout 30 import -window "$1" "$work/shot.png"
  convert "$work/shot.png" -colors 128 "PNG8:$root/docs/images/$2.png"
  echo "docs/images/$2.png"
}

(cd "$work" && exec SceneViewer3D scene.3Dscene) >/dev/null 2>&1 &
pids+=($!)
w=$(window "SceneViewer3D - Part")
place "$w" 900 650
shoot "$w" sceneviewer3d
kill "${pids[-1]}"
wait "${pids[-1]}" 2>/dev/null || true

# RawLogViewer on rawlog $1 into image $2: its tip-of-the-day dialog first, then select entry $3.
viewer() {
  (cd "$work" && exec RawLogViewer -l "$root/$build/lib/libdbacov_mrpt.so" "$1") >/dev/null 2>&1 &
  pids+=($!)
  w=$(window "RawlogViewer - Part")
  # The tip-of-the-day dialog comes up after the main window: close it (and wait until it is gone).
  for _ in $(seq 60); do
    t=$(xdotool search --onlyvisible --name "Tip of the Day" 2>/dev/null | head -1) || true
    if [ -n "$t" ]; then
      sleep 1
      timeout 5 xdotool windowfocus --sync "$t" 2>/dev/null || true
      xdotool key --window "$t" Escape 2>/dev/null || true
      sleep 1
      xdotool search --onlyvisible --name "Tip of the Day" >/dev/null 2>&1 || break
    fi
    sleep 0.5
  done
  place "$w" 1000 600
  xdotool mousemove --window "$w" 120 $((123 + 17 * $3)) click 1 # the tree's entry $3
  sleep 2
  shoot "$w" "$2"
  kill "${pids[-1]}"
  wait "${pids[-1]}" 2>/dev/null || true # its windows are gone before the next viewer's are searched
  sleep 1
}
viewer snapshots.rawlog rawlogviewer_snapshots 0
viewer poses.rawlog rawlogviewer_poses 9 # the newest keyframe (entries 0 and 1: the fixed gauge)
