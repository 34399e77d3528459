"""Badly scaled models: python-control's mixsyn closed loops (||A|| up to 2e12, a pole near -1e10
next to one near -1e-3), stored with python-control's values in fixtures/mixsyn_closed_loops.json
(written by fixtures/make_mixsyn_closed_loops.py with control + slycot). Before, hinf_norm returned
(inf, nan) on stable ones and minreal dropped every state (changing the gain from 1.02 to 0.67)."""
import json
import os

import numpy as np
import pytest

import skyloop as sk
from skyloop import _model, _skyloop

with open(os.path.join(os.path.dirname(__file__), "fixtures", "mixsyn_closed_loops.json"), encoding="utf-8") as f:
    CASES = json.load(f)["cases"]


def model(c):
    return sk.ss(c["A"], c["B"], c["C"], c["D"])


def test_the_fixture_is_badly_scaled():
    norms = [np.linalg.norm(np.asarray(c["A"])) for c in CASES]
    assert min(norms) > 1e9 and max(norms) > 1e12


@pytest.mark.parametrize("i", range(len(CASES)))
def test_hinf_norm_is_finite_and_matches_control(i):
    c = CASES[i]
    n, w = sk.hinf_norm(model(c))
    assert np.isfinite(n) and np.isfinite(w)
    # The realizations are ill-conditioned (python-control's own frequency responses of them carry
    # 1e-4 relative errors): python-control's L-infinity norm within 1e-3.
    assert n == pytest.approx(c["linfnorm"], rel=1e-3)
    # and no less than the synthesis' gamma says the closed loop can be (mixsyn: ||CL|| <= gamma)
    assert n <= c["gamma"] * (1 + 1e-3)


@pytest.mark.parametrize("i", range(len(CASES)))
def test_minreal_never_changes_the_response(i):
    c = CASES[i]
    g = model(c)
    m = sk.minreal(g)
    assert m.nstates > 0
    np.testing.assert_allclose(np.ravel(sk.dcgain(m)), c["dcgain"], rtol=1e-2, atol=1e-4)
    w = np.logspace(-3, 3, 200)
    ref = _model._ss_eval(sk.balance(g), 1j * w)
    got = _model._ss_eval(m, 1j * w)
    assert np.max(np.abs(got - ref)) <= 1e-2 * np.max(np.abs(ref))


def test_unbalanced_rust_answers_were_wrong_here():
    """The regression this guards: the raw library calls on these realizations."""
    bad = sum(1 for c in CASES if not np.isfinite(_skyloop.hinf_norm(model(c))[0]))
    dropped = sum(1 for c in CASES if _skyloop.minreal(model(c)).nstates == 0)
    assert bad >= 3 and dropped >= 20


def test_dcgain_matches_control():
    for c in CASES:
        np.testing.assert_allclose(np.ravel(sk.dcgain(model(c))), c["dcgain"], rtol=1e-2, atol=1e-4)
