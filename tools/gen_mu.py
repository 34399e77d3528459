#!/usr/bin/env python3
"""Reference values for skyloop's structured singular value (mu) bounds.

Writes crates/skyloop-robust/tests/fixtures/mu/mu_cases.json. Each case holds a complex matrix M
(row-major, [re, im] pairs), a block spec in skyloop's syntax, and reference values computed here
independently of skyloop with numpy/scipy:

* "exact": structures with 2S+F <= 3 (Packard & Doyle 1993, Thm 9.1: the D-scaling upper bound
  equals mu). mu is computed twice: the upper bound by minimizing sigma_max(D M D^-1) over the few
  free scalings with scipy Nelder-Mead (many restarts), and a brute-force lower bound by maximizing
  rho(Q M) over block unitary Q (random starts + Nelder-Mead on the Q parameters). The case is kept
  only when both agree to 1e-7 relative, so the fixture value is mu itself.
* "full": one full block, mu = sigma_max(M) (numpy SVD).
* "rank_one": M = u v^H with non-repeated complex scalar blocks, mu = sum |u_i| |v_i|.
* "general": larger structures (no exactness theorem); reference upper bound from scipy (best of
  restarts) and brute-force lower bound, so skyloop must satisfy lower_ref <= our upper and
  our upper <= upper_ref (1 + 1e-4).

Usage: python3 tools/gen_mu.py
"""
import json
import os

import numpy as np
from scipy.optimize import minimize

rng = np.random.default_rng(20261123)
OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-robust", "tests", "fixtures", "mu")


def parse(spec):
    """Blocks as (kind, rows, cols) with kind in {'c', 'f'}; M is sum(cols) x sum(rows)."""
    out = []
    for t in spec.split(","):
        if t.startswith("c") and t.endswith("r"):
            r = int(t[1:-1])
            out.append(("c", r, r))
        else:
            m, n = t[1:].split("x")
            out.append(("f", int(m), int(n)))
    return out


def ranges(blocks):
    rr, cr, r0, c0 = [], [], 0, 0
    for k, m, n in blocks:
        rr.append(slice(r0, r0 + n))  # rows of M read by the block (its columns)
        cr.append(slice(c0, c0 + m))
        r0 += n
        c0 += m
    return rr, cr


def herm(p, r):
    """Hermitian r x r matrix from r*r real parameters."""
    e = np.zeros((r, r), complex)
    k = 0
    for i in range(r):
        e[i, i] = p[k]
        k += 1
    for i in range(r):
        for j in range(i + 1, r):
            e[i, j] = p[k] + 1j * p[k + 1]
            e[j, i] = np.conj(e[i, j])
            k += 2
    return e


def nparams_d(blocks):
    return sum(1 if k == "f" else r * r for k, r, _ in blocks)


def expm_herm(E, scale=1.0):
    """exp(scale * E) for Hermitian E by its eigendecomposition (scale may be 1j)."""
    lam, V = np.linalg.eigh(E)
    return (V * np.exp(scale * lam)) @ V.conj().T


def scaled_sigma(M, blocks, p):
    rr, cr = ranges(blocks)
    DL = np.zeros((M.shape[0], M.shape[0]), complex)
    DRi = np.zeros((M.shape[1], M.shape[1]), complex)
    k = 0
    for j, (kind, m, n) in enumerate(blocks):
        if kind == "f":
            DL[rr[j], rr[j]] = np.exp(p[k]) * np.eye(n)
            DRi[cr[j], cr[j]] = np.exp(-p[k]) * np.eye(m)
            k += 1
        else:
            E = herm(p[k : k + m * m], m)
            DL[rr[j], rr[j]] = expm_herm(E)
            DRi[cr[j], cr[j]] = expm_herm(E, -1.0)
            k += m * m
    return np.linalg.norm(DL @ M @ DRi, 2)


NM = {"xatol": 1e-12, "fatol": 1e-15, "maxiter": 3000, "maxfev": 3000}


