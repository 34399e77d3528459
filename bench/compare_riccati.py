#!/usr/bin/env python3
"""Side-by-side timings: skyloop-linalg CARE/DARE/Schur vs scipy and SLICOT (python-control + slycot).

Our timings come from criterion (crates/skyloop-linalg/benches/riccati.rs); pass --run to run the
benchmark first, otherwise the last results in $CARGO_TARGET_DIR/criterion (default target/) are read.
The problems are the same fixtures (tests/fixtures/riccati/*.json) on both sides.

    python3 bench/compare_riccati.py --run
"""
import argparse
import json
import os

# Single-threaded BLAS on both sides (our code is single-threaded); a threaded BLAS on a busy
# machine makes the reference look slower than it is.
for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")
import subprocess
import sys
import timeit

import control
import numpy as np
import scipy.linalg as sla

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIX = os.path.join(ROOT, "crates", "skyloop-linalg", "tests", "fixtures", "riccati")


def case(file, name):
    with open(os.path.join(FIX, file)) as f:
        for c in json.load(f)["cases"]:
            if c["name"] == name:
                return [np.array(c[k], dtype=float) for k in ("a", "b", "q", "r")]
    sys.exit(f"case {name} not in {file}")


def best_of(f, number=None):
    t = timeit.Timer(f)
    if number is None:
        number, _ = t.autorange()
    return min(t.repeat(repeat=5, number=number)) / number


def criterion_best_s(name):
    """Fastest per-iteration time among criterion's samples (the same statistic as best_of: on a
    shared, busy machine the minimum is the least noisy estimate of the uncontended time)."""
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    path = os.path.join(target, "criterion", name, "new", "sample.json")
    try:
        with open(path) as f:
            s = json.load(f)
        return min(t / i for t, i in zip(s["times"], s["iters"])) * 1e-9
    except OSError:
        return None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--run", action="store_true", help="run `cargo bench -p skyloop-linalg --bench riccati` first")
    args = ap.parse_args()
    if args.run:
        subprocess.run(["cargo", "bench", "-p", "skyloop-linalg", "--bench", "riccati"], cwd=ROOT, check=True)

    a, b, q, r = case("care.json", "random_n50_m10")
    ad, bd, qd, rd = case("dare.json", "random_n50_m5")
    m = np.random.default_rng(7).uniform(-1, 1, (100, 100))
    rows = [
        ("care_n50", "scipy solve_continuous_are", lambda: sla.solve_continuous_are(a, b, q, r)),
        ("care_n50", "slycot SB02MD (control.care)", lambda: control.care(a, b, q, r, method="slycot")),
        ("dare_n50", "scipy solve_discrete_are", lambda: sla.solve_discrete_are(ad, bd, qd, rd)),
        ("dare_n50", "slycot SB02MD (control.dare)", lambda: control.dare(ad, bd, qd, rd, method="slycot")),
        ("schur_n100", "scipy.linalg.schur (LAPACK dgees)", lambda: sla.schur(m)),
    ]
    print("best-of timings (single-threaded BLAS for the references)")
    print(f"{'benchmark':<12} {'reference':<34} {'reference':>12} {'skyloop':>12} {'speed-up':>9}")
    for bench, who, f in rows:
        ref = best_of(f)
        ours = criterion_best_s(bench)
        ours_s = f"{ours * 1e3:9.3f} ms" if ours else "    (none)"
        ratio = f"{ref / ours:8.1f}x" if ours else "        -"
        print(f"{bench:<12} {who:<34} {ref * 1e3:9.3f} ms {ours_s} {ratio}")


if __name__ == "__main__":
    main()
