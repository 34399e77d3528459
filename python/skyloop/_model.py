"""The python-control idioms of skyloop's models, in Python.

``TransferFunction`` is an exact rational matrix (numerator / denominator polynomials per I/O
pair, highest power first as numpy and python-control, an exact delay per channel in seconds, a
sample period ``dt``). It may be improper while you compute with it (``s = tf('s')``,
``(s + 1) / (s + 2)``); it is realized as the Rust :class:`~skyloop.StateSpace` when a function
needs a state space, which needs it proper.

The Rust ``StateSpace`` forwards the methods and operators written here (``G.poles()``, ``G(1j)``,
``G[0, 1]``, ``G / H``, ``G ** 2``, arithmetic with python-control objects) to this module.
"""
from __future__ import annotations

import numbers
from typing import Any, List, Optional, Tuple

import numpy as _np

from . import _skyloop
from ._skyloop import InputError, ModelError, StateSpace

_EPS = _np.finfo(float).eps


# ---------------------------------------------------------------------------------------------
# polynomials (numpy order: highest power first)

def _trim(p) -> _np.ndarray:
    """A 1-D float polynomial without leading zeros (the zero polynomial is [0.])."""
    a = _np.atleast_1d(_np.asarray(p, dtype=float)).ravel()
    nz = _np.flatnonzero(a)
    return a[nz[0]:].copy() if nz.size else _np.zeros(1)


def _padd(a, b) -> _np.ndarray:
    return _trim(_np.polyadd(a, b))


def _pmul(a, b) -> _np.ndarray:
    return _trim(_np.polymul(a, b))


def _is_zero(p) -> bool:
    return p.size == 1 and p[0] == 0.0


def _dt_of(dt) -> float:
    """A sample period: None / False / 0 continuous; dt=True refused (python-control's unspecified)."""
    if dt is True:
        raise InputError("dt=True (discrete time with an unspecified sample time) is not supported: "
                         "skyloop's discrete models, delays and discretizations need the period in s")
    if dt is None or dt is False:
        return 0.0
    d = float(dt)
    if not d >= 0.0 or not _np.isfinite(d):
        raise InputError(f"dt must be a sample period >= 0 (s), got {dt!r}")
    return d


def _common_dt(a: float, b: float) -> float:
    if a == b:
        return a
    raise ModelError(f"sample periods differ: {a} s and {b} s")


def _is_control(x) -> bool:
    return (type(x).__module__ or "").startswith("control")


def _is_scalar(x) -> bool:
    return isinstance(x, numbers.Number) and not isinstance(x, bool) or isinstance(x, _np.number) \
        or (isinstance(x, _np.ndarray) and x.ndim == 0)


# ---------------------------------------------------------------------------------------------
# TransferFunction

