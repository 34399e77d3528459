"""python-control's idioms, written the python-control way and compared with python-control's values
(1e-9 relative): s = tf('s'), tf(num, den[, dt]), ss(...), conversions, mixed arithmetic, methods,
evaluation, indexing, numpy interplay."""
import pickle

import control as ct
import numpy as np
import pytest

import skyloop as sk
from skyloop import ss, tf

try:
    import slycot  # noqa: F401
    HAVE_SLYCOT = True
except ImportError:
    HAVE_SLYCOT = False
needs_slycot = pytest.mark.skipif(not HAVE_SLYCOT, reason="python-control needs slycot for this reference")

W = np.logspace(-2, 3, 60)
RT = 1e-9


def close(a, b, rtol=RT, atol=1e-12):
    np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=rtol, atol=atol)


def cresp(sys, w=W):
    """python-control's response as [ny, nu, nfreq]."""
    return np.asarray(ct.frequency_response(sys, w, squeeze=False).fresp)


def same_roots(a, b, rtol=1e-9):
    """The same root sets, compared as the monic polynomials they define (multiple roots are
    ill-conditioned themselves: a triple root moves by eps^(1/3) under rounding)."""
    a, b = np.asarray(a, complex), np.asarray(b, complex)
    assert a.shape == b.shape, (a, b)
    pa, pb = np.poly(a), np.poly(b)
    close(pa, pb, rtol=rtol, atol=rtol * np.max(np.abs(pb)))


def test_s_variable_builds_exact_rational_models():
    s = tf('s')
    cs = ct.tf('s')
    G = (s + 2) / (s**2 + 0.4 * s + 4) * 3
    cG = (cs + 2) / (cs**2 + 0.4 * cs + 4) * 3
    assert isinstance(G, sk.TransferFunction)
    close(G(1j), cG(1j))
    close(G(W * 1j), cG(W * 1j))
    close(G.freqresp(W), cresp(cG))
    same_roots(G.poles(), cG.poles())
    same_roots(G.zeros(), cG.zeros())
    assert isinstance(G.dcgain(), float)
    close(G.dcgain(), cG.dcgain())
    # improper intermediates are fine; the proper end result is realized when needed
    H = (s + 1) * (s + 3) / ((s + 2) * (s + 4) * (s + 5))
    cH = (cs + 1) * (cs + 3) / ((cs + 2) * (cs + 4) * (cs + 5))
    close(sk.freqresp(H, W), cresp(cH))
    if HAVE_SLYCOT:   # python-control's linfnorm is slycot's ab13dd
        close(sk.hinf_norm(H)[0], ct.linfnorm(cH)[0], rtol=1e-6)
    close(ss(H)(2j), cH(2j))


def test_division_power_negative_power_and_rdiv():
    s, cs = tf('s'), ct.tf('s')
    for g, cg in [(1 / (s + 1), 1 / (cs + 1)), ((s + 1) ** 2 / (s + 3) ** 3, (cs + 1) ** 2 / (cs + 3) ** 3),
                  ((s + 2) ** -1, (cs + 2) ** -1), (2 / (s**2 + s + 1) / (s + 4), 2 / (cs**2 + cs + 1) / (cs + 4)),
                  (5 - 1 / (s + 1), 5 - 1 / (cs + 1)), (-(s + 1) / (s + 2) + 1.5, -(cs + 1) / (cs + 2) + 1.5)]:
        close(g(W * 1j), cg(W * 1j))
        same_roots(g.poles(), cg.poles())


def test_tf_num_den_dt_and_discrete_z():
    G = tf([1, 2], [1, 3, 2])
    cG = ct.tf([1, 2], [1, 3, 2])
    close(G(0.5j), cG(0.5j))
    Gd = tf([0.1, 0.05], [1, -1.2, 0.4], 0.01)
    cGd = ct.tf([0.1, 0.05], [1, -1.2, 0.4], 0.01)
    close(sk.freqresp(Gd, W[:40]), cresp(cGd, W[:40]))
    z = tf('z', 0.01)
    cz = ct.tf([1, 0], [1], 0.01)   # python-control 0.10.2 has no tf('z', dt)
    assert tf('z', dt=0.01).dt == 0.01
    H = (z - 0.5) / (z**2 - 1.5 * z + 0.7)
    cH = (cz - 0.5) / (cz**2 - 1.5 * cz + 0.7)
    close(H(np.exp(0.3j)), cH(np.exp(0.3j)))
    close(H.dcgain(), cH.dcgain())
    close(sk.freqresp(ss(H), W[:40]), cresp(cH, W[:40]))
    # MIMO num/den lists of lists, python-control's layout
    num = [[[1.0], [2.0, 1.0]], [[1.0, 0.0], [3.0]]]
    den = [[[1.0, 1.0], [1.0, 2.0, 5.0]], [[1.0, 4.0], [1.0, 0.5]]]
    M, cM = tf(num, den), ct.tf(num, den)
    close(M(1j), cM(1j))
    close(M.freqresp(W), cresp(cM))
    close(sk.freqresp(ss(M), W), cresp(cM))
    close(M.dcgain(), cM.dcgain())


