#!/usr/bin/env bash
# Source checks that CI runs before building (scripts/test.sh): fails on
#   1. C++ files that differ from the committed .clang-format (fix: scripts/check_source.sh --fix);
#   2. an MRPT header included in libs/, apps/ or python/ outside libs/mrpt: the MRPT bridge is
#      the only code that sees MRPT, so the other libraries and the Python module load without it
#      (tests may include MRPT: they check the files we write with MRPT itself);
#   3. OpenCV included in libs/core, libs/io, libs/sim or libs/app (only libs/mrpt and libs/flow use it);
#   4. source text (C++, Python, shell, CMake under libs/ apps/ python/ tests/ scripts/ share/ cmake/)
#      that cites what a reader of the repository cannot open: an issue number ("issue 19",
#      "Issue 15's", a "#12" in a comment), a STYLE.md or a "SPEC §" the repository does not hold,
#      or a document outside it (a .tex file, ../shared/seed or ../shared/docs). A comment says
#      what the code does and why; the history is in CHANGELOG.md, the design in docs/.
#      (Not flagged: #include and other preprocessor lines, "#888888"-style colours in strings,
#      "owner/repo#123" references to public projects' trackers, ../shared/data, the test data.)
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
scope=(libs apps python tests scripts share cmake CMakeLists.txt)
kinds=('*.h' '*.hpp' '*.cpp' '*.cc' '*.py' '*.sh' '*.cmake' 'CMakeLists.txt')
pathspecs=()
for d in "${scope[@]}"; do
  for k in "${kinds[@]}"; do
    if [ "$d" = CMakeLists.txt ]; then pathspecs+=("$d"); break; fi
    pathspecs+=("$d/**/$k" "$d/$k")
  done
done
pathspecs+=(':!scripts/check_source.sh')  # this file names the patterns it looks for
# Anywhere in a line (comments, docstrings, messages): issue numbers, missing or outside documents.
cited=$(git grep --untracked -nIiE -e '(^|[^[:alnum:]_/])issues? #?[0-9]+' -e 'STYLE\.md' -e 'SPEC *§' \
  -e '[[:alnum:]_]\.tex([^[:alnum:]_]|$)' -e '\.\./shared/(seed|docs)' -- "${pathspecs[@]}" || true)
# In comments only: a bare "#12" (after // in C++, after the comment's # elsewhere), preceded by
# a space or a bracket, so that "#include", "'#888888'" and "google/sanitizers#1353" pass.
hash_c=$(git grep --untracked -nIE '//.*(^|[[:space:](])#[0-9]+([^[:alnum:]_]|$)' -- \
  "${pathspecs[@]}" ':!*.py' ':!*.sh' ':!*.cmake' ':!*CMakeLists.txt' || true)
hash_s=$(git grep --untracked -nIE '^[^"'"'"']*#.*[[:space:](]#[0-9]+([^[:alnum:]_]|$)' -- \
  "${pathspecs[@]}" ':!*.h' ':!*.hpp' ':!*.cpp' ':!*.cc' || true)
citations=$(printf '%s\n%s\n%s\n' "$cited" "$hash_c" "$hash_s" | sed '/^$/d' | sort -u)
if [ -n "$citations" ]; then
  echo "check_source: comments cite an issue number, a missing file or a document outside the" >&2
  echo "repository; say what the code does and why instead (history: CHANGELOG.md):" >&2
  echo "$citations" | sed 's/^/  /' >&2
  status=1
fi
[ "$status" -eq 0 ] && echo "check_source: ${#files[@]} C++ files formatted; MRPT only in libs/mrpt; no citations" >&2
exit "$status"
