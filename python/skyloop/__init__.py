"""skyloop: robust flight-control design in pure Rust, in-process from Python.

Models with exact time delays, frequency responses, margins, norms, discretization, reduction,
H-infinity synthesis, Glover-McFarlane loop shaping, mixed sensitivity, mu analysis and
mu-synthesis, identification from flight logs, and the nonlinear 6-DOF simulation with its Monte
Carlo studies. Names follow python-control where it has them; arrays are numpy float64 /
complex128. Every computation runs in Rust with the GIL released.

Units: rad/s for ``omega`` and ``w_*`` fields, Hz where a name says ``_hz``, seconds for ``dt``,
delays and times, dB and degrees where a name says ``_db`` / ``_deg``.

Errors raise :class:`SkyloopError` subclasses (``ModelError``, ``RobustError``, ``InputError``,
...) carrying the Rust error's message; a panic inside skyloop becomes ``InternalError``.
"""
from __future__ import annotations

import os as _os
from typing import Iterable, Optional, Sequence, Union

import numpy as _np

from . import _skyloop
from ._skyloop import (  # noqa: F401  (re-exported API)
    FileError,
    InputError,
    InternalError,
    LinalgError,
    ModelError,
    RobustError,
    SimError,
    SkyloopError,
    StateSpace,
    SysidError,
    allmargin,
    balred,
    c2d,
    dcgain,
    ducted_fan_plants,
    diskmargin,
    feedback,
    h2_norm,
    hinf_norm,
    hinfsyn,
    hsvd,
    lft,
    margins,
    minreal,
    mixsyn,
    musyn_spec,
    ncfsyn,
    poles,
    read_log,
    reproduce,
    subsystem,
    tf,
    zeros,
)

__version__ = _skyloop.__version__

__all__ = [
    "SkyloopError", "LinalgError", "ModelError", "RobustError", "SysidError", "SimError",
    "InputError", "FileError", "InternalError",
    "StateSpace", "ss", "tf", "from_control", "feedback", "lft", "subsystem",
    "freqresp", "bode", "margins", "allmargin", "diskmargin", "hinf_norm", "h2_norm", "poles",
    "zeros", "dcgain", "step", "c2d", "balred", "hsvd", "minreal",
    "hinfsyn", "hinfstruct", "tune", "ncfsyn", "mixsyn", "mu", "musyn", "musyn_spec",
    "identify", "read_log", "simulate", "montecarlo", "summarize", "scenario_text", "reproduce",
    "ducted_fan_plants",
]


def _mat(x, name: str, rows: Optional[int] = None, cols: Optional[int] = None) -> _np.ndarray:
    """A float64 2-D C-contiguous array from an array-like; an empty input becomes (rows, cols) zeros."""
    a = _np.asarray(x, dtype=float)
    if a.size == 0:
        return _np.zeros((rows or 0, cols or 0))
    if a.ndim == 0:
        a = a.reshape(1, 1)
    elif a.ndim == 1:
        a = a.reshape(1, -1)
    elif a.ndim > 2:
        raise InputError(f"{name} must be a 2-D matrix, got an array of shape {a.shape}")
    return _np.ascontiguousarray(a)


def _vec(x, name: str) -> _np.ndarray:
    a = _np.ascontiguousarray(_np.asarray(x, dtype=float))
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise InputError(f"{name} must be a 1-D array, got shape {a.shape}")
    return a


def ss(A, B, C, D, dt: float = 0, input_delay=None, output_delay=None) -> StateSpace:
    """State-space model x' = A x + B u, y = C x + D u (python-control's ``ss``).

    A (nx x nx), B (nx x nu), C (ny x nx), D (ny x nu) array-likes; ``dt`` the sample period in s
    (0: continuous time); ``input_delay`` / ``output_delay`` delays in s per input / output.
    An empty A, B, C gives a static gain D.
    """
    d = _mat(D, "D")
    a = _mat(A, "A")
    nx = a.shape[0]
    b = _mat(B, "B", nx, d.shape[1])
    c = _mat(C, "C", d.shape[0], nx)
    if dt is None or dt is False:
        dt = 0.0
    if dt is True:
        raise InputError("dt=True (unspecified sample time) is not supported: give the sample period in s")
    ind = None if input_delay is None else [float(v) for v in _np.atleast_1d(input_delay)]
    outd = None if output_delay is None else [float(v) for v in _np.atleast_1d(output_delay)]
    return _skyloop._ss(a, b, c, d, float(dt), ind, outd)