class TransferFunction:
    """An exact rational transfer-function matrix with exact delays (python-control's ``tf`` object).

    ``num[i][j]`` / ``den[i][j]`` are numpy polynomials (highest power first) of output i / input j,
    ``delay[i, j]`` the exact delay of that channel in s (``exp(-delay*s)``), ``dt`` the sample
    period in s (0: continuous). Build one with :func:`skyloop.tf`.

    Arithmetic (``+ - * /``, ``**`` with an integer, :meth:`feedback`) is exact polynomial
    arithmetic, as python-control's; the result may be improper, and is realized as a
    :class:`~skyloop.StateSpace` (:func:`skyloop.ss`) when proper.

    >>> import skyloop as sk
    >>> s = sk.tf('s')
    >>> G = 1 / (s + 1)
    >>> G
    TransferFunction(num=[1.0], den=[1.0, 1.0], dt=0.0)
    >>> complex(G(1j))
    (0.5-0.5j)
    """

    __array_priority__ = 100.0

    def __init__(self, num, den, dt: float = 0.0, delay=None):
        num_l = _nested(num)
        den_l = _nested(den)
        ny, nu = len(num_l), len(num_l[0])
        if (len(den_l), len(den_l[0])) != (ny, nu) or any(len(r) != nu for r in num_l + den_l):
            raise InputError("num and den must have the same ny x nu shape")
        self._num: List[List[_np.ndarray]] = [[_trim(p) for p in row] for row in num_l]
        self._den: List[List[_np.ndarray]] = [[_trim(p) for p in row] for row in den_l]
        for row in self._den:
            for p in row:
                if _is_zero(p):
                    raise InputError("a denominator is the zero polynomial")
        self.dt = _dt_of(dt)
        d = _np.zeros((ny, nu)) if delay is None else _np.broadcast_to(_np.asarray(delay, float), (ny, nu)).copy()
        if _np.any(~_np.isfinite(d)):
            raise InputError("delays must be finite")
        self._delay = d

    # --- python-control's attributes
    @property
    def num(self) -> List[List[_np.ndarray]]:
        """Numerators, ``num[i][j]`` of output i / input j (highest power first)."""
        return [[p.copy() for p in r] for r in self._num]

    @property
    def den(self) -> List[List[_np.ndarray]]:
        """Denominators, ``den[i][j]``."""
        return [[p.copy() for p in r] for r in self._den]

    @property
    def delay(self) -> _np.ndarray:
        """Exact delay of each channel in s, [ny, nu]."""
        return self._delay.copy()

    @property
    def noutputs(self) -> int:
        return len(self._num)

    @property
    def ninputs(self) -> int:
        return len(self._num[0])

    @property
    def shape(self) -> Tuple[int, int]:
        return (self.noutputs, self.ninputs)

    def issiso(self) -> bool:
        return self.shape == (1, 1)

    def isctime(self) -> bool:
        return self.dt == 0.0

    def isdtime(self) -> bool:
        return self.dt > 0.0

    def has_delay(self) -> bool:
        return bool(_np.any(self._delay != 0.0))

    def is_proper(self) -> bool:
        """Whether every channel has deg num <= deg den (so a state space exists)."""
        return all(n.size <= d.size for rn, rd in zip(self._num, self._den) for n, d in zip(rn, rd))

    def __repr__(self) -> str:
        def f(p):
            return [float(x) for x in p]
        extra = f", delay={float(self._delay[0, 0])!r}" if self.has_delay() and self.issiso() else (
            f", delay={self._delay.tolist()!r}" if self.has_delay() else "")
        if self.issiso():
            return f"TransferFunction(num={f(self._num[0][0])}, den={f(self._den[0][0])}, dt={self.dt!r}{extra})"
        return (f"TransferFunction(num={[[f(p) for p in r] for r in self._num]}, "
                f"den={[[f(p) for p in r] for r in self._den]}, dt={self.dt!r}{extra})")

    def __str__(self) -> str:
        var = "z" if self.dt else "s"
        out = []
        for i in range(self.noutputs):
            for j in range(self.ninputs):
                head = f"[{i},{j}]: " if not self.issiso() else ""
                dl = f" * exp(-{self._delay[i, j]:g}*{var})" if self._delay[i, j] else ""
                out.append(f"{head}({_pstr(self._num[i][j], var)}) / ({_pstr(self._den[i][j], var)}){dl}")
        return "\n".join(out) + (f"\ndt = {self.dt}" if self.dt else "")

    def __reduce__(self):
        return (TransferFunction, (self.num, self.den, self.dt, self.delay))

    # --- arithmetic
    def _coerce(self, other) -> Optional["TransferFunction"]:
        if isinstance(other, TransferFunction):
            return other
        if _is_scalar(other):
            v = complex(other)
            if v.imag != 0:
                return None
            k = v.real
            if self.issiso():
                return TransferFunction([[[k]]], [[[1.0]]], self.dt)
            n = self.ninputs
            return TransferFunction([[[k if i == j else 0.0] for j in range(n)] for i in range(n)],
                                    [[[1.0]] * n for _ in range(n)], self.dt)
        if isinstance(other, (list, tuple, _np.ndarray)):
            a = _np.asarray(other, dtype=float)
            if a.ndim == 0:
                return self._coerce(float(a))
            a = _np.atleast_2d(a)
            if a.ndim != 2:
                return None
            return TransferFunction([[[x] for x in r] for r in a], [[[1.0]] * a.shape[1] for _ in a], self.dt)
        if isinstance(other, StateSpace) or _is_control(other):
            return tf_of(other)
        return None

    def _gain_like(self, k) -> "TransferFunction":
        """A scalar k as a gain of the shape needed to add to self."""
        ny, nu = self.shape
        return TransferFunction([[[k]] * nu for _ in range(ny)], [[[1.0]] * nu for _ in range(ny)], self.dt)

    def __neg__(self) -> "TransferFunction":
        return TransferFunction([[-p for p in r] for r in self._num], self._den, self.dt, self._delay)

    def __pos__(self) -> "TransferFunction":
        return self

    def __add__(self, other):
        if _is_scalar(other) and not self.issiso():
            other = self._gain_like(float(_np.real(other)))
        o = self._coerce(other)
        if o is None:
            return NotImplemented
        return _tf_add(self, o)

    def __radd__(self, other):
        if _is_scalar(other) and not self.issiso():
            other = self._gain_like(float(_np.real(other)))
        o = self._coerce(other)
        if o is None:
            return NotImplemented
        return _tf_add(o, self)

    def __sub__(self, other):
        if _is_scalar(other) and not self.issiso():
            other = self._gain_like(float(_np.real(other)))
        o = self._coerce(other)
        if o is None:
            return NotImplemented
        return _tf_add(self, -o)

    def __rsub__(self, other):
        if _is_scalar(other) and not self.issiso():
            other = self._gain_like(float(_np.real(other)))
        o = self._coerce(other)
        if o is None:
            return NotImplemented
        return _tf_add(o, -self)

    def __mul__(self, other):
        o = self._coerce(other)
        if o is None:
            return NotImplemented
        return _tf_mul(self, o)

    def __rmul__(self, other):
        o = self._coerce(other)
        if o is None:
            return NotImplemented
        return _tf_mul(o, self)

    def __truediv__(self, other):
        o = self._coerce(other)
        if o is None:
            return NotImplemented
        return _tf_mul(self, _tf_inv(o))

    def __rtruediv__(self, other):
        o = self._coerce(other)
        if o is None:
            return NotImplemented
        return _tf_mul(o, _tf_inv(self))

    def __pow__(self, n):
        if isinstance(n, bool) or not isinstance(n, (int, _np.integer)):
            if isinstance(n, float) and n.is_integer():
                n = int(n)
            else:
                raise InputError(f"a model's power must be an integer, got {n!r}")
        n = int(n)
        if not self.issiso() and n != 1:
            if self.noutputs != self.ninputs:
                raise ModelError("only a square model has powers")
        base = self if n >= 0 else _tf_inv(self)
        out = _tf_identity(self.noutputs, self.dt)
        for _ in range(abs(n)):
            out = _tf_mul(out, base)
        return out

    # --- evaluation, indexing
    def __call__(self, x, squeeze: Optional[bool] = None):
        """The response at the complex point(s) x (s in continuous time, z in discrete time),
        delays exact: SISO a complex (or an array shaped as x), MIMO [ny, nu] (or [ny, nu, len(x)])."""
        xa = _np.asarray(x, dtype=complex)
        pts = xa.ravel()
        ny, nu = self.shape
        out = _np.empty((ny, nu, pts.size), dtype=complex)
        with _np.errstate(divide="ignore", invalid="ignore"):
            for i in range(ny):
                for j in range(nu):
                    v = _np.polyval(self._num[i][j], pts) / _np.polyval(self._den[i][j], pts)
                    tau = self._delay[i, j]
                    if tau:
                        v = v * _delay_factor(tau, pts, self.dt)
                    out[i, j] = v
        return _shape_eval(out, xa, self.issiso(), squeeze)

    def __getitem__(self, key) -> "TransferFunction":
        rows, cols = _index_lists(key, self.shape)
        return TransferFunction([[self._num[i][j] for j in cols] for i in rows],
                                [[self._den[i][j] for j in cols] for i in rows], self.dt,
                                self._delay[_np.ix_(rows, cols)])

    # --- methods (python-control's names)
    def poles(self) -> _np.ndarray:
        """Poles: the roots of the denominator (SISO; MIMO: the realization's poles)."""
        if self.issiso():
            return _np.roots(self._den[0][0]).astype(complex)
        return _skyloop.poles(_to_ss(self))

    def zeros(self) -> _np.ndarray:
        """Zeros: the roots of the numerator (SISO; MIMO: the realization's transmission zeros)."""
        if self.issiso():
            return _np.roots(self._num[0][0]).astype(complex)
        return _skyloop.zeros(_to_ss(self))

    def dcgain(self):
        """Steady-state gain: G(0) (continuous) or G(1) (discrete); a float for SISO, else [ny, nu]."""
        v = self(1.0 if self.dt else 0.0, squeeze=False)
        r = _np.real(v)
        return float(r[0, 0]) if self.issiso() else r

    def freqresp(self, omega) -> _np.ndarray:
        """Complex frequency response [ny, nu, nfreq] at ``omega`` (rad/s)."""
        w = _np.atleast_1d(_np.asarray(omega, dtype=float))
        pts = _np.exp(1j * w * self.dt) if self.dt else 1j * w
        return self(pts, squeeze=False)

    def frequency_response(self, omega):
        """python-control's ``(mag, phase_rad, omega)``; SISO squeezed to [nfreq]."""
        w = _np.atleast_1d(_np.asarray(omega, dtype=float))
        h = self.freqresp(w)
        if self.issiso():
            h = h[0, 0]
        return _np.abs(h), _np.angle(h), w

    def bode(self, omega=None) -> dict:
        from . import bode
        return bode(self, omega)

    def step(self, t=None) -> dict:
        from . import step
        return step(self, t)

    def feedback(self, other=1, sign: float = -1) -> "TransferFunction":
        """Closed loop self / (1 - sign*self*other), exact (SISO, no delay in the loop); MIMO through
        the state space."""
        o = self._coerce(other)
        if o is None:
            raise InputError(f"feedback: cannot use a {type(other).__name__} as the return path")
        if sign not in (1, -1):
            raise InputError(f"feedback sign must be +1 or -1, got {sign}")
        if self.issiso() and o.issiso():
            if self.has_delay() or o.has_delay():
                raise ModelError("feedback: a delay inside a feedback loop has no exact rational form "
                                 "(use .pade(n) on the state space first)")
            dt = _common_dt(self.dt, o.dt)
            n1, d1, n2, d2 = self._num[0][0], self._den[0][0], o._num[0][0], o._den[0][0]
            num = _pmul(n1, d2)
            den = _padd(_pmul(d1, d2), -sign * _pmul(n1, n2))
            return TransferFunction([[num]], [[den]], dt)
        return tf_of(_skyloop.feedback(_to_ss(self), _to_ss(o), float(sign)))

    def minreal(self, tol: Optional[float] = None) -> "TransferFunction":
        """Cancels pole-zero pairs closer than ``tol`` (default sqrt(eps), relative to their size)."""
        tol = _np.sqrt(_EPS) if tol is None else float(tol)
        num, den = [], []
        for rn, rd in zip(self._num, self._den):
            nr, dr = [], []
            for n, d in zip(rn, rd):
                n2, d2 = _cancel(n, d, tol)
                nr.append(n2)
                dr.append(d2)
            num.append(nr)
            den.append(dr)
        return TransferFunction(num, den, self.dt, self._delay)

    def c2d(self, dt: float, method: str = "zoh", prewarp: Optional[float] = None) -> "TransferFunction":
        from . import c2d
        return tf_of(c2d(_to_ss(self), dt, method, prewarp))

    sample = c2d

    def hinf_norm(self) -> Tuple[float, float]:
        from . import hinf_norm
        return hinf_norm(self)

    def h2_norm(self) -> float:
        from . import h2_norm
        return h2_norm(self)

    def to_ss(self) -> StateSpace:
        """The state-space realization (needs the model proper)."""
        return _to_ss(self)

    def to_control(self, pade: Optional[int] = None) -> Any:
        """A ``control.TransferFunction`` (delays need ``pade``: a Padé approximant of that order)."""
        import control  # noqa: PLC0415

        if self.has_delay():
            return control.tf(_to_ss(self).to_control(pade=pade))
        return control.tf(self.num, self.den, None if self.dt == 0 else self.dt)


