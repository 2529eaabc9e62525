"""Call overhead of `import dbacov`: Covariance(snapshot, stated_model=True) + marginals() timed
from Python against the same work timed inside C++ (dbacov._dbacov._engine_seconds), on the shared
DROID snapshot; then the default, self-calibrated Covariance(snapshot) and
write_pose_rawlog (first call: loads the MRPT bridge; then per call). Run after the build:

    PYTHONPATH=build/python /usr/bin/python3 tests/benchmarks/bench_python.py ../shared/data/droid_window_0055.npz
"""

import os
import sys
import tempfile
import time

import dbacov
from dbacov import _dbacov


def main(path, repeats=7, iterations=10):
    snap = dbacov.load(path)
    dbacov.Covariance(snap).marginals()  # warm up (thread pool, caches)
    py, cpp = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(iterations):
            dbacov.Covariance(snap).marginals()
        py.append((time.perf_counter() - t0) / iterations)
        cpp.append(_dbacov._engine_seconds(snap, iterations))
    py_s, cpp_s = min(py), min(cpp)
    print(f"python {py_s * 1e3:.2f} ms, C++ {cpp_s * 1e3:.2f} ms per snapshot "
          f"(best of {repeats} x {iterations}); overhead {100 * (py_s - cpp_s) / cpp_s:+.1f} %")
    cal = []
    for _ in range(3):
        t0 = time.perf_counter()
        cov = dbacov.Covariance(snap, self_calibrate=True)
        cal.append(time.perf_counter() - t0)
    print(f"Covariance(self_calibrate=True): {min(cal) * 1e3:.1f} ms (best of 3; dba-covariance "
          "--self-calibrate prints its own 's per snapshot' for the same work)")
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "poses.rawlog")
        t0 = time.perf_counter()
        cov.write_pose_rawlog(out, fps=20, emit="all")
        first = time.perf_counter() - t0
        w = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            cov.write_pose_rawlog(out, fps=20, emit="all")
            w.append(time.perf_counter() - t0)
    print(f"write_pose_rawlog(emit='all'): first call {first * 1e3:.1f} ms (loads the MRPT "
          f"bridge), then {min(w) * 1e3:.2f} ms (best of {repeats})")


if __name__ == "__main__":
    main(sys.argv[1])
