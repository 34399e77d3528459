#!/usr/bin/env python3
"""Reference fixtures for skyloop-lti frequency analysis (freqresp, H-inf/H2 norms, margins).

References come from python-control 0.10.2 + slycot:
  * frequency response: control.frequency_response (slycot tb05ad), times the exact delay factor
    e^{-jw(tau_out + tau_in)} computed here with numpy (python-control has no delays);
  * H-inf (L-inf) norm and peak frequency: control.linfnorm (slycot ab13dd, tol 1e-10);
  * H2 norm: control.norm(sys, 2) (slycot ab13bd);
  * margins of rational loops: control.stability_margins(returnall=True) (polynomial method);
  * margins of delayed loops and disk margins: a dense-grid reference written here, independent of
    skyloop: 400k log-spaced points, sign changes refined by scipy.optimize.brentq on the exact
    response (numpy, with the delay), disk-margin peak refined by scipy.optimize.minimize_scalar.

Run from the repository root:  python3 tools/gen_freq.py
Writes crates/skyloop-lti/tests/fixtures/freq/{freqresp,norms,margins}.json
"""
import json
import os

import control
import numpy as np
import scipy.optimize as so

OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-lti", "tests", "fixtures", "freq")
rng = np.random.default_rng(20261123)


def lti_json(sys, in_delay=None, out_delay=None):
    a, b, c, d = (np.atleast_2d(m) for m in control.ssdata(sys))
    j = {
        "a": a.tolist(),
        "b": b.tolist(),
        "c": c.tolist(),
        "d": d.tolist(),
        "dt": float(sys.dt) if sys.dt else 0.0,
    }
    if in_delay is not None:
        j["input_delay"] = list(in_delay)
    if out_delay is not None:
        j["output_delay"] = list(out_delay)
    return j


def seeded_rss(n, ny, nu, seed, discrete=False, strictly_proper=False):
    np.random.seed(seed)
    if discrete:
        return control.drss(n, ny, nu, strictly_proper=strictly_proper, dt=0.01)
    return control.rss(n, ny, nu, strictly_proper=strictly_proper)


def gen_freqresp():
    cases = []
    specs = [
        (1, 1, 1, False, False),
        (3, 1, 2, False, False),
        (8, 2, 2, False, True),
        (20, 2, 2, False, False),
        (12, 3, 2, False, True),
        (6, 2, 1, True, False),
        (15, 2, 3, True, True),
    ]
    for k, (n, ny, nu, disc, delayed) in enumerate(specs):
        sys = seeded_rss(n, ny, nu, 100 + k, discrete=disc)
        w = np.logspace(-2, 2.4, 37) if not disc else np.logspace(-1, np.log10(np.pi / 0.01), 37)
        resp = control.frequency_response(sys, w).frdata  # shape (ny, nu, nw)
        resp = np.reshape(resp, (ny, nu, len(w)))
        tin = tout = None
        if delayed:
            # continuous: arbitrary delays; discrete: whole numbers of samples
            tin = [float(x) for x in (rng.uniform(0, 0.05, nu) if not disc else 0.01 * rng.integers(0, 4, nu))]
            tout = [float(x) for x in (rng.uniform(0, 0.05, ny) if not disc else 0.01 * rng.integers(0, 4, ny))]
            tot = np.add.outer(np.array(tout), np.array(tin))
            resp = resp * np.exp(-1j * tot[:, :, None] * w[None, None, :])
        g = np.transpose(resp, (2, 0, 1))  # [freq][out][in]
        cases.append(
            {
                "name": f"rss n={n} {ny}x{nu} {'discrete' if disc else 'continuous'}{' delayed' if delayed else ''}",
                "sys": lti_json(sys, tin, tout),
                "w_rad_s": w.tolist(),
                "re": g.real.tolist(),
                "im": g.imag.tolist(),
            }
        )
    return cases


