"""Models and classical analysis against python-control on seeded random models."""
import pickle

import control
import numpy as np
import pytest
import scipy.linalg

import skyloop as sk
from conftest import random_ss

try:
    import slycot  # noqa: F401
    HAVE_SLYCOT = True
except ImportError:
    HAVE_SLYCOT = False
needs_slycot = pytest.mark.skipif(not HAVE_SLYCOT, reason="python-control needs slycot for this reference")


def twins(rng, n, ny, nu, dt=0.0, strictly_proper=False):
    a, b, c, d = random_ss(rng, n, ny, nu, dt, strictly_proper)
    return sk.ss(a, b, c, d, dt=dt), control.ss(a, b, c, d, dt)


def cfresp(sysc, w):
    """python-control's response as [ny, nu, nfreq] (skyloop's freqresp shape too)."""
    r = control.frequency_response(sysc, w, squeeze=False)
    return np.asarray(r.fresp)


def test_ss_properties_round_trip(rng):
    a, b, c, d = random_ss(rng, 4, 2, 3)
    s = sk.ss(a, b, c, d)
    for name, m in zip("ABCD", (a, b, c, d)):
        np.testing.assert_array_equal(getattr(s, name), m)
    assert s.dt == 0.0 and (s.nstates, s.noutputs, s.ninputs) == (4, 2, 3)
    np.testing.assert_array_equal(s.input_delay, np.zeros(3))
    sd = sk.ss(a, b, c, d, dt=0.01, input_delay=[0.02, 0, 0.03])
    assert sd.dt == 0.01
    np.testing.assert_array_equal(sd.input_delay, [0.02, 0, 0.03])
    g = sk.ss([], [], [], [[2.0]])
    assert g.nstates == 0 and g.D[0, 0] == 2.0


def test_tf_expression_with_delay_is_exact():
    g = sk.tf("0.0887*exp(-0.032*s)/(0.0256*s+1)")
    assert g.nstates == 1 and abs(g.input_delay[0] - 0.032) < 1e-15
    w = np.logspace(-1, 3, 50)
    h = sk.freqresp(g, w)[0, 0, :]
    ref = 0.0887 * np.exp(-0.032j * w) / (0.0256j * w + 1)
    np.testing.assert_allclose(h, ref, rtol=1e-12)


@pytest.mark.parametrize("dt", [0.0, 0.01])
def test_freqresp_matches_control(rng, dt):
    for _ in range(6):
        n, ny, nu = rng.integers(1, 15), rng.integers(1, 4), rng.integers(1, 4)
        s, sc = twins(rng, n, ny, nu, dt)
        w = np.logspace(-2, np.log10(np.pi / dt) - 0.01 if dt else 3, 300)
        g = sk.freqresp(s, w)
        assert g.shape == (ny, nu, 300) and g.dtype == np.complex128
        np.testing.assert_allclose(g, cfresp(sc, w), rtol=1e-9, atol=1e-11)


def test_bode_matches_freqresp(rng):
    s, sc = twins(rng, 5, 2, 1)
    w = np.logspace(-1, 2, 40)
    b = sk.bode(s, w)
    g = sk.freqresp(s, w)
    np.testing.assert_allclose(b["w_rad_s"], w)
    np.testing.assert_allclose(b["freq_hz"], w / (2 * np.pi))
    np.testing.assert_allclose(b["mag_db"], 20 * np.log10(np.abs(g)), rtol=1e-10)
    ph = np.unwrap(np.angle(g), axis=-1)
    # Unwrapped phase: equal to numpy's up to a whole number of turns.
    k = (np.deg2rad(b["phase_deg"]) - ph) / (2 * np.pi)
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)


