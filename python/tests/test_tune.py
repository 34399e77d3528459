"""tune and hinfstruct. The tuned loop's claimed margins are recomputed without skyloop's analysis:
on a dense grid with numpy (python-control evaluates the rational parts, the delay is exact) and
with python-control's stability_margins on a Pade approximant of the delay. hinfstruct's gamma is
checked against hinfsyn's bounds and the committed SLICOT values, and recomputed from a closed loop
built in numpy."""
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

W = np.logspace(-2, 4, 60_001)  # rad/s; 1e4 points a decade: interpolation errors ~ 1e-7 relative


def exact_loop(num, den, delay_s, C):
    """L(jW) = C(jW) * num/den(jW) * exp(-jW delay), C a skyloop controller via python-control."""
    Cc = C.to_control()
    Pr = control.tf(num, den)
    return np.asarray(Cc(1j * W)).ravel() * np.asarray(Pr(1j * W)).ravel() * np.exp(-1j * W * delay_s)


def crossings(f):
    """Grid indices k with a sign change of f between W[k] and W[k+1], and the interpolation weights."""
    k = np.nonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0)[0]
    return k, f[k] / (f[k] - f[k + 1])


def grid_margins(L):
    """Phase margin (deg) and crossover (Hz) at the first gain crossover, Ms, Mt, disk alpha (sigma = 0)."""
    mag = np.abs(L)
    ph = np.degrees(np.unwrap(np.angle(L)))
    k, t = crossings(mag - 1.0)
    assert len(k) >= 1
    wc = np.exp(np.log(W[k[0]]) + t[0] * (np.log(W[k[0] + 1]) - np.log(W[k[0]])))
    phc = ph[k[0]] + t[0] * (ph[k[0] + 1] - ph[k[0]])
    pm = (phc + 180.0) % 360.0
    if pm > 180:
        pm -= 360
    S = 1.0 / (1.0 + L)
    T = L / (1.0 + L)
    # Symmetric disk margin (Seiler, Packard & Gahinet 2020): alpha = 1 / max |S - T| / 2.
    alpha = 2.0 / np.max(np.abs(S - T))
    return {"phase_margin_deg": pm, "crossover_hz": wc / (2 * np.pi), "ms": np.max(np.abs(S)),
            "mt": np.max(np.abs(T)), "disk_alpha": alpha}


def check_claims(r, num, den, delay_s):
    m = r["margins"]
    L = exact_loop(num, den, delay_s, r["feedback_controller"])
    g = grid_margins(L)
    assert m["stable"] is True
    assert abs(g["phase_margin_deg"] - m["phase_margin_deg"]) < 1e-3, (g, m)
    assert abs(g["crossover_hz"] / m["crossover_hz"] - 1) < 1e-4, (g, m)
    for k in ("ms", "mt", "disk_alpha"):
        assert abs(g[k] / m[k] - 1) < 1e-4, (k, g[k], m[k])
    # python-control's own margins and closed-loop poles, the delay as a 6th-order Pade approximant.
    Lp = control.series(r["feedback_controller"].to_control(), control.tf(num, den),
                        control.tf(*control.pade(delay_s, 6)))
    gm, pm, _sm, _wpc, wgc, _wms = control.stability_margins(Lp)
    assert abs(pm - m["phase_margin_deg"]) < 0.05, (pm, m)
    assert abs(wgc / (2 * np.pi) / m["crossover_hz"] - 1) < 1e-3
    if m["gain_margin_db"] is not None and np.isfinite(gm):
        assert abs(20 * np.log10(gm) - m["gain_margin_db"]) < 0.05, (gm, m)
    assert np.all(control.poles(control.feedback(Lp, 1)).real < 0)
    # The dict is the library's own margins of loop_plant * C_fb as well.
    own = sk.margins(r["loop_plant"] * r["feedback_controller"])
    assert abs(own["phase_margin_deg"] - m["phase_margin_deg"]) < 1e-6 * max(1.0, abs(m["phase_margin_deg"]))
    return g


CLI_TUNE_KEYS = {"gains", "feedback_controller", "discrete_controller", "margins", "goals", "cli", "defaults",
                 "notes", "feedforward", "setpoint_weights", "loop"}


