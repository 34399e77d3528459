#!/usr/bin/env python3
"""Fixtures for skyloop-linalg balancing and real Schur tests.

Writes crates/skyloop-linalg/tests/fixtures/schur/cases.json: a list of square matrices with their
eigenvalues from numpy (LAPACK dgeev) and the dgebal-balanced matrix from scipy.linalg.matrix_balance.
Run from the repository root: python3 tools/gen_schur.py
"""
import json
import os

import numpy as np
import scipy.linalg as sla

rng = np.random.default_rng(20261123)
cases = []


def add(name, a):
    a = np.asarray(a, dtype=float)
    ev = np.linalg.eigvals(a)
    bal, (sc, perm) = sla.matrix_balance(a, permute=True, scale=True, separate=True)
    cases.append({
        "name": name,
        "a": a.tolist(),
        "eig_re": ev.real.tolist(),
        "eig_im": ev.imag.tolist(),
        "balanced": bal.tolist(),
    })


for n in [1, 2, 3, 5, 8, 17, 40]:
    add(f"randn_{n}", rng.standard_normal((n, n)))
# Badly scaled: D·R·D⁻¹ with D spanning 12 orders of magnitude (balancing undoes it).
n = 10
d = np.diag(10.0 ** np.linspace(-6, 6, n))
add("badly_scaled_10", d @ rng.standard_normal((n, n)) @ np.linalg.inv(d))
# Companion matrix of a polynomial with known roots 1..8 (Wilkinson-like, non-normal).
add("companion_roots_1_to_8", np.vstack([-np.poly(np.arange(1, 9))[1:], np.eye(8)[:-1]]))
# Rotations: pure imaginary pairs and a Jordan-like block.
add("rotation_blocks", sla.block_diag([[0, 2], [-2, 0]], [[1, 5], [-0.2, 1]], [[3.0]]))
add("jordan_4", np.eye(4) * 2 + np.diag(np.ones(3), 1))
# Triangular plus permutation: dgebal isolates eigenvalues.
p = np.eye(6)[[3, 0, 5, 1, 4, 2]]
add("permuted_triangular_6", p @ np.triu(rng.standard_normal((6, 6))) @ p.T)
# Symmetric (real eigenvalues), skew-symmetric (imaginary eigenvalues).
s = rng.standard_normal((12, 12))
add("symmetric_12", s + s.T)
add("skew_12", s - s.T)
# A Hamiltonian matrix of a 20-state CARE (the Riccati solver's use case).
a = rng.standard_normal((20, 20))
b = rng.standard_normal((20, 3))
add("hamiltonian_40", np.block([[a, -b @ b.T], [-np.eye(20), -a.T]]))
add("zero_3", np.zeros((3, 3)))

out = os.path.join("crates", "skyloop-linalg", "tests", "fixtures", "schur", "cases.json")
os.makedirs(os.path.dirname(out), exist_ok=True)
with open(out, "w") as f:
    json.dump({"generator": "tools/gen_schur.py (numpy eigvals, scipy matrix_balance)", "cases": cases}, f)
print(f"wrote {len(cases)} cases to {out}")