def _pstr(p, var: str) -> str:
    n = p.size - 1
    terms = []
    for k, c in enumerate(p):
        e = n - k
        if c == 0 and p.size > 1:
            continue
        t = f"{c:g}"
        if e >= 1:
            v = var + (f"^{e}" if e > 1 else "")
            t = v if c == 1 else (f"-{v}" if c == -1 else f"{t}*{v}")
        terms.append(t)
    if not terms:
        return "0"
    out = terms[0]
    for t in terms[1:]:
        out += f" - {t[1:]}" if t.startswith("-") else f" + {t}"
    return out


def _nested(x) -> List[List[Any]]:
    """num/den as python-control takes them: a number, a 1-D list (SISO), or lists of lists."""
    if _is_scalar(x):
        return [[_np.array([float(_np.real(x))])]]
    if isinstance(x, _np.ndarray) and x.ndim == 1:
        return [[x]]
    if isinstance(x, (list, tuple)):
        if len(x) == 0:
            raise InputError("an empty polynomial")
        if all(_is_scalar(v) for v in x):
            return [[_np.asarray(x, dtype=float)]]
        if all(isinstance(r, (list, tuple)) for r in x):
            return [[_np.atleast_1d(_np.asarray(p, dtype=float)) for p in r] for r in x]
    if isinstance(x, _np.ndarray) and x.ndim == 3:
        return [[x[i, j] for j in range(x.shape[1])] for i in range(x.shape[0])]
    raise InputError(f"cannot read a polynomial (array) from {x!r}")