def gen_norms():
    cases = []
    specs = [
        (2, 1, 1, False, True),
        (5, 2, 2, False, False),
        (10, 3, 2, False, True),
        (20, 2, 2, False, False),
        (40, 3, 3, False, False),
        (6, 2, 2, True, True),
        (12, 2, 3, True, False),
    ]
    for k, (n, ny, nu, disc, sp) in enumerate(specs):
        sys = seeded_rss(n, ny, nu, 300 + k, discrete=disc, strictly_proper=sp)
        gpeak, fpeak = control.linfnorm(sys, tol=1e-10)
        h2 = control.norm(sys, 2) if (disc or sp) else None
        cases.append(
            {
                "name": f"rss n={n} {ny}x{nu} {'discrete' if disc else 'continuous'}",
                "sys": lti_json(sys),
                "hinf": float(gpeak),
                "hinf_w_rad_s": float(fpeak),
                "h2": None if h2 is None else float(h2),
            }
        )
    # Badly scaled stable model: a diagonal similarity T = diag(10^-4 .. 10^4) inflates ‖A‖ by about
    # 1e8 while the poles (and both norms) stay those of the well-scaled rss model.
    sys = seeded_rss(6, 2, 2, 320, strictly_proper=True)
    a, b, c, d = (np.atleast_2d(m) for m in control.ssdata(sys))
    t = np.logspace(-4, 4, 6)
    scaled = control.ss(t[:, None] * a / t[None, :], t[:, None] * b, c / t[None, :], d)
    gpeak, fpeak = control.linfnorm(scaled, tol=1e-10)
    cases.append(
        {
            "name": "badly scaled rss n=6 2x2 continuous",
            "sys": lti_json(scaled),
            "hinf": float(gpeak),
            "hinf_w_rad_s": float(fpeak),
            # H2 of the unscaled model (similarity-invariant): ab13bd on the scaled one is off by 2e-4.
            "h2": float(control.norm(sys, 2)),
            "unscaled_hinf": float(control.linfnorm(sys, tol=1e-10)[0]),
            "poles": sorted(np.linalg.eigvals(a).real.tolist()),
        }
    )
    return cases


def fin(x):
    return float(x) if np.isfinite(x) else None


def tf_eval(num, den, delay, s):
    return np.polyval(num, s) / np.polyval(den, s) * np.exp(-s * delay)


def dense_margins(num, den, delay, wlo, whi):
    """All gain/phase crossings and the disk margin of L = num/den * e^{-s delay} on [wlo, whi]."""
    w = np.logspace(np.log10(wlo), np.log10(whi), 400_001)
    L = tf_eval(num, den, delay, 1j * w)

    def im(x):
        return tf_eval(num, den, delay, 1j * x).imag

    def mag(x):
        return np.log(np.abs(tf_eval(num, den, delay, 1j * x)))

    pcs = []
    for i in np.where(np.diff(np.sign(L.imag)) != 0)[0]:
        x = so.brentq(im, w[i], w[i + 1], xtol=1e-14, rtol=1e-15)
        v = tf_eval(num, den, delay, 1j * x)
        if v.real < 0:
            pcs.append({"gm_db": float(-20 * np.log10(abs(v))), "w_rad_s": float(x)})
    gcs = []
    for i in np.where(np.diff(np.sign(np.log(np.abs(L)))) != 0)[0]:
        x = so.brentq(mag, w[i], w[i + 1], xtol=1e-14, rtol=1e-15)
        v = tf_eval(num, den, delay, 1j * x)
        gcs.append({"pm_deg": float(np.degrees(np.angle(-v))), "w_rad_s": float(x)})
    # symmetric disk margin: alpha = 1 / max |S - 1/2| = 1 / max |(1 - L) / (2 (1 + L))|
    f = np.abs((1 - L) / (2 * (1 + L)))
    i = int(np.argmax(f))
    lo, hi = w[max(i - 1, 0)], w[min(i + 1, len(w) - 1)]
    r = so.minimize_scalar(
        lambda x: -abs((1 - tf_eval(num, den, delay, 1j * x)) / (2 * (1 + tf_eval(num, den, delay, 1j * x)))),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-12 * hi},
    )
    alpha = 1.0 / max(-r.fun, f[i])
    return pcs, gcs, alpha, float(r.x)