def from_control(sys) -> StateSpace:
    """A skyloop model from a python-control ``StateSpace`` or ``TransferFunction`` (dt None -> 0).

    python-control models have no delays; a ``TransferFunction`` is converted with ``control.ss``.
    """
    import control  # noqa: PLC0415  (optional dependency)

    if not isinstance(sys, control.StateSpace):
        sys = control.ss(sys)
    dt = sys.dt
    if dt is None:
        dt = 0.0
    return ss(sys.A, sys.B, sys.C, sys.D, dt=dt)


def _as_sys(sys) -> StateSpace:
    if isinstance(sys, StateSpace):
        return sys
    if isinstance(sys, str):
        return tf(sys)
    mod = type(sys).__module__ or ""
    if mod.startswith("control"):
        return from_control(sys)
    raise InputError(f"expected a skyloop.StateSpace, an expression or a python-control model, got {type(sys).__name__}")


def freqresp(sys, omega) -> _np.ndarray:
    """Frequency response at ``omega`` (rad/s, 1-D): complex array [nfreq, ny, nu], exact with delays."""
    return _skyloop._freqresp(_as_sys(sys), _vec(omega, "omega"))


def bode(sys, omega=None) -> dict:
    """Bode data: {w_rad_s, freq_hz [nfreq], mag_db, phase_deg (unwrapped) [ny, nu, nfreq]}; ``omega`` rad/s."""
    return _skyloop._bode(_as_sys(sys), None if omega is None else _vec(omega, "omega"))


def step(sys, t=None) -> dict:
    """Unit-step response: {t_s [nt] (s), y [ny, nu, nt]}; ``t`` uniform from 0 (default automatic)."""
    return _skyloop._step(_as_sys(sys), None if t is None else _vec(t, "t"))


def mu(M, blocks: str, omega=None) -> dict:
    """Structured singular value bounds of ``M`` against ``blocks`` (e.g. ``"c1x1,f2x2,r1,c3r"``).

    ``M`` a model: bounds over ``omega`` (rad/s; default a grid over its dynamics), dict {upper, lower,
    w_rad_s, freq_hz, peak {upper, lower, w_rad_s, freq_hz, margin_lower, margin_upper,
    margin_freq_hz}}. ``M`` a complex matrix: {upper, lower, delta} of that matrix.
    """
    if isinstance(M, _np.ndarray) or (isinstance(M, (list, tuple)) and not isinstance(M, StateSpace)):
        m = _np.ascontiguousarray(_np.atleast_2d(_np.asarray(M, dtype=complex)))
        return _skyloop._mu(m, blocks, None)
    return _skyloop._mu(_as_sys(M), blocks, None if omega is None else _vec(omega, "omega"))


def musyn(P, blocks: str, nmeas: int, ncon: int, omega=None, max_iter: int = 6, d_order: int = 2,
          tol: float = 1e-2, reduce_order: Optional[int] = None) -> dict:
    """mu-synthesis by DK-iteration (uncertainty channels of P first, then performance, then y/u).

    ``omega`` the D-scale fit grid in rad/s (default automatic). Dict {controller, mu_peak, best,
    stop_reason, iterations [{gamma, mu_peak, mu_peak_w_rad_s, mu_lower_peak, mu_rs_peak,
    controller_order, scaled_plant_order}]}.
    """
    w = None if omega is None else [float(x) for x in _vec(omega, "omega")]
    return _skyloop._musyn(_as_sys(P), blocks, int(nmeas), int(ncon), w, int(max_iter), int(d_order),
                           float(tol), reduce_order)


def _count(x, name: str) -> int:
    """A non-negative integer argument, or InputError naming it (never a bare OverflowError from
    the conversion); the library checks the allowed range and names it."""
    if isinstance(x, bool) or not isinstance(x, (int, _np.integer)):
        raise InputError(f"{name} must be a non-negative integer, got {x!r}")
    if not 0 <= int(x) < 1 << 63:
        raise InputError(f"{name} must be a non-negative integer, got {int(x)}")
    return int(x)