def _delay_factor(tau: float, pts, dt: float):
    if dt:
        k = tau / dt
        return pts ** (-k)
    return _np.exp(-tau * pts)


def _shape_eval(out, xa, siso: bool, squeeze):
    """python-control's squeeze rule: SISO -> shape of x; MIMO -> [ny, nu] or [ny, nu, n]."""
    if squeeze is False:
        return out if xa.ndim else out[:, :, 0]
    if siso:
        v = out[0, 0]
        return complex(v[0]) if xa.ndim == 0 else v.reshape(xa.shape)
    return out[:, :, 0] if xa.ndim == 0 else out


def _index_lists(key, shape) -> Tuple[List[int], List[int]]:
    if not isinstance(key, tuple):
        key = (key, slice(None))
    if len(key) != 2:
        raise InputError("index a model with [outputs, inputs]")

    def one(k, n):
        if isinstance(k, slice):
            return list(range(n))[k]
        if isinstance(k, (int, _np.integer)):
            i = int(k)
            if not -n <= i < n:
                raise IndexError(f"index {i} out of range for {n}")
            return [i % n]
        idx = [int(v) for v in k]
        for i in idx:
            if not -n <= i < n:
                raise IndexError(f"index {i} out of range for {n}")
        return [i % n for i in idx]

    return one(key[0], shape[0]), one(key[1], shape[1])


def _cancel(n, d, tol):
    """Cancels common roots of n and d (|z - p| <= tol * max(1, |p|)), keeping the leading ratio."""
    if n.size == 1 or d.size == 1:
        return n, d
    z = list(_np.roots(n))
    p = list(_np.roots(d))
    keep_z = []
    for zz in z:
        j = min(range(len(p)), key=lambda k: abs(p[k] - zz)) if p else None
        if j is not None and abs(p[j] - zz) <= tol * max(1.0, abs(p[j])):
            p.pop(j)
        else:
            keep_z.append(zz)
    kn = n[0] / d[0]
    num = kn * _np.real(_np.poly(keep_z)) if keep_z else _np.array([kn])
    den = _np.real(_np.poly(p)) if p else _np.array([1.0])
    return _trim(num), _trim(den)


def _tf_identity(n: int, dt: float) -> TransferFunction:
    return TransferFunction([[[1.0 if i == j else 0.0] for j in range(n)] for i in range(n)],
                            [[[1.0]] * n for _ in range(n)], dt)


def _add_siso(n1, d1, n2, d2):
    if _is_zero(n1):
        return n2, d2
    if _is_zero(n2):
        return n1, d1
    if d1.size == d2.size and _np.array_equal(d1, d2):
        return _padd(n1, n2), d1.copy()
    return _padd(_pmul(n1, d2), _pmul(n2, d1)), _pmul(d1, d2)


def _tf_add(a: TransferFunction, b: TransferFunction) -> TransferFunction:
    if a.shape != b.shape:
        if a.issiso() or b.issiso():
            raise ModelError(f"cannot add a {a.shape[0]}x{a.shape[1]} and a {b.shape[0]}x{b.shape[1]} model")
        raise ModelError(f"cannot add a {a.shape[0]}x{a.shape[1]} and a {b.shape[0]}x{b.shape[1]} model")
    dt = _common_dt(a.dt, b.dt)
    ny, nu = a.shape
    num = [[None] * nu for _ in range(ny)]
    den = [[None] * nu for _ in range(ny)]
    delay = _np.zeros((ny, nu))
    for i in range(ny):
        for j in range(nu):
            n1, d1, n2, d2 = a._num[i][j], a._den[i][j], b._num[i][j], b._den[i][j]
            t1, t2 = a._delay[i, j], b._delay[i, j]
            if _is_zero(n1):
                t1 = t2
            if _is_zero(n2):
                t2 = t1
            if t1 != t2:
                raise ModelError("the sum of two channels with different delays has no exact rational form "
                                 f"(delays {t1} s and {t2} s); approximate one with .pade(n) first")
            num[i][j], den[i][j] = _add_siso(n1, d1, n2, d2)
            delay[i, j] = t1
    return TransferFunction(num, den, dt, delay)


