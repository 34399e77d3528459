"""Plots on matplotlib (optional: ``pip install ./python[plot]``), in the CLI's conventions.

Frequencies are shown in Hz (as the CLI's figures), magnitudes in dB, phases in degrees; the
functions take any model skyloop takes (StateSpace, TransferFunction, python-control models,
expressions) and return the matplotlib ``Figure``.

>>> import skyloop as sk, skyloop.plot
>>> s = sk.tf('s')
>>> fig = skyloop.plot.bode(4 / (s * (s + 1) * (0.1 * s + 1)), margins=True)
>>> len(fig.axes)
2
"""
from __future__ import annotations

from typing import Any, Optional, Sequence

import numpy as _np

import skyloop as _sk

__all__ = ["bode", "nyquist", "step", "sigma", "nichols", "stepinfo"]

_TAU = 2 * _np.pi


def _plt():
    try:
        import matplotlib.pyplot as plt  # noqa: PLC0415
    except ImportError:
        raise ImportError("skyloop.plot needs matplotlib: pip install 'skyloop[plot]' "
                          "(from the repository: pip install './python[plot]') or pip install matplotlib") from None
    return plt


def _omega(sys, omega) -> _np.ndarray:
    if omega is not None:
        return _np.asarray(omega, dtype=float)
    return _np.asarray(_sk.bode(sys)["w_rad_s"], dtype=float)


def bode(sys, omega=None, margins: bool = False, label: Optional[str] = None,
         phase_floor_db: Optional[float] = -60.0) -> Any:
    """Bode plot: magnitude (dB) and unwrapped phase (deg) against frequency (Hz), one curve per
    channel; the phase is drawn where the gain is at least ``phase_floor_db`` (as the CLI's figure:
    a delay's phase far below the gain floor would squash the axis; None draws it all).
    ``margins=True`` (SISO loops L) marks the crossover, the phase margin at it and the gain
    margin at the -180 deg crossing, with the 0 dB and -180 deg lines, as the CLI's figure.

    >>> import skyloop as sk, skyloop.plot
    >>> fig = skyloop.plot.bode(sk.tf([1], [1, 1]))
    >>> fig.axes[1].get_xlabel()
    'frequency [Hz]'
    """
    plt = _plt()
    b = _sk.bode(sys, omega)
    f = _np.asarray(b["freq_hz"])
    fig, (am, ap) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    ny, nu = b["mag_db"].shape[:2]
    masked = False
    for i in range(ny):
        for j in range(nu):
            name = label if (ny, nu) == (1, 1) else f"u{j + 1} -> y{i + 1}"
            mag, ph = b["mag_db"][i, j], b["phase_deg"][i, j].copy()
            if phase_floor_db is not None:
                hidden = mag < phase_floor_db
                if hidden.any() and not hidden.all():
                    ph[hidden] = _np.nan
                    masked = True
            am.semilogx(f, mag, label=name)
            ap.semilogx(f, ph, label=name)
    am.set_ylabel("magnitude [dB]")
    ap.set_ylabel(f"phase [deg], shown where gain ≥ {phase_floor_db:.0f} dB" if masked else "phase [deg]")
    ap.set_xlabel("frequency [Hz]")
    for a in (am, ap):
        a.grid(True, which="both", alpha=0.3)
    if margins:
        if (ny, nu) != (1, 1):
            raise _sk.InputError("margins=True needs a SISO loop L")
        m = _sk.margins(sys)
        am.axhline(0.0, color="k", lw=0.8, ls=":", label="0 dB")
        # the -180 deg line at the branch of the plotted phase
        ph = b["phase_deg"][0, 0]
        near = _np.abs(b["mag_db"][0, 0]) < 20
        k = _np.round((_np.median(ph[near] if near.any() else ph) + 180.0) / 360.0)
        ap.axhline(-180.0 + 360.0 * k, color="k", lw=0.8, ls=":", label="-180°")
        fc = m.get("phase_margin_freq_hz")
        pm = m.get("phase_margin_deg")
        if fc is not None and _np.isfinite(fc):
            am.axvline(fc, color="C3", lw=0.8, ls="--")
            ap.axvline(fc, color="C3", lw=0.8, ls="--",
                       label=f"PM {pm:.1f}° at {fc:.3g} Hz" if pm is not None else None)
        fg = m.get("gain_margin_freq_hz")
        gm = m.get("gain_margin_db")
        if fg is not None and gm is not None and _np.isfinite(fg) and _np.isfinite(gm):
            am.axvline(fg, color="C2", lw=0.8, ls="--", label=f"GM {gm:.2f} dB at {fg:.3g} Hz")
            ap.axvline(fg, color="C2", lw=0.8, ls="--")
        am.legend(loc="best", fontsize=8)
        ap.legend(loc="best", fontsize=8)
        am.set_title(_margin_title(m))
    elif label is not None or (ny, nu) != (1, 1):
        am.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig


