"""Call overhead of `import dbacov` (issue 17): Covariance(snapshot) + marginals() timed from
Python against the same work timed inside C++ (dbacov._dbacov._engine_seconds), on the shared DROID
snapshot. Run after the build:

    PYTHONPATH=build/python /usr/bin/python3 tests/benchmarks/bench_python.py ../shared/data/droid_window_0055.npz
"""

import sys
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


if __name__ == "__main__":
    main(sys.argv[1])
