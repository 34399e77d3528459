#!/usr/bin/env python3
"""Side-by-side timing of skyloop-sysid against scipy/numpy (and pyulog when installed).

Run the criterion bench first:
    CARGO_TARGET_DIR=... cargo bench -p skyloop-sysid --bench sysid
then: python3 bench/compare_sysid.py [CARGO_TARGET_DIR]
Reads our mean times from CARGO_TARGET_DIR/criterion/<bench>/new/estimates.json and prints ratios.
"""
import json
import os
import sys
import time

import numpy as np
from scipy import signal

target = sys.argv[1] if len(sys.argv) > 1 else os.environ.get("CARGO_TARGET_DIR", "target")


def ours(name):
    p = os.path.join(target, "criterion", name, "new", "estimates.json")
    try:
        return json.load(open(p))["mean"]["point_estimate"] * 1e-9
    except OSError:
        return float("nan")


def best_of(f, n=5):
    t = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        t.append(time.perf_counter() - t0)
    return min(t)


n, dt = 600_000, 0.001
i = np.arange(n)
tt = i * dt
u = np.sin(7.1 * tt) + np.sin(113 * tt) + np.cos(1337 * tt) + (i * 7919 % 1000) / 500 - 1
y = signal.lfilter([0, 0.1], [1, -0.9], u)


def spafdr_numpy():
    # The same estimator in numpy: full-record rfft, Hann smoothing of width 0.15 f on 100 log points.
    U, Y = np.fft.rfft(u - u.mean()), np.fft.rfft(y - y.mean())
    df = 1 / (n * dt)
    fr = np.logspace(np.log10(12 * df), np.log10(0.5 / dt), 100)
    out = []
    for f in fr:
        w = max(0.15 * f, 6 * df)
        k = np.arange(max(1, int(np.ceil((f - w / 2) / df))), min(len(U) - 1, int((f + w / 2) / df)) + 1)
        wt = 0.5 * (1 + np.cos(2 * np.pi * (k * df - f) / w))
        suu = np.sum(wt * np.abs(U[k]) ** 2)
        syu = np.sum(wt * Y[k] * np.conj(U[k]))
        out.append(syu / suu)
    return out


def welch_scipy():
    _, puu = signal.welch(u, fs=1 / dt, nperseg=65536)
    _, puy = signal.csd(u, y, fs=1 / dt, nperseg=65536)
    return puy / puu


rows = [("spafdr 600k samples", ours("spafdr_600k_samples"), best_of(spafdr_numpy), "numpy port"),
        ("spafdr 600k (ours) vs scipy welch H1", ours("spafdr_600k_samples"), best_of(welch_scipy), "scipy.signal.csd")]
try:
    import pyulog  # noqa: F401
    from pyulog import ULog

    p = os.path.join(os.path.dirname(__file__), "..", "testdata", "logs", "sample.ulg")
    rows.append(("read sample.ulg (4 MB)", ours("read_sample_ulg_4mb"), best_of(lambda: ULog(p), 3), "pyulog"))
except ImportError:
    rows.append(("read sample.ulg (4 MB)", ours("read_sample_ulg_4mb"), float("nan"), "pyulog not installed"))

print(f"{'case':40} {'skyloop [ms]':>13} {'reference [ms]':>15} {'ratio':>7}  reference")
for name, a, b, ref in rows:
    print(f"{name:40} {a * 1e3:13.2f} {b * 1e3:15.2f} {b / a if a == a and a > 0 else float('nan'):7.2f}  {ref}")