def _margin_title(m: dict) -> str:
    parts = []
    if m.get("gain_margin_db") is not None:
        parts.append(f"GM {m['gain_margin_db']:.2f} dB")
    if m.get("phase_margin_deg") is not None:
        parts.append(f"PM {m['phase_margin_deg']:.1f}°")
    dm = m.get("disk_margin") or {}
    if dm.get("alpha") is not None:
        parts.append(f"disk margin α {dm['alpha']:.3f}")
    return ", ".join(parts)


def _disk(alpha: float):
    """Center and radius of the region the Nyquist curve of L must avoid for a symmetric disk margin
    alpha (gains in [(2-a)/(2+a), (2+a)/(2-a)] with any phase in the disk): -1/f over that disk."""
    if not 0 < alpha < 2:
        return None
    lo, hi = (2 - alpha) / (2 + alpha), (2 + alpha) / (2 - alpha)
    a, b = -1 / lo, -1 / hi
    return (a + b) / 2, abs(a - b) / 2


def nyquist(L, omega=None, disk: bool = True, radius: Optional[float] = 3.0) -> Any:
    """Nyquist plot of the SISO loop L: solid for w > 0, dashed for w < 0 (mirror), the -1 point,
    the unit circle, and (``disk=True``) the disk-margin disk, the region around -1 the curve avoids by
    its symmetric disk margin alpha (gain and phase changes inside it are tolerated at once).
    ``radius`` limits the view (None: the whole curve).

    >>> import skyloop as sk, skyloop.plot
    >>> s = sk.tf('s')
    >>> fig = skyloop.plot.nyquist(4 / (s * (s + 1) * (0.1 * s + 1)))
    >>> fig.axes[0].get_xlabel()
    'real'
    """
    plt = _plt()
    w = _omega(L, omega)
    h = _sk.freqresp(L, w)
    if h.shape[:2] != (1, 1):
        raise _sk.InputError("nyquist needs a SISO loop L")
    h = h[0, 0]
    fig, ax = plt.subplots(figsize=(6, 6))
    ax.plot(h.real, h.imag, "C0-", label="L(jω), ω > 0")
    ax.plot(h.real, -h.imag, "C0--", lw=0.8, label="ω < 0")
    mid = len(h) // 2
    if len(h) > 2:
        ax.annotate("", xy=(h.real[mid + 1], h.imag[mid + 1]), xytext=(h.real[mid], h.imag[mid]),
                    arrowprops={"arrowstyle": "->", "color": "C0"})
    t = _np.linspace(0, _TAU, 400)
    ax.plot(_np.cos(t), _np.sin(t), color="0.6", lw=0.8, ls=":", label="|L| = 1")
    ax.plot([-1], [0], "r+", ms=12, mew=2, label="−1")
    if disk:
        try:
            alpha = _sk.diskmargin(L).get("alpha")
        except _sk.SkyloopError:   # e.g. a FrequencyResponseData: no model to take the margin of
            alpha = None
        cr = _disk(alpha) if alpha is not None else None
        if cr is not None:
            c, r = cr
            ax.fill(c + r * _np.cos(t), r * _np.sin(t), color="C3", alpha=0.15,
                    label=f"disk margin α = {alpha:.3f}")
            ax.plot(c + r * _np.cos(t), r * _np.sin(t), color="C3", lw=0.8)
    ax.set_xlabel("real")
    ax.set_ylabel("imaginary")
    ax.set_title("solid ω > 0, dashed ω < 0; arrow: increasing ω")
    ax.set_aspect("equal", adjustable="box")
    if radius is not None:
        ax.set_xlim(-radius, radius)
        ax.set_ylim(-radius, radius)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    return fig


