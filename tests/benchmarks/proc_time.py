#!/usr/bin/python3
"""Times a whole process: proc_time.py REPEATS CMD [ARG...].

Runs CMD REPEATS times (stdout to /dev/null) and prints the median wall time and the median CPU
time (user + sys of the child and its children, from wait4's rusage) in seconds, with microsecond
resolution: /usr/bin/time prints CPU times in steps of 10 ms, as large as the whole of a
one-snapshot run of dba-covariance. Exits 1 when a run fails.
"""
import os
import statistics
import sys
import time


def main() -> int:
    repeats, cmd = int(sys.argv[1]), sys.argv[2:]
    walls, cpus = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        pid = os.posix_spawnp(
            cmd[0], cmd, os.environ, file_actions=[(os.POSIX_SPAWN_OPEN, 1, os.devnull, os.O_WRONLY, 0)])
        _, status, usage = os.wait4(pid, 0)
        walls.append(time.perf_counter() - start)
        if os.waitstatus_to_exitcode(status) != 0:
            print(f"proc_time: {' '.join(cmd)}: exit {os.waitstatus_to_exitcode(status)}", file=sys.stderr)
            return 1
        cpus.append(usage.ru_utime + usage.ru_stime)
    print(f"{statistics.median(walls):.6f} {statistics.median(cpus):.6f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