def test_generic_pid_claims_hold_independently():
    # The plant of the CLI's tune test (crates/skyloop-cli/tests/tune.rs): 200/(s (0.05 s + 1)), 20 ms delay.
    r = sk.tune("exp(-0.02*s)*200/(s*(0.05*s+1))", "generic", goals=["ms<=1.5", "phase_margin_deg>=45"],
                starts=4)
    assert set(r) == CLI_TUNE_KEYS | {"loop_plant"}
    assert set(r["margins"]) == {"disk_alpha", "gain_margin_db", "phase_margin_deg", "crossover_hz", "ms", "mt",
                                 "stable"}
    assert r["discrete_controller"] is None and r["cli"] == []
    kp, ki, kd, tf = (r["gains"][k] for k in ("kp", "ki", "kd", "tf"))
    assert ki > 0 and tf > 0
    # C_fb is the PID the gains say: kp + ki/s + kd s/(tf s + 1).
    C = r["feedback_controller"]
    s = 1j * W[::300]
    want = kp + ki / s + kd * s / (tf * s + 1)
    assert np.allclose(sk.freqresp(C, W[::300])[0, 0, :], want, rtol=1e-9)
    assert r["loop_plant"].input_delay[0] == pytest.approx(0.02, abs=1e-15)
    g = check_claims(r, [200], [0.05, 1, 0], 0.02)
    assert g["ms"] <= 1.5 * (1 + 1e-4) and g["phase_margin_deg"] >= 45 - 1e-3
    labels = [x["goal"] for x in r["goals"]]
    assert labels[:2] == ["ms<=1.5", "phase_margin_deg>=45"]
    assert all(x["met"] for x in r["goals"])
    assert any("default" in x for x in labels)


def test_betaflight_gains_with_the_hold_delay(tmp_path):
    # The CLI test's Betaflight roll plant (PID sum -> deg/s); the 4 kHz loop adds a 125 us hold.
    r = sk.tune("exp(-0.003*s)*400/(s*(0.025*s+1))", "betaflight", goals=["disk_margin>=0.6"], starts=4,
                out=tmp_path / "bf")
    assert set(r) == CLI_TUNE_KEYS | {"loop_plant"}
    for k in ("p", "i", "d", "f"):
        assert isinstance(r["gains"][k], int), (k, r["gains"])
    assert r["cli"][0] == f"set p_roll = {r['gains']['p']}"
    assert (tmp_path / "bf" / "cli.txt").read_text().startswith(r["cli"][0])
    assert json.loads((tmp_path / "bf" / "tune.json").read_text())["gains"] == r["gains"]
    assert r["discrete_controller"].dt > 0
    hold = r["loop_plant"].input_delay[0]
    assert hold == pytest.approx(0.003125, abs=1e-12)
    g = check_claims(r, [400], [0.025, 1, 0], hold)
    assert g["disk_alpha"] >= 0.6 * (1 - 1e-4)
    # F is fitted to the loop (Betaflight's FTERM_SCALE/100 per unit), or kept at the default.
    assert r["gains"]["f"] == round(r["feedforward"]["gain"] / (0.013754 / 100))
    kept = sk.tune("exp(-0.003*s)*400/(s*(0.025*s+1))", "betaflight", goals=["disk_margin>=0.6"], starts=2,
                   keep_feedforward=True)
    assert kept["gains"]["f"] == 120 and kept["feedforward"] is None


def test_pid2_and_ardupilot():
    r = sk.tune("exp(-0.1*s)/(s+1)^2", "generic", goals=["ms<=1.6"], structure="pid2", starts=2)
    w = r["setpoint_weights"]
    assert 0 <= r["gains"]["b"] <= 1 and 0 <= r["gains"]["c"] <= 1 and w["b"] == r["gains"]["b"]
    a = sk.tune("exp(-0.004*s)*60/(s*(0.03*s+1))", "ardupilot", maximize="crossover", starts=2)
    assert a["cli"][0].startswith("param set ATC_RAT_RLL_P ")
    corner = [x for x in a["goals"] if x["goal"].startswith("integral_corner")]
    assert len(corner) == 2 and all(x["met"] for x in corner)
    g = check_claims(a, [60], [0.03, 1, 0], a["loop_plant"].input_delay[0])
    assert g["disk_alpha"] >= 0.5 * (1 - 1e-4)


