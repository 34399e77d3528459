#!/usr/bin/env python3
"""Side-by-side timings of skyloop against python-control 0.10.2 + slycot; prints speed ratios.

Usage (from the repository root):  python3 bench/compare.py [--only NAME] [--skip-build] [--quick]

`--quick` (CI, after the tests): at most three repetitions per timing, exit status 0 whatever the
ratios; rows under 1.0x are listed after the table. Targets are the same-run ratios of issue 44.

Each comparison times the reference in Python (best of several runs) and skyloop through its
release CLI with `--bench N` (the CLI repeats the computation N times and prints the fastest wall
time on stderr as `bench_seconds T`, so process start-up and printing are not timed).

Extending: any `bench/compare_<area>.py` next to this file that defines
    def comparisons(skyloop) -> list of (name, ours_seconds, reference_seconds, target_ratio)
is imported and run too; `skyloop(args) -> float` runs the CLI with `--bench` and returns seconds.
A target ratio of r means skyloop must be at least r times faster (1.0: no slower).

The dense linear-algebra rows (schur, care, dare, lyapunov) need no CLI: one run of the
`time_linalg` example of skyloop-linalg times them, and scipy/SLICOT are timed here on the same
matrices (the example's random matrices come from an LCG reproduced below; it prints check
values). BLAS is single-threaded on both sides (our code is single-threaded; a threaded BLAS on a
busy machine makes the reference look slower than it is).

The step, reduction and identification rows (groups step, reduce, sysid) likewise come from one
run of the `time_workflows` example of the skyloop crate (bench/workflow_times.py), thread CPU time
on both sides. Nothing here writes a tracked file.
"""
import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse
import glob
import importlib.util
import json
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from workflow_times import reps  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
BIN = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "skyloop")


def build():
    subprocess.run(["cargo", "build", "--release", "-p", "skyloop-cli"], cwd=ROOT, check=True)


def skyloop(args, repeat=20):
    """Runs the release CLI with --bench and returns the fastest computation time in seconds."""
    p = subprocess.run([BIN, *args, "--bench", str(reps(repeat))], capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"skyloop {' '.join(args)} failed: {p.stderr}")
    for line in p.stderr.splitlines():
        if line.startswith("bench_seconds"):
            return float(line.split()[1])
    raise RuntimeError(f"no bench_seconds in: {p.stderr}")


def best_of(f, repeat=10):
    best = float("inf")
    for _ in range(reps(repeat)):
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
    """Issue 2: frequency response (>= 20x faster); the H-inf norm row is hinf_norm_comparisons."""
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
    # Issue 15: the whole CLI call (start-up, computation, streaming 10k frequencies of JSON to a
    # pipe), wall time, against python-control's in-process call.
    args = [BIN, "freqresp", path, "--logspace-hz", f"{w[0] / (2 * np.pi)},{w[-1] / (2 * np.pi)},10000", "--json"]
    whole = best_of(lambda: subprocess.run(args, stdout=subprocess.PIPE, check=True), 10)
    out.append(("freqresp --json whole CLI call vs in-process", whole, ref, 5.0))

    return out


def hinf_norm_comparisons(run):
    """Issues 15 and 19: H-inf norm of a 40-state 3x3 model, >= 2x SLICOT AB13DD (python-control's
    linfnorm). Both sides as smallest thread CPU time: ours by the `time_hinf_norm` example of
    skyloop-lti (no CLI build needed), AB13DD here."""
    import control

    del run
    tmp = tempfile.mkdtemp(prefix="skyloop-bench-")
    np.random.seed(2)
    g = control.rss(40, 3, 3)
    path = os.path.join(tmp, "rss40.json")
    write_model(g, path)
    out = subprocess.run(["cargo", "run", "--release", "-q", "-p", "skyloop-lti", "--example", "time_hinf_norm",
                          "--", path, "50"], cwd=ROOT, check=True, capture_output=True, text=True).stdout
    ours = json.loads(out)
    ref_norm = control.linfnorm(g, tol=1e-10)[0]
    if abs(ours["norm"] - ref_norm) > 1e-6 * ref_norm:
        print(f"H-inf norm: ours {ours['norm']:.10g} vs AB13DD {ref_norm:.10g}")
    best = float("inf")
    for _ in range(reps(30)):
        t = time.thread_time()
        control.linfnorm(g, tol=1e-10)
        best = min(best, time.thread_time() - t)
    return [("H-inf norm 40 states 3x3 (ab13dd)", ours["seconds"], best, 3.0)]


