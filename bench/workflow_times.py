"""One run of the `time_workflows` example of the skyloop crate, shared by the compare_step,
compare_reduce and compare_sysid groups of bench/compare.py (smallest thread CPU times, seconds)."""
import functools
import json
import os
import subprocess

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))


def reps(repeat):
    """`repeat`, or at most 3 under `bench/compare.py --quick` (SKYLOOP_BENCH_QUICK=1): CI prints
    the table on every change without spending minutes on best-of-30 timings."""
    return min(repeat, 3) if os.environ.get("SKYLOOP_BENCH_QUICK") == "1" else repeat


@functools.lru_cache(maxsize=None)
def ours():
    out = subprocess.run(["cargo", "run", "--release", "-q", "-p", "skyloop", "--example", "time_workflows"],
                         cwd=ROOT, check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def thread_best(f, repeat):
    """Smallest thread CPU time of `repeat` calls of f, after one warm-up call (as the example measures)."""
    import time

    f()
    best = float("inf")
    for _ in range(reps(repeat)):
        t = time.thread_time()
        f()
        best = min(best, time.thread_time() - t)
    return best