def _tf_mul(a: TransferFunction, b: TransferFunction) -> TransferFunction:
    """a * b: b first, then a (python-control's order); a SISO factor scales every channel."""
    dt = _common_dt(a.dt, b.dt)
    if a.issiso() and not b.issiso():
        a = _tf_diag(a, b.noutputs)
    elif b.issiso() and not a.issiso():
        b = _tf_diag(b, a.ninputs)
    if a.ninputs != b.noutputs:
        raise ModelError(f"cannot multiply a {a.shape[0]}x{a.shape[1]} by a {b.shape[0]}x{b.shape[1]} model")
    ny, nk, nu = a.noutputs, a.ninputs, b.ninputs
    num = [[None] * nu for _ in range(ny)]
    den = [[None] * nu for _ in range(ny)]
    delay = _np.zeros((ny, nu))
    for i in range(ny):
        for j in range(nu):
            n, d, tau = _np.zeros(1), _np.ones(1), None
            for k in range(nk):
                pn = _pmul(a._num[i][k], b._num[k][j])
                pd = _pmul(a._den[i][k], b._den[k][j])
                if _is_zero(pn):
                    continue
                t = a._delay[i, k] + b._delay[k, j]
                if tau is not None and t != tau:
                    raise ModelError("this product sums channels with different delays, which has no exact "
                                     "rational form; approximate with .pade(n) first")
                tau = t
                n, d = _add_siso(n, d, pn, pd)
            num[i][j], den[i][j] = n, d
            delay[i, j] = tau or 0.0
    return TransferFunction(num, den, dt, delay)


def _tf_diag(g: TransferFunction, n: int) -> TransferFunction:
    z, one = _np.zeros(1), _np.ones(1)
    num = [[g._num[0][0] if i == j else z for j in range(n)] for i in range(n)]
    den = [[g._den[0][0] if i == j else one for j in range(n)] for i in range(n)]
    delay = _np.eye(n) * g._delay[0, 0]
    return TransferFunction(num, den, g.dt, delay)


def _tf_inv(g: TransferFunction) -> TransferFunction:
    if g.issiso():
        if _is_zero(g._num[0][0]):
            raise ModelError("division by a zero transfer function")
        return TransferFunction([[g._den[0][0]]], [[g._num[0][0]]], g.dt, -g._delay)
    if g.noutputs != g.ninputs:
        raise ModelError("only a square model has an inverse")
    if g.has_delay():
        raise ModelError("the inverse of a MIMO model with delays has no exact form")
    return tf_of(_ss_inv(_to_ss(g)))


# ---------------------------------------------------------------------------------------------
# realization and conversion

def _realize_siso(num, den):
    """Controllable canonical form of a proper num/den: (A, B, C, D)."""
    lead = den[0]
    a = den / lead
    n = a.size - 1
    b = _np.concatenate([_np.zeros(a.size - num.size), num / lead])
    D = b[0]
    if n == 0:
        return _np.zeros((0, 0)), _np.zeros((0, 1)), _np.zeros((1, 0)), _np.array([[D]])
    A = _np.zeros((n, n))
    A[0, :] = -a[1:]
    A[1:, :-1] = _np.eye(n - 1)
    B = _np.zeros((n, 1))
    B[0, 0] = 1.0
    C = (b[1:] - D * a[1:]).reshape(1, n)
    return A, B, C, _np.array([[D]])


def _split_delays(delay):
    """delay[i, j] = out[i] + in[j] with in, out >= 0, or None."""
    ny, nu = delay.shape
    inp = delay.min(axis=0)
    out = delay[:, 0] - inp[0]
    if _np.allclose(out[:, None] + inp[None, :], delay, rtol=1e-12, atol=1e-15) and _np.all(out >= 0):
        return list(map(float, inp)), list(map(float, out))
    return None


def _to_ss(sys) -> StateSpace:
    """Any model as the Rust StateSpace: itself, a realization of a proper TransferFunction, a
    python-control model converted, or an expression parsed."""
    if isinstance(sys, StateSpace):
        return sys
    if isinstance(sys, TransferFunction):
        if not sys.is_proper():
            raise ModelError("the transfer function is improper (a numerator degree above its "
                             "denominator's): it has no state-space form; this function needs one")
        if _np.any(sys._delay < 0):
            raise ModelError("a negative delay (a prediction) has no state-space form")
        ny, nu = sys.shape
        parts = [[_realize_siso(sys._num[i][j], sys._den[i][j]) for j in range(nu)] for i in range(ny)]
        nx = sum(p[0].shape[0] for r in parts for p in r)
        A = _np.zeros((nx, nx))
        B = _np.zeros((nx, nu))
        C = _np.zeros((ny, nx))
        D = _np.zeros((ny, nu))
        k = 0
        for i in range(ny):
            for j in range(nu):
                a, b, c, d = parts[i][j]
                m = a.shape[0]
                A[k:k + m, k:k + m] = a
                B[k:k + m, j:j + 1] = b
                C[i:i + 1, k:k + m] = c
                D[i, j] = d[0, 0]
                k += m
        ind = outd = None
        if sys.has_delay():
            sp = _split_delays(sys._delay)
            if sp is None:
                raise ModelError("these channel delays are not an input delay plus an output delay: "
                                 "no state-space form with exact delays")
            ind, outd = sp
        out = _skyloop._ss(A, B, C, D, sys.dt, ind, outd)
        if not sys.issiso() and nx:
            # channel by channel is not minimal for MIMO (shared poles repeat): python-control's
            # realization is minimal, so is this one (minreal keeps the response, see its docstring)
            from . import minreal
            out = minreal(out)
        return out
    if isinstance(sys, str):
        from . import tf
        return _to_ss(tf(sys))
    if _is_scalar(sys) or isinstance(sys, (list, tuple, _np.ndarray)):
        k = _np.asarray(sys, dtype=float)
        if k.ndim <= 2 and k.size:
            return _gain_ss(k, 0.0)
    if _is_control(sys):
        from . import from_control
        return from_control(sys)
    raise InputError(f"expected a skyloop model (StateSpace, TransferFunction), an expression or a "
                     f"python-control model, got {type(sys).__name__}")


