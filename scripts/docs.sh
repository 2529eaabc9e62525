#!/usr/bin/env bash
# Builds the documentation and fails on any warning (CI runs it from scripts/test.sh):
#   1. the site: mkdocs build --strict (mkdocs.yml; docs/ → build/site): a broken link to a page or
#      a file, or a nav entry without its page, fails; so does a page of docs/ that the nav leaves
#      out (mkdocs 1.4 only logs that);
#   2. the C++ API reference: Doxygen over the public headers (docs/Doxyfile → build/doxygen/html,
#      copied to build/site/api): any warning in build/doxygen/warnings.log fails.
# Needs Debian's mkdocs, mkdocs-material and doxygen (scripts/setup.sh installs them).
# Usage: scripts/docs.sh
set -euo pipefail
cd "$(dirname "$0")/.."
for tool in mkdocs doxygen; do
  if ! command -v "$tool" > /dev/null; then
    echo "docs: $tool is not installed (scripts/setup.sh installs it)" >&2
    exit 1
  fi
done
status=0
mkdir -p build
log=build/mkdocs.log
# The Debian theme's templates raise a DeprecationWarning of Python's own (an escape sequence in
# jinja2), which is no finding about the documentation.
if ! PYTHONWARNINGS=ignore::DeprecationWarning mkdocs build --strict --clean > "$log" 2>&1; then
  echo "docs: mkdocs build --strict failed:" >&2
  grep -vE '^INFO' "$log" | sed 's/^/  /' >&2
  status=1
fi
if grep -q "not included in the \"nav\"" "$log"; then
  echo "docs: pages of docs/ that mkdocs.yml's nav leaves out:" >&2
  sed -n '/not included in the "nav"/,/^[A-Z]/p' "$log" | grep -E '^\s+- ' | sed 's/^/  /' >&2
  status=1
fi
rm -rf build/doxygen
mkdir -p build/doxygen
doxygen docs/Doxyfile > build/doxygen/doxygen.log 2>&1 || {
  echo "docs: doxygen failed:" >&2
  sed 's/^/  /' build/doxygen/doxygen.log >&2
  status=1
}
if [ -s build/doxygen/warnings.log ]; then
  echo "docs: Doxygen warnings on the public headers (fix the comments):" >&2
  sort -u build/doxygen/warnings.log | sed "s|^$PWD/||; s/^/  /" >&2
  status=1
fi
if [ -f build/doxygen/html/index.html ] && [ -d build/site ]; then
  rm -rf build/site/api
  cp -r build/doxygen/html build/site/api
fi
# The site links the reference as raw HTML (mkdocs cannot check a file it does not build).
if [ ! -f build/site/api/index.html ]; then
  echo "docs: build/site/api/index.html is missing (the C++ reference the site links to)" >&2
  status=1
fi
[ "$status" -eq 0 ] &&
  echo "docs: site in build/site ($(find build/site -name '*.html' -not -path '*/api/*' | wc -l) pages), C++ reference in build/site/api, no warnings" >&2
exit "$status"
