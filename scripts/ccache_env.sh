# Sourced by scripts/setup.sh and scripts/sanitizer_tree.sh: ccache's settings for this checkout.
# Paths under the checkout are hashed relative to it (CCACHE_BASEDIR), so that a fresh clone in
# another directory on the same machine (CI) reuses what an earlier build compiled; the cache
# lives in ccache's default directory (~/.cache/ccache) unless CCACHE_DIR says otherwise.
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
export CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-true}
export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-8G}
