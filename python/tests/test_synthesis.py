"""Synthesis and mu against python-control + slycot, and against the committed SLICOT reference
fixtures of the Rust tests (crates/skyloop-robust/tests/fixtures), which need no slycot."""
import json

import control
import numpy as np
import pytest

import skyloop as sk
from conftest import fixture_path

try:
    import slycot  # noqa: F401
    HAVE_SLYCOT = True
except ImportError:
    HAVE_SLYCOT = False


def load(name):
    with open(fixture_path("crates", "skyloop-robust", "tests", "fixtures", *name.split("/"))) as f:
        return json.load(f)


def plant(j):
    return sk._skyloop._from_json(json.dumps(j))


def test_hinfsyn_gamma_matches_committed_slicot_values():
    cases = load("hinf/hinfsyn_random.json")["cases"]
    assert len(cases) >= 8
    for c in cases:
        P = plant(c["plant"])
        K, _CL, gamma, _rcond = sk.hinfsyn(P, c["nmeas"], c["ncon"])
        g_ref = c["gamma_slicot"]
        # Never worse than SLICOT by more than 1 % (being a little better than sb10ad is allowed).
        assert (gamma - g_ref) / g_ref < 1e-2, (c["name"], gamma, g_ref)
        assert gamma > g_ref * (1 - 5e-2), (c["name"], gamma, g_ref)
        assert K.noutputs == c["ncon"] and K.ninputs == c["nmeas"]
        full = sk.hinfsyn(P, c["nmeas"], c["ncon"], full=True)
        assert full["closed_loop_norm"] <= full["gamma"] * (1 + 1e-3)
        assert np.all(sk.poles(full["closed_loop"]).real < 0)


@pytest.mark.skipif(not HAVE_SLYCOT, reason="python-control's hinfsyn needs slycot")
def test_hinfsyn_gamma_matches_control_on_random_plants():
    rng = np.random.default_rng(7)
    for _ in range(4):
        n, nw, nz = int(rng.integers(3, 7)), 2, 2
        a = rng.standard_normal((n, n))
        a -= (np.linalg.eigvals(a).real.max() + 0.5) * np.eye(n)
        b1, b2 = rng.standard_normal((n, nw)), rng.standard_normal((n, 1))
        c1, c2 = rng.standard_normal((nz, n)), rng.standard_normal((1, n))
        B = np.hstack([b1, b2])
        C = np.vstack([c1, c2])
        D = np.zeros((nz + 1, nw + 1))
        D[nz - 1, nw] = 1.0   # D12 = [0; 1]
        D[nz, nw - 1] = 1.0   # D21 = [0 1]
        Pc = control.ss(a, B, C, D)
        _K, _cl, g_ref, _rcond = control.hinfsyn(Pc, 1, 1)
        P = sk.from_control(Pc)
        K, _CL, gamma, _rcond = sk.hinfsyn(P, 1, 1)
        assert (gamma - g_ref) / g_ref < 1e-2 and gamma > g_ref * 0.95, (gamma, g_ref)
        cl = sk.lft(P, K)
        assert np.all(sk.poles(cl).real < 0)
        assert sk.hinf_norm(cl)[0] <= gamma * (1 + 1e-3)


def test_ncfsyn_gamma_min_matches_committed_reference():
    for c in load("hinf/ncfsyn_gamma_min.json")["cases"]:
        r = sk.ncfsyn(plant(c["shaped_plant"]))
        assert abs(r["gamma_min"] - c["gamma_min"]) / c["gamma_min"] < 1e-6, c["name"]
        assert r["gamma_min"] * (1 - 1e-6) <= r["gamma"] <= 1.1 * r["gamma_min"] * (1 + 1e-6)


def test_ncfsyn_bicopter_paper():
    P = sk.tf("0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s * 2.221e5/(s^2 + 666.4*s + 2.221e5)")
    W1 = sk.tf("0.03511*(s+0.3419)/s")
    W2 = sk.tf("307.5*(s+3.816)/((s+11.35)*(s+103.4))")
    r = sk.ncfsyn(P, W1, W2, factor=1.1)
    assert abs(r["gamma_min"] - 1.748) < 5e-4
    C = r["controller"]
    # The loop with the exact delay is stable with a positive phase margin.
    m = sk.margins(P * C)
    assert m["closed_loop_stable"] and m["phase_margin_deg"] > 20


@pytest.mark.skipif(not HAVE_SLYCOT, reason="python-control's mixsyn needs slycot")
def test_mixsyn_matches_control():
    G = control.tf([200], [10, 1]) * control.tf([1], [0.05, 1]) ** 2
    W1 = control.tf([1 / 2, 1], [1, 1e-2])
    W2 = control.tf([0.1], [1])
    _K, _cl, (g_ref, _rc) = control.mixsyn(G, W1, W2)
    K, CL, gamma = sk.mixsyn(sk.from_control(G), sk.from_control(W1), sk.from_control(W2))
    assert abs(gamma - g_ref) / g_ref < 1e-2
    assert sk.hinf_norm(CL)[0] <= gamma * (1 + 1e-3)


def test_mu_bounds_against_reference_cases():
    cases = load("mu/mu_cases.json")["cases"]
    checked = 0
    for c in cases:
        if c["kind"] not in ("full", "rank_one", "exact"):
            continue
        m = np.array([[complex(*z) for z in row] for row in c["m"]])
        r = sk.mu(m, c["blocks"])
        ref = c["mu"]
        assert r["lower"] <= ref * (1 + 1e-6) and r["upper"] >= ref * (1 - 1e-6), c["name"]
        assert r["upper"] <= ref * (1 + 1e-3), (c["name"], r["upper"], ref)
        checked += 1
    assert checked >= 6


def test_mu_of_a_system_full_block_is_the_largest_singular_value(rng):
    a = -np.eye(3) * 2 + 0.3 * rng.standard_normal((3, 3))
    S = sk.ss(a, rng.standard_normal((3, 2)), rng.standard_normal((2, 3)), rng.standard_normal((2, 2)))
    w = np.logspace(-1, 2, 25)
    r = sk.mu(S, "f2x2", w)
    sv = np.linalg.svd(np.moveaxis(sk.freqresp(S, w), -1, 0), compute_uv=False)[:, 0]
    np.testing.assert_allclose(r["upper"], sv, rtol=1e-5)
    np.testing.assert_allclose(r["lower"], sv, rtol=1e-5)
    np.testing.assert_allclose(r["freq_hz"], w / (2 * np.pi))
    assert r["peak"]["upper"] >= sv.max() * (1 - 1e-6)
    np.testing.assert_allclose(r["peak"]["margin_lower"], 1 / r["peak"]["upper"])


def test_musyn_distillation_first_iteration_matches_reference():
    # The spec of examples/musyn-distillation.toml with 2 iterations (S&P 8.12.4: mu = 1.1798 first).
    d = sk.musyn_spec(fixture_path("examples", "musyn-distillation.toml"))
    it = d["iterations"]
    assert len(it) >= 2
    ref = load("musyn/distillation.json")["cases"][0]["gamma_unscaled"]
    assert abs(it[0]["gamma"] - ref) / ref < 1e-2
    assert d["mu_peak"] <= it[0]["mu_peak"] + 1e-9
    assert d["mu_peak"] < 1.1
    K = d["controller"]
    assert K.ninputs == 2 and K.noutputs == 2