def gen_margins():
    cases = []
    s = control.tf("s")
    # rational loops (python-control's exact polynomial method is the reference)
    loops = [
        ("k/(s(s+1)(s+2))", 3.0 / (s * (s + 1) * (s + 2)), 0.0),
        ("lead-lag with integrator", 20 * (s + 2) / (s * (s + 10) * (s + 0.5)), 0.0),
        ("conditionally stable", 100 * (s + 1) ** 2 / (s**3 * (s + 10) * (s + 20)) * 10, 0.0),
        ("unstable closed loop", 4 * (s**2 + 0.2 * s + 1) / ((s + 0.1) * (s**2 + 0.02 * s + 0.25) * (s + 3)), 0.0),
        ("stable with resonance", 0.5 * 100 / (s**2 + 2 * s + 100) * 5 / (s + 5), 0.0),
        ("unstable open loop", 10 * (s + 3) / ((s - 1) * (s + 8)), 0.0),
        # delayed loops (dense-grid reference)
        ("integrator with delay", 2.0 / s, 0.1),
        ("second order with delay", 8.0 / ((s + 1) * (s + 4)), 0.05),
    ]
    # Bicopter roll-rate loop, Li et al. (seeds/000): P from eq. (8) with its 0.032 s delay, C from eq. (12)
    P = 0.0887 / (0.0256 * s + 1) * (42**2 - s**2) / s * 2.221e5 / (s**2 + 666.4 * s + 2.221e5)
    C = 24.02 * (s + 54.01) * (s + 0.2474) * (s**2 + 139.3 * s + 2.624e4) / (
        s * (s**2 + 24.14 * s + 8544) * (s**2 + 232.4 * s + 7.041e4)
    )
    loops.append(("bicopter P*C", P * C, 0.032))
    for name, L, delay in loops:
        num, den = (np.array(x, dtype=float) for x in (L.num[0][0], L.den[0][0]))
        sys = control.ss(L)
        case = {"name": name, "sys": lti_json(sys, [delay] if delay > 0 else None), "delay_s": delay}
        if delay == 0.0:
            gm, pm, sm, wpc, wgc, wms = control.stability_margins(L, returnall=True)
            case["stability_margins"] = {
                "gm_abs": [float(x) for x in gm],
                "w_pc_rad_s": [float(x) for x in wpc],
                "pm_deg": [float(x) for x in pm],
                "w_gc_rad_s": [float(x) for x in wgc],
            }
            gm1, pm1, _, wpc1, wgc1, _ = control.stability_margins(L)
            case["margin"] = {  # null where python-control reports inf/nan (no crossing)
                "gm_abs": fin(gm1),
                "pm_deg": fin(pm1),
                "w_pc_rad_s": fin(wpc1),
                "w_gc_rad_s": fin(wgc1),
            }
            cl = control.feedback(L, 1)
            case["closed_loop_stable"] = bool(np.all(np.real(cl.poles()) < 0))
        pcs, gcs, alpha, wdm = dense_margins(num, den, delay, 1e-3, 1e3)
        case["dense"] = {"phase_crossings": pcs, "gain_crossings": gcs, "disk_alpha": alpha, "disk_w_rad_s": wdm}
        cases.append(case)
    return cases


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, gen in [("freqresp", gen_freqresp), ("norms", gen_norms), ("margins", gen_margins)]:
        data = {"generator": "tools/gen_freq.py", "python_control": control.__version__, "cases": gen()}
        with open(os.path.join(OUT, name + ".json"), "w") as f:
            json.dump(data, f, indent=None, allow_nan=False)
        print(name, len(data["cases"]), "cases")


if __name__ == "__main__":
    main()
