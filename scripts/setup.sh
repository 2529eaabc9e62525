#!/usr/bin/env bash
# Installs every Debian package that dbacov's build, tests, demo and benchmarks need, then configures
# and builds the project (Release) in ./build (or $DBACOV_BUILD_DIR). Idempotent: packages already
# present are not reinstalled and the build is incremental; compilations go through ccache
# (scripts/ccache_env.sh), so a rebuild of unchanged sources, in this checkout or a fresh clone on
# the same machine, is fast.
# Usage: scripts/setup.sh [--no-build | TARGET...]   (targets: build only those, e.g. the demo's)
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake ninja-build pkg-config git ccache time
  libeigen3-dev libsuitesparse-dev libzip-dev libdeflate-dev
  libmrpt-dev mrpt-apps
  libopencv-dev
  libcli11-dev nlohmann-json3-dev libtbb-dev
  libgtest-dev libgmock-dev libbenchmark-dev libceres-dev
  # Pictures (dba-covariance --plots, --snapshot): gnuplot's pngcairo terminal draws with the
  # DejaVu Sans font that the figures name (fontconfig would otherwise fall back to whatever font is
  # there, or none on a minimal system); MRPT's offscreen CFBORender needs Mesa's EGL (no X server).
  gnuplot-nox fonts-dejavu-core
  libegl1 libegl-mesa0 libgl1-mesa-dri
  python3-numpy
  # import dbacov (build/python) and its pytest suite on tensors shaped as DROID's.
  python3-dev python3-pytest python3-torch pybind11-dev
  # Reliability (scripts/test.sh, scripts/fuzz.sh): zlib (rawlogs from pipes), clang with its
  # libFuzzer and sanitizer runtimes for the fuzz targets (the sanitizer pass itself uses GCC).
  zlib1g-dev clang libclang-rt-14-dev
  # Source checks (scripts/check_source.sh): the tree is formatted with Debian 12's clang-format 14.
  clang-format
  # Documentation (scripts/docs.sh): the site (mkdocs.yml, docs/) and the C++ API reference.
  mkdocs mkdocs-material doxygen
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

if [ "${1:-}" != "--no-build" ]; then
  build=${DBACOV_BUILD_DIR:-build}
  source scripts/ccache_env.sh
  # Unity builds: a cold build about a third faster (top-level CMakeLists.txt), same outputs.
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDBACOV_UNITY_BUILD=ON \
    -DCMAKE_CXX_COMPILER_LAUNCHER=ccache > /dev/null
  targets=()
  for t in "$@"; do targets+=(--target "$t"); done
  cmake --build "$build" -j"$(nproc)" "${targets[@]}"
fi
