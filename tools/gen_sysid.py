#!/usr/bin/env python3
"""Reference fixtures for skyloop-sysid's spectral estimators and fits.

Writes crates/skyloop-sysid/tests/fixtures/sysid/*.json:
- welch.json: scipy.signal.csd/welch/coherence (H1 = P_uy/P_uu) on a filtered-noise record, for two
  window/overlap settings;
- etfe_spa.json: the raw ETFE Y/U (numpy.fft) and a Blackman-Tukey estimate computed directly from
  time-domain correlations with a Hann lag window (independent of the FFT route used in Rust);
- eq8.json: the bicopter roll-rate model of the paper's eq. (8) evaluated with numpy on a grid (the
  exact delay as exp(-j w Td)), for the parametric-fit tests.
Run: python3 tools/gen_sysid.py
"""
import json
import os

import numpy as np
from scipy import signal

OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-sysid", "tests", "fixtures", "sysid")
os.makedirs(OUT, exist_ok=True)
rng = np.random.default_rng(7)

# A discrete 2nd-order resonance plus a one-sample delay, driven by white noise, output noise added.
n = 4096
dt = 0.004
u = rng.standard_normal(n)
b, a = signal.butter(2, 0.2)
y = signal.lfilter(np.r_[0.0, b], a, u) + 0.05 * rng.standard_normal(n)

cases = []
for win, nper, nover in [("hann", 256, 128), ("hamming", 512, 384)]:
    f, puu = signal.welch(u, fs=1 / dt, window=win, nperseg=nper, noverlap=nover, detrend="constant")
    _, puy = signal.csd(u, y, fs=1 / dt, window=win, nperseg=nper, noverlap=nover, detrend="constant")
    _, coh = signal.coherence(u, y, fs=1 / dt, window=win, nperseg=nper, noverlap=nover, detrend="constant")
    g = puy / puu
    cases.append({
        "window": win, "nperseg": nper, "noverlap": nover,
        "freq_hz": f[1:].tolist(), "re": g.real[1:].tolist(), "im": g.imag[1:].tolist(), "coherence": coh[1:].tolist(),
    })
json.dump({"dt": dt, "u": u.tolist(), "y": y.tolist(), "cases": cases}, open(os.path.join(OUT, "welch.json"), "w"))

# ETFE and Blackman-Tukey on a shorter record (mean removed first, as the Rust default).
m_rec = 1000
u2 = u[:m_rec] - u[:m_rec].mean()
y2 = y[:m_rec] - y[:m_rec].mean()
U = np.fft.rfft(u2)
Y = np.fft.rfft(y2)
k = np.arange(1, m_rec // 2 + 1)
etfe = Y[k] / U[k]
M = 40
lags = np.arange(-M, M + 1)


def corr(a, b):
    # R_ab(tau) = 1/N sum_t a(t+tau) b(t)
    out = []
    for tau in lags:
        if tau >= 0:
            out.append(np.dot(a[tau:], b[: m_rec - tau]) / m_rec)
        else:
            out.append(np.dot(a[: m_rec + tau], b[-tau:]) / m_rec)
    return np.array(out)


W = 0.5 * (1 + np.cos(np.pi * lags / M))
freqs = np.linspace(0.5, 120.0, 60)
ruu, ryu = corr(u2, u2), corr(y2, u2)
G = []
for fr in freqs:
    e = np.exp(-1j * 2 * np.pi * fr * dt * lags)
    G.append(np.sum(W * ryu * e) / np.sum(W * ruu * e).real)
G = np.array(G)
json.dump({
    "dt": dt, "n": m_rec, "etfe_freq_hz": (k / (m_rec * dt)).tolist(), "etfe_re": etfe.real.tolist(), "etfe_im": etfe.imag.tolist(),
    "lag_window": M, "spa_freq_hz": freqs.tolist(), "spa_re": G.real.tolist(), "spa_im": G.imag.tolist(),
}, open(os.path.join(OUT, "etfe_spa.json"), "w"))

# Eq. (8) of the bicopter paper on a log grid.
fz = np.logspace(np.log10(0.5), np.log10(40), 50)
s = 2j * np.pi * fz
P = 0.0887 * np.exp(-0.032 * s) / (0.0256 * s + 1) * (42**2 - s**2) / s * 2.221e5 / (s**2 + 666.4 * s + 2.221e5)
json.dump({"freq_hz": fz.tolist(), "re": P.real.tolist(), "im": P.imag.tolist()}, open(os.path.join(OUT, "eq8.json"), "w"))
print("wrote", OUT)
