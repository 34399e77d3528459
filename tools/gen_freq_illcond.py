#!/usr/bin/env python3
"""Reference fixture for skyloop-lti's frequency response on ill-conditioned models: 26 states, 3 x 3,
A made of three companion blocks (orders 9, 9, 8, poles spread over 0.1..1000 rad/s) with small
couplings, B and C scaled over four decades. Entries of A span ~20 orders of magnitude, so an
orthogonal change of basis (Schur or Hessenberg) perturbs the small entries that set the response.

The reference is exact to well below 1e-15: G(jw) = C (jwI - A)^-1 B solved in 40-digit arithmetic
(mpmath, BSD) on the float64 matrices as stored. Beside it, the relative error of python-control's
frequency_response (slycot tb05ad when slycot is installed) and of a numpy direct solve, to record
what the usual tools reach on the same models.

Run from the repository root:  python3 tools/gen_freq_illcond.py   (needs numpy, mpmath, control)
Writes crates/skyloop-lti/tests/fixtures/freq/freqresp_illcond.json
"""
import json
import os

import control
import mpmath as mp
import numpy as np

mp.mp.dps = 40
OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-lti", "tests", "fixtures", "freq")


def companion_model(seed, n=26, ny=3, nu=3):
    rng = np.random.default_rng(seed)
    a = np.zeros((n, n))
    off = 0
    for m in (9, 9, 8):
        p = -np.logspace(-1, 3, m) * (1 + 0.1 * rng.standard_normal(m))
        c = np.poly(p).real
        blk = np.zeros((m, m))
        blk[0, :] = -c[1:]
        blk[1:, :-1] = np.eye(m - 1)
        a[off:off + m, off:off + m] = blk
        off += m
    a += 1e-3 * rng.standard_normal((n, n)) * (np.abs(a) > 0)
    b = rng.standard_normal((n, nu)) * np.logspace(-2, 2, n)[:, None]
    c = rng.standard_normal((ny, n)) * np.logspace(2, -2, n)[None, :]
    return a, b, c, np.zeros((ny, nu))


def exact(a, b, c, w):
    n, nu, ny = a.shape[0], b.shape[1], c.shape[0]
    am, bm, cm = mp.matrix(a.tolist()), mp.matrix(b.tolist()), mp.matrix(c.tolist())
    out = np.zeros((len(w), ny, nu), dtype=complex)
    for k, wk in enumerate(w):
        m = mp.mpc(0, mp.mpf(wk)) * mp.eye(n) - am
        for j in range(nu):
            g = cm * mp.lu_solve(m, bm.column(j))
            for i in range(ny):
                out[k, i, j] = complex(g[i])
    return out


def main():
    cases = []
    w = 2 * np.pi * np.logspace(-3, 3.5, 40)
    for seed in (5, 6, 7):
        a, b, c, d = companion_model(seed)
        ref = exact(a, b, c, w)
        pc = np.moveaxis(np.reshape(control.ss(a, b, c, d)(1j * w), (3, 3, len(w))), -1, 0)
        direct = np.array([c @ np.linalg.solve(1j * wk * np.eye(a.shape[0]) - a, b) for wk in w])
        rel = lambda x: float((np.abs(x - ref) / np.abs(ref)).max())
        cases.append({
            "name": f"companion blocks n=26 3x3 seed {seed}",
            "sys": {"a": a.tolist(), "b": b.tolist(), "c": c.tolist(), "d": d.tolist(), "dt": 0.0},
            "w_rad_s": w.tolist(),
            "re": ref.real.tolist(),
            "im": ref.imag.tolist(),
            "python_control_rel_err": rel(pc),
            "numpy_direct_rel_err": rel(direct),
        })
        print(cases[-1]["name"], "python-control", rel(pc), "direct", rel(direct))
    data = {
        "generator": "tools/gen_freq_illcond.py",
        "python_control": control.__version__,
        "slycot": control.exception.slycot_check(),
        "mpmath_dps": mp.mp.dps,
        "cases": cases,
    }
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "freqresp_illcond.json"), "w") as f:
        json.dump(data, f, allow_nan=False)


if __name__ == "__main__":
    main()
