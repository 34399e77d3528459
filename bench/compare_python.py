#!/usr/bin/env python3
"""In-process timings of the skyloop Python package against python-control 0.10 (+ slycot where
installed), in one process; prints speed ratios (reference time / skyloop time) and the targets of
issue 16.

Usage:  pip install ./python control slycot scipy && python3 bench/compare_python.py [--runs N]
        [--only NAME] [--repeat R]

Each timing is the best of R calls (default 5) after one warm-up call. The Monte Carlo line is the
1000-flight, 20 s SSI-PI quadrotor study of bench/montecarlo.py on 2 threads vs 1 (best wall time of
min(R, 3) alternating runs each), with the CPU time ratio that tells a busy machine from a
serial bottleneck.
This file defines no `comparisons()`, so bench/compare.py (which imports every compare_*.py)
skips it; everything runs under `main()`.

BLAS is single-threaded on both sides, as in bench/compare.py (skyloop is single-threaded per call;
a threaded OpenBLAS on a busy machine makes slycot and numpy look slower than they are: in one such
run ab09ad took 42 ms and balred showed 10.6x, against 2.1-2.3x with one BLAS thread).
"""
import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse
import re
import resource
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))


def best(f, repeat):
    f()
    t = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        t = min(t, time.perf_counter() - t0)
    return t


def random_stable(rng, n, ny, nu):
    import numpy as np

    a = rng.standard_normal((n, n))
    a -= (np.linalg.eigvals(a).real.max() + 0.5) * np.eye(n)
    return a, rng.standard_normal((n, nu)), rng.standard_normal((ny, n)), rng.standard_normal((ny, nu))


