#!/usr/bin/env python3
"""Writes crates/skyloop/tests/fixtures/iv_reference.json: an independent instrumental-variable
identification of the rate loop of real acro flights, for `skyloop identify LOG --axis ...` to be
checked against.

Run: python3 -m venv /tmp/ivenv && /tmp/ivenv/bin/pip install "pip<23" &&
     /tmp/ivenv/bin/pip install orangebox==0.5.0 numpy scipy
     /tmp/ivenv/bin/python tools/gen_iv_reference.py

Nothing here comes from skyloop: the log is decoded by orangebox, the spectra are scipy's, the fit is
scipy.optimize.least_squares. What it shares with skyloop is the recipe, as docs/flight-logs.md states it:

- channels: input u = axisP[i]+axisI[i]+axisD[i]+axisF[i] (the PID sum; terms the log lacks are
  left out), output y = gyroADC[i], instrument r = setpoint[i];
- airborne samples: rcCommand[3] > 1050, every motor[k] inside the motorOutput range less 1 % of it
  at either end, every |gyroADC[j]| < 1950 deg/s; each run of airborne samples trimmed by 0.2 s at
  both ends (and by 1 s more if it runs to the end of the log), kept if at least 2 s long;
- FRF: G = S_yr / S_ur, Welch cross spectra (Hann window of NPERSEG samples, 50 % overlap, mean removed
  per window) estimated within each segment and summed over segments with weights equal to their
  numbers of windows (so a segment weighs as its length; segments shorter than a window are left out);
- fit of K*exp(-Td*s)/(s*(tau*s+1)) in [FMIN, FMAX] Hz by least squares on the complex log error
  ln(G_model/G), Re and Im, unweighted ("none") and with inverse-variance weights 2*nu*g2/(1-g2)
  ("inverse_variance", g2 capped at 0.999), nu the Welch equivalent number of averages and g2 the
  closed-loop coherence |G|^2*Phi_u(r) / (|G|^2*Phi_u(r) + Phi_vv) with Phi_u(r) = |S_ur|^2/S_rr and
  Phi_vv the spectrum of y - G*u; best of a 3x3 grid of starts in tau and Td, K started from the data.

Times are the flight controller's clock (the blackbox `time` field, s), which is also the time base
of `skyloop log export` and of the `from_clock_s`/`to_clock_s` of `skyloop identify --json`.
"""

import json
import logging
import os
import sys

import numpy as np
from orangebox import Parser
from scipy import optimize, signal

logging.disable(logging.CRITICAL)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LOGS = os.path.join(ROOT, "testdata", "logs")
OUT = os.path.join(ROOT, "crates", "skyloop", "tests", "fixtures", "iv_reference.json")
# (file, session counted from 1, axis)
CASES = [("btfl_all.bbl", 4, "roll"), ("btfl_all.bbl", 4, "pitch")]
NPERSEG = 1024
FMIN, FMAX = 2.0, 50.0
AXES = {"roll": 0, "pitch": 1, "yaw": 2}


def frames(path, session):
    p = Parser.load(path, session)
    names = [f.name for f in p.reader.field_defs[list(p.reader.field_defs.keys())[0]]]
    rows, started = [], False
    for f in p.frames():
        # orangebox decodes the frames before a session's first I-frame against an empty history
        # (see tools/gen_blackbox.py): they are not trusted.
        if not started:
            if f.type.value != "I":
                continue
            started = True
        rows.append(f.data[: len(names)])
    motor = p.headers.get("motorOutput", [1000, 2000])
    return names, np.array(rows, dtype=float), (float(motor[0]), float(motor[1]))


def airborne(names, a, motor_range):
    col = lambda n: a[:, names.index(n)]
    t = col("time") * 1e-6
    ok = col("rcCommand[3]") > 1050
    lo, hi = motor_range
    edge = 0.01 * (hi - lo)
    for k in range(8):
        if f"motor[{k}]" in names:
            m = col(f"motor[{k}]")
            ok &= (m > lo + edge) & (m < hi - edge)
    for j in range(3):
        ok &= np.abs(col(f"gyroADC[{j}]")) < 0.975 * 2000
    segs = []
    n = len(ok)
    i = 0
    # The frames are the loop's samples, one per P interval; their timestamps jitter with the logging
    # task, so the sample interval is the mean one (and the frames are taken as they are, uniform).
    dt = (t[-1] - t[0]) / (len(t) - 1)
    while i < n:
        if not ok[i]:
            i += 1
            continue
        j = i
        while j < n and ok[j]:
            j += 1
        a0, b0 = t[i] + 0.2, t[j - 1] - 0.2
        if j == n:
            b0 -= 1.0
        if b0 - a0 >= 2.0:
            segs.append((a0, b0))
        i = j
    return t, dt, segs


