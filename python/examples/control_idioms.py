"""skyloop written the way python-control users already write it (checked by mypy in CI).

    python examples/control_idioms.py            # prints the values, writes four PNG figures
"""
from __future__ import annotations

import numpy as np

import skyloop as sk

s = sk.tf("s")
G = 4 / (s * (s + 1) * (0.1 * s + 1))                 # an exact rational model
P = sk.tf("exp(-0.02*s)/(s**2 + 0.8*s + 4)")          # an expression with an exact delay
C = 2 + 1 / s                                         # a PI controller, improper-free
L = P * C                                             # series: C first, then P
T = sk.feedback(G)                                    # G / (1 + G), exact polynomials

print("poles of T:", np.sort_complex(T.poles()))
print("zeros of G:", G.zeros())
print("dc gain of T:", T.dcgain())                    # a float for a SISO model
print("G(1j) =", G(1j))
w = np.logspace(-1, 2, 5)
print("|L(jw)|:", np.abs(L(1j * w)))
print("freqresp shape:", sk.freqresp(L, w).shape)     # [ny, nu, nfreq]
m = sk.margins(L)
print(f"PM {m['phase_margin_deg']:.1f} deg, GM {m['gain_margin_db']:.2f} dB, disk alpha {sk.diskmargin(L)['alpha']:.3f}")
print("H-infinity norm of T:", T.hinf_norm())

# MIMO: indexing, numpy gains as series connections
M = sk.tf([[[1.0], [2.0, 1.0]], [[1.0, 0.0], [3.0]]], [[[1.0, 1.0], [1.0, 2.0, 5.0]], [[1.0, 4.0], [1.0, 0.5]]])
Ms = sk.ss(M)
print("M[0, 1](1j) =", M[0, 1](1j))
scaled = np.diag([1.0, 10.0]) * Ms                   # a series connection, not an object array
print("scaled is a", type(scaled).__name__)

# discrete time
z = sk.tf("z", 0.01)
H = (z - 0.5) / (z**2 - 1.5 * z + 0.7)
print("H dc gain:", H.dcgain(), " G sampled:", G.feedback().c2d(0.01).dcgain())

# synthesis, python-control's shapes
# x' = -x + w + u; z = [x, 0.1 u]; y = x + 0.1 w
Pgen = sk.ss([[-1.0]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]], [[0.0, 0.0], [0.0, 0.1], [0.1, 0.0]])
K, CL, gamma, rcond = sk.hinfsyn(Pgen, 1, 1)
print(f"hinfsyn gamma {gamma:.4f}, closed-loop norm {sk.hinf_norm(CL)[0]:.4f}")

try:
    import skyloop.plot as skplot
except ImportError:  # pragma: no cover
    skplot = None  # type: ignore[assignment]
if skplot is not None:
    try:
        for name, fig in [("bode", skplot.bode(L, margins=True)), ("nyquist", skplot.nyquist(L)),
                          ("step", skplot.step(T)), ("sigma", skplot.sigma(Ms)), ("nichols", skplot.nichols(L))]:
            fig.savefig(f"control_idioms_{name}.png", dpi=80)
    except ImportError as e:
        print(e)