def test_operators_match_control(rng):
    s1, c1 = twins(rng, 3, 1, 1)
    s2, c2 = twins(rng, 4, 1, 1)
    w = np.logspace(-1, 2, 60)
    for sky, ref in [(s1 * s2, c1 * c2), (s1 + s2, c1 + c2), (s1 - s2, c1 - c2), (2.5 * s1, 2.5 * c1),
                     (s1 * 3.0, c1 * 3.0), (-s1, -c1), (1 - s1, 1 - c1),
                     (sk.feedback(s1, s2), control.feedback(c1, c2)),
                     (sk.feedback(s1, s2, sign=1), control.feedback(c1, c2, sign=1)),
                     (sk.feedback(s1), control.feedback(c1, 1))]:
        np.testing.assert_allclose(sk.freqresp(sky, w), cfresp(ref, w), rtol=1e-9, atol=1e-12)
    # MIMO series follows the matrix product: (2x3)·(3x1).
    a, ca = twins(rng, 2, 2, 3)
    b, cb = twins(rng, 3, 3, 1)
    np.testing.assert_allclose(sk.freqresp(a * b, w), cfresp(ca * cb, w), rtol=1e-9, atol=1e-12)


def test_control_conversion_and_pickle(rng):
    s, sc = twins(rng, 5, 2, 2, dt=0.05)
    back = sk.from_control(sc)
    np.testing.assert_array_equal(back.A, s.A)
    assert back.dt == 0.05
    tc = s.to_control()
    assert isinstance(tc, control.StateSpace) and tc.dt == 0.05
    np.testing.assert_array_equal(tc.B, s.B)
    h = sk.from_control(control.tf([1, 2], [1, 3, 2]))
    np.testing.assert_allclose(sk.dcgain(h), [[1.0]])
    d = sk.tf("exp(-0.1*s)/(s+1)")
    with pytest.raises(sk.InputError, match="pade"):
        d.to_control()
    assert d.to_control(pade=3).nstates == 4
    p = pickle.loads(pickle.dumps(d))
    np.testing.assert_array_equal(p.A, d.A)
    np.testing.assert_array_equal(p.input_delay, d.input_delay)


def loop(rng):
    """A type-1 third-order loop k/(s(s+a)(s+b)) with both margins finite and a stable closed loop."""
    a, b = rng.uniform(0.5, 5, 2)
    k = a * b * (a + b) * rng.uniform(0.1, 0.6)
    sys = control.tf([k], np.polymul([1, 0], np.polymul([1, a], [1, b])))
    return sk.from_control(sys), sys


def test_margins_match_control(rng):
    for _ in range(8):
        s, sc = loop(rng)
        gm, pm, _sm, wpc, wgc, _wms = control.stability_margins(sc)
        m = sk.margins(s)
        assert m["closed_loop_stable"] is True
        np.testing.assert_allclose(m["gain_margin_db"], 20 * np.log10(gm), rtol=1e-6)
        np.testing.assert_allclose(m["phase_margin_deg"], pm, rtol=1e-6)
        np.testing.assert_allclose(m["gain_margin_freq_hz"] * 2 * np.pi, wpc, rtol=1e-6)
        np.testing.assert_allclose(m["phase_margin_freq_hz"] * 2 * np.pi, wgc, rtol=1e-6)
        np.testing.assert_allclose(m["delay_margin_s"], np.deg2rad(pm) / wgc, rtol=1e-6)
        am = sk.allmargin(s)
        assert len(am["gain_margins"]) == 1 and len(am["phase_margins"]) == 1 and am["stable"]
        dm = sk.diskmargin(s)
        assert 0 < dm["alpha"] < 2 and dm["gain_db"][0] < 0 < dm["gain_db"][1]
        assert dm["phase_deg"] <= pm + 1e-9


def test_margins_with_exact_delay():
    # The delay margin of L is the delay that, added to the loop, lowers the phase margin to zero.
    m0 = sk.margins(sk.tf("4/(s*(s+2))"))
    m1 = sk.margins(sk.tf(f"4*exp(-{0.5 * m0['delay_margin_s']}*s)/(s*(s+2))"))
    np.testing.assert_allclose(m1["delay_margin_s"], 0.5 * m0["delay_margin_s"], rtol=1e-6)
    assert m1["phase_margin_deg"] < m0["phase_margin_deg"]


def skyloop_cli():
    """The skyloop binary: $SKYLOOP_CLI, else one cargo built in the repository (.ci/run's cargo test
    builds target/debug/skyloop before the Python stage), else one on PATH."""
    import os
    import shutil

    from conftest import ROOT

    cands = [os.environ.get("SKYLOOP_CLI", "")] + [os.path.join(ROOT, "target", p, "skyloop")
                                                   for p in ("release", "debug")]
    for c in cands:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    return shutil.which("skyloop")


