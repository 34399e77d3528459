#!/usr/bin/env python3
"""gamma_opt references for hinfstruct at full order (crates/skyloop-robust/tests/hinfstruct.rs).

For each random generalized plant of tools/gen_hinf.py (the plants of hinfsyn_random.json), the
optimal H-inf level gamma_opt is found independently of SLICOT by bisection on the existence
conditions of the general output-feedback problem (Glover & Doyle 1988; Zhou, Doyle & Glover,
"Robust and Optimal Control", ch. 17), written in a form that needs no normalization of D12/D21:

  (i)   D11' (I - D12 D12^+) D11 < gamma^2 I  and  D11 (I - D21^+ D21) D11' < gamma^2 I,
  (ii)  X = Ric(H) >= 0 with H = [A 0; -C1'C1 -A'] - [B; -C1'D1.] R^-1 [D1.'C1  B'],
        R = D1.'D1. - diag(gamma^2 I, 0), D1. = [D11 D12], B = [B1 B2],
  (iii) Y = Ric(J) >= 0, the dual with D.1 = [D11; D21], C = [C1; C2],
  (iv)  rho(X Y) < gamma^2,

after removing D22 by the loop shift K -> K (I - D22 K)^-1, which leaves the achievable set of
norms unchanged. Ric is the stabilizing solution from scipy's ordered real Schur form. Each value
is cross-checked against SLICOT sb10ad (python-control hinfsyn): both are stored.

Run: python3 tools/gen_hinfstruct.py (needs numpy, scipy, control, slycot)
"""
import json
import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np
import scipy.linalg as sla

HERE = os.path.dirname(__file__)
FIX = os.path.join(HERE, "..", "crates", "skyloop-robust", "tests", "fixtures", "hinf")


def ric(h):
    """Stabilizing solution of the Riccati equation of Hamiltonian h, or None."""
    n = h.shape[0] // 2
    ev = np.linalg.eigvals(h)
    scale = max(1.0, np.max(np.abs(ev)))
    if np.min(np.abs(ev.real)) < 1e-9 * scale:
        return None
    t, z, sdim = sla.schur(h, output="real", sort="lhp")
    if sdim != n:
        return None
    x1, x2 = z[:n, :n], z[n:, :n]
    if np.linalg.cond(x1) > 1e12:
        return None
    x = np.linalg.solve(x1.T, x2.T).T
    return 0.5 * (x + x.T)


def psd(x):
    return np.min(np.linalg.eigvalsh(x)) >= -1e-9 * max(1.0, np.max(np.abs(x)))


def parts(p, nmeas, ncon):
    a, b, c, d = (np.array(p[k], dtype=float) for k in "abcd")
    m1 = b.shape[1] - ncon
    p1 = c.shape[0] - nmeas
    return a, b[:, :m1], b[:, m1:], c[:p1], c[p1:], d[:p1, :m1], d[:p1, m1:], d[p1:, :m1], d[p1:, m1:]


def feasible(gam, a, b1, b2, c1, c2, d11, d12, d21):
    n, m1, p1 = a.shape[0], b1.shape[1], c1.shape[0]
    g2 = gam * gam
    pr12 = np.eye(p1) - d12 @ np.linalg.pinv(d12)
    pr21 = np.eye(m1) - np.linalg.pinv(d21) @ d21
    if np.max(np.linalg.eigvalsh(d11.T @ pr12 @ d11)) >= g2:
        return False
    if np.max(np.linalg.eigvalsh(d11 @ pr21 @ d11.T)) >= g2:
        return False
    b = np.hstack([b1, b2])
    d1 = np.hstack([d11, d12])
    r = d1.T @ d1
    r[:m1, :m1] -= g2 * np.eye(m1)
    ri = np.linalg.inv(r)
    h = np.block([[a, np.zeros((n, n))], [-c1.T @ c1, -a.T]]) - np.vstack([b, -c1.T @ d1]) @ ri @ np.hstack(
        [d1.T @ c1, b.T])
    x = ric(h)
    if x is None or not psd(x):
        return False
    c = np.vstack([c1, c2])
    dd = np.vstack([d11, d21])
    rt = dd @ dd.T
    rt[:p1, :p1] -= g2 * np.eye(p1)
    rti = np.linalg.inv(rt)
    j = np.block([[a.T, np.zeros((n, n))], [-b1 @ b1.T, -a]]) - np.vstack([c.T, -b1 @ dd.T]) @ rti @ np.hstack(
        [dd @ b1.T, c])
    y = ric(j)
    if y is None or not psd(y):
        return False
    return np.max(np.abs(np.linalg.eigvals(x @ y))) < g2


def gamma_opt(p, nmeas, ncon, rtol=1e-7):
    a, b1, b2, c1, c2, d11, d12, d21, d22 = parts(p, nmeas, ncon)
    # D22 only reparametrizes K (loop shift): the achievable closed loops are those of D22 = 0.
    del d22
    lo, hi = 0.0, 1.0
    while not feasible(hi, a, b1, b2, c1, c2, d11, d12, d21):
        lo, hi = hi, 2.0 * hi
        if hi > 1e8:
            return None
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if feasible(mid, a, b1, b2, c1, c2, d11, d12, d21):
            hi = mid
        else:
            lo = mid
    return hi


def slycot_gamma(p, nmeas, ncon):
    import control
    P = control.ss(*(np.array(p[k], dtype=float) for k in "abcd"))
    try:
        _, _, gam, _ = control.hinfsyn(P, nmeas, ncon)
        return float(gam)
    except Exception:
        return None


def main():
    src = json.load(open(os.path.join(FIX, "hinfsyn_random.json")))
    cases = []
    for c in src["cases"]:
        g = gamma_opt(c["plant"], c["nmeas"], c["ncon"])
        s = slycot_gamma(c["plant"], c["nmeas"], c["ncon"])
        print(c["name"], "bisection", g, "slycot", s, flush=True)
        cases.append({"name": c["name"], "plant": c["plant"], "nmeas": c["nmeas"], "ncon": c["ncon"],
                      "gamma_opt": g, "gamma_slycot": s})
    out = {
        "source": "gamma_opt: bisection (rtol 1e-7) on the Glover-Doyle existence conditions with scipy "
                  "ordered Schur Riccati solutions (tools/gen_hinfstruct.py); gamma_slycot: python-control "
                  "0.10.2 hinfsyn (SLICOT sb10ad) for comparison; plants: hinfsyn_random.json",
        "cases": cases,
    }
    with open(os.path.join(FIX, "hinfstruct_gamma.json"), "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
