#!/usr/bin/env bash
# Source checks that CI runs before building (scripts/test.sh): fails on
#   1. C++ files that differ from the committed .clang-format (fix: scripts/check_source.sh --fix);
#   2. an MRPT header included in libs/, apps/ or python/ outside libs/mrpt: the MRPT bridge is
#      the only code that sees MRPT, so the other libraries and the Python module load without it
#      (tests may include MRPT: they check the files we write with MRPT itself);
#   3. OpenCV included in libs/core, libs/io, libs/sim or libs/app (only libs/mrpt and libs/flow use it).
# Usage: scripts/check_source.sh [--fix]
set -euo pipefail
cd "$(dirname "$0")/.."
status=0
# The tree is formatted with clang-format 14 (Debian 12's; scripts/setup.sh installs it): another
# major version formats differently, so it is refused rather than trusted.
if ! command -v clang-format > /dev/null; then
  echo "check_source: clang-format is not installed (scripts/setup.sh installs it)" >&2
  exit 1
fi
version=$(clang-format --version | sed -n 's/.*version \([0-9]*\)\..*/\1/p')
if [ "$version" != "14" ]; then
  echo "check_source: clang-format $version found, the tree is formatted with version 14" >&2
  exit 1
fi
# Tracked files and new ones not yet added (but not ignored: no build trees).
mapfile -t files < <(git ls-files --cached --others --exclude-standard '*.cpp' '*.h' '*.hpp' '*.cc')
if [ "${1:-}" = "--fix" ]; then
  clang-format -i "${files[@]}"
fi
unformatted=()
for f in "${files[@]}"; do
  [ -f "$f" ] || continue
  clang-format --dry-run -Werror "$f" > /dev/null 2>&1 || unformatted+=("$f")
done
if ((${#unformatted[@]})); then
  echo "check_source: ${#unformatted[@]} file(s) differ from .clang-format (run scripts/check_source.sh --fix):" >&2
  printf '  %s\n' "${unformatted[@]}" >&2
  status=1
fi
mrpt=$(git grep -nE '^\s*#\s*include\s*[<"]mrpt/' -- 'libs' 'apps' 'python' ':!libs/mrpt/' || true)
if [ -n "$mrpt" ]; then
  echo "check_source: MRPT is included outside libs/mrpt (move the code into the bridge):" >&2
  echo "$mrpt" | sed 's/^/  /' >&2
  status=1
fi
opencv=$(git grep -nE '^\s*#\s*include\s*[<"]opencv2/' -- 'libs/core' 'libs/io' 'libs/sim' 'libs/app' || true)
if [ -n "$opencv" ]; then
  echo "check_source: OpenCV is included in libs/core, libs/io, libs/sim or libs/app:" >&2
  echo "$opencv" | sed 's/^/  /' >&2
  status=1
fi
[ "$status" -eq 0 ] && echo "check_source: ${#files[@]} C++ files formatted; MRPT only in libs/mrpt" >&2
exit "$status"
