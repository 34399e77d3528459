"""Group `compare_sysid` of bench/compare.py: identification workloads against numpy/scipy/pyulog.

- SPAFDR of 10 minutes of 1 kHz data (600,000 samples) against the same estimator in numpy
  (full-record rfft, Hann smoothing of width 0.15 f on 100 log points) and against scipy's Welch H1
  estimate (csd/welch, 65,536-sample segments), the estimate a scipy user would reach for.
- Reading the 4 MB testdata/logs/sample.ulg against pyulog (when installed).
"""
import os

import numpy as np

from workflow_times import ROOT, ours, thread_best

N, DT = 600_000, 0.001


def record():
    from scipy import signal

    i = np.arange(N)
    tt = i * DT
    u = np.sin(7.1 * tt) + np.sin(113 * tt) + np.cos(1337 * tt) + (i * 7919 % 1000) / 500 - 1
    return u, signal.lfilter([0, 0.1], [1, -0.9], u)


def spafdr_numpy(u, y):
    U, Y = np.fft.rfft(u - u.mean()), np.fft.rfft(y - y.mean())
    df = 1 / (N * DT)
    out = []
    for f in np.logspace(np.log10(12 * df), np.log10(0.5 / DT), 100):
        w = max(0.15 * f, 6 * df)
        k = np.arange(max(1, int(np.ceil((f - w / 2) / df))), min(len(U) - 1, int((f + w / 2) / df)) + 1)
        wt = 0.5 * (1 + np.cos(2 * np.pi * (k * df - f) / w))
        out.append(np.sum(wt * Y[k] * np.conj(U[k])) / np.sum(wt * np.abs(U[k]) ** 2))
    return out


def comparisons(run):
    del run
    from scipy import signal

    u, y = record()
    t = ours()
    if abs(t["check_y_last"] - y[-1]) > 1e-9 * max(1.0, abs(y[-1])):
        raise RuntimeError(f"record mismatch: ours y[-1] = {t['check_y_last']}, numpy {y[-1]}")

    def welch():
        _, puu = signal.welch(u, fs=1 / DT, nperseg=65536)
        _, puy = signal.csd(u, y, fs=1 / DT, nperseg=65536)
        return puy / puu

    rows = [
        ("spafdr 600k samples (numpy port)", t["spafdr_600k_samples"], thread_best(lambda: spafdr_numpy(u, y), 3), 1.0),
        ("spafdr 600k vs scipy welch H1", t["spafdr_600k_samples"], thread_best(welch, 3), 1.0),
    ]
    try:
        from pyulog import ULog

        p = os.path.join(ROOT, "testdata", "logs", "sample.ulg")
        rows.append(("read sample.ulg 4 MB (pyulog)", t["read_sample_ulg_4mb"], thread_best(lambda: ULog(p), 3), 1.0))
    except ImportError:
        print("compare_sysid: pyulog not installed, the ULog row is skipped")
    return rows