def _char_poly(A) -> _np.ndarray:
    if A.shape[0] == 0:
        return _np.ones(1)
    return _np.real(_np.poly(A))


def tf_of(sys) -> TransferFunction:
    """Any model as a TransferFunction (a state space converted channel by channel, exact delays kept)."""
    if isinstance(sys, TransferFunction):
        return sys
    if _is_control(sys):
        import control  # noqa: PLC0415

        if isinstance(sys, control.TransferFunction):
            dt = _dt_of(sys.dt)
            return TransferFunction([[_np.asarray(p, float) for p in r] for r in sys.num],
                                    [[_np.asarray(p, float) for p in r] for r in sys.den], dt)
    ss_ = _to_ss(sys)
    A, B, C, D = ss_.A, ss_.B, ss_.C, ss_.D
    ny, nu = D.shape
    num, den = [], []
    for i in range(ny):
        nr, dr = [], []
        for j in range(nu):
            a, b, c, d = _channel_min(A, B[:, j:j + 1], C[i:i + 1, :], D[i, j])
            pa = _char_poly(a)
            n = _np.real(_char_poly(a - b @ c)) - pa if a.shape[0] else _np.zeros(1)
            n = _np.polyadd(n, d * pa)
            # The leading coefficient of det(sI-A+bc) - det(sI-A) cancels exactly; roundoff leaves
            # the others: drop leading terms below eps * the size of the polynomial.
            n = _trim(n)
            scale = max(float(_np.max(_np.abs(n))), float(_np.max(_np.abs(pa))))
            while n.size > 1 and abs(n[0]) <= 1e-12 * scale:
                n = n[1:]
            nr.append(n)
            dr.append(pa)
        num.append(nr)
        den.append(dr)
    delay = _np.add.outer(ss_.output_delay, ss_.input_delay)
    return TransferFunction(num, den, ss_.dt, delay)


def _channel_min(A, b, c, d):
    """The controllable and observable part of one channel (staircase by SVD), so its transfer
    function has no spurious pole-zero pairs."""
    n = A.shape[0]
    if n == 0:
        return A, b, c, d
    # controllable subspace
    K = b.copy()
    basis = _orth(K)
    for _ in range(n):
        K = _np.hstack([basis, A @ basis])
        nb = _orth(K)
        if nb.shape[1] == basis.shape[1]:
            break
        basis = nb
    if basis.shape[1] == 0:
        return _np.zeros((0, 0)), _np.zeros((0, 1)), _np.zeros((1, 0)), d
    A1, b1, c1 = basis.T @ A @ basis, basis.T @ b, c @ basis
    # observable subspace
    O = c1.T.copy()
    ob = _orth(O)
    for _ in range(A1.shape[0]):
        O = _np.hstack([ob, A1.T @ ob])
        nb = _orth(O)
        if nb.shape[1] == ob.shape[1]:
            break
        ob = nb
    if ob.shape[1] == 0:
        return _np.zeros((0, 0)), _np.zeros((0, 1)), _np.zeros((1, 0)), d
    return ob.T @ A1 @ ob, ob.T @ b1, c1 @ ob, d


def _orth(M):
    if M.size == 0:
        return _np.zeros((M.shape[0], 0))
    u, sv, _ = _np.linalg.svd(M, full_matrices=False)
    if sv.size == 0 or sv[0] == 0:
        return _np.zeros((M.shape[0], 0))
    r = int(_np.sum(sv > max(M.shape) * _EPS * 1e3 * sv[0]))
    return u[:, :r]


def _ss_inv(g: StateSpace) -> StateSpace:
    """The inverse of a square state space with an invertible D (else ModelError)."""
    D = g.D
    if D.shape[0] != D.shape[1]:
        raise ModelError("only a square model has an inverse")
    if g.has_delay():
        raise ModelError("the inverse of a delay is a prediction: no state-space form")
    if _np.linalg.matrix_rank(D) < D.shape[0]:
        raise ModelError("the inverse is improper (D singular): convert with skyloop.tf(sys) to divide exactly")
    Di = _np.linalg.inv(D)
    A, B, C = g.A, g.B, g.C
    return _skyloop._ss(A - B @ Di @ C, B @ Di, -Di @ C, Di, g.dt, None, None)


# ---------------------------------------------------------------------------------------------
# the StateSpace's Python half (called from the Rust class)

def _ss_binop(op: str, me: StateSpace, other):
    """The Rust StateSpace's operators for what Rust does not handle: TransferFunction, python-control
    objects, ``/`` and ``**``."""
    if op == "pow":
        n = other
        if isinstance(n, float) and n.is_integer():
            n = int(n)
        if isinstance(n, bool) or not isinstance(n, (int, _np.integer)):
            raise InputError(f"a model's power must be an integer, got {other!r}")
        n = int(n)
        base = me if n >= 0 else _ss_inv(me)
        if me.noutputs != me.ninputs:
            raise ModelError("only a square model has powers")
        out = _skyloop._ss(_np.zeros((0, 0)), _np.zeros((0, me.ninputs)), _np.zeros((me.noutputs, 0)),
                           _np.eye(me.noutputs), me.dt, None, None)
        for _ in range(abs(n)):
            out = base * out
        return out
    if isinstance(other, TransferFunction):
        if other.is_proper():
            other = _to_ss(other)
        else:
            return _tf_op(op, tf_of(me), other)
    elif _is_control(other):
        import control  # noqa: PLC0415

        if isinstance(other, control.FrequencyResponseData):
            return NotImplemented
        other = _to_ss(other)
    elif isinstance(other, (list, tuple)):
        other = _np.atleast_2d(_np.asarray(other, dtype=float))
    elif isinstance(other, _np.ndarray) and other.dtype != float:
        other = _np.asarray(other, dtype=float)
    if op == "truediv":
        if _is_scalar(other):
            return me * (1.0 / float(_np.real(other)))
        o = _to_ss(other) if not isinstance(other, _np.ndarray) else _gain_ss(other, me.dt)
        if o.noutputs == 1 and o.ninputs == 1 and me.ninputs > 1:
            return me * _ss_inv_or_tf(o)
        return me * _ss_inv_or_tf(o)
    if op == "rtruediv":
        inv = _ss_inv_or_tf(me)
        return other * inv
    if isinstance(other, _np.ndarray) and other.ndim == 2:
        other = _gain_ss(other, me.dt)
    if not isinstance(other, StateSpace):
        return NotImplemented
    return {"mul": lambda: me * other, "rmul": lambda: other * me, "add": lambda: me + other,
            "radd": lambda: other + me, "sub": lambda: me - other, "rsub": lambda: other - me}[op]()


