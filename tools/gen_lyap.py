#!/usr/bin/env python3
"""Reference solutions of Sylvester and Lyapunov equations for skyloop-linalg tests.

Writes crates/skyloop-linalg/tests/fixtures/lyap/cases.json. Each case holds its inputs and the
reference solution: scipy.linalg for X (solve_sylvester, solve_continuous_lyapunov,
solve_discrete_lyapunov) and SLICOT SB03OD (through slycot, TRANS='T') for the Cholesky factor U
with X = U·Uᵀ. Run: python3 tools/gen_lyap.py
"""
import json
import os

import numpy as np
import scipy.linalg as sla
import slycot

rng = np.random.default_rng(20261123)
OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-linalg", "tests", "fixtures", "lyap")


def stable(n, margin=0.1):
    """A random continuous-time stable matrix (spectral abscissa −margin)."""
    a = rng.standard_normal((n, n))
    return a - (max(np.linalg.eigvals(a).real) + margin) * np.eye(n)


def schur_stable(n, radius=0.9):
    a = rng.standard_normal((n, n))
    return a * (radius / max(abs(np.linalg.eigvals(a))))


def chol_factor(dico, a, b):
    n, m = b.shape
    # The slycot wrapper with TRANS='T' accepts only an n×n array for B (so m <= n here).
    assert m <= n
    bb = np.zeros((n, n))
    bb[:, :m] = b
    u, scale, _ = slycot.sb03od(n, m, a.copy(), np.zeros((n, n)), bb, dico, fact="N", trans="T")
    u = np.triu(u[:n, :n]) / scale
    # Signs of U's columns are free; fix a non-negative diagonal like skyloop.
    for j in range(n):
        if u[j, j] < 0:
            u[:, j] = -u[:, j]
    return u


cases = []
for n in (1, 2, 5, 10, 30):
    # Sylvester A X + X B = C with a B of different size.
    a = rng.standard_normal((n, n))
    b = rng.standard_normal((n + 2, n + 2)) + 3.0 * np.eye(n + 2)
    a = a - 3.0 * np.eye(n)
    c = rng.standard_normal((n, n + 2))
    cases.append({"kind": "sylvester", "a": a.tolist(), "b": b.tolist(), "c": c.tolist(),
                  "x": sla.solve_sylvester(a, b, c).tolist()})
    # Continuous Lyapunov with an unstable but regular A, and with a stable A.
    for a in (rng.standard_normal((n, n)) + 0.3 * np.eye(n), stable(n)):
        q = rng.standard_normal((n, n))
        q = q @ q.T
        cases.append({"kind": "lyap", "a": a.tolist(), "q": q.tolist(),
                      "x": sla.solve_continuous_lyapunov(a, -q).tolist()})
    a = schur_stable(n)
    q = rng.standard_normal((n, n))
    q = q + q.T
    cases.append({"kind": "dlyap", "a": a.tolist(), "q": q.tolist(),
                  "x": sla.solve_discrete_lyapunov(a, q).tolist()})
    for m in [m for m in (1, 3) if m <= n]:
        a = stable(n)
        b = rng.standard_normal((n, m))
        cases.append({"kind": "lyap_chol", "a": a.tolist(), "b": b.tolist(),
                      "u": chol_factor("C", a, b).tolist()})
        a = schur_stable(n)
        cases.append({"kind": "dlyap_chol", "a": a.tolist(), "b": b.tolist(),
                      "u": chol_factor("D", a, b).tolist()})

os.makedirs(OUT, exist_ok=True)
with open(os.path.join(OUT, "cases.json"), "w") as f:
    json.dump({"source": "tools/gen_lyap.py (scipy.linalg, slycot SB03OD)", "cases": cases}, f)
print(f"wrote {len(cases)} cases")