def same_json(a, b, where, rtol=1e-7):
    """Equal keys, lengths, types, booleans and nulls; floats to rtol. Not bit for bit: the CLI found
    is usually a debug/test-profile build and the package a release build, and the two differ in
    the last bits (the disk margin's frequency, where an optimizer stops, by ~1e-9)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and sorted(a) == sorted(b), (where, sorted(a), b)
        for k in a:
            same_json(a[k], b[k], f"{where}.{k}", rtol)
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), (where, a, b)
        for i, (x, y) in enumerate(zip(a, b)):
            same_json(x, y, f"{where}[{i}]", rtol)
    elif isinstance(a, float) and isinstance(b, (int, float)) and not isinstance(b, bool):
        assert abs(a - b) <= rtol * max(abs(a), abs(b)) + 1e-300, (where, a, b)
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


@pytest.mark.skipif(skyloop_cli() is None, reason="no skyloop binary built (cargo build -p skyloop-cli)")
def test_margins_dict_is_the_cli_json(tmp_path):
    # One library function (skyloop::json_out) builds both; delayed loops: several phase
    # crossovers, an unstable closed loop, no gain crossover (null margins where infinite).
    import json
    import subprocess

    loops = ["4*exp(-0.1*s)/(s*(s+2))",
             "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2-s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)"
             " * 24.02*(s+54.01)*(s+0.2474)*(s^2+139.3*s+2.624e4) / (s*(s^2+24.14*s+8544)*(s^2+232.4*s+7.041e4))",
             "30*exp(-0.2*s)/((s+1)*(0.1*s+1))",
             "0.5*exp(-0.05*s)/(s+1)"]
    for expr in loops:
        path = tmp_path / "l.json"
        path.write_text(sk.tf(expr).to_json())
        out = subprocess.run([skyloop_cli(), "margins", str(path), "--json"], capture_output=True, text=True,
                             check=True).stdout
        cli = json.loads(out)
        same_json(sk.margins(sk.tf(str(path))), cli, expr)
        same_json(sk.margins(sk.tf(expr)), cli, expr)


@needs_slycot
def test_hinf_norm_matches_ab13dd(rng):
    for dt in (0.0, 0.02):
        for _ in range(5):
            s, sc = twins(rng, rng.integers(2, 20), rng.integers(1, 4), rng.integers(1, 4), dt)
            ref = control.norm(sc, "inf", tol=1e-10)
            np.testing.assert_allclose(sk.hinf_norm(s)[0], ref, rtol=1e-6)


def test_hinf_norm_bounds_a_dense_grid(rng):
    for _ in range(5):
        s, _ = twins(rng, rng.integers(2, 12), 2, 2)
        nrm, wpk = sk.hinf_norm(s)
        w = np.concatenate([np.logspace(-3, 4, 4000), [wpk] if np.isfinite(wpk) else []])
        sv = np.linalg.svd(np.moveaxis(sk.freqresp(s, w), -1, 0), compute_uv=False)[:, 0]
        assert sv.max() <= nrm * (1 + 1e-9)
        if np.isfinite(wpk):
            np.testing.assert_allclose(sv[-1], nrm, rtol=1e-6)  # attained at the reported peak
        else:  # the peak is at infinite frequency: the norm of D
            np.testing.assert_allclose(np.linalg.norm(s.D, 2), nrm, rtol=1e-9)
    assert sk.hinf_norm(sk.tf("1/(s-1)"))[0] == np.inf


def test_h2_norm_matches_control(rng):
    for dt in (0.0, 0.05):
        for _ in range(5):
            s, sc = twins(rng, rng.integers(2, 15), rng.integers(1, 3), rng.integers(1, 3), dt,
                          strictly_proper=(dt == 0))
            np.testing.assert_allclose(sk.h2_norm(s), control.norm(sc, 2), rtol=1e-8)
    assert sk.h2_norm(sk.tf("1/(s+1)")) == pytest.approx(np.sqrt(0.5), rel=1e-12)


def test_poles_zeros(rng):
    s, sc = twins(rng, 9, 2, 2)
    np.testing.assert_allclose(np.sort_complex(sk.poles(s)), np.sort_complex(control.poles(sc)), rtol=1e-9)
    z = sk.zeros(sk.tf("(s+2)*(s^2+s+4)/((s+1)*(s+3)*(s+5)*(s+7))"))
    np.testing.assert_allclose(np.sort_complex(z), np.sort_complex(np.roots([1, 3, 6, 8])), rtol=1e-9)


@pytest.mark.parametrize("method", ["zoh", "tustin", "foh"])
def test_c2d_matches_control(rng, method):
    for _ in range(4):
        s, sc = twins(rng, rng.integers(1, 10), 2, 2)
        dt = rng.uniform(0.01, 0.2)
        sd = sk.c2d(s, dt, method)
        ref = control.sample_system(sc, dt, method="bilinear" if method == "tustin" else method)
        assert sd.dt == dt
        w = np.logspace(-2, np.log10(np.pi / dt) - 0.01, 100)
        np.testing.assert_allclose(sk.freqresp(sd, w), cfresp(ref, w), rtol=1e-8, atol=1e-10)


def test_c2d_tustin_prewarp_matches_at_the_frequency():
    s = sk.tf("100/(s^2+2*s+100)")
    sd = sk.c2d(s, 0.05, "tustin", prewarp=10.0)
    np.testing.assert_allclose(sk.freqresp(sd, [10.0]), sk.freqresp(s, [10.0]), rtol=1e-10)


@needs_slycot
def test_balred_matches_control(rng):
    for _ in range(4):
        s, sc = twins(rng, 14, 2, 2)
        r = sk.balred(s, 5)
        ref = control.balred(sc, 5, method="truncate")
        assert r.nstates == 5
        w = np.logspace(-2, 3, 200)
        np.testing.assert_allclose(sk.freqresp(r, w), cfresp(ref, w), rtol=1e-6, atol=1e-9)
        # Hankel singular values from the gramians (scipy), the definition.
        P_ = scipy.linalg.solve_continuous_lyapunov(s.A, -s.B @ s.B.T)
        Q_ = scipy.linalg.solve_continuous_lyapunov(s.A.T, -s.C.T @ s.C)
        ref_hsv = np.sort(np.sqrt(np.abs(np.linalg.eigvals(P_ @ Q_))))[::-1]
        big = ref_hsv > 1e-4 * ref_hsv[0]  # eig(PQ) loses the small ones
        np.testing.assert_allclose(sk.hsvd(s)[big], ref_hsv[big], rtol=1e-5)
        rm = sk.balred(s, 5, "matchdc")
        refm = control.balred(sc, 5, method="matchdc")
        np.testing.assert_allclose(sk.dcgain(rm), sk.dcgain(s), rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(sk.freqresp(rm, w), cfresp(refm, w), rtol=1e-5, atol=1e-8)


def test_balred_error_bound(rng):
    for _ in range(4):
        s, _ = twins(rng, 16, 2, 2)
        k = int(rng.integers(2, 10))
        hsv = sk.hsvd(s)
        err = sk.hinf_norm(s - sk.balred(s, k))[0]
        assert hsv[k] <= err * (1 + 1e-6) and err <= 2 * hsv[k:].sum() * (1 + 1e-6)


def test_minreal_removes_cancelled_modes():
    g = sk.tf("(s+1)/((s+1)*(s+2))")
    m = sk.minreal(g)
    assert m.nstates == 1
    w = np.logspace(-1, 2, 20)
    np.testing.assert_allclose(sk.freqresp(m, w), sk.freqresp(sk.tf("1/(s+2)"), w), rtol=1e-9)


def test_step_matches_control(rng):
    s, sc = twins(rng, 6, 2, 1)
    t = np.linspace(0, 5, 501)
    r = sk.step(s, t)
    ref = control.step_response(sc, t, squeeze=False)
    np.testing.assert_allclose(r["t_s"], t)
    assert r["y"].shape == (2, 1, 501)
    np.testing.assert_allclose(r["y"], np.asarray(ref.outputs), rtol=1e-7, atol=1e-9)
    # A delay shifts the response exactly.
    y = sk.step(sk.tf("exp(-0.5*s)/(s+1)"), t)["y"][0, 0]
    np.testing.assert_allclose(y, np.where(t >= 0.5, 1 - np.exp(-(t - 0.5)), 0.0), atol=1e-9)