def upper_ref(M, blocks, restarts=2):
    n = nparams_d(blocks)
    best = np.linalg.norm(M, 2)
    for t in range(restarts):
        x0 = np.zeros(n) if t == 0 else rng.normal(scale=1.0, size=n)
        f = lambda p: scaled_sigma(M, blocks, p)
        r = minimize(f, x0, method="Nelder-Mead", options=NM)
        r = minimize(f, r.x, method="Nelder-Mead", options=NM)
        best = min(best, r.fun)
    return best


def unitary(p, r):
    """Unitary r x r matrix exp(i H(p))."""
    return expm_herm(herm(p, r), 1j)


def qmat(blocks, p, shape):
    rr, cr = ranges(blocks)
    Q = np.zeros(shape, complex)
    k = 0
    for j, (kind, m, n) in enumerate(blocks):
        if kind == "c":
            Q[cr[j], rr[j]] = np.exp(1j * p[k]) * np.eye(m)
            k += 1
        else:
            s = max(m, n)
            U = unitary(p[k : k + s * s], s)
            Q[cr[j], rr[j]] = U[:m, :n]
            k += s * s
    return Q


def nparams_q(blocks):
    return sum(1 if k == "c" else max(m, n) ** 2 for k, m, n in blocks)


def lower_ref(M, blocks, restarts=4):
    n = nparams_q(blocks)
    shape = (M.shape[1], M.shape[0])
    f = lambda p: -np.max(np.abs(np.linalg.eigvals(qmat(blocks, p, shape) @ M)))
    best = 0.0
    for _ in range(restarts):
        r = minimize(f, rng.uniform(-np.pi, np.pi, size=n), method="Nelder-Mead", options=NM)
        r = minimize(f, r.x, method="Nelder-Mead", options=NM)
        best = max(best, -r.fun)
    return best


def crandn(*shape):
    return rng.normal(size=shape) + 1j * rng.normal(size=shape)


def dims(blocks):
    return sum(n for _, _, n in blocks), sum(m for _, m, _ in blocks)


def enc(M):
    return [[[float(z.real), float(z.imag)] for z in row] for row in M]


cases = []

# One full block: mu = sigma_max.
for spec in ["f4x4", "f3x5", "f1x1"]:
    M = crandn(*dims(parse(spec)))
    cases.append({"name": f"full_{spec}", "kind": "full", "blocks": spec, "m": enc(M), "mu": float(np.linalg.norm(M, 2))})

# Rank one with non-repeated complex scalars: mu = sum |u_i||v_i| (Packard & Doyle 1993, sec. 6).
for n in [3, 5, 8]:
    u, v = crandn(n), crandn(n)
    M = np.outer(u, v.conj())
    cases.append({"name": f"rank_one_{n}", "kind": "rank_one", "blocks": ",".join(["c1x1"] * n), "m": enc(M),
                  "mu": float(np.sum(np.abs(u) * np.abs(v)))})

# 2S + F <= 3: upper bound exact.
for spec in ["c1x1,c1x1", "c1x1,c1x1,c1x1", "f2x2,c1x1", "c2r,f1x1", "f1x2,f2x1"]:
    for rep in range(1):
        bl = parse(spec)
        M = crandn(*dims(bl))
        up = upper_ref(M, bl)
        lo = lower_ref(M, bl)
        if abs(up - lo) > 1e-7 * up:
            print(f"skip {spec}: upper {up} lower {lo}")
            continue
        print(spec, up, lo, flush=True)
        cases.append({"name": f"exact_{spec}_{rep}", "kind": "exact", "blocks": spec, "m": enc(M), "mu": 0.5 * (up + lo),
                      "upper_ref": up, "lower_ref": lo})

# General structures (no exactness): bracket only.
for spec in ["c1x1,c1x1,c1x1,c1x1", "c2r,c1x1,c1x1"]:
    bl = parse(spec)
    M = crandn(*dims(bl))
    cases.append({"name": f"general_{spec}", "kind": "general", "blocks": spec, "m": enc(M),
                  "upper_ref": upper_ref(M, bl), "lower_ref": lower_ref(M, bl)})

os.makedirs(OUT, exist_ok=True)
with open(os.path.join(OUT, "mu_cases.json"), "w") as f:
    json.dump({"generator": "tools/gen_mu.py (numpy %s)" % np.__version__, "cases": cases}, f, indent=1)
print(f"wrote {len(cases)} cases")