def test_ss_forms_and_conversions():
    A = [[0.0, 1.0], [-4.0, -0.4]]
    B = [[0.0], [1.0]]
    C = [[1.0, 0.0]]
    D = [[0.0]]
    G, cG = ss(A, B, C, D), ct.ss(A, B, C, D)
    close(G(1j), cG(1j))
    close(G(W * 1j), cG(W * 1j))
    same_roots(G.poles(), cG.poles())
    Gd = ss(A, B, C, D, 0.05)
    assert Gd.dt == 0.05
    # ss(model) and tf(model) convert, as python-control's
    close(ss(cG)(2j), cG(2j))
    close(ss(ct.tf([1, 2], [1, 3, 2]))(2j), ct.tf([1, 2], [1, 3, 2])(2j))
    T = tf(G)
    assert isinstance(T, sk.TransferFunction)
    close(T(W * 1j), cG(W * 1j))
    close(tf(ct.tf([1, 2], [1, 3, 2]))(1j), ct.tf([1, 2], [1, 3, 2])(1j))
    close(tf(ss(tf([1, 2], [1, 3, 2])))(1j), ct.tf([1, 2], [1, 3, 2])(1j))
    with pytest.raises(sk.InputError):
        ss([], [], [], [])
    with pytest.raises(sk.InputError, match="dt=True"):
        tf([1], [1, 1], True)
    with pytest.raises(sk.InputError, match="dt=True"):
        sk.from_control(ct.tf([1], [1, 0.5], True))


def test_improper_where_a_state_space_is_needed_is_a_clear_error():
    s = tf('s')
    with pytest.raises(sk.ModelError, match="improper"):
        ss(s + 1)
    with pytest.raises(sk.ModelError, match="improper"):
        sk.margins(s)
    # but frequency-domain evaluation of an improper model is exact
    close(sk.freqresp(s + 1, [2.0])[0, 0, 0], 1 + 2j)


def test_delays_ride_along_exactly():
    s = tf('s')
    P = tf("exp(-0.03*s)/(s**2+0.5*s+4)")
    assert isinstance(P, sk.StateSpace)
    close(P.input_delay, [0.03])
    L = P * (2 + 1 / s)
    expect = np.exp(-0.03j * W) / ((1j * W) ** 2 + 0.5j * W + 4) * (2 + 1 / (1j * W))
    close(sk.freqresp(L, W)[0, 0], expect)
    close(L(1j * W), expect)
    # an improper expression with a delay stays a rational object with its delay
    D = tf("(s+1)*exp(-0.01*s)")
    assert isinstance(D, sk.TransferFunction)
    close(D(2j), (1 + 2j) * np.exp(-0.02j))
    m = sk.margins(L)
    assert m["phase_margin_deg"] is not None


def test_callable_and_indexing_mimo():
    num = [[[1.0], [2.0, 1.0]], [[1.0, 0.0], [3.0]]]
    den = [[[1.0, 1.0], [1.0, 2.0, 5.0]], [[1.0, 4.0], [1.0, 0.5]]]
    M, cM = tf(num, den), ct.tf(num, den)
    close(M[0, 1](1j), cM[0, 1](1j))
    close(M[1, :](1j), cM[1, :](1j))
    close(M[:, 0](W * 1j), cM[:, 0](W * 1j))
    if not HAVE_SLYCOT:
        pytest.skip("python-control's MIMO tf -> ss needs slycot")
    S, cS = ss(M), ct.ss(cM)
    close(S[0, 1](1j), cS[0, 1](1j))
    close(S[1, :](2j), cS[1, :](2j))
    assert S(1j).shape == (2, 2)
    assert S(W * 1j).shape == (2, 2, W.size)
    # a MIMO realization is minimal, as python-control's
    same_roots(M.poles(), cM.poles())
    assert S.nstates == cS.nstates
    shared = tf(num, [[[1.0, 1.0]] * 2] * 2)
    cshared = ct.tf(num, [[[1.0, 1.0]] * 2] * 2)
    same_roots(shared.poles(), cshared.poles())
    close(ss(shared)(W * 1j), cshared(W * 1j))