def test_tune_bad_input_names_the_argument():
    with pytest.raises(sk.InputError, match="--firmware must be betaflight"):
        sk.tune("1/(s+1)", "dji")
    with pytest.raises(sk.InputError, match="allowed: ms, mt"):
        sk.tune("1/(s+1)", "generic", goals=["bandwidth>=3"])
    with pytest.raises(sk.SkyloopError, match="> 1"):
        sk.tune("1/(s+1)", "generic", goals="ms<=0.8")
    with pytest.raises(sk.InputError, match="1..=64"):
        sk.tune("1/(s+1)", "generic", starts=0)
    with pytest.raises(sk.InputError, match="non-negative integer"):
        sk.tune("1/(s+1)", "generic", starts=-3)
    with pytest.raises(sk.InputError, match="SISO"):
        sk.tune(sk.ss(-np.eye(2), np.eye(2), np.eye(2), np.zeros((2, 2))), "generic")
    with pytest.raises(sk.InputError, match="structure"):
        sk.tune("1/(s+1)", "generic", structure="lead")
    with pytest.raises(sk.InputError, match="d-filter-tau"):
        sk.tune("1/(s+1)", "generic", d_filter_tau=-1.0)


def load_cases():
    path = fixture_path("crates", "skyloop-robust", "tests", "fixtures", "hinf", "hinfsyn_random.json")
    with open(path) as f:
        return json.load(f)["cases"]


def lft_numpy(P, nmeas, ncon, K):
    """lft(P, K) with u = K y, from the matrices alone: (A, B, C, D) of the closed loop."""
    A, B, C, D = P.A, P.B, P.C, P.D
    nx, nw, nz = A.shape[0], B.shape[1] - ncon, C.shape[0] - nmeas
    B1, B2, C1, C2 = B[:, :nw], B[:, nw:], C[:nz], C[nz:]
    D11, D12, D21, D22 = D[:nz, :nw], D[:nz, nw:], D[nz:, :nw], D[nz:, nw:]
    Ak, Bk, Ck, Dk = K.A, K.B, K.C, K.D
    nk = Ak.shape[0]
    # y = C2 x + D21 w + D22 u, u = Ck xk + Dk y  =>  y = S (C2 x + D22 Ck xk + D21 w), S = (I - D22 Dk)^-1.
    S = np.linalg.inv(np.eye(nmeas) - D22 @ Dk)
    Y = S @ np.hstack([C2, D22 @ Ck, D21])          # y as a map of [x, xk, w]
    U = np.hstack([np.zeros((ncon, nx)), Ck, np.zeros((ncon, nw))]) + Dk @ Y
    X = np.hstack([A, np.zeros((nx, nk)), B1]) + B2 @ U
    XK = np.hstack([np.zeros((nk, nx)), Ak, np.zeros((nk, nw))]) + Bk @ Y
    Z = np.hstack([C1, np.zeros((nz, nk)), D11]) + D12 @ U
    n = nx + nk
    top = np.vstack([X, XK])
    return top[:, :n], top[:, n:], Z[:, :n], Z[:, n:]


def grid_hinf(A, B, C, D, w):
    n = A.shape[0]
    return max(np.linalg.norm(C @ np.linalg.solve(1j * x * np.eye(n) - A, B) + D, 2) for x in w)


# The 2- and 3-state plants. (On the 4- to 6-state ones of the same file, full-order hinfstruct
# stays 26-47 % above hinfsyn's gamma whatever the number of starts: reported, not asserted here.)
@pytest.mark.parametrize("idx", [0, 1])
def test_hinfstruct_full_order_within_a_few_percent_of_hinfsyn(idx):
    c = load_cases()[idx]
    P = sk._skyloop._from_json(json.dumps(c["plant"]))
    nm, nc = c["nmeas"], c["ncon"]
    full = sk.hinfsyn(P, nm, nc, full=True)
    r = sk.hinfstruct(P, nm, nc, P.nstates)
    assert set(r) == {"gamma", "controller", "stabilized_starts", "starts_run", "added_starts"}
    assert 1 <= r["stabilized_starts"] <= r["starts_run"] == 8 + r["added_starts"]
    K = r["controller"]
    assert (K.nstates, K.noutputs, K.ninputs) == (P.nstates, nc, nm)
    g = r["gamma"]
    # Never below the optimum (hinfsyn's verified lower bound), at most a few % above hinfsyn's gamma
    # and SLICOT's (sb10ad, committed by tools/).
    assert g >= full["gamma_lower"] * (1 - 1e-6), (g, full["gamma_lower"])
    assert g <= full["gamma"] * 1.05 and g <= c["gamma_slicot"] * 1.05, (g, full["gamma"], c["gamma_slicot"])
    # gamma is the norm of the closed loop rebuilt here from P and K's matrices.
    A, B, C, D = lft_numpy(P, nm, nc, K)
    assert np.all(np.linalg.eigvals(A).real < 0)
    # skyloop only says where to look (its peak frequency); the value there is numpy's.
    peak = sk.hinf_norm(sk.lft(P, K))[1]
    w = np.concatenate([np.logspace(-3, 4, 3000), [peak] if np.isfinite(peak) else []])
    lower = grid_hinf(A, B, C, D, w)
    assert lower <= g * (1 + 1e-8)
    assert lower >= g * (1 - 1e-6), (lower, g)
    if HAVE_SLYCOT:
        assert abs(control.norm(control.ss(A, B, C, D), "inf") / g - 1) < 1e-5