def hinfstruct(P, nmeas: int, ncon: int, order: int, starts: int = 8, seed: int = 1) -> dict:
    """Fixed-order H-infinity synthesis by nonsmooth optimization (``skyloop hinfstruct``).

    MATLAB conventions as :func:`hinfsyn`: the last ``nmeas`` outputs of ``P`` are the measurements
    y, the last ``ncon`` inputs the controls u, u = K y. ``order`` is the controller's number of
    states (0..=50; 0 is a static gain, P's order is hinfsyn's full-order problem); ``starts``
    random starts (1..=1000) run in parallel, start k seeded with ``seed + k``. Returns the CLI's
    ``--json`` fields: {gamma (the H-infinity norm of lft(P, K), recomputed), controller
    (StateSpace K), stabilized_starts}. A fixed-order gamma is never below hinfsyn's optimum.
    """
    return _skyloop._hinfstruct(_as_sys(P), _count(nmeas, "nmeas"), _count(ncon, "ncon"), _count(order, "order"),
                                _count(starts, "starts"), _count(seed, "seed"))


def tune(plant, firmware: str, goals: Iterable[str] = (), structure: str = "pid",
         d_filter_tau: Optional[float] = None, maximize: str = "integral_gain", axis: str = "roll",
         starts: int = 8, out: Optional[Union[str, "_os.PathLike[str]"]] = None,
         keep_feedforward: bool = False) -> dict:
    """Rate-loop gains for the flight controller, tuned against margin goals (``skyloop tune --plant``).

    ``plant``: the continuous SISO rate-loop plant in the firmware's units (Betaflight: PID sum ->
    gyro deg/s; PX4 and ArduPilot: normalized torque -> rad/s; generic: any), exact delays allowed.
    ``firmware`` ``"betaflight"``, ``"px4"``, ``"ardupilot"`` or ``"generic"`` (C = kp + ki/s +
    kd s/(tf s + 1), ``structure`` ``"pi"``, ``"pid"`` or ``"pid2"`` (setpoint weights b, c fitted
    for tracking); ``d_filter_tau`` fixes tf in s). ``goals`` like ``"ms<=1.4"``, ``"mt<=1.3"``,
    ``"disk_margin>=0.6"``, ``"gain_margin_db>=6"``, ``"phase_margin_deg>=45"``,
    ``"crossover_hz>=20"``, ``"integral_corner>=0.067"``; a disk-margin floor (0.5) and a noise
    limit are added unless given. ``maximize`` ``"integral_gain"`` or ``"crossover"`` (which keeps
    ki/kp within 1/15..1/4 of the crossover unless an ``integral_corner`` goal is given); ``axis``
    roll / pitch / yaw; ``starts`` 1..=64; ``out`` a directory to also write the CLI's files
    (tune.json, report.html, ...). The feedforward (Betaflight F, PX4/ArduPilot FF) is fitted to
    the tuned loop unless ``keep_feedforward``.

    Returns the CLI's ``--json`` fields: {gains (the firmware's keys and units), feedback_controller
    (StateSpace C_fb, y -> u, continuous, of the rounded gains), discrete_controller (C_fb at the
    loop rate, None for generic), margins {disk_alpha, gain_margin_db (dB), phase_margin_deg (deg),
    crossover_hz (Hz), ms, mt, stable}, goals [{goal, value, met, active}], cli, defaults, notes,
    feedforward (the fit, or None), setpoint_weights (pid2, or None)},
    plus ``loop_plant`` (the plant the margins were checked with: ``plant`` with the firmware's
    sample-and-hold delay added), so ``margins(loop_plant * feedback_controller)`` re-derives them.
    """
    if isinstance(goals, str):
        goals = [goals]
    return _skyloop._tune(_as_sys(plant), str(firmware), [str(g) for g in goals], str(structure),
                          None if d_filter_tau is None else float(d_filter_tau), str(maximize), str(axis),
                          _count(starts, "starts"), None if out is None else _os.fspath(out),
                          bool(keep_feedforward))