def test_methods_on_models_match_control():
    s, cs = tf('s'), ct.tf('s')
    G, cG = 10 / (s * (s + 1) * (0.1 * s + 1)), 10 / (cs * (cs + 1) * (0.1 * cs + 1))
    T, cT = G.feedback(), ct.feedback(cG)
    close(T(W * 1j), cT(W * 1j))
    close(sk.feedback(G, 0.5)(1j), ct.feedback(cG, 0.5)(1j))
    close(sk.feedback(G, 1 / (s + 3), sign=1)(1j), ct.feedback(cG, 1 / (cs + 3), sign=1)(1j))
    same_roots(T.poles(), cT.poles())
    close(T.dcgain(), cT.dcgain())
    Gs, cGs = ss(G), ct.ss(cG)
    close(Gs.feedback()(W * 1j), ct.feedback(cGs)(W * 1j))
    same_roots(Gs.feedback().poles(), ct.feedback(cGs).poles())
    close(Gs.feedback().dcgain(), ct.feedback(cGs).dcgain())
    # minreal cancels exactly as python-control's
    R, cR = ((s + 1) * (s + 2) / ((s + 1) * (s + 3))).minreal(), ((cs + 1) * (cs + 2) / ((cs + 1) * (cs + 3))).minreal()
    same_roots(R.poles(), cR.poles())
    close(R(1j), cR(1j))
    # c2d
    Gd = (1 / (s + 1)).c2d(0.1)
    cGd = ct.sample_system(1 / (cs + 1), 0.1)
    close(Gd(np.exp(0.2j)), cGd(np.exp(0.2j)))
    Gd2 = ss(1 / (s**2 + s + 1)).c2d(0.1, "tustin")
    cGd2 = ct.sample_system(ct.ss(1 / (cs**2 + cs + 1)), 0.1, "tustin")
    close(Gd2(np.exp(0.2j)), cGd2(np.exp(0.2j)))
    # norms
    F, cF = 1 / (s**2 + 0.2 * s + 1), 1 / (cs**2 + 0.2 * cs + 1)
    if HAVE_SLYCOT:
        close(F.hinf_norm()[0], ct.linfnorm(cF)[0], rtol=1e-7)
    else:   # the resonance peak in closed form: 1 / (2 zeta sqrt(1 - zeta^2)), zeta = 0.1
        close(F.hinf_norm()[0], 1 / (0.2 * np.sqrt(0.99)), rtol=1e-9)
    close(F.h2_norm(), np.sqrt(1 / (4 * 0.1)), rtol=1e-8)   # 1/(s^2+2 zeta s+1): H2^2 = 1/(4 zeta)
    # freqresp shape, bode / step dicts
    assert sk.freqresp(F, W).shape == (1, 1, W.size)
    assert F.bode(W)["mag_db"].shape == (1, 1, W.size)
    r = F.step(np.linspace(0, 10, 101))
    ref = ct.step_response(cF, np.linspace(0, 10, 101))
    close(r["y"][0, 0], ref.outputs, rtol=1e-7, atol=1e-9)
    mag, phase, w = F.frequency_response(W)
    cm, cp, _ = ct.frequency_response(cF, W)
    close(mag, cm)
    close(np.unwrap(phase), np.unwrap(cp), atol=1e-9)


def test_python_control_objects_accepted_everywhere():
    cG = ct.tf([2.0], [1.0, 1.2, 4.0])
    cS = ct.ss(cG)
    for f in (sk.poles, sk.zeros, sk.dcgain, sk.hinf_norm, sk.h2_norm, sk.margins, sk.allmargin,
              sk.diskmargin, sk.hsvd, sk.minreal, sk.step, sk.bode):
        f(cG)
        f(cS)
    sk.c2d(cG, 0.1)
    sk.balred(cS, 1)
    sk.feedback(cG, cS)
    sk.lft(ct.ss([[-1.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]]), ct.tf([-1.0], [1.0]))
    P = ct.ss([[-1.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 1.0], [1.0, 0.0]])
    K, CL, gamma, rcond = sk.hinfsyn(P, 1, 1)
    assert isinstance(K, sk.StateSpace) and isinstance(CL, sk.StateSpace) and gamma > 0
    full = sk.hinfsyn(P, 1, 1, full=True)
    assert set(full) >= {"controller", "gamma", "gamma_lower", "closed_loop_norm", "closed_loop"}
    close(sk.dcgain(cG), cG.dcgain())
    same_roots(sk.poles(cS), cS.poles())
    # FrequencyResponseData where a frequency response is meant
    frd = ct.frd(cG, W)
    close(sk.freqresp(frd, W), cresp(cG))
    assert sk.bode(frd)["mag_db"].shape == (1, 1, W.size)
    with pytest.raises(sk.InputError, match="FrequencyResponseData"):
        sk.from_control(frd)