def test_hinfstruct_lower_orders():
    c = load_cases()[0]  # 2 states
    P = sk._skyloop._from_json(json.dumps(c["plant"]))
    full = sk.hinfsyn(P, 1, 1, full=True)
    for order in (0, 1):
        r = sk.hinfstruct(P, 1, 1, order, seed=3)
        assert r["controller"].nstates == order
        assert r["gamma"] >= full["gamma_lower"] * (1 - 1e-6)
        A, B, C, D = lft_numpy(P, 1, 1, r["controller"])
        assert np.all(np.linalg.eigvals(A).real < 0)
        assert grid_hinf(A, B, C, D, np.logspace(-3, 4, 2000)) <= r["gamma"] * (1 + 1e-8)
        if order == 1:
            assert r["gamma"] <= full["gamma"] * 1.05
    # Same seed, same answer (the starts are seeded, whatever the thread scheduling).
    a = sk.hinfstruct(P, 1, 1, 1, starts=4, seed=3)
    b = sk.hinfstruct(P, 1, 1, 1, starts=4, seed=3)
    assert a["gamma"] == b["gamma"] and np.array_equal(a["controller"].A, b["controller"].A)


# The closed loop of the order-1 controller above (seed 3), as hinfstruct once returned it: |G(jw)|
# peaks at 1.3615532814 near 0.378 rad/s (numpy here; slycot's ab13dd agrees to 1e-12), 3e-7 above
# |D|. hinf_norm used to return |D| (3e-7 low); its D-dominant start now climbs every local maximum
# of a frequency grid.
NEARLY_FLAT = ('{"a":[[-1.04587772197857,2.5770488881106024,-1.174130497499393],[-25.791167393325566,'
               '1.6950369398322218,-23.78013273766823],[-4.911907605784793,0.39954559919877997,-4.93374691646352]],'
               '"b":[[2.7714076333658633],[30.033071580938337],[5.719527638799711]],'
               '"c":[[-0.005351262050479422,0.19165953636086458,-1.0608614567975168]],'
               '"d":[[1.3615528522615936]],"dt":0.0}')


def test_hinf_norm_of_a_nearly_flat_loop():
    G = sk._skyloop._from_json(NEARLY_FLAT)
    w = np.logspace(-1, 0, 20001)
    ref = grid_hinf(G.A, G.B, G.C, G.D, w)
    assert ref > abs(G.D[0, 0]) * (1 + 1e-7)
    assert sk.hinf_norm(G)[0] >= ref * (1 - 1e-8)


def test_hinfstruct_says_when_no_static_gain_stabilizes():
    c = load_cases()[1]  # 3 states, one unstable pole; D22 = 0
    P = sk._skyloop._from_json(json.dumps(c["plant"]))
    A, B, C = P.A, P.B, P.C
    assert P.D[-1, -1] == 0
    # Independently: no static u = k y in +-[1e-4, 1e4] moves every closed-loop pole left.
    ks = np.concatenate([-np.logspace(-4, 4, 4001), np.logspace(-4, 4, 4001)])
    assert min(np.linalg.eigvals(A + k * B[:, -1:] @ C[-1:]).real.max() for k in ks) > 0.5
    with pytest.raises(sk.RobustError, match="no start found a stabilizing controller of order 0"):
        sk.hinfstruct(P, 1, 1, 0, starts=4)


def test_hinfstruct_bad_input_names_the_argument():
    c = load_cases()[0]
    P = sk._skyloop._from_json(json.dumps(c["plant"]))
    with pytest.raises(sk.RobustError, match="0..=50"):
        sk.hinfstruct(P, 1, 1, 51)
    with pytest.raises(sk.RobustError, match="1..=1000"):
        sk.hinfstruct(P, 1, 1, 1, starts=0)
    with pytest.raises(sk.SkyloopError, match="nmeas must be in"):
        sk.hinfstruct(sk.tf("1/(s+1)"), 1, 1, 1)
    with pytest.raises(sk.InputError, match="order must be a non-negative integer"):
        sk.hinfstruct(P, 1, 1, -1)
    with pytest.raises(sk.InputError, match="order must be a non-negative integer"):
        sk.hinfstruct(P, 1, 1, 1.5)
