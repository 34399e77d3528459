#!/usr/bin/env python3
"""Side-by-side timings: skyloop-linalg CARE/DARE/Schur vs scipy and SLICOT (python-control + slycot).

Both sides are timed as best-of-N wall time of one solve (robust on a shared, busy machine): ours by
`cargo run --release -p skyloop-linalg --example time_riccati`, the references with timeit. With
--criterion the fastest criterion sample of `benches/riccati.rs` (last `cargo bench` run, in
$CARGO_TARGET_DIR/criterion) is used instead. The problems are the same fixtures
(tests/fixtures/riccati/*.json) on both sides.

    python3 bench/compare_riccati.py
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


def best_of(f, repeat=30):
    """Fastest single call out of `repeat` (the statistic the Rust example uses too)."""
    f()  # warm-up
    return min(timeit.repeat(f, number=1, repeat=repeat))


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
    ap.add_argument("--criterion", action="store_true", help="use the last criterion results instead")
    args = ap.parse_args()
    ours_all = {}
    if not args.criterion:
        out = subprocess.run(["cargo", "run", "--release", "-q", "-p", "skyloop-linalg", "--example", "time_riccati"],
                             cwd=ROOT, check=True, capture_output=True, text=True).stdout
        ours_all = json.loads(out)

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
    print("best-of timings (single-threaded BLAS for the references; ours single-threaded)")
    print(f"{'benchmark':<12} {'reference':<34} {'reference':>12} {'skyloop':>12} {'speed-up':>9}")
    for bench, who, f in rows:
        ref = best_of(f)
        ours = criterion_best_s(bench) if args.criterion else ours_all.get(bench)
        ours_s = f"{ours * 1e3:9.3f} ms" if ours else "    (none)"
        ratio = f"{ref / ours:8.1f}x" if ours else "        -"
        print(f"{bench:<12} {who:<34} {ref * 1e3:9.3f} ms {ours_s} {ratio}")


if __name__ == "__main__":
    main()
