#!/usr/bin/python3
"""Old against new library, as whole processes: ab_libraries.py RUNS OLD_DIR NEW_DIR CMD [ARG...].

Runs CMD RUNS times with LD_LIBRARY_PATH=OLD_DIR and RUNS times with NEW_DIR, alternating (and
alternating which goes first), stdout to /dev/null, and prints for each the minimum and median of
the CPU time (user + sys from wait4's rusage) and of the wall time. Copy a build's libdbacov_*.so
into OLD_DIR before a change and into NEW_DIR after it; the binaries stay the same. On a machine
whose speed drifts, alternation is what makes the two comparable. Exits 1 when a run fails.
"""
import os
import statistics
import sys
import time


def main() -> int:
    runs, dirs, cmd = int(sys.argv[1]), {"old": sys.argv[2], "new": sys.argv[3]}, sys.argv[4:]
    res = {"old": ([], []), "new": ([], [])}
    for i in range(runs):
        for v in ("old", "new") if i % 2 == 0 else ("new", "old"):
            env = dict(os.environ, LD_LIBRARY_PATH=dirs[v])
            start = time.perf_counter()
            pid = os.posix_spawnp(cmd[0], cmd, env,
                                  file_actions=[(os.POSIX_SPAWN_OPEN, 1, os.devnull, os.O_WRONLY, 0)])
            _, status, usage = os.wait4(pid, 0)
            if os.waitstatus_to_exitcode(status) != 0:
                print(f"ab_libraries: {v}: exit {os.waitstatus_to_exitcode(status)}", file=sys.stderr)
                return 1
            res[v][0].append(time.perf_counter() - start)
            res[v][1].append(usage.ru_utime + usage.ru_stime)
    for v in ("old", "new"):
        wall, cpu = res[v]
        print(f"{v}: cpu min {min(cpu) * 1e3:.1f} median {statistics.median(cpu) * 1e3:.1f} ms | "
              f"wall min {min(wall) * 1e3:.1f} median {statistics.median(wall) * 1e3:.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
