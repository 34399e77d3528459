#!/usr/bin/env python3
"""Reference model-reduction results from SLICOT (through slycot and python-control).

Writes crates/skyloop-lti/tests/fixtures/reduce/cases.json. For each system:
  - hsv: Hankel singular values of the (alpha-)stable part from SLICOT AB09AD (stable systems) or
    AB09MD (unstable systems), descending;
  - for the requested order: the frequency response of the reduced model from AB09AD/AB09MD
    (balanced truncation, square-root, JOB='B') and from AB09ND (singular perturbation, 'matchdc',
    balancing-free JOB='N'),
    at the frequencies `w` (rad/s; z = exp(j·w·dt) in discrete time);
  - minreal cases: the minimal order found by control.minreal (SLICOT TB01PD).
Random systems come from control.rss / control.drss with fixed seeds.
Run: python3 tools/gen_reduce.py
"""
import json
import os

import control
import numpy as np
import slycot

OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-lti", "tests", "fixtures", "reduce")
W = np.logspace(-2, 3, 25)


def response(a, b, c, d, w, dt):
    n = a.shape[0]
    out = []
    for wk in w:
        s = np.exp(1j * wk * dt) if dt > 0 else 1j * wk
        g = d + c @ np.linalg.solve(s * np.eye(n) - a, b) if n > 0 else d.astype(complex)
        out.append({"re": g.real.tolist(), "im": g.imag.tolist()})
    return out


def mat(x):
    return np.asarray(x, dtype=float).tolist()


def case(name, sys, order, dt=0.0):
    a, b, c, d = (np.asarray(x, dtype=float) for x in (sys.A, sys.B, sys.C, sys.D))
    n, m, p = a.shape[0], b.shape[1], c.shape[0]
    dico = "D" if dt > 0 else "C"
    eig = np.linalg.eigvals(a)
    unstable = np.any(abs(eig) >= 1.0) if dt > 0 else np.any(eig.real >= 0.0)
    alpha = 1.0 if dt > 0 else 0.0
    if unstable:
        nr, ar, br, cr, ns, hsv = slycot.ab09md(dico, "B", "N", n, m, p, a, b, c, alpha=alpha, nr=order, tol=0.0)
        hsv = hsv[:ns]
    else:
        nr, ar, br, cr, hsv = slycot.ab09ad(dico, "B", "N", n, m, p, a, b, c, nr=order, tol=0.0)
    assert nr == order, (name, nr, order)
    bt = response(ar[:nr, :nr], br[:nr, :], cr[:, :nr], d, W, dt)
    # JOB='N' (balancing-free square root, Varga): with JOB='B' this slycot build returns discrete
    # SPA models whose DC gain differs from the original's (checked on drss_n8), which SPA must match.
    nr2, ar2, br2, cr2, dr2, ns2, hsv2 = slycot.ab09nd(
        dico, "N", "N", n, m, p, a, b, c, d, alpha=alpha, nr=order, tol1=0.0, tol2=0.0)
    assert nr2 == order
    spa = response(ar2[:nr2, :nr2], br2[:nr2, :], cr2[:, :nr2], dr2, W, dt)
    return {"name": name, "a": mat(a), "b": mat(b), "c": mat(c), "d": mat(d), "dt": dt, "order": order,
            "hsv": mat(hsv), "w": W.tolist(), "balanced": bt, "spa": spa}


def with_unstable(sys, poles, rng):
    """Appends unstable modes (real or complex) and hides them with a random similarity."""
    a, b, c, d = sys.A, sys.B, sys.C, sys.D
    blocks = []
    for p in poles:
        if np.iscomplex(p):
            blocks.append(np.array([[p.real, p.imag], [-p.imag, p.real]]))
        else:
            blocks.append(np.array([[p.real]]))
    au = np.zeros((sum(x.shape[0] for x in blocks),) * 2)
    k = 0
    for x in blocks:
        au[k:k + x.shape[0], k:k + x.shape[0]] = x
        k += x.shape[0]
    nu = au.shape[0]
    n = a.shape[0]
    A = np.block([[a, np.zeros((n, nu))], [np.zeros((nu, n)), au]])
    B = np.vstack([b, rng.standard_normal((nu, b.shape[1]))])
    C = np.hstack([c, rng.standard_normal((c.shape[0], nu))])
    t = rng.standard_normal((n + nu, n + nu)) + 3 * np.eye(n + nu)
    ti = np.linalg.inv(t)
    return control.ss(ti @ A @ t, ti @ B, C @ t, d, sys.dt)


