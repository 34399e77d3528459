#!/usr/bin/env python3
"""Reference fixtures for skyloop-robust hinfsyn/ncfsyn.

hinfsyn: random generalized plants solved by python-control `hinfsyn` (SLICOT sb10ad); we store
SLICOT's gamma and the H-inf norm its own closed loop actually reaches (control.norm, SLICOT ab13dd).
ncfsyn: gamma_min = sqrt(1 + rho(X Z)) from the two normalized-coprime-factor CAREs solved with
scipy.linalg.solve_continuous_are, for the bicopter shaped plant (paper eq. (8)-(10), 3rd-order Pade)
and for a random MIMO shaped plant with D != 0.

Run: python3 tools/gen_hinf.py  (writes crates/skyloop-robust/tests/fixtures/hinf/*.json)
"""
import json
import os
import multiprocessing as mp
import queue

# One BLAS thread: on a loaded machine OpenBLAS threads thrash and sb10ad takes seconds.
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import control
import numpy as np
import scipy.linalg as sla

OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-robust", "tests", "fixtures", "hinf")


def rows(m):
    m = np.atleast_2d(np.asarray(m, dtype=float))
    return [list(map(float, r)) for r in m]


def lti_json(sys):
    return {"a": rows(sys.A) if sys.nstates else [], "b": rows(sys.B) if sys.nstates else [],
            "c": rows(sys.C) if sys.nstates else [], "d": rows(sys.D), "dt": 0.0}


def random_plant(rng, n, m1, m2, p1, p2, d11=True, d22=True):
    a = rng.standard_normal((n, n)) / np.sqrt(n)  # eigenvalues O(1), some unstable
    b = rng.standard_normal((n, m1 + m2))
    c = rng.standard_normal((p1 + p2, n))
    d = np.zeros((p1 + p2, m1 + m2))
    if d11:
        d[:p1, :m1] = 0.3 * rng.standard_normal((p1, m1))
    d[:p1, m1:] = rng.standard_normal((p1, m2))
    d[p1:, :m1] = rng.standard_normal((p2, m1))
    if d22:
        d[p1:, m1:] = 0.5 * rng.standard_normal((p2, m2))
    return control.ss(a, b, c, d)


def hinf_cases():
    rng = np.random.default_rng(20261123)
    shapes = [
        # n, m1, m2, p1, p2, d11, d22
        (2, 1, 1, 1, 1, False, False),
        (3, 2, 1, 2, 1, False, False),
        (4, 2, 1, 2, 1, True, False),
        (4, 3, 2, 3, 2, True, True),
        (5, 2, 1, 3, 1, True, True),
        (6, 3, 1, 2, 2, False, True),
        (6, 2, 2, 3, 1, True, False),
        (8, 3, 2, 3, 2, True, True),
        (8, 4, 1, 2, 3, True, True),
        (10, 3, 2, 4, 2, True, True),
    ]
    cases = []
    for k, (n, m1, m2, p1, p2, d11, d22) in enumerate(shapes):
        for attempt in range(20):
            P = random_plant(rng, n, m1, m2, p1, p2, d11, d22)
            res = solve_with_timeout(P, p2, m2, 60)
            if res is None:
                continue
            gam = res[0]
            CL = control.ss(*res[1:])
            if not np.isfinite(gam) or gam > 1e4:
                continue
            poles = np.linalg.eigvals(CL.A) if CL.nstates else np.array([])
            stable = bool(np.all(poles.real < 0))
            cl_norm = float(control.norm(CL, p="inf")) if stable else None  # JSON has no Infinity
            print(k, attempt, gam, flush=True)
            cases.append({"name": f"rand{k}_n{n}", "plant": lti_json(P), "nmeas": p2, "ncon": m2,
                          "gamma_slicot": float(gam), "cl_norm_slicot": cl_norm, "cl_stable_slicot": stable})
            break
    return cases


