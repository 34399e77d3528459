"""Group `compare_logtune` of bench/compare.py: `skyloop tune LOG` on every axis of a real flight
log against the time budget a pilot is promised (issue 34: a 2-minute log tunes all three axes in
at most 20 s on the 2-core machine).

There is no reference tool that tunes from a log, so the "reference" column is the budget itself:
the ratio is budget / our time, and the row passes when it is at least 1. Our time is the wall time
of the release CLI (identification, the flown tune, the candidate search, the 6-DOF checks and the
report of all three axes), the best of three runs.

- btfl_all.bbl session 4: Betaflight 4.2.8, 145 s of acro flight at 500 Hz logging.
- pid-analyzer_example_smooth_tune.BBL: Betaflight 3.1.5, 39 s at about 2 kHz logging.
"""
import os
import subprocess
import tempfile
import time

from workflow_times import ROOT

BIN = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "skyloop")
LOGS = os.path.join(ROOT, "testdata", "logs")
BUDGET_S = 20.0


def wall(args, repeat=3):
    best = float("inf")
    for _ in range(repeat):
        out = tempfile.mkdtemp(prefix="skyloop-logtune-")
        t = time.perf_counter()
        p = subprocess.run([BIN, *args, "--out", out], capture_output=True, text=True)
        dt = time.perf_counter() - t
        if p.returncode != 0:
            raise RuntimeError(f"skyloop {' '.join(args)} failed: {p.stderr}")
        best = min(best, dt)
    return best


def comparisons(_skyloop):
    rows = []
    for name, log in [
        ("tune LOG, 3 axes, btfl_all 145 s (budget 20 s)", "btfl_all.bbl"),
        ("tune LOG, 3 axes, smooth-tune 39 s (budget 20 s)", "pid-analyzer_example_smooth_tune.BBL"),
    ]:
        rows.append((name, wall(["tune", os.path.join(LOGS, log), "--firmware", "betaflight"]), BUDGET_S, 1.0))
    return rows


if __name__ == "__main__":
    for name, ours, ref, target in comparisons(None):
        print(f"{name:<52} {ours:8.2f} s  budget {ref:.0f} s  ratio {ref / ours:.1f}x")