def stepinfo(t, y, settling_band: float = 0.02) -> dict:
    """MATLAB's ``stepinfo`` of one step response y(t): {rise_time_s (10 % to 90 %), settling_time_s
    (last exit from the +-2 % band of the final value), overshoot_pct, peak, peak_time_s, final};
    None where undefined (all three when the final value is below 1e-3 of the peak: no steady state).

    >>> import numpy as np, skyloop.plot
    >>> t = np.linspace(0, 10, 10001)
    >>> round(skyloop.plot.stepinfo(t, 1 - np.exp(-t))["rise_time_s"], 3)
    2.197
    """
    t = _np.asarray(t, dtype=float)
    y = _np.asarray(y, dtype=float)
    yf = float(y[-1])
    out: dict = {"final": yf, "rise_time_s": None, "settling_time_s": None, "overshoot_pct": None,
                 "peak": float(_np.max(_np.abs(y))), "peak_time_s": float(t[int(_np.argmax(_np.abs(y)))])}
    if not _np.isfinite(yf) or abs(yf) <= 1e-3 * out["peak"]:
        return out   # no steady state to measure against (e.g. a derivative-like channel)
    yn = y / yf

    def cross(level):
        k = _np.flatnonzero(yn >= level)
        if not k.size:
            return None
        i = int(k[0])
        if i == 0:
            return float(t[0])
        return float(t[i - 1] + (level - yn[i - 1]) * (t[i] - t[i - 1]) / (yn[i] - yn[i - 1]))

    t10, t90 = cross(0.1), cross(0.9)
    if t10 is not None and t90 is not None:
        out["rise_time_s"] = t90 - t10
    outside = _np.flatnonzero(_np.abs(yn - 1) > settling_band)
    if not outside.size:
        out["settling_time_s"] = float(t[0])
    elif outside[-1] < len(t) - 1:
        out["settling_time_s"] = float(t[outside[-1] + 1])
    out["overshoot_pct"] = max(0.0, float((_np.max(yn) - 1) * 100))
    return out