def bench_plant():
    """A 12-state plant for the speed comparison (bench/compare_hinf.py)."""
    rng = np.random.default_rng(12)
    return random_plant(rng, 12, 3, 2, 3, 2, True, True)


def ncf_gamma_min(ps):
    """gamma_min of Glover-McFarlane loop shaping (Skogestad & Postlethwaite eq. 9.66-9.68) via scipy CAREs."""
    a, b, c, d = ps.A, ps.B, ps.C, ps.D
    s = np.eye(d.shape[1]) + d.T @ d
    r = np.eye(d.shape[0]) + d @ d.T
    si = np.linalg.inv(s)
    ri = np.linalg.inv(r)
    ar = a - b @ si @ d.T @ c
    x = sla.solve_continuous_are(ar, b, c.T @ ri @ c, s)
    z = sla.solve_continuous_are(ar.T, c.T, b @ si @ b.T, r)
    rho = max(abs(np.linalg.eigvals(x @ z)))
    return float(np.sqrt(1.0 + rho))


def bicopter_shaped():
    s = control.tf("s")
    num, den = control.pade(0.032, 3)
    delay = control.tf(num, den)
    p = 0.0887 * delay / (0.0256 * s + 1) * (42**2 - s**2) / s * 2.221e5 / (s**2 + 666.4 * s + 2.221e5)
    w1 = 0.03511 * (s + 0.3419) / s
    w2 = 307.5 * (s + 3.816) / ((s + 11.35) * (s + 103.4))
    ps = control.ss(w2 * p * w1)
    return ps


def _solve(P, p2, m2, q):
    try:
        K, CL, gam, _ = control.hinfsyn(P, p2, m2)
        q.put((float(gam), CL.A, CL.B, CL.C, CL.D))
    except Exception:
        q.put(None)


def solve_with_timeout(P, p2, m2, seconds):
    """sb10ad occasionally crawls on a random draw: run it in a child process and skip slow draws."""
    q = mp.Queue()
    proc = mp.Process(target=_solve, args=(P, p2, m2, q))
    proc.start()
    try:
        return q.get(timeout=seconds)
    except queue.Empty:
        return None
    finally:
        proc.terminate()
        proc.join()


def main():
    os.makedirs(OUT, exist_ok=True)
    ps = bicopter_shaped()
    rng = np.random.default_rng(7)
    mimo = control.ss(rng.standard_normal((5, 5)) - 2 * np.eye(5), rng.standard_normal((5, 2)),
                      rng.standard_normal((2, 5)), 0.2 * rng.standard_normal((2, 2)))
    ncf = [
        {"name": "bicopter_pade3", "shaped_plant": lti_json(ps), "gamma_min": ncf_gamma_min(ps)},
        {"name": "random_mimo_d", "shaped_plant": lti_json(mimo), "gamma_min": ncf_gamma_min(mimo)},
    ]
    with open(os.path.join(OUT, "ncfsyn_gamma_min.json"), "w") as f:
        json.dump({"source": "scipy.linalg.solve_continuous_are, gamma_min = sqrt(1 + rho(XZ))", "cases": ncf},
                  f, indent=1)
    cases = hinf_cases()
    with open(os.path.join(OUT, "hinfsyn_random.json"), "w") as f:
        json.dump({"source": "python-control 0.10.2 hinfsyn (SLICOT sb10ad), control.norm (ab13dd)",
                   "cases": cases}, f, indent=1)
    with open(os.path.join(OUT, "bench_plant12.json"), "w") as f:
        json.dump({"plant": lti_json(bench_plant()), "nmeas": 2, "ncon": 2}, f, indent=1)

    for c in cases:
        print(c["name"], c["gamma_slicot"], c["cl_norm_slicot"], c["cl_stable_slicot"])
    for c in ncf:
        print(c["name"], c["gamma_min"])


if __name__ == "__main__":
    main()