def lcg(rows, cols, seed):
    """The LCG matrix of `examples/time_linalg.rs` (uniform in [-1, 1), filled column by column)."""
    mask = (1 << 64) - 1
    state = seed
    out = np.empty(rows * cols)
    for k in range(rows * cols):
        state = (state * 6364136223846793005 + 1442695040888963407) & mask
        out[k] = ((state >> 11) / float(1 << 53)) * 2.0 - 1.0
    return out.reshape(cols, rows).T.copy()


def linalg_comparisons(run):
    """Issue 19: real Schur vs LAPACK dgees (>= 1x), QZ eigenvalues vs LAPACK dggev (>= 1x), CARE
    vs SLICOT SB02MD (>= 2x), Lyapunov at n = 1000 vs scipy (>= 1x; issue 15). One run of the Rust
    example, then the references."""
    import scipy.linalg as sla

    del run  # no CLI needed
    out = subprocess.run(["cargo", "run", "--release", "-q", "-p", "skyloop-linalg", "--example", "time_linalg"],
                         cwd=ROOT, check=True, capture_output=True, text=True).stdout
    ours = json.loads(out)
    fix = os.path.join(ROOT, "crates", "skyloop-linalg", "tests", "fixtures", "riccati")

    def case(file, name):
        with open(os.path.join(fix, file)) as f:
            c = next(c for c in json.load(f)["cases"] if c["name"] == name)
        return [np.array(c[k], dtype=float) for k in ("a", "b", "q", "r")]

    def best(f, repeat):
        # Thread CPU time, as the Rust example measures it (wall time on a loaded machine is
        # mostly waiting for a core).
        f()  # warm-up
        out = float("inf")
        for _ in range(reps(repeat)):
            t = time.thread_time()
            f()
            out = min(out, time.thread_time() - t)
        return out

    m100, m400 = lcg(100, 100, 7), lcg(400, 400, 7)
    n100, n400 = lcg(100, 100, 8), lcg(400, 400, 8)
    a1k = lcg(1000, 1000, 11) - np.sqrt(1000) * np.eye(1000)
    b1k = lcg(1000, 2, 12)
    assert np.allclose([m100[1, 0], m100[0, 1]], ours["check_schur"], rtol=1e-15), "LCG mismatch"
    assert np.allclose([a1k[3, 2], b1k[999, 1]], ours["check_lyap"], rtol=1e-15), "LCG mismatch"
    a, b, q, r = case("care.json", "random_n50_m10")
    ad, bd, qd, rd = case("dare.json", "random_n50_m5")
    rows = [
        ("schur n=100 (scipy.linalg.schur, dgees)", ours["schur_n100"], best(lambda: sla.schur(m100), 30), 1.0),
        ("schur n=400 (scipy.linalg.schur, dgees)", ours["schur_n400"], best(lambda: sla.schur(m400), 5), 1.5),
        ("qz eigenvalues n=100 (scipy.linalg.eigvals(a, b), dggev)", ours["qz_n100"],
         best(lambda: sla.eigvals(m100, n100), 30), 1.5),
        ("qz eigenvalues n=400 (scipy.linalg.eigvals(a, b), dggev)", ours["qz_n400"],
         best(lambda: sla.eigvals(m400, n400), 3), 1.5),
        ("care n=50 (scipy solve_continuous_are)", ours["care_n50"],
         best(lambda: sla.solve_continuous_are(a, b, q, r), 30), 1.0),
        ("dare n=50 (scipy solve_discrete_are)", ours["dare_n50"],
         best(lambda: sla.solve_discrete_are(ad, bd, qd, rd), 30), 1.0),
    ]
    try:
        import control

        rows.append(("care n=50 (slycot SB02MD via control.care)", ours["care_n50"],
                     best(lambda: control.care(a, b, q, r, method="slycot"), 30), 4.0))
        rows.append(("dare n=50 (slycot SB02MD via control.dare)", ours["dare_n50"],
                     best(lambda: control.dare(ad, bd, qd, rd, method="slycot"), 30), 4.0))
    except ImportError:
        print("care/dare: python-control/slycot not installed, SLICOT rows skipped")
    q1k = b1k @ b1k.T
    rows.append(("lyapunov n=1000 (scipy solve_continuous_lyapunov)", ours["lyap_n1000"],
                 best(lambda: sla.solve_continuous_lyapunov(a1k, -q1k), 1), 1.0))
    try:
        import slycot

        # SB03OD: Cholesky factor of the controllability gramian (the routine AB09AD uses), with
        # op(A) = A^T and op(B) = B^T: A X + X A^T = -B B^T. Its B argument is n x n, B^T on top.
        bpad = np.zeros((1000, 1000))
        bpad[:2, :] = b1k.T
        rows.append(("lyapunov Cholesky factor n=1000 (slycot SB03OD)", ours["lyap_chol_n1000"],
                     best(lambda: slycot.sb03od(1000, 2, a1k.T.copy(), np.zeros((1000, 1000)), bpad, dico="C"), 1),
                     2.0))
    except ImportError:
        print("lyapunov: slycot not installed, SB03OD row skipped")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="run only comparisons whose name contains this text")
    ap.add_argument("--skip-build", action="store_true", help="use the existing release binary")
    ap.add_argument("--quick", action="store_true",
                    help="at most 3 repetitions per timing (CI prints the table on every change); gates nothing: "
                         "exit 0 whatever the ratios, ratios under 1.0x listed at the end")
    ap.add_argument("--group", action="append",
                    help="run only this group (linalg, hinf_norm, freq, or a compare_<area> module); repeatable")
    args = ap.parse_args()
    if args.quick:
        os.environ["SKYLOOP_BENCH_QUICK"] = "1"  # read by workflow_times.reps in every group
    if not args.skip_build and not (args.group and set(args.group) <= {"linalg", "hinf_norm"}):
        build()  # the linalg and hinf_norm groups build their own small examples
    groups = [("linalg", linalg_comparisons), ("hinf_norm", hinf_norm_comparisons), ("freq", freq_comparisons)]
    for path in sorted(glob.glob(os.path.join(os.path.dirname(__file__), "compare_*.py"))):
        name = os.path.splitext(os.path.basename(path))[0]
        if args.group and not (name in args.group or name.removeprefix("compare_") in args.group):
            continue  # some modules run their benchmark when imported: skip unrequested ones
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        if hasattr(mod, "comparisons"):
            groups.append((name, mod.comparisons))
    if args.group:
        groups = [(g, fn) for g, fn in groups if g in args.group or g.removeprefix("compare_") in args.group]
    print(f"{'comparison':<48} {'skyloop':>11} {'reference':>11} {'ratio':>8} {'target':>8}  ok")
    failed = 0
    slower = []
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
            if ratio < 1.0:
                slower.append(f"{name}: {ratio:.2f}x")
    if slower:
        print("ratio under 1.0x (skyloop slower than the reference):")
        for line in slower:
            print(f"  {line}")
    if args.quick:
        print(f"quick run: {failed} row(s) or group(s) below target; nothing is gated")
        sys.exit(0)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