def main():
    import control
    import numpy as np

    import skyloop as sk

    try:
        import slycot  # noqa: F401
        have_slycot = True
    except ImportError:
        have_slycot = False

    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=1000, help="Monte Carlo flights (default 1000)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--only", help="run only comparisons whose name contains this text")
    a = ap.parse_args()
    rng = np.random.default_rng(16)
    rows = []

    def row(name, ours, ref, target, ref_name):
        rows.append((name, ours, ref, target, ref_name))
        r = ref / ours if ours > 0 else float("inf")
        ok = "ok" if r >= target else "BELOW TARGET"
        print(f"{name:<34} skyloop {ours * 1e3:10.3f} ms   {ref_name:<22} {ref * 1e3:10.3f} ms   "
              f"ratio {r:7.2f}x  (target >= {target:g}x: {ok})", flush=True)

    want = lambda name: a.only is None or a.only in name  # noqa: E731

    print(f"python-control {control.__version__}, slycot {'yes' if have_slycot else 'not installed'}, "
          f"skyloop {sk.__version__}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}")

    if want("freqresp"):
        A, B, C, D = random_stable(rng, 20, 2, 2)
        s, sc = sk.ss(A, B, C, D), control.ss(A, B, C, D)
        w = np.logspace(-2, 3, 10_000)
        g = sk.freqresp(s, w)
        ref = np.moveaxis(control.frequency_response(sc, w, squeeze=False).fresp, -1, 0)
        assert np.allclose(g, ref, rtol=1e-8, atol=1e-10)
        row("freqresp 20 states 2x2, 10k freqs", best(lambda: sk.freqresp(s, w), a.repeat),
            best(lambda: control.frequency_response(sc, w), a.repeat), 15, "control.freq_resp")

    if want("hinf_norm") and have_slycot:
        A, B, C, D = random_stable(rng, 40, 2, 2)
        s, sc = sk.ss(A, B, C, D), control.ss(A, B, C, D)
        assert abs(sk.hinf_norm(s)[0] - control.norm(sc, "inf")) < 1e-6 * sk.hinf_norm(s)[0]
        row("hinf_norm 40 states 2x2", best(lambda: sk.hinf_norm(s), a.repeat),
            best(lambda: control.norm(sc, "inf"), a.repeat), 2, "slycot ab13dd")

    if want("hinfsyn") and have_slycot:
        # The 12-state plant of bench/compare_hinf.py (A shifted stable: on an unstable A sb10ad
        # did not finish in 20 s).
        r1 = np.random.default_rng(1)
        n, m1, m2, p1, p2 = 12, 2, 1, 2, 1
        A = r1.standard_normal((n, n)) / np.sqrt(n)
        A -= (max(np.linalg.eigvals(A).real) + 0.5) * np.eye(n)
        B = r1.standard_normal((n, m1 + m2))
        C = r1.standard_normal((p1 + p2, n))
        D = np.zeros((p1 + p2, m1 + m2))
        D[:p1, :m1] = 0.3 * r1.standard_normal((p1, m1))
        D[:p1, m1:] = r1.standard_normal((p1, m2))
        D[p1:, :m1] = r1.standard_normal((p2, m1))
        D[p1:, m1:] = 0.5 * r1.standard_normal((p2, m2))
        p, pc, nm, nc = sk.ss(A, B, C, D), control.ss(A, B, C, D), 1, 1
        g_ours = sk.hinfsyn(p, nm, nc)[1]
        g_ref = control.hinfsyn(pc, nm, nc)[2]
        print(f"  (hinfsyn gamma: skyloop {g_ours:.6f}, slycot sb10ad {g_ref:.6f})")
        row("hinfsyn 12 states", best(lambda: sk.hinfsyn(p, nm, nc), a.repeat),
            best(lambda: control.hinfsyn(pc, nm, nc), a.repeat), 20, "control + sb10ad")

    if want("balred") and have_slycot:
        A, B, C, D = random_stable(rng, 100, 2, 2)
        s, sc = sk.ss(A, B, C, D), control.ss(A, B, C, D)
        row("balred 100 -> 10", best(lambda: sk.balred(s, 10), a.repeat),
            best(lambda: control.balred(sc, 10), a.repeat), 2, "slycot ab09ad")

    if want("montecarlo"):
        with open(os.path.join(ROOT, "examples", "quadrotor-ssi.toml")) as f:
            text = f.read()
        text = re.sub(r"(?m)^duration_s = .*$", "duration_s = 20.0", text)
        text = re.sub(r"(?m)^runs = .*$", f"runs = {a.runs}", text)
        # Alternating 1- and 2-thread runs, best wall time of each: a burst of load from another
        # process then spoils one sample, not the ratio. CPU time (user + sys) is reported too: on
        # a busy machine the wall-clock ratio says how many cores the OS gave us, while CPU(2) /
        # CPU(1) near 1 says the parallel run does no extra work (no lock spinning, no contention).
        def timed(threads):
            c0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
            out = sk.montecarlo(text, threads=threads)
            t, c1 = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_SELF)
            return out, t, (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)

        best_t = {1: float("inf"), 2: float("inf")}
        best_c = {1: float("inf"), 2: float("inf")}
        results = {}
        for _ in range(max(1, min(a.repeat, 3))):
            for threads in (1, 2):
                out, t, c = timed(threads)
                results[threads] = out
                best_t[threads] = min(best_t[threads], t)
                best_c[threads] = min(best_c[threads], c)
        assert results[1] == results[2], "the Monte Carlo result depends on the thread count"
        t1, t2 = best_t[1], best_t[2]
        print(f"{'montecarlo ' + str(a.runs) + ' flights x 20 s':<34} 2 threads {t2:8.2f} s   1 thread {t1:8.2f} s"
              f"   speed-up {t1 / t2:5.2f}x  (target >= 1.8x: {'ok' if t1 / t2 >= 1.8 else 'BELOW TARGET'}); "
              f"cores used on 2 threads {best_c[2] / t2:4.2f}, CPU time 2 threads / 1 thread "
              f"{best_c[2] / best_c[1]:5.3f}")
    if not have_slycot:
        print("slycot not installed: the hinf_norm, hinfsyn and balred comparisons were skipped")
    print(f"load average at the end: {os.getloadavg()[0]:.1f} (ratios are only meaningful near 0)")


if __name__ == "__main__":
    main()