def identify(data, input: Optional[str] = None, output: Optional[str] = None, **options) -> dict:
    """Frequency response (and optional parametric fits) of logged data; the options are the flags of
    ``skyloop identify`` (``method``, ``fmin_hz``, ``fmax_hz``, ``start_s``, ``end_s``, ``where_``,
    ``model``, ``init``, ``bounds``, ``tf``, ...; frequencies Hz, times s).

    ``axis="roll"|"pitch"|"yaw"`` applies the firmware's rate-loop preset (columns, airborne
    segments, model) instead of ``input`` / ``output``. ``data`` a log path (CSV with a time_s column, PX4 ULog, Betaflight blackbox) or a mapping of
    equal-length 1-D arrays with a ``time_s`` column (s), written to a temporary CSV at full
    precision and read by the same reader. Dict as ``identify --json``: {frf {freq_hz, mag,
    phase_deg, coherence, ...}, fit {...} with ``model``, tf {...} with ``tf``}.
    """
    if isinstance(data, dict):
        import tempfile

        if "time_s" not in data:
            raise InputError("data: a mapping of arrays needs a 'time_s' column (s)")
        names = ["time_s"] + [k for k in data if k != "time_s"]
        cols = [_vec(data[k], k) for k in names]
        if len({c.size for c in cols}) != 1:
            raise InputError("data: every column must have the length of time_s")
        with tempfile.TemporaryDirectory() as d:
            path = _os.path.join(d, "data.csv")
            _np.savetxt(path, _np.column_stack(cols), delimiter=",", header=",".join(names), comments="",
                        fmt="%.17g")
            return _skyloop.identify(path, input, output, **options)
    return _skyloop.identify(_os.fspath(data), input, output, **options)


def scenario_text(scenario: Union[str, "_os.PathLike[str]"]) -> str:
    """The TOML text of a scenario given as a file path or as TOML text itself."""
    s = _os.fspath(scenario)
    if "\n" not in s and _os.path.isfile(s):
        with open(s, encoding="utf-8") as f:
            return f.read()
    if "\n" not in s and s.endswith(".toml"):
        raise FileError(f"cannot read {s}: no such file")
    return s


def simulate(scenario) -> dict:
    """One nonlinear 6-DOF run of a scenario (TOML path or text).

    Dict {metrics {max_abs_error, rms_error, settling_time_s (s, None if never), saturated_fraction,
    crashed}, trajectory {t_s, pos_m (NED), euler_rad, rates_rad_s, reference, tracked,
    rate_sp_rad_s, torque_n_m (N m), u, saturated}} with arrays [n] or [n, 3].
    """
    return _skyloop._simulate(scenario_text(scenario))


def _seeds(seeds) -> Optional[list]:
    if seeds is None:
        return None
    if isinstance(seeds, str):
        a, _, b = seeds.partition("..")
        try:
            return list(range(int(a), int(b))) if b else [int(a)]
        except ValueError:
            raise InputError(f"seeds: expected 'A..B', got {seeds!r}") from None
    out = [int(s) for s in seeds]
    if any(s < 0 for s in out):
        raise InputError("seeds must be non-negative run indices")
    return out


def montecarlo(scenario, seeds: Union[None, str, Iterable[int]] = None, threads: Optional[int] = None) -> dict:
    """Runs of a scenario's ``[monte_carlo]`` study, in parallel on ``threads`` threads (default all cores).

    ``seeds`` are run indices (``range(a, b)``, a list, or ``"A..B"``; default all the study's runs);
    run i uses noise seed ``monte_carlo.seed + i`` and its own sampled parameters, so any split of a
    campaign gives the same runs. Dict {seeds, runs [{max_abs_error, rms_error, settling_time_s,
    saturated_fraction, crashed}], summary {runs, crashed, unsettled, <metric> {mean, std, min, p95,
    max}}} (the CLI's monte_carlo.json plus the seeds).
    """
    return _skyloop._montecarlo(scenario_text(scenario), _seeds(seeds), threads)


def summarize(runs: Sequence[dict]) -> dict:
    """The Monte Carlo ``summary`` dict of a list of run metrics (as ``montecarlo(...)["runs"]``)."""
    return _skyloop._summarize([dict(r) for r in runs])