def _tf_op(op, a: TransferFunction, b: TransferFunction):
    return {"mul": lambda: a * b, "rmul": lambda: b * a, "add": lambda: a + b, "radd": lambda: b + a,
            "sub": lambda: a - b, "rsub": lambda: b - a, "truediv": lambda: a / b,
            "rtruediv": lambda: b / a}[op]()


def _gain_ss(k, dt: float) -> StateSpace:
    k = _np.atleast_2d(_np.asarray(k, dtype=float))
    return _skyloop._ss(_np.zeros((0, 0)), _np.zeros((0, k.shape[1])), _np.zeros((k.shape[0], 0)),
                        _np.ascontiguousarray(k), dt, None, None)


def _ss_inv_or_tf(g: StateSpace):
    try:
        return _ss_inv(g)
    except ModelError:
        if g.has_delay() and g.noutputs * g.ninputs != 1:
            raise
        return _tf_inv(tf_of(g))


def _ss_eval(g: StateSpace, pts) -> _np.ndarray:
    """[ny, nu, n] response of a state space at complex points, delays exact."""
    A, B, C, D = g.A, g.B, g.C, g.D
    ny, nu = D.shape
    n = A.shape[0]
    out = _np.empty((ny, nu, pts.size), dtype=complex)
    eye = _np.eye(n)
    for k, x in enumerate(pts):
        if n:
            try:
                out[:, :, k] = C @ _np.linalg.solve(x * eye - A, B) + D
            except _np.linalg.LinAlgError:
                out[:, :, k] = _np.inf
        else:
            out[:, :, k] = D
    if g.has_delay():
        for i, to in enumerate(g.output_delay):
            for j, ti in enumerate(g.input_delay):
                if to + ti:
                    out[i, j] *= _delay_factor(to + ti, pts, g.dt)
    return out


def _ss_call(me: StateSpace, x, squeeze=None):
    xa = _np.asarray(x, dtype=complex)
    out = _ss_eval(me, xa.ravel())
    return _shape_eval(out, xa, me.noutputs == 1 and me.ninputs == 1, squeeze)


def _ss_getitem(me: StateSpace, key) -> StateSpace:
    rows, cols = _index_lists(key, (me.noutputs, me.ninputs))
    return _skyloop.subsystem(me, rows, cols)


_SS_METHODS = ("poles", "zeros", "dcgain", "freqresp", "bode", "step", "feedback", "minreal", "c2d",
               "hinf_norm", "h2_norm", "margins", "allmargin", "diskmargin", "balred", "hsvd", "lft")


def _ss_getattr(me: StateSpace, name: str):
    if name in _SS_METHODS or name in ("sample", "frequency_response", "to_ss", "issiso", "isdtime",
                                       "shape", "is_proper"):
        import skyloop  # noqa: PLC0415

        if name == "sample":
            name = "c2d"
        if name == "to_ss":
            return lambda: me
        if name == "issiso":
            return lambda: me.noutputs == 1 and me.ninputs == 1
        if name == "isdtime":
            return lambda: me.dt > 0
        if name == "is_proper":
            return lambda: True
        if name == "shape":
            return (me.noutputs, me.ninputs)
        if name == "frequency_response":
            def fr(omega):
                w = _np.atleast_1d(_np.asarray(omega, dtype=float))
                h = skyloop.freqresp(me, w)
                if me.noutputs == 1 and me.ninputs == 1:
                    h = h[0, 0]
                return _np.abs(h), _np.angle(h), w
            return fr
        f = getattr(skyloop, name)

        def method(*args, **kwargs):
            return f(me, *args, **kwargs)
        method.__name__ = name
        method.__doc__ = f.__doc__
        return method
    raise AttributeError(f"'skyloop.StateSpace' object has no attribute '{name}'")


# ---------------------------------------------------------------------------------------------
# scaling

