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
from typing import Any, Iterable, Optional, Sequence, Tuple, Union

import numpy as _np

from . import _model, _skyloop
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
)
from ._model import TransferFunction, balance

__version__ = _skyloop.__version__


def __getattr__(name: str):
    """``skyloop.plot`` (matplotlib) and ``skyloop.dask`` load on first use."""
    if name in ("plot", "dask"):
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'skyloop' has no attribute {name!r}")

__all__ = [
    "SkyloopError", "LinalgError", "ModelError", "RobustError", "SysidError", "SimError",
    "InputError", "FileError", "InternalError",
    "StateSpace", "TransferFunction", "ss", "tf", "from_control", "balance", "feedback", "lft", "subsystem",
    "freqresp", "bode", "margins", "allmargin", "diskmargin", "hinf_norm", "h2_norm", "poles",
    "zeros", "dcgain", "step", "c2d", "balred", "hsvd", "minreal",
    "hinfsyn", "hinfstruct", "tune", "ncfsyn", "mixsyn", "mu", "musyn", "musyn_spec",
    "identify", "read_log", "simulate", "montecarlo", "summarize", "scenario_text", "reproduce",
    "ducted_fan_plants",
    "step_response", "frequency_response", "margin", "ss2tf", "tf2ss", "series", "parallel",
    "sample_system",
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


def _delays(v) -> Optional[list]:
    return None if v is None else [float(x) for x in _np.atleast_1d(v)]


_NAME_KWARGS = ("name", "inputs", "outputs", "states", "input_prefix", "output_prefix", "state_prefix")


def _drop_names(kwargs: dict, fn: str) -> None:
    """python-control's signal-name keywords are accepted and not kept (skyloop's models are
    unnamed); anything else is an error."""
    bad = [k for k in kwargs if k not in _NAME_KWARGS]
    if bad:
        raise InputError(f"{fn}() got unexpected keyword arguments {bad}")


def ss(*args, dt: Any = None, input_delay=None, output_delay=None, **names) -> StateSpace:
    """State-space model x' = A x + B u, y = C x + D u (python-control's ``ss``).

    ``ss(A, B, C, D)`` or ``ss(A, B, C, D, dt)``: A (nx x nx), B (nx x nu), C (ny x nx), D (ny x nu)
    array-likes, ``dt`` the sample period in s (0 or None: continuous; ``dt=True`` is refused: the
    period must be known). ``input_delay`` / ``output_delay`` exact delays in s per input / output.
    An empty A, B, C gives a static gain D. ``ss(sys)`` converts any model (a
    :class:`TransferFunction` when proper, a python-control model, an expression string).
    python-control's naming keywords (``name``, ``inputs``, ``outputs``, ``states``) are accepted
    and not kept.

    >>> import skyloop as sk
    >>> G = sk.ss([[-1.0]], [[1.0]], [[2.0]], [[0.0]])
    >>> G.dcgain()
    2.0
    >>> sk.ss(sk.tf([1], [1, 1])).A
    array([[-1.]])
    """
    _drop_names(names, "ss")
    if len(args) == 1:
        if dt is not None or input_delay is not None or output_delay is not None:
            raise InputError("ss(sys) converts a model; give dt or delays with ss(A, B, C, D, ...)")
        return _model._to_ss(args[0])
    if len(args) == 5:
        if dt is not None:
            raise InputError("dt given twice")
        *args, dt = args
    if len(args) != 4:
        raise InputError(f"ss takes (A, B, C, D[, dt]) or one model, got {len(args)} arguments")
    A, B, C, D = args
    if all(_np.size(x) == 0 for x in (A, B, C, D)):
        raise InputError("ss: A, B, C and D are all empty: a model needs at least one input and one output")
    d = _mat(D, "D")
    a = _mat(A, "A")
    nx = a.shape[0]
    b = _mat(B, "B", nx, d.shape[1])
    c = _mat(C, "C", d.shape[0], nx)
    if d.size == 0:
        d = _np.zeros((c.shape[0], b.shape[1]))
    return _skyloop._ss(a, b, c, d, _model._dt_of(dt), _delays(input_delay), _delays(output_delay))


def tf(*args, dt: Any = None, **names) -> Any:
    """A transfer function, python-control's way or from an expression.

    - ``tf('s')`` (continuous) or ``tf('z', dt)``: the Laplace / z variable as a
      :class:`TransferFunction`, to build models with arithmetic: ``s = tf('s'); G = 1/(s+1)``.
      It may be improper while you compute; it is realized as a state space when proper.
    - ``tf(num, den)`` / ``tf(num, den, dt)``: polynomial coefficients, highest power first
      (a list for SISO, lists of lists for MIMO, as python-control) -> :class:`TransferFunction`.
    - ``tf(model)``: any model (a StateSpace, a python-control model) converted to a
      :class:`TransferFunction`, exact delays kept.
    - ``tf("expr")``: skyloop's expression language (numbers, ``s``, ``+ - * /``, integer ``^`` or
      ``**``, parentheses, ``exp(-T*s)`` for an exact delay of T s), or a path to an LTI JSON file
      -> a :class:`StateSpace` (as before); an improper expression gives a :class:`TransferFunction`.

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> G = 2 / (s**2 + 3*s + 2)
    >>> G.dcgain()
    1.0
    >>> sk.tf([1], [1, 1], 0.1).dt
    0.1
    >>> P = sk.tf("exp(-0.03*s)/(s**2+1)")
    >>> P.input_delay
    array([0.03])

    python-control's naming keywords (``name``, ``inputs``, ``outputs``) are accepted and not kept.
    """
    _drop_names(names, "tf")
    if len(args) == 3:
        if dt is not None:
            raise InputError("dt given twice")
        num, den, dt = args
        return TransferFunction(num, den, _model._dt_of(dt))
    if len(args) == 2 and not isinstance(args[0], str):
        return TransferFunction(args[0], args[1], _model._dt_of(dt))
    if len(args) == 2 and isinstance(args[0], str):
        if dt is not None:
            raise InputError("dt given twice")
        args, dt = (args[0],), args[1]
    if len(args) != 1:
        raise InputError("tf takes ('s'), ('z', dt), (num, den[, dt]), (model) or ('expression')")
    x = args[0]
    if isinstance(x, str):
        v = x.strip()
        if v in ("s", "z"):
            d = _model._dt_of(dt)
            if v == "z" and d == 0:
                raise InputError("tf('z') needs the sample period: tf('z', dt)")
            if v == "s" and d != 0:
                raise InputError("tf('s') is continuous: use tf('z', dt) for discrete time")
            return TransferFunction([1.0, 0.0], [1.0], d)
        if dt is not None:
            raise InputError("an expression sets its own time base: dt applies to tf('z', dt) and tf(num, den, dt)")
        return _tf_expr(v)
    if dt is not None:
        raise InputError("tf(model) keeps the model's sample period: dt does not apply")
    return _model.tf_of(x)


def _tf_expr(expr: str):
    """An expression string: the Rust parser (a StateSpace), else, for an improper expression, the
    same text evaluated exactly as a TransferFunction."""
    if _os.path.isfile(expr):
        return _skyloop.tf(expr)
    text = expr.replace("**", "^")
    try:
        return _skyloop.tf(text)
    except ModelError as e:
        if "improper" not in str(e):
            raise
    import re

    if not re.fullmatch(r"[\s0-9eE.+\-*/^()sxp]*", expr.replace("exp", "x")):
        raise InputError(f"cannot parse {expr!r}")
    s_ = TransferFunction([1.0, 0.0], [1.0])

    def exp_(arg):
        # exp(-T*s): an exact delay T
        if isinstance(arg, TransferFunction) and arg.issiso() and arg.den[0][0].size == 1:
            n = arg.num[0][0] / arg.den[0][0][0]
            if n.size == 2 and n[1] == 0 and n[0] <= 0:
                return TransferFunction([1.0], [1.0], 0.0, -float(n[0]))
        raise InputError("exp(...) must be exp(-T*s), an exact delay of T seconds")

    return eval(expr.replace("^", "**"), {"__builtins__": {}}, {"s": s_, "exp": exp_})  # noqa: S307


def from_control(sys) -> StateSpace:
    """A skyloop model from a python-control ``StateSpace`` or ``TransferFunction`` (dt None -> 0).

    python-control models have no delays; a ``TransferFunction`` is converted with ``control.ss``.
    ``dt=True`` (discrete, period unspecified) is refused: skyloop needs the period. A
    ``FrequencyResponseData`` has no state space: pass it to :func:`freqresp`, :func:`bode` or the
    plots, which take it as it is.

    >>> import control, skyloop as sk
    >>> sk.from_control(control.tf([1], [1, 2])).dcgain()
    0.5
    """
    import control  # noqa: PLC0415  (optional dependency)

    if isinstance(sys, control.FrequencyResponseData):
        raise InputError("a FrequencyResponseData has no state-space form: freqresp, bode and skyloop.plot "
                         "take it directly")
    dt = _model._dt_of(sys.dt)
    if not isinstance(sys, control.StateSpace):
        sys = control.ss(sys)
    return ss(sys.A, sys.B, sys.C, sys.D, dt=dt)


def _as_sys(sys) -> StateSpace:
    return _model._to_ss(sys)


def _is_frd(sys) -> bool:
    return _model._is_control(sys) and type(sys).__name__ == "FrequencyResponseData"


def _needs_python_freq(sys) -> bool:
    return _is_frd(sys) or (isinstance(sys, TransferFunction) and not sys.is_proper())


def freqresp(sys, omega) -> _np.ndarray:
    """Frequency response at ``omega`` (rad/s, 1-D): complex array [ny, nu, nfreq], exact with delays.

    The shape is python-control's ``frequency_response(sys, omega, squeeze=False).fresp`` (and
    :func:`bode`'s). Any model: a StateSpace, a TransferFunction (improper too), a python-control
    model, an expression, or a ``control.FrequencyResponseData`` (evaluated at ``omega``).

    >>> import skyloop as sk
    >>> h = sk.freqresp(sk.tf([1], [1, 1]), [0.0, 1.0])
    >>> h.shape
    (1, 1, 2)
    >>> complex(h[0, 0, 1])
    (0.5-0.5j)
    """
    w = _vec(omega, "omega")
    if _is_frd(sys):
        return _np.asarray(sys.eval(w, squeeze=False), dtype=complex).reshape(sys.noutputs, sys.ninputs, w.size)
    if isinstance(sys, TransferFunction):
        return sys.freqresp(w)
    return _np.ascontiguousarray(_np.moveaxis(_skyloop._freqresp(_as_sys(sys), w), 0, -1))


def bode(sys, omega=None) -> dict:
    """Bode data: {w_rad_s, freq_hz [nfreq], mag_db, phase_deg (unwrapped) [ny, nu, nfreq]}.

    ``omega`` in rad/s (default: a grid over the model's dynamics). Magnitudes in dB and phases in
    degrees here; :func:`freqresp` gives the complex values. Any model, including a
    ``control.FrequencyResponseData`` (its own frequencies when ``omega`` is None).

    >>> import skyloop as sk
    >>> b = sk.bode(sk.tf([1], [1, 1]), [1.0])
    >>> round(float(b["mag_db"][0, 0, 0]), 3), round(float(b["phase_deg"][0, 0, 0]), 1)
    (-3.01, -45.0)
    """
    if _needs_python_freq(sys):
        if omega is None:
            if _is_frd(sys):
                omega = _np.asarray(sys.omega, dtype=float)
            else:
                r = _np.abs(_np.concatenate([sys.poles(), sys.zeros()]))
                r = r[r > 0]
                lo, hi = (r.min() / 100, r.max() * 100) if r.size else (0.01, 100.0)
                omega = _np.logspace(_np.log10(lo), _np.log10(hi), 500)
        w = _vec(omega, "omega")
        h = freqresp(sys, w)
        return {"w_rad_s": w, "freq_hz": w / (2 * _np.pi), "mag_db": 20 * _np.log10(_np.abs(h)),
                "phase_deg": _np.degrees(_np.unwrap(_np.angle(h), axis=-1))}
    return _skyloop._bode(_as_sys(sys), None if omega is None else _vec(omega, "omega"))


def step(sys, t=None) -> dict:
    """Unit-step response: {t_s [nt] (s), y [ny, nu, nt]}; ``t`` uniform from 0 (default automatic).

    >>> import skyloop as sk
    >>> r = sk.step(sk.tf([1], [1, 1]), [0.0, 1.0])
    >>> round(float(r["y"][0, 0, 1]), 6)
    0.632121
    """
    return _skyloop._step(_as_sys(sys), None if t is None else _vec(t, "t"))


def feedback(sys1, sys2=1, sign: float = -1) -> Any:
    """Feedback connection y = sys1 (u + sign * sys2 y); ``sign=-1`` (default) negative feedback.

    ``sys2`` a model or a number (a gain). Two :class:`TransferFunction` give an exact
    TransferFunction (python-control's polynomials); otherwise a StateSpace. A delay inside the
    loop has no exact form and raises (approximate it with ``.pade(n)``).

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> sk.feedback(10 / (s + 1))
    TransferFunction(num=[10.0], den=[1.0, 11.0], dt=0.0)
    """
    if sign not in (1, -1):
        raise InputError(f"feedback sign must be +1 or -1, got {sign}")
    if isinstance(sys1, TransferFunction) and not isinstance(sys2, StateSpace):
        return sys1.feedback(sys2, sign)
    if isinstance(sys1, StateSpace) and isinstance(sys2, TransferFunction) and not sys2.is_proper():
        return _model.tf_of(sys1).feedback(sys2, sign)
    g1 = _as_sys(sys1)
    if isinstance(sys2, (int, float, _np.number)) and not isinstance(sys2, bool):
        k = float(sys2)
        g2 = _model._gain_ss(k * _np.eye(g1.ninputs, g1.noutputs), g1.dt)
    elif isinstance(sys2, (list, tuple, _np.ndarray)):
        g2 = _model._gain_ss(_np.asarray(sys2, dtype=float), g1.dt)
    else:
        g2 = _as_sys(sys2)
    return _skyloop.feedback(g1, g2, float(sign))


def lft(P, K) -> StateSpace:
    """Lower linear fractional transformation lft(P, K): K (u = K y) closes the last K.noutputs
    inputs and K.ninputs outputs of P (MATLAB ``lft(P, K)``).

    >>> import skyloop as sk
    >>> P = sk.ss([[-1.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]])
    >>> sk.lft(P, sk.ss([], [], [], [[-1.0]])).poles()
    array([-2.+0.j])
    """
    return _skyloop.lft(_as_sys(P), _as_sys(K))


def subsystem(sys, outputs: Sequence[int], inputs: Sequence[int]) -> StateSpace:
    """The channels ``outputs`` x ``inputs`` (index lists) of a model, delays included (also
    ``sys[outputs, inputs]``).

    >>> import skyloop as sk
    >>> G = sk.ss([[-1.0]], [[1.0, 2.0]], [[1.0]], [[0.0, 0.0]])
    >>> sk.subsystem(G, [0], [1]).dcgain()
    2.0
    """
    return _skyloop.subsystem(_as_sys(sys), [int(i) for i in outputs], [int(j) for j in inputs])


def margins(sys) -> dict:
    """Classical margins of the SISO loop L (negative feedback), the CLI's ``margins --json`` dict:
    gain_margin_db (dB), phase_margin_deg (deg), crossovers in Hz (``*_hz``), disk margin, ...

    Units: this dict (and the CLI's) is in dB / degrees / Hz, each field named with its unit;
    :func:`allmargin` gives dB / degrees / rad/s, :func:`margin` python-control's tuple (linear gain,
    degrees, rad/s).

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> m = sk.margins(4 / (s * (s + 1) * (0.1 * s + 1)))
    >>> round(m["phase_margin_deg"], 4), round(m["gain_margin_db"], 4)   # python-control: 17.705, 20 log10(2.75)
    (17.705, 8.7867)
    """
    return _skyloop.margins(_as_sys(sys))


def allmargin(sys) -> dict:
    """Every gain / phase crossing of the SISO loop L (MATLAB ``allmargin``): {gain_margins [{gm_db,
    w_rad_s}], phase_margins [{pm_deg, w_rad_s, delay_margin_s}], delay_margin_s, stable, ...}:
    dB, degrees, rad/s (frequencies in rad/s as python-control's ``stability_margins``; see
    :func:`margin` for python-control's tuple with a linear gain margin).

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> a = sk.allmargin(4 / (s * (s + 1) * (0.1 * s + 1)))
    >>> sorted(a)[:3]
    ['delay_margin_s', 'gain_margins', 'phase_margins']
    """
    return _skyloop.allmargin(_as_sys(sys))


def diskmargin(sys) -> dict:
    """Symmetric disk margin of the SISO loop L: {alpha, gain_db [low, high] (dB), phase_deg (deg),
    w_rad_s (rad/s, where the disk is touched)}.

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> 0 < sk.diskmargin(4 / (s * (s + 1) * (0.1 * s + 1)))["alpha"] < 2
    True
    """
    return _skyloop.diskmargin(_as_sys(sys))


def hinf_norm(sys) -> Tuple[float, float]:
    """H-infinity norm and the frequency (rad/s) of its peak: ``(norm, w_peak)``; ``(inf, nan)`` for an
    unstable model. The realization is balanced first (:func:`balance`), so badly scaled models
    (python-control's mixsyn closed loops) are decided correctly.

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> n, w = sk.hinf_norm(1 / (s**2 + 0.2*s + 1))
    >>> round(n, 6), round(w, 4)
    (5.025189, 0.9899)
    """
    orig = _as_sys(sys)
    g = balance(orig)
    n, wp = _skyloop.hinf_norm(g)
    return _model._hinf_check(g, n, wp, _model._stable_dense(orig))


def h2_norm(sys) -> float:
    """H2 norm (inf for an unstable or, in continuous time, non-strictly-proper model).

    >>> import skyloop as sk
    >>> round(sk.h2_norm(sk.tf([1], [1, 1])), 12)
    0.707106781187
    """
    return _skyloop.h2_norm(balance(_as_sys(sys)))


def poles(sys) -> _np.ndarray:
    """Poles, complex array (rad/s in continuous time): a SISO TransferFunction's are the roots of
    its denominator (as python-control's), a state space's the eigenvalues of A.

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> sk.poles(1 / (s + 2))
    array([-2.+0.j])
    """
    if isinstance(sys, TransferFunction):
        return sys.poles()
    return _skyloop.poles(_as_sys(sys))


def zeros(sys) -> _np.ndarray:
    """Zeros: a SISO TransferFunction's numerator roots, else the transmission zeros.

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> sk.zeros((s + 3) / (s + 1) ** 2)
    array([-3.+0.j])
    """
    if isinstance(sys, TransferFunction):
        return sys.zeros()
    return _skyloop.zeros(_as_sys(sys))


def dcgain(sys) -> Union[float, _np.ndarray]:
    """Steady-state gain: a float for a SISO model (python-control's), else an array [ny, nu].

    >>> import skyloop as sk
    >>> sk.dcgain(sk.tf([2], [1, 4]))
    0.5
    """
    if isinstance(sys, TransferFunction):
        return sys.dcgain()
    m = balance(_as_sys(sys))
    g = _skyloop.dcgain(m)
    if not _np.all(_np.isfinite(g)):
        g = _model._dcgain_dense(m, g)
    return float(g[0, 0]) if g.shape == (1, 1) else g


def c2d(sys, dt: float, method: str = "zoh", prewarp: Optional[float] = None) -> Any:
    """Discretizes with sample period ``dt`` (s) by ``method``: ``zoh``, ``foh``, ``tustin``
    (``bilinear``; ``prewarp`` in rad/s) or ``matched``. A TransferFunction gives a
    TransferFunction, a state space a StateSpace (python-control's ``sample_system``).

    >>> import skyloop as sk
    >>> Gd = sk.c2d(sk.tf([1], [1, 1]), 0.1)
    >>> round(Gd.dcgain(), 12)
    1.0
    """
    if isinstance(sys, TransferFunction):
        return sys.c2d(dt, method, prewarp)
    return _skyloop.c2d(_as_sys(sys), float(dt), method, prewarp)


def balred(sys, order: int, method: str = "truncate") -> StateSpace:
    """Balanced reduction to ``order`` states, unstable part kept exactly: ``method`` ``truncate``
    (``balanced``, SLICOT AB09AD) or ``matchdc`` (``spa``, singular perturbation keeping the DC gain).

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> sk.balred(1 / ((s + 1) * (s + 100)), 1).nstates
    1
    """
    return _skyloop.balred(_as_sys(sys), _count(order, "order"), method)


def hsvd(sys) -> _np.ndarray:
    """Hankel singular values of the stable part, descending.

    >>> import skyloop as sk
    >>> sk.hsvd(sk.tf([1], [1, 1])).round(6)
    array([0.5])
    """
    return _skyloop.hsvd(_as_sys(sys))


def minreal(sys, tol: Optional[float] = None) -> Any:
    """Minimal realization: removes uncontrollable and unobservable states (``tol`` relative; default
    automatic). The model is balanced first (:func:`balance`), and the result is checked against the
    original's frequency response: a reduction that would change it is refused (the balanced model is
    returned instead), so minreal never changes the response. A TransferFunction cancels pole-zero
    pairs (python-control's).

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> sk.minreal((s + 1) / ((s + 1) * (s + 2)))
    TransferFunction(num=[1.0], den=[1.0, 2.0], dt=0.0)
    """
    if isinstance(sys, TransferFunction):
        return sys.minreal(tol)
    full = balance(_as_sys(sys))
    red = _skyloop.minreal(full, tol)
    if red.nstates == full.nstates or _same_response(full, red):
        return red
    if tol is None:
        for t in (1e-10, 1e-12):
            red = _skyloop.minreal(full, t)
            if _same_response(full, red):
                return red
    return full


def _same_response(a: StateSpace, b: StateSpace, rtol: float = 1e-6) -> bool:
    """Whether two models agree on a frequency grid around a's dynamics (relative to the peak)."""
    p = _np.abs(_skyloop.poles(a)) if a.nstates else _np.ones(1)
    p = p[p > 0]
    lo, hi = (p.min() / 10, p.max() * 10) if p.size else (0.1, 10.0)
    w = _np.concatenate([[0.0], _np.logspace(_np.log10(lo), _np.log10(hi), 200)])
    if a.dt:
        w = w[w < _np.pi / a.dt]
    with _np.errstate(all="ignore"):
        ha = _model._ss_eval(a, _np.exp(1j * w * a.dt) if a.dt else 1j * w)
        hb = _model._ss_eval(b, _np.exp(1j * w * b.dt) if b.dt else 1j * w)
    ok = _np.isfinite(ha) & _np.isfinite(hb)
    if not ok.any():
        return False
    scale = max(float(_np.max(_np.abs(ha[ok]))), 1e-300)
    return bool(_np.all(_np.abs(ha[ok] - hb[ok]) <= rtol * scale) and _np.array_equal(ok, _np.isfinite(ha)))


def hinfsyn(P, nmeas: int, ncon: int, gamma_min: float = 0.0, gamma_max: Optional[float] = None,
            tol: float = 1e-4, full: bool = False) -> Any:
    """H-infinity output-feedback synthesis, python-control's ``(K, CL, gamma, rcond)``.

    MATLAB / python-control conventions: the last ``nmeas`` outputs of P are the measurements y,
    the last ``ncon`` inputs the controls u, u = K y, CL = lft(P, K). gamma is bisected on the
    two-Riccati test until the bracket is within ``tol`` (relative); the central controller is then
    built at exactly gamma = gamma_hi * (1 + 1e-3), gamma_hi the bracket's upper (feasible) end,
    because its Z factor is singular at the optimum (if that controller's verified closed loop
    misses it, the back-off is tripled, up to 12 times, never above ``gamma_max``). So the returned
    gamma is 0.1 % (plus at most ``tol``) above the optimum whatever ``tol`` is, and
    ||CL||_inf <= gamma (1 + 1e-3) is verified. ``rcond`` is None: skyloop's solver has no LAPACK
    condition estimates to report (python-control returns SLICOT's four).

    ``full=True`` returns the dict of earlier versions {controller, gamma, gamma_lower (the largest
    infeasible gamma), closed_loop_norm, closed_loop}.

    >>> import skyloop as sk
    >>> P = sk.ss([[-1.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 1.0], [1.0, 0.0]])
    >>> K, CL, gamma, rcond = sk.hinfsyn(P, 1, 1)
    >>> bool(sk.hinf_norm(CL)[0] <= gamma * (1 + 1e-3))
    True
    """
    d = _skyloop.hinfsyn(_as_sys(P), _count(nmeas, "nmeas"), _count(ncon, "ncon"), float(gamma_min),
                         None if gamma_max is None else float(gamma_max), float(tol), True)
    if full:
        return d
    return d["controller"], d["closed_loop"], d["gamma"], None


def ncfsyn(P, W1=None, W2=None, factor: float = 1.1, pade: int = 3) -> dict:
    """Glover-McFarlane loop shaping: shaped plant W2 P W1, robust controller at ``factor`` x the
    optimal gamma. Dict {controller (u = K y, negative feedback convention as MATLAB ncfsyn's
    K = W1 K_inf W2), k_inf, shaped_plant, gamma_min, gamma}; delays of P enter through a Pade
    approximant of order ``pade`` for the synthesis only.

    >>> import skyloop as sk
    >>> r = sk.ncfsyn(sk.tf("1/(s+1)"), sk.tf("1"))
    >>> round(r["gamma_min"], 4)
    1.0824
    """
    return _skyloop.ncfsyn(_as_sys(P), _opt(W1), _opt(W2), float(factor), _count(pade, "pade"))


def mixsyn(G, W1=None, W2=None, W3=None, gamma_max: Optional[float] = None, tol: float = 1e-4) -> tuple:
    """Mixed-sensitivity H-infinity synthesis minimizing ||[W1 S; W2 K S; W3 T]||_inf:
    ``(K, CL, gamma)``. python-control returns ``(K, CL, (gamma, rcond))``; skyloop's third item is
    gamma itself (no condition estimates to report).

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> K, CL, gamma = sk.mixsyn(1 / (s + 1), (s + 10) / (10 * s + 1), 0.1, (s + 1) / (s + 100))
    >>> bool(gamma > 0)
    True
    """
    return _skyloop.mixsyn(_as_sys(G), _opt(W1), _opt(W2), _opt(W3), gamma_max, float(tol))


def _opt(w) -> Optional[StateSpace]:
    return None if w is None else _as_sys(w)


def mu(M, blocks: str, omega=None) -> dict:
    """Structured singular value bounds of ``M`` against ``blocks`` (e.g. ``"c1x1,f2x2,r1,c3r"``).

    ``M`` a model: bounds over ``omega`` (rad/s; default a grid over its dynamics), dict {upper, lower,
    w_rad_s, freq_hz, peak {upper, lower, w_rad_s, freq_hz, margin_lower, margin_upper,
    margin_freq_hz}}. ``M`` a complex matrix: {upper, lower, delta} of that matrix.
    
    >>> import numpy as np, skyloop as sk
    >>> r = sk.mu(np.array([[0.5, 0.2], [0.1, 0.3]]), "c1x1,c1x1")
    >>> round(r["upper"], 6), round(r["lower"], 6)
    (0.573205, 0.573205)
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
    
    >>> import skyloop as sk
    >>> p = sk.ducted_fan_plants()
    >>> blocks = ",".join(["c1x1"] * p["n_unc"])        # 14 scalar complex uncertainties
    >>> r = sk.musyn(p["g"], blocks, p["nmeas"], p["ncon"], max_iter=1)
    >>> len(r["iterations"]), sorted(r)
    (1, ['best', 'controller', 'iterations', 'mu_peak', 'stop_reason'])
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
    
    >>> import skyloop as sk
    >>> P = sk.ss([[-1.0]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]], [[0.0, 0.0], [0.0, 0.1], [0.1, 0.0]])
    >>> r = sk.hinfstruct(P, 1, 1, 0, starts=2)
    >>> round(r["gamma"], 4), r["controller"].nstates
    (0.0995, 0)
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
    
    >>> import skyloop as sk
    >>> r = sk.tune("exp(-0.003*s)*400/(s*(0.025*s+1))", "betaflight", goals=["disk_margin>=0.6"], starts=2)
    >>> sorted(r["gains"])
    ['d', 'f', 'i', 'p']
    >>> r["margins"]["disk_alpha"] >= 0.6
    True
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
    
    >>> import numpy as np, skyloop as sk
    >>> t = np.arange(0, 20, 0.002)
    >>> u = np.random.default_rng(0).standard_normal(t.size)
    >>> y = np.zeros_like(u)
    >>> for k in range(1, t.size):
    ...     y[k] = 0.98 * y[k - 1] + 0.02 * u[k - 1]
    >>> r = sk.identify({"time_s": t, "u": u, "y": y}, "u", "y")
    >>> sorted(r["frf"])[:3]
    ['coherence', 'dof', 'freq_hz']
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
    """The TOML text of a scenario given as a file path or as TOML text itself.
    >>> import skyloop as sk
    >>> sk.scenario_text("examples/quadrotor-ssi.toml").startswith("#")
    True
    """
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
    
    >>> import skyloop as sk
    >>> r = sk.simulate("examples/quadrotor-ssi.toml")
    >>> sorted(r["metrics"])
    ['crashed', 'max_abs_error', 'rms_error', 'saturated_fraction', 'settling_time_s']
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
    
    >>> import skyloop as sk
    >>> r = sk.montecarlo("examples/quadrotor-ssi.toml", range(2), threads=1)
    >>> r["seeds"], r["summary"]["runs"]
    ([0, 1], 2)
    """
    return _skyloop._montecarlo(scenario_text(scenario), _seeds(seeds), threads)


def summarize(runs: Sequence[dict]) -> dict:
    """The Monte Carlo ``summary`` dict of a list of run metrics (as ``montecarlo(...)["runs"]``).
    >>> import skyloop as sk
    >>> runs = sk.montecarlo("examples/quadrotor-ssi.toml", range(3), threads=1)["runs"]
    >>> sk.summarize(runs)["runs"]
    3
    """
    return _skyloop._summarize([dict(r) for r in runs])


def ducted_fan_plants() -> dict:
    """The ducted-fan paper's plants (skyloop's reproduction, default design): dict {g (generalized
    plant: inputs [v n_unc | w n_w | u ncon], outputs [z n_unc | e n_e | y nmeas]), g_nom (nominal
    plant for the H-infinity design, eq. (11)), n_unc, n_w, n_e, nmeas, ncon}.

    >>> import skyloop as sk
    >>> p = sk.ducted_fan_plants()
    >>> p["nmeas"], p["ncon"], isinstance(p["g"], sk.StateSpace)
    (12, 5, True)
    """
    return _skyloop.ducted_fan_plants()


def musyn_spec(path: Union[str, "_os.PathLike[str]"]) -> dict:
    """mu-synthesis from a spec file (the CLI's ``skyloop musyn spec.toml``): the :func:`musyn` dict.

    >>> import skyloop as sk
    >>> r = sk.musyn_spec("examples/musyn-distillation.toml")
    >>> r["controller"].ninputs, round(r["iterations"][0]["mu_peak"], 2)
    (2, 1.18)
    """
    return _skyloop.musyn_spec(_os.fspath(path))


def read_log(path: Union[str, "_os.PathLike[str]"], session: Optional[int] = None) -> dict:
    """A flight log's channels (CSV with a time_s column, PX4 ULog, Betaflight blackbox ``session``):
    {channel: array, "<group>.time_s": array (s)} (a CSV's group is ``csv``).

    >>> import os, tempfile, numpy as np, skyloop as sk
    >>> d = tempfile.mkdtemp()
    >>> p = os.path.join(d, "log.csv")
    >>> np.savetxt(p, np.column_stack([np.arange(5) * 0.01, np.arange(5.0)]), delimiter=",", header="time_s,gyro", comments="")
    >>> sorted(sk.read_log(p))
    ['csv.time_s', 'gyro']
    """
    return _skyloop.read_log(_os.fspath(path), session)


def reproduce(name: str, out: Union[str, "_os.PathLike[str]"], quick: bool = False) -> list:
    """Reproduces a paper ("bicopter", "quadrotor-ssi", "ducted-fan"; ``quick`` for the shorter
    ducted-fan run), writing figures and report.html into ``out``: list of claims {what, paper,
    ours, tolerance, reproduced, line} as in the reproduction's report (a ``quick`` run reproduces
    fewer of them).

    >>> import tempfile, skyloop as sk
    >>> claims = sk.reproduce("bicopter", tempfile.mkdtemp(), quick=True)
    >>> sorted(claims[0])
    ['line', 'ours', 'paper', 'reproduced', 'tolerance', 'what']
    """
    return _skyloop.reproduce(str(name), _os.fspath(out), bool(quick))


# ---------------------------------------------------------------------------------------------
# python-control's function names, as thin shapes over the functions above

def step_response(sys, T=None) -> Tuple[_np.ndarray, _np.ndarray]:
    """python-control's ``t, y = step_response(sys, T)``: y squeezed to [nt] for a SISO model, else
    [ny, nu, nt] (the :func:`step` dict's arrays).

    >>> import skyloop as sk
    >>> t, y = sk.step_response(sk.tf([1], [1, 1]), [0.0, 1.0])
    >>> round(float(y[-1]), 6)
    0.632121
    """
    r = step(sys, T)
    y = r["y"]
    return r["t_s"], (y[0, 0] if y.shape[:2] == (1, 1) else y)


def frequency_response(sys, omega) -> Tuple[_np.ndarray, _np.ndarray, _np.ndarray]:
    """python-control's ``mag, phase, omega = frequency_response(sys, omega)``: linear magnitude,
    phase in rad (wrapped, as python-control's), omega rad/s; SISO squeezed to [nfreq], else
    [ny, nu, nfreq].

    >>> import skyloop as sk
    >>> mag, phase, w = sk.frequency_response(sk.tf([1], [1, 1]), [1.0])
    >>> round(float(mag[0]), 6), round(float(phase[0]), 6)
    (0.707107, -0.785398)
    """
    w = _vec(omega, "omega")
    h = freqresp(sys, w)
    if h.shape[:2] == (1, 1):
        h = h[0, 0]
    return _np.abs(h), _np.angle(h), w


def margin(L) -> Tuple[float, float, float, float]:
    """python-control's ``gm, pm, wcg, wcp = margin(L)``: gain margin (linear), phase margin (deg),
    phase-crossover and gain-crossover frequencies (rad/s); inf / nan where there is none. (The
    :func:`margins` dict has the same numbers in dB and Hz.)

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> gm, pm, wcg, wcp = sk.margin(4 / (s * (s + 1) * (0.1 * s + 1)))
    >>> round(gm, 6), round(pm, 4), round(wcg, 6), round(wcp, 6)
    (2.75, 17.705, 3.162278, 1.861216)
    """
    m = margins(L)
    gdb, pm = m.get("gain_margin_db"), m.get("phase_margin_deg")
    fg, fp = m.get("gain_margin_freq_hz"), m.get("phase_margin_freq_hz")
    gm = float("inf") if gdb is None else float(10 ** (gdb / 20))
    return (gm, float("inf") if pm is None else float(pm),
            float("nan") if fg is None else float(fg) * 2 * _np.pi,
            float("nan") if fp is None else float(fp) * 2 * _np.pi)


def ss2tf(sys) -> TransferFunction:
    """python-control's ``ss2tf``: ``tf(sys)``.

    >>> import skyloop as sk
    >>> sk.ss2tf(sk.ss([[-2.0]], [[1.0]], [[3.0]], [[0.0]]))
    TransferFunction(num=[3.0], den=[1.0, 2.0], dt=0.0)
    """
    return _model.tf_of(sys)


def tf2ss(*args) -> StateSpace:
    """python-control's ``tf2ss(sys)`` or ``tf2ss(num, den[, dt])``: ``ss(tf(...))``.

    >>> import skyloop as sk
    >>> sk.tf2ss([1], [1, 2]).poles()
    array([-2.+0.j])
    """
    return _model._to_ss(args[0] if len(args) == 1 else tf(*args))


def series(*systems) -> Any:
    """python-control's ``series(sys1, sys2, ...)``: sys1 first, then sys2 (``sysn * ... * sys1``).

    >>> import skyloop as sk
    >>> sk.series(sk.tf([1], [1, 1]), 2).dcgain()
    2.0
    """
    out = systems[0]
    for g in systems[1:]:
        out = g * out
    if isinstance(out, (int, float)):
        raise InputError("series needs at least one model")
    return out


def parallel(*systems) -> Any:
    """python-control's ``parallel(sys1, sys2, ...)``: the sum.

    >>> import skyloop as sk
    >>> sk.parallel(sk.tf([1], [1, 1]), 2).dcgain()
    3.0
    """
    out = systems[0]
    for g in systems[1:]:
        out = out + g
    return out


def sample_system(sys, Ts: float, method: str = "zoh", prewarp_frequency: Optional[float] = None) -> Any:
    """python-control's ``sample_system``: :func:`c2d`.

    >>> import skyloop as sk
    >>> round(sk.sample_system(sk.tf([1], [1, 1]), 0.1).dcgain(), 12)
    1.0
    """
    return c2d(sys, Ts, method, prewarp_frequency)
