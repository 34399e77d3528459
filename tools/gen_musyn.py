#!/usr/bin/env python3
"""Reference H-infinity levels for skyloop's DK-iteration tests (python-control + slycot sb10ad).

The distillation column of Skogestad & Postlethwaite, Multivariable Feedback Control (2nd ed.),
Sec. 8.12.4 (companion file Sec8_124.m): G = G0/(75s+1), input uncertainty wI = (s+0.2)/(0.5s+1),
performance wP = 0.5(10s+1)/(10s + 10*pole) (S&P: pole = 1e-6; skyloop's tests use 1e-4 and 1e-3,
see tests/musyn.rs), generalized plant inputs [dI(2); w(2); u(2)], outputs [wI u; wP(G(u+dI)+w);
-G(u+dI)-w]. Writes the optimal gamma of the unscaled plant and of the plant scaled by
Lundstrom's mu-optimal D-scale (Sec8_124.m), to
crates/skyloop-robust/tests/fixtures/musyn/distillation.json.

Usage: python3 tools/gen_musyn.py
"""
import json
import os

import control as ct
import numpy as np

OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-robust", "tests", "fixtures", "musyn")


def plant(pole):
    g0 = np.array([[87.8, -86.4], [108.2, -109.6]])
    a, b, c, d = (np.zeros((6, 6)) for _ in range(4))
    cp = 0.5 * (0.1 - pole)
    for i in range(2):
        a[i, i] = -1 / 75
        for j in range(2):
            b[i, j] = g0[i, j] / 75
            b[i, 4 + j] = g0[i, j] / 75
        a[2 + i, 2 + i] = -2
        b[2 + i, 4 + i] = 1
        a[4 + i, 4 + i] = -pole
        a[4 + i, i] = 1
        b[4 + i, 2 + i] = 1
        c[i, 2 + i] = -3.6
        d[i, 4 + i] = 2
        c[2 + i, 4 + i] = cp
        c[2 + i, i] = 0.5
        d[2 + i, 2 + i] = 0.5
        c[4 + i, i] = -1
        d[4 + i, 2 + i] = -1
    return ct.ss(a, b, c, d)


def main():
    s = ct.tf("s")
    dopt = 2 * (0.001 * s + 1) * (s + 0.25) * (s + 0.054) / (((s + 0.67) ** 2 + 0.56**2) * (s + 0.013))
    one = ct.ss([], [], [], [[1.0]])
    out = {"source": "python-control %s hinfsyn (slycot sb10ad)" % ct.__version__, "cases": []}
    for pole in (1e-4, 1e-3):
        p = plant(pole)
        _, _, g0, _ = ct.hinfsyn(p, 2, 2)
        dl = ct.append(ct.ss(dopt), ct.ss(dopt), one, one, one, one)
        dr = ct.append(ct.ss(1 / dopt), ct.ss(1 / dopt), one, one, one, one)
        _, _, gd, _ = ct.hinfsyn(ct.ss(dl * p * dr), 2, 2)
        out["cases"].append({"wp_pole": pole, "gamma_unscaled": float(g0), "gamma_lundstrom_d": float(gd)})
        print(pole, g0, gd)
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "distillation.json"), "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
