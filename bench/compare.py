#!/usr/bin/env python3
"""Side-by-side timings of skyloop against python-control 0.10.2 + slycot; prints speed ratios.

Usage (from the repository root):  python3 bench/compare.py [--only NAME] [--skip-build]

Each comparison times the reference in Python (best of several runs) and skyloop through its
release CLI with `--bench N` (the CLI repeats the computation N times and prints the fastest wall
time on stderr as `bench_seconds T`, so process start-up and printing are not timed).

Extending: any `bench/compare_<area>.py` next to this file that defines
    def comparisons(skyloop) -> list of (name, ours_seconds, reference_seconds, target_ratio)
is imported and run too; `skyloop(args) -> float` runs the CLI with `--bench` and returns seconds.
A target ratio of r means skyloop must be at least r times faster (1.0: no slower).
"""
import argparse
import glob
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
BIN = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "skyloop")


def build():
    subprocess.run(["cargo", "build", "--release", "-p", "skyloop-cli"], cwd=ROOT, check=True)


def skyloop(args, repeat=20):
    """Runs the release CLI with --bench and returns the fastest computation time in seconds."""
    p = subprocess.run([BIN, *args, "--bench", str(repeat)], capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"skyloop {' '.join(args)} failed: {p.stderr}")
    for line in p.stderr.splitlines():
        if line.startswith("bench_seconds"):
            return float(line.split()[1])
    raise RuntimeError(f"no bench_seconds in: {p.stderr}")


def best_of(f, repeat=10):
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def write_model(sys_, path):
    import control

    a, b, c, d = (np.atleast_2d(m) for m in control.ssdata(sys_))
    with open(path, "w") as f:
        json.dump({"a": a.tolist(), "b": b.tolist(), "c": c.tolist(), "d": d.tolist(), "dt": 0.0}, f)


def freq_comparisons(run):
    """Issue 2: frequency response (>= 20x faster) and H-inf norm (no slower than ab13dd)."""
    import control

    out = []
    tmp = tempfile.mkdtemp(prefix="skyloop-bench-")
    np.random.seed(1)
    g = control.rss(20, 2, 2)
    path = os.path.join(tmp, "rss20.json")
    write_model(g, path)
    w = np.logspace(-2, 3, 10_000)
    ref = best_of(lambda: control.frequency_response(g, w), 5)
    ours = run(["freqresp", path, "--logspace-hz", f"{w[0] / (2 * np.pi)},{w[-1] / (2 * np.pi)},10000"], 20)
    out.append(("freqresp 20 states 2x2, 10k frequencies", ours, ref, 20.0))

    np.random.seed(2)
    g = control.rss(40, 3, 3)
    path = os.path.join(tmp, "rss40.json")
    write_model(g, path)
    ref = best_of(lambda: control.linfnorm(g, tol=1e-10), 10)
    ours = run(["norm", path], 20)
    out.append(("H-inf norm 40 states 3x3 (ab13dd)", ours, ref, 1.0))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="run only comparisons whose name contains this text")
    ap.add_argument("--skip-build", action="store_true", help="use the existing release binary")
    args = ap.parse_args()
    if not args.skip_build:
        build()
    groups = [("freq", freq_comparisons)]
    for path in sorted(glob.glob(os.path.join(os.path.dirname(__file__), "compare_*.py"))):
        name = os.path.splitext(os.path.basename(path))[0]
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        if hasattr(mod, "comparisons"):
            groups.append((name, mod.comparisons))
    print(f"{'comparison':<48} {'skyloop':>11} {'reference':>11} {'ratio':>8} {'target':>8}  ok")
    failed = 0
    for gname, fn in groups:
        try:
            rows = fn(skyloop)
        except Exception as e:  # one broken group must not hide the others
            print(f"{gname}: failed: {e}")
            failed += 1
            continue
        for name, ours, ref, target in rows:
            if args.only and args.only not in name:
                continue
            ratio = ref / ours
            ok = ratio >= target
            failed += 0 if ok else 1
            print(f"{name:<48} {ours * 1e3:>9.3f}ms {ref * 1e3:>9.3f}ms {ratio:>7.1f}x {target:>7.1f}x  {'yes' if ok else 'NO'}")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