def step(sys, t=None, info: bool = True) -> Any:
    """Unit-step responses against time (s), one panel per output / input pair; ``info=True`` marks
    MATLAB's ``stepinfo`` on each: the 10 %-90 % rise, the peak (overshoot) and the 2 % settling
    time with its band.

    >>> import skyloop as sk, skyloop.plot
    >>> fig = skyloop.plot.step(sk.tf([1], [1, 1]))
    >>> fig.axes[0].get_xlabel()
    'time [s]'
    """
    plt = _plt()
    r = _sk.step(sys, t)
    ts, y = r["t_s"], r["y"]
    ny, nu = y.shape[:2]
    fig, axs = plt.subplots(ny, nu, squeeze=False, figsize=(max(6, 4 * nu), max(4, 2.8 * ny)))
    for i in range(ny):
        for j in range(nu):
            ax = axs[i, j]
            yy = y[i, j]
            ax.plot(ts, yy, "C0-", label="y")
            if info:
                si = stepinfo(ts, yy)
                yf = si["final"]
                if si["overshoot_pct"] is not None:
                    ax.axhline(yf, color="0.5", lw=0.8, ls=":")
                    ax.axhspan(yf * 0.98, yf * 1.02, color="C2", alpha=0.12, label="±2 % band")
                    if si["rise_time_s"] is not None:
                        t10 = _np.interp(0.1, yy / yf, ts) if _np.all(_np.diff(yy[: _np.argmax(yy / yf >= 0.9) + 1] / yf) >= 0) else None
                        if t10 is not None:
                            ax.axvspan(t10, t10 + si["rise_time_s"], color="C1", alpha=0.12,
                                       label=f"rise {si['rise_time_s']:.3g} s")
                    if si["overshoot_pct"]:
                        ax.plot([si["peak_time_s"]], [yy[_np.argmax(_np.abs(yy))]], "rv",
                                label=f"peak {si['peak']:.3g} ({si['overshoot_pct']:.1f} % overshoot)")
                    if si["settling_time_s"] is not None:
                        ax.axvline(si["settling_time_s"], color="C2", lw=1, ls="--",
                                   label=f"settling {si['settling_time_s']:.3g} s")
                ax.legend(loc="lower right", fontsize=8)
            ax.set_xlabel("time [s]")
            ax.set_ylabel("output" if (ny, nu) == (1, 1) else f"from u{j + 1} to y{i + 1}")
            ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def sigma(sys, omega=None) -> Any:
    """Singular values (dB) of the frequency response against frequency (Hz), as python-control's
    ``singular_values_plot``; the largest is the H-infinity norm's curve, its peak marked.

    >>> import skyloop as sk, skyloop.plot
    >>> fig = skyloop.plot.sigma(sk.tf([1], [1, 1]))
    >>> fig.axes[0].get_ylabel()
    'singular values [dB]'
    """
    plt = _plt()
    w = _omega(sys, omega)
    h = _sk.freqresp(sys, w)
    sv = _np.linalg.svd(_np.moveaxis(h, -1, 0), compute_uv=False)
    fig, ax = plt.subplots(figsize=(7, 4))
    f = w / _TAU
    for k in range(sv.shape[1]):
        ax.semilogx(f, 20 * _np.log10(sv[:, k]), label=f"σ{k + 1}")
    try:
        n, wp = _sk.hinf_norm(sys)
        if _np.isfinite(n) and _np.isfinite(wp):
            ax.plot([max(wp, f[0] * _TAU) / _TAU], [20 * _np.log10(n)], "rv",
                    label=f"‖·‖∞ = {n:.4g} at {wp / _TAU:.3g} Hz")
    except (_sk.SkyloopError, TypeError):
        pass
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("singular values [dB]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig


def nichols(L, omega=None, m_circles_db: Sequence[float] = (1.0, 3.0, 6.0)) -> Any:
    """Nichols chart of the SISO loop L: open-loop gain (dB) against phase (deg) where the gain is
    within +-60 dB, the critical point (-180°, 0 dB) on the branch the loop crosses 0 dB, and the
    closed-loop |T| contours at ``m_circles_db``.

    >>> import skyloop as sk, skyloop.plot
    >>> s = sk.tf('s')
    >>> fig = skyloop.plot.nichols(4 / (s * (s + 1) * (0.1 * s + 1)))
    >>> fig.axes[0].get_xlabel()
    'open-loop phase [deg]'
    """
    plt = _plt()
    b = _sk.bode(L, omega)
    if b["mag_db"].shape[:2] != (1, 1):
        raise _sk.InputError("nichols needs a SISO loop L")
    mag, ph = b["mag_db"][0, 0], b["phase_deg"][0, 0]
    keep = (mag >= -60) & (mag <= 60)
    if keep.any():
        mag, ph = mag[keep], ph[keep]
    fig, ax = plt.subplots(figsize=(7, 5))
    ax.plot(ph, mag, "C0-", label="L")
    near = _np.abs(mag) < 20
    k = _np.round((_np.median(ph[near] if near.any() else ph) + 180.0) / 360.0)
    crit = -180.0 + 360.0 * k
    ax.plot([crit], [0.0], "r+", ms=12, mew=2, label="(-180°, 0 dB)")
    # |T| = |L / (1 + L)| = M contours, L = g e^{jp}
    p = _np.radians(_np.linspace(-359.9, -0.1, 721))
    for mdb in m_circles_db:
        M = 10 ** (mdb / 20)
        # |g|^2 (1 - 1/M^2) + 2 g cos p + 1 = 0 ... solved for g > 0 on each phase
        a2 = 1 - 1 / M ** 2
        disc = _np.cos(p) ** 2 - a2
        ok = disc >= 0
        for sgn in (-1, 1):
            g = (-_np.cos(p[ok]) + sgn * _np.sqrt(disc[ok])) / a2
            good = g > 0
            ax.plot(_np.degrees(p[ok][good]) + 360.0 * k, 20 * _np.log10(g[good]), color="0.6", lw=0.7,
                    ls=":", label=f"|T| = {mdb:g} dB" if sgn == 1 else None)
    ax.set_xlabel("open-loop phase [deg]")
    ax.set_ylabel("open-loop gain [dB]")
    lo, hi = _np.nanmin(mag), _np.nanmax(mag)
    ax.set_ylim(max(lo, -60) - 5, min(hi, 60) + 5)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig


# python-control's names
bode_plot = bode
nyquist_plot = nyquist
singular_values_plot = sigma
nichols_plot = nichols