def spectra(t, fs, segs, u, y, r):
    acc = {}
    nu = 0.0
    step = NPERSEG // 2
    w = signal.get_window("hann", NPERSEG)
    rho = np.sum(w[: NPERSEG - step] * w[step:]) / np.sum(w * w)
    used = []
    for a0, b0 in segs:
        s = (t >= a0 - 1e-9) & (t <= b0 + 1e-9)
        n = int(s.sum())
        if n < NPERSEG:
            continue
        k = (n - NPERSEG) // step + 1
        used.append((a0, b0))
        x = {"u": u[s], "y": y[s], "r": r[s]}
        for name, (p, q) in {"ru": ("r", "u"), "ry": ("r", "y"), "rr": ("r", "r"), "uu": ("u", "u"),
                             "yy": ("y", "y"), "uy": ("u", "y")}.items():
            f, c = signal.csd(x[p], x[q], fs=fs, window="hann", nperseg=NPERSEG, noverlap=step,
                              detrend="constant")
            acc[name] = acc.get(name, 0) + k * c
        # Welch (1967): correlated overlapping windows, only the neighbour overlaps at 50 %.
        nu += k / (1 + 2 * (1 - 1 / k) * rho**2) if k > 1 else 1.0
    return f, acc, nu, used


def model(p, f):
    k, tau, td = p
    s = 2j * np.pi * f
    return k * np.exp(-td * s) / (s * (tau * s + 1))


def fit(f, g, weight):
    def res(p):
        e = np.log(model(p, f) / g) * weight
        return np.concatenate([e.real, e.imag])

    best = None
    for tau in [0.01, 0.03, 0.1]:
        for td in [0.002, 0.008, 0.03]:
            w = 2 * np.pi * f
            k0 = np.median(np.abs(g) * w * np.sqrt(1 + (w * tau) ** 2))
            r = optimize.least_squares(res, [k0, tau, td], bounds=([0, 1e-4, 0], [np.inf, 2, 0.2]),
                                       x_scale=[k0, 0.01, 0.01], xtol=1e-14, ftol=1e-14, gtol=1e-14,
                                       max_nfev=20000)
            if best is None or r.cost < best.cost:
                best = r
    gm = model(best.x, f)
    fit_percent = 100 * (1 - np.linalg.norm(g - gm) / np.linalg.norm(g - g.mean()))
    rms = float(np.sqrt(np.mean(np.abs(np.log(gm / g)) ** 2)))
    return {"K": best.x[0], "tau": best.x[1], "Td": best.x[2], "fit_percent": fit_percent,
            "log_residual_rms": rms}


def case(name, session, axis):
    path = os.path.join(LOGS, name)
    names, a, motor = frames(path, session)
    i = AXES[axis]
    col = lambda n: a[:, names.index(n)]
    terms = [f"axis{x}[{i}]" for x in "PIDF" if f"axis{x}[{i}]" in names]
    u = sum(col(n) for n in terms)
    y, r = col(f"gyroADC[{i}]"), col(f"setpoint[{i}]")
    t, dt, segs = airborne(names, a, motor)
    fs = 1.0 / dt
    f, acc, nu, used = spectra(t, fs, segs, u, y, r)
    g = acc["ry"] / acc["ru"]
    uu, yy, rr = acc["uu"].real, acc["yy"].real, acc["rr"].real
    phi_yu = acc["uy"]  # conj(U)*Y
    vv = np.maximum(yy - 2 * (np.conj(g) * phi_yu).real + np.abs(g) ** 2 * uu, 0)
    sig = np.abs(g) ** 2 * np.abs(acc["ru"]) ** 2 / rr
    g2 = sig / (sig + vv)
    band = (f >= FMIN) & (f <= FMAX)
    c = np.minimum(g2[band], 0.999)
    fits = {
        "none": fit(f[band], g[band], np.ones(band.sum())),
        "inverse_variance": fit(f[band], g[band], np.sqrt(2 * nu * c / (1 - c))),
    }
    print(name, session, axis, len(segs), "segments", f"{sum(b - a for a, b in segs):.1f} s", fits,
          file=sys.stderr)
    return {
        "file": name,
        "session": session,
        "axis": axis,
        "input": "+".join(terms),
        "rate_hz": fs,
        "segments_clock_s": [[a0, b0] for a0, b0 in segs],
        "segments_used_clock_s": [[a0, b0] for a0, b0 in used],
        "nperseg": NPERSEG,
        "dof": nu,
        "band_hz": [FMIN, FMAX],
        "frf": {
            "freq_hz": f[band].tolist(),
            "re": g[band].real.tolist(),
            "im": g[band].imag.tolist(),
            "coherence": g2[band].tolist(),
        },
        "fit": fits,
    }


def main():
    out = {
        "generator": "tools/gen_iv_reference.py with orangebox 0.5.0, numpy "
        + np.__version__ + ", scipy " + __import__("scipy").__version__,
        "model": "K*exp(-Td*s)/(s*(tau*s+1))",
        "cases": [case(*c) for c in CASES],
    }
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    with open(OUT, "w") as fh:
        json.dump(out, fh, indent=1)
        fh.write("\n")
    print(OUT, os.path.getsize(OUT), "bytes", file=sys.stderr)


if __name__ == "__main__":
    main()
