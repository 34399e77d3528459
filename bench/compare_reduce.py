#!/usr/bin/env python3
"""Balanced reduction of a 100-state 2x2 system to order 10: skyloop vs python-control + slycot.

The system is rss_n100 from crates/skyloop-lti/tests/fixtures/reduce/cases.json (control.rss,
written by tools/gen_reduce.py). python-control's balanced_reduction (SLICOT AB09AD) and
matchdc (AB09ND) are timed here with timeit; skyloop's time is read from criterion's estimates
after `cargo bench -p skyloop-lti --bench reduce` (CARGO_TARGET_DIR or ./target). Prints ratios.
Run from the repository root: python3 bench/compare_reduce.py
"""
import json
import os
import sys
import timeit

import control
import numpy as np
import slycot

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
FIX = os.path.join(ROOT, "crates", "skyloop-lti", "tests", "fixtures", "reduce", "cases.json")
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))


def criterion_seconds(name):
    path = os.path.join(TARGET, "criterion", name, "new", "estimates.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)["median"]["point_estimate"] * 1e-9


def best_of(fn, repeat=7):
    n, _ = timeit.Timer(fn).autorange()
    return min(timeit.repeat(fn, number=n, repeat=repeat)) / n


def main():
    case = next(c for c in json.load(open(FIX))["cases"] if c["name"] == "rss_n100")
    a, b, c, d = (np.array(case[k]) for k in "abcd")
    sys_ = control.ss(a, b, c, d)
    rows = [
        ("balanced truncation", "balred_100_2x2_to_10", lambda: control.balanced_reduction(sys_, 10, "truncate")),
        ("SPA (matchdc)", "balred_spa_100_2x2_to_10", lambda: control.balanced_reduction(sys_, 10, "matchdc")),
        # SLICOT alone, without python-control's wrapper (which dominates the 'truncate' time).
        ("BT, slycot AB09AD only", "balred_100_2x2_to_10",
         lambda: slycot.ab09ad("C", "B", "N", 100, 2, 2, a, b, c, nr=10, tol=0.0)),
    ]
    ok = True
    print(f"{'problem':<24}{'python-control+slycot':>24}{'skyloop':>12}{'ratio':>8}")
    for label, bench, fn in rows:
        t_py = best_of(fn)
        t_rs = criterion_seconds(bench)
        if t_rs is None:
            print(f"{label:<24}{t_py * 1e3:>21.3f} ms   (run `cargo bench -p skyloop-lti --bench reduce` first)")
            ok = False
            continue
        print(f"{label:<24}{t_py * 1e3:>21.3f} ms{t_rs * 1e3:>9.3f} ms{t_py / t_rs:>7.1f}x")
    print("target: balanced truncation ratio >= 2x")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