def main():
    cases = []
    np.random.seed(11)
    for n, p, m, r in [(4, 1, 1, 2), (10, 2, 2, 4), (25, 1, 3, 8), (50, 3, 2, 12), (100, 2, 2, 10)]:
        cases.append(case(f"rss_n{n}", control.rss(n, p, m), r))
    for n, p, m, r in [(8, 1, 1, 3), (30, 2, 2, 9)]:
        cases.append(case(f"drss_n{n}", control.drss(n, p, m, dt=0.01), r, dt=0.01))
    rng = np.random.default_rng(5)
    cases.append(case("unstable_n12", with_unstable(control.rss(9, 2, 1), [0.5, 0.2 + 3j], rng), 6))
    cases.append(case("unstable_d_n10", with_unstable(control.drss(8, 1, 2, dt=0.1), [1.2 + 0.0j, -1.5], rng),
                      5, dt=0.1))
    # Nearly uncontrollable: a mode whose input row is 1e-9 (tiny Hankel singular value).
    sys = control.rss(12, 2, 2)
    bn = np.array(sys.B)
    bn[-1, :] *= 1e-9
    cases.append(case("nearly_uncontrollable_n12", control.ss(sys.A, bn, sys.C, sys.D), 5))

    mincases = []
    for n, nunc, nuno, p, m in [(6, 2, 1, 1, 1), (12, 3, 2, 2, 2), (20, 0, 4, 2, 3)]:
        base = control.rss(n - nunc - nuno, p, m)
        a, b, c, d = base.A, base.B, base.C, base.D
        k = a.shape[0]
        # Uncontrollable states (zero input rows, no coupling into the rest) and unobservable ones.
        au = rng.standard_normal((nunc, nunc)) - 2 * np.eye(nunc)
        ao = rng.standard_normal((nuno, nuno)) - 2 * np.eye(nuno)
        A = np.zeros((n, n))
        A[:k, :k] = a
        A[k:k + nunc, k:k + nunc] = au
        A[k + nunc:, k + nunc:] = ao
        A[:k, k:k + nunc] = rng.standard_normal((k, nunc))  # uncontrollable drives controllable
        A[k + nunc:, :k] = rng.standard_normal((nuno, k))  # unobservable is driven by the rest
        B = np.vstack([b, np.zeros((nunc, m)), rng.standard_normal((nuno, m))])
        C = np.hstack([c, rng.standard_normal((p, nunc)), np.zeros((p, nuno))])
        t = rng.standard_normal((n, n)) + 3 * np.eye(n)
        ti = np.linalg.inv(t)
        sys = control.ss(ti @ A @ t, ti @ B, C @ t, d)
        red = control.minreal(sys, tol=1e-9, verbose=False)
        mincases.append({"name": f"minreal_n{n}", "a": mat(sys.A), "b": mat(sys.B), "c": mat(sys.C),
                         "d": mat(sys.D), "dt": 0.0, "tol": 1e-9, "order": int(red.nstates), "expected_order": k,
                         "w": W.tolist(), "response": response(sys.A, sys.B, sys.C, sys.D, W, 0.0)})

    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "cases.json"), "w") as f:
        json.dump({"source": "tools/gen_reduce.py (slycot AB09AD/AB09MD JOB=B, AB09ND JOB=N, control.minreal/TB01PD)",
                   "cases": cases, "minreal": mincases}, f)
    print(f"wrote {len(cases)} reduction cases, {len(mincases)} minreal cases")
    for c in cases:
        h = np.array(c["hsv"])
        print(c["name"], len(h), f"hsv {h[0]:.3e} .. {h[-1]:.3e}")
    for c in mincases:
        print(c["name"], "minreal order", c["order"], "expected", c["expected_order"])


main()