def balance(sys: StateSpace) -> StateSpace:
    """The same model under a diagonal state similarity of powers of 2 (exact in floating point)
    that equalizes the off-diagonal row and column norms of A (LAPACK dgebal's scaling, without
    permutations; B and C are scaled with it), so that badly scaled realizations (python-control's
    mixsyn closed loops, ||A|| ~ 1e12) spoil eigenvalues, rank decisions and norms less. The response
    is unchanged.

    >>> import skyloop as sk
    >>> G = sk.ss([[-1.0, 1e6], [1e-6, -2.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
    >>> Gb = sk.balance(G)
    >>> float(abs(Gb.A).max()) < 4, round(Gb.dcgain() / G.dcgain(), 12)
    (True, 1.0)
    """
    sys = _to_ss(sys)
    A, B, C = sys.A, sys.B, sys.C
    n = A.shape[0]
    if n == 0:
        return sys
    d = _np.ones(n)
    Ab, Bb, Cb = A.copy(), B.copy(), C.copy()
    for _ in range(100):
        changed = False
        for i in range(n):
            off_c = _np.sum(_np.abs(Ab[:, i])) - abs(Ab[i, i])
            off_r = _np.sum(_np.abs(Ab[i, :])) - abs(Ab[i, i])
            if off_c == 0 or off_r == 0:
                continue
            f = 1.0
            c, r = off_c, off_r
            s = c + r
            while c < r / 2:
                c *= 2
                r /= 2
                f *= 2
            while c >= r * 2:
                c /= 2
                r *= 2
                f /= 2
            if (c + r) < 0.95 * s:
                changed = True
                d[i] *= f
                Ab[:, i] *= f
                Ab[i, :] /= f
                Cb[:, i] *= f
                Bb[i, :] /= f
        if not changed:
            break
    return _skyloop._ss(Ab, Bb, Cb, sys.D, sys.dt, list(sys.input_delay), list(sys.output_delay))


def _dense_grid(g: StateSpace) -> _np.ndarray:
    """Frequencies (rad/s) covering every mode of g, 40 a decade, two decades beyond each end."""
    lam = _np.abs(_np.linalg.eigvals(g.A)) if g.nstates else _np.ones(1)
    lam = lam[lam > 0]
    lo, hi = (lam.min() / 100, lam.max() * 100) if lam.size else (1e-2, 1e2)
    if g.dt:
        hi = min(hi, _np.pi / g.dt)
        lo = min(lo, hi / 10)
    n = int(max(40 * _np.log10(hi / lo), 200))
    return _np.concatenate([[0.0], _np.logspace(_np.log10(lo), _np.log10(hi), n)])


def _sigma_max_at(g: StateSpace, w: _np.ndarray) -> _np.ndarray:
    pts = _np.exp(1j * w * g.dt) if g.dt else 1j * w
    with _np.errstate(all="ignore"):
        h = _ss_eval(g, pts)
    return _np.array([_np.linalg.svd(h[:, :, k], compute_uv=False)[0] if _np.all(_np.isfinite(h[:, :, k]))
                      else _np.inf for k in range(w.size)])


def _stable_dense(g: StateSpace) -> bool:
    """Stability decided on the eigenvalues of A computed five ways (LAPACK dgeev on A, on A^T and on
    A balanced by :func:`balance`, skyloop's own on A and on A balanced): on a badly scaled realization (||A|| ~ 1e12)
    the eigenvalues near the imaginary axis are ill-conditioned, and one computation may show a
    spurious unstable pole that the others do not; a model is stable when one of them shows every
    pole stable. On well-conditioned models they agree."""
    if g.nstates == 0:
        return True

    def ok(lam):
        return bool(_np.all(_np.abs(lam) < 1.0)) if g.dt else bool(_np.all(lam.real < 0))

    for get in (lambda: _np.linalg.eigvals(g.A), lambda: _np.linalg.eigvals(g.A.T),
                lambda: _np.linalg.eigvals(balance(g).A), lambda: _skyloop.poles(g),
                lambda: _skyloop.poles(balance(g))):
        try:
            if ok(get()):
                return True
        except (_np.linalg.LinAlgError, ModelError):
            continue
    return False


def _hinf_check(g: StateSpace, n: float, wp: float, stable: bool) -> Tuple[float, float]:
    """Cross-checks the Rust H-infinity norm on a dense grid evaluated by LU solves (numpy): on badly
    scaled models (||A|| ~ 1e12) the Rust answer may call a stable model unstable (a slow pole
    within 1e-7 ||A|| of 0 taken for an integrator) or miss the peak; the grid's refined peak is
    returned then."""
    if g.nstates == 0 or g.nstates > 200:
        return n, wp
    if not stable:
        return float("inf"), float("nan")
    if _np.isfinite(n) and _np.max(_np.abs(g.A)) < 1e8:
        return n, wp   # well scaled: the library's answer stands
    w = _dense_grid(g)
    sv = _sigma_max_at(g, w)
    if not _np.all(_np.isfinite(sv)):
        return n, wp
    k = int(_np.argmax(sv))
    peak = float(sv[k])
    if _np.isfinite(n) and peak <= n * (1 + 1e-6):
        return n, wp
    # refine the grid's peak (golden section on log w between the neighbours)
    if k == 0:
        return peak, 0.0
    a = _np.log(w[max(k - 1, 1)])
    b = _np.log(w[min(k + 1, w.size - 1)])
    gr = (_np.sqrt(5) - 1) / 2
    f = lambda x: float(_sigma_max_at(g, _np.array([_np.exp(x)]))[0])  # noqa: E731
    c, d = b - gr * (b - a), a + gr * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(60):
        if fc > fd:
            b, d, fd = d, c, fc
            c = b - gr * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + gr * (b - a)
            fd = f(d)
    x = (a + b) / 2
    best = max(peak, f(x))
    return best, float(_np.exp(x)) if best > peak else float(w[k])


def _dcgain_dense(g: StateSpace, rust: _np.ndarray) -> _np.ndarray:
    """G(0) (G(1) in discrete time) by a dense LU solve, where the Rust answer was not finite because
    a slow pole looked like an integrator against a huge ||A||."""
    A = g.A - _np.eye(g.nstates) if g.dt else g.A
    if g.nstates == 0:
        return g.D
    lam = _np.abs(_np.linalg.eigvals(A))
    if lam.min() <= 1e-14 * max(lam.max(), 1.0):
        return rust
    return g.D - g.C @ _np.linalg.solve(A, g.B)
