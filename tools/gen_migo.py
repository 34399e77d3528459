#!/usr/bin/env python3
"""Reference optimum for skyloop's fixed-structure tuner: the PI controller C = kp + ki/s with the
largest integral gain ki under Ms = max_w |1/(1 + P C)| <= 1.4 (Astrom & Hagglund's MIGO design),
computed independently of skyloop with numpy/scipy:

1. brute force: for each kp on a grid, ki is raised from 1e-3 in steps of 2 % until Ms first
   exceeds 1.4, then bisected between the last feasible and first infeasible step (a loop that
   stays at Ms <= 1.4 along the path from ki = 0+ cannot have become unstable, since a pole
   crossing the imaginary axis needs Ms = inf; a bisection over a wide bracket could land on an
   unstable loop whose |S| on the axis happens to be small);
2. polish: SLSQP maximizing ki with the constraints Ms^2 <= 1.4^2 at every point of a dense
   frequency grid, started from the best grid point.

Delays are exact (e^{-j w T}) in the frequency response. Writes
crates/skyloop-robust/tests/fixtures/migo/pi_ms14.json.

Usage: python3 -m venv /tmp/venv && /tmp/venv/bin/pip install scipy numpy
       /tmp/venv/bin/python tools/gen_migo.py
"""
import json
import math
import os

import numpy as np
from scipy.interpolate import pade
from scipy.optimize import minimize

MS = 1.4
W = np.logspace(-3, 2, 40000)

def pade_delay(t, order=8):
    """Numerator and denominator of the order-`order` Pade approximant of e^{-s t} (highest power first)."""
    an = [(-t) ** k / math.factorial(k) for k in range(2 * order + 1)]
    p, q = pade(an, order)
    return np.poly1d(p.coeffs), np.poly1d(q.coeffs)


LAG = np.poly1d([1.0, 1.0])
PD_NUM, PD_DEN = pade_delay(1.0)
PLANTS = [
    # name, skyloop expression, exact frequency response, (num, den) for the stability test
    ("lag4", "1/(s+1)^4", lambda s: 1.0 / (s + 1) ** 4, (np.poly1d([1.0]), LAG**4)),
    ("delay_lag2", "exp(-1*s)/(s+1)^2", lambda s: np.exp(-s) / (s + 1) ** 2, (PD_NUM, PD_DEN * LAG**2)),
    ("integrator_lag3", "1/(s*(s+1)^3)", lambda s: 1.0 / (s * (s + 1) ** 3), (np.poly1d([1.0]), np.poly1d([1.0, 0.0]) * LAG**3)),
]


def stable(nd, kp, ki):
    """Closed-loop poles of P = num/den with C = (kp s + ki)/s (delay as its Pade approximant)."""
    num, den = nd
    char = den * np.poly1d([1.0, 0.0]) + num * np.poly1d([kp, ki])
    return bool(np.all(np.roots(char.coeffs).real < 0))


def ms(p, kp, ki, w=None):
    s = 1j * (W if w is None else w)
    l = p(s) * (kp + ki / s)
    return np.max(np.abs(1.0 / (1.0 + l)))


def ki_max(p, kp, w=None):
    p, nd = p
    if not stable(nd, kp, 1e-3) or ms(p, kp, 1e-3, w) > MS:
        return 0.0
    lo = 1e-3
    while lo < 50.0:
        hi = lo * 1.02
        if ms(p, kp, hi, w) > MS or not stable(nd, kp, hi):
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                if ms(p, kp, mid, w) <= MS and stable(nd, kp, mid):
                    lo = mid
                else:
                    hi = mid
            return lo
        lo = hi
    return lo


def optimum(pnd):
    p, nd = pnd
    coarse = np.logspace(-3, 2, 3000)
    kps = np.linspace(0.0, 3.0, 151)
    kis = [ki_max(pnd, kp, coarse) for kp in kps]
    i = int(np.argmax(kis))
    fine = np.linspace(kps[max(i - 1, 0)], kps[min(i + 1, len(kps) - 1)], 201)
    kis_f = [ki_max(pnd, kp) for kp in fine]
    j = int(np.argmax(kis_f))
    x0 = np.array([fine[j], kis_f[j]])
    s = 1j * W

    def cons(x):
        l = p(s) * (x[0] + x[1] / s)
        return MS**2 - np.abs(1.0 / (1.0 + l)) ** 2

    r = minimize(lambda x: -x[1], x0, method="SLSQP", constraints=[{"type": "ineq", "fun": cons}],
                 options={"ftol": 1e-12, "maxiter": 200})
    x = r.x if (r.success and np.min(cons(r.x)) > -1e-9 and r.x[1] >= x0[1] and stable(nd, *r.x)) else x0
    return float(x[0]), float(x[1]), float(ms(p, x[0], x[1])), float(x0[1])


def main():
    cases = []
    for name, expr, p, nd in PLANTS:
        kp, ki, m, ki_grid = optimum((p, nd))
        print(f"{name}: kp {kp:.6f} ki {ki:.6f} Ms {m:.6f} (grid ki {ki_grid:.6f})")
        cases.append({"name": name, "plant": expr, "ms_max": MS, "kp": kp, "ki": ki, "ms": m, "ki_grid": ki_grid})
    out = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-robust", "tests", "fixtures", "migo")
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "pi_ms14.json"), "w") as f:
        json.dump({"source": "tools/gen_migo.py (numpy/scipy brute force + SLSQP, exact delays)", "cases": cases}, f, indent=1)


if __name__ == "__main__":
    main()