def test_mixed_arithmetic_both_orders_gives_skyloop_models():
    s, cs = tf('s'), ct.tf('s')
    G, cG = 1 / (s + 1), 1 / (cs + 1)
    cH = ct.tf([3.0], [1.0, 5.0])
    cHs = ct.ss(cH)
    ref = {"*": cG * cH, "+": cG + cH, "-": cG - cH}
    for other in (cH, cHs):
        for op, r in ref.items():
            a = eval("G" + op + "other")
            b = eval("other" + op + "G")
            rb = eval("cH" + op + "cG")
            assert isinstance(a, (sk.TransferFunction, sk.StateSpace)), (op, type(a))
            assert isinstance(b, (sk.TransferFunction, sk.StateSpace)), (op, type(b))
            close(a(W * 1j), r(W * 1j))
            close(b(W * 1j), rb(W * 1j))
    Gs = ss(G)
    for other in (cH, cHs):
        for op, r in ref.items():
            a = eval("Gs" + op + "other")
            b = eval("other" + op + "Gs")
            rb = eval("cH" + op + "cG")
            assert isinstance(a, (sk.TransferFunction, sk.StateSpace))
            assert isinstance(b, (sk.TransferFunction, sk.StateSpace))
            close(a(W * 1j), r(W * 1j))
            close(b(W * 1j), rb(W * 1j))
    # division: a skyloop model on the left takes python-control's on the right
    close((G / cH)(2j), (cG / cH)(2j))
    close((Gs / cHs)(2j), (cG / cH)(2j))
    # python-control's StateSpace divided by a skyloop model goes through our reflected product
    q = cHs / Gs
    assert isinstance(q, (sk.TransferFunction, sk.StateSpace))
    close(q(2j), (cH / cG)(2j))


def test_numpy_arrays_combine_as_series_connections():
    s = tf('s')
    G = ss([[-1.0, 0.0], [0.0, -2.0]], np.eye(2), np.eye(2), np.zeros((2, 2)))
    left = np.eye(2) * G
    assert isinstance(left, sk.StateSpace)
    right = G * (2 * np.eye(2))
    assert isinstance(right, sk.StateSpace)
    close(right(1j), 2 * G(1j))
    M = np.array([[1.0, 2.0], [0.0, 1.0]])
    close((M * G)(1j), M @ G(1j))
    close((G * M)(1j), G(1j) @ M)
    T = 1 / (s + 1)
    r = np.float64(2.0) * T
    assert isinstance(r, sk.TransferFunction)
    out = np.array([[1.0]]) * T
    assert isinstance(out, sk.TransferFunction)
    assert sk.StateSpace.__array_priority__ > ct.StateSpace.__array_priority__


def test_expression_strings_take_python_power():
    a = tf("1/(s**2+1)")
    b = tf("1/(s^2+1)")
    close(a(0.5j), b(0.5j))
    close(a(0.5j), 1 / (1 - 0.25))


def test_models_pickle():
    s = tf('s')
    G = (s + 1) / (s**2 + 2 * s + 5)
    H = pickle.loads(pickle.dumps(G))
    close(H(1j), G(1j))


def test_balred_and_empty_ss_errors():
    G = ss(tf([1], [1, 3, 2]))
    with pytest.raises(sk.InputError, match="order"):
        sk.balred(G, -1)
    with pytest.raises(sk.InputError):
        ss([], [], [], [])


def test_help_signatures():
    import inspect

    assert "sign: float = -1" in str(inspect.signature(sk.feedback)).replace("'float'", "float")
    assert "keep_feedforward" in str(inspect.signature(sk.tune))


def test_python_control_function_names():
    s, cs = tf('s'), ct.tf('s')
    L, cL = 4 / (s * (s + 1) * (0.1 * s + 1)), 4 / (cs * (cs + 1) * (0.1 * cs + 1))
    close(sk.margin(L), ct.margin(cL), rtol=1e-9)
    T = np.linspace(0, 5, 51)
    t, y = sk.step_response(1 / (s + 1), T)
    r = ct.step_response(1 / (cs + 1), T)
    close(t, r.time)
    close(y, r.outputs, rtol=1e-9, atol=1e-12)
    mag, phase, w = sk.frequency_response(L, W)
    cm, cp, _ = ct.frequency_response(cL, W)
    close(mag, cm)
    close(np.exp(1j * phase), np.exp(1j * np.asarray(cp)))
    close(sk.series(1 / (s + 1), 2 / (s + 3))(1j), ct.series(1 / (cs + 1), 2 / (cs + 3))(1j))
    close(sk.parallel(1 / (s + 1), 2 / (s + 3))(1j), ct.parallel(1 / (cs + 1), 2 / (cs + 3))(1j))
    close(sk.ss2tf(ss(1 / (s + 1)))(1j), (1 / (cs + 1))(1j))
    close(sk.tf2ss([1], [1, 1])(1j), (1 / (cs + 1))(1j))
    close(sk.sample_system(1 / (s + 1), 0.1)(np.exp(0.3j)), ct.sample_system(1 / (cs + 1), 0.1)(np.exp(0.3j)))
