#!/usr/bin/env python3
"""Reference fixtures for skyloop-lti from python-control 0.10.2 + slycot + scipy.

Writes crates/skyloop-lti/tests/fixtures/lti/*.json: ss2tf, zeros, poles, c2d (zoh, foh, tustin,
tustin with prewarp, matched), step responses and Pade coefficients. Matrices are row-major lists.
Run: python3 tools/gen_lti.py
"""
import json
import os

import control
import numpy as np

OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-lti", "tests", "fixtures", "lti")
os.makedirs(OUT, exist_ok=True)
rng_seed = 20261123


def mat(m):
    return np.atleast_2d(np.asarray(m, dtype=float)).tolist()


def ss_json(s):
    return {"a": mat(s.A), "b": mat(s.B), "c": mat(s.C), "d": mat(s.D), "dt": float(s.dt or 0.0)}


def cplx(v):
    v = np.asarray(v, dtype=complex)
    return {"re": v.real.tolist(), "im": v.imag.tolist()}


def write(name, obj):
    with open(os.path.join(OUT, name), "w") as f:
        json.dump({"source": f"python-control {control.__version__} + slycot/scipy, tools/gen_lti.py", **obj}, f)


np.random.seed(rng_seed)

# Random stable systems: (states, outputs, inputs).
shapes = [(3, 1, 1), (5, 1, 1), (8, 1, 1), (4, 2, 2), (6, 3, 2), (5, 2, 3), (7, 2, 2)]
systems = []
for n, p, m in shapes:
    s = control.rss(n, p, m)
    # Make D non-zero on half of the systems so both relative degrees are exercised.
    if len(systems) % 2 == 1:
        s = control.ss(s.A, s.B, s.C, np.random.randn(p, m))
    systems.append(s)

# ss2tf (slycot tb04ad through python-control), entry by entry.
cases = []
for s in systems:
    tf = control.ss2tf(s)
    cases.append({
        "sys": ss_json(s),
        "num": [[np.atleast_1d(tf.num[i][j]).tolist() for j in range(s.ninputs)] for i in range(s.noutputs)],
        "den": [[np.atleast_1d(tf.den[i][j]).tolist() for j in range(s.ninputs)] for i in range(s.noutputs)],
    })
write("ss2tf.json", {"cases": cases})

# Poles and transmission zeros (slycot ab08nd), including a degenerate non-square case.
cases = []
extra = control.ss([[-1.0]], [[1.0]], [[1.0], [1.0]], [[1.0], [1.0]])
for s in systems + [extra]:
    cases.append({"sys": ss_json(s), "poles": cplx(s.poles()), "zeros": cplx(s.zeros())})
write("zeros.json", {"cases": cases})

# c2d: python-control sample_system (scipy cont2discrete) for state space.
cases = []
for s in systems:
    for dt in (0.05, 0.3):
        for method, w in (("zoh", None), ("foh", None), ("tustin", None), ("tustin", 2.0)):
            sd = control.sample_system(s, dt, method=method, prewarp_frequency=w)
            cases.append({"sys": ss_json(s), "dt": dt, "method": method, "prewarp_rad_s": w, "out": ss_json(sd)})
write("c2d.json", {"cases": cases})

# matched (SISO transfer functions).
cases = []
for s in systems:
    if s.ninputs == 1 and s.noutputs == 1:
        g = control.ss2tf(s)
        for dt in (0.05, 0.3):
            gd = control.sample_system(g, dt, method="matched")
            cases.append({"sys": ss_json(s), "dt": dt, "num": np.atleast_1d(gd.num[0][0]).tolist(),
                          "den": np.atleast_1d(gd.den[0][0]).tolist()})
write("matched.json", {"cases": cases})

# Step responses on a fixed grid.
cases = []
for s in systems:
    t = np.linspace(0.0, 10.0, 201)
    r = control.step_response(s, T=t, squeeze=False)
    cases.append({"sys": ss_json(s), "t": t.tolist(), "y": np.asarray(r.outputs).tolist()})
write("step.json", {"cases": cases})

# Pade approximants (python-control pade, documented as MATLAB-equal).
cases = []
for T in (0.032, 0.1, 1.0, 2.5):
    for n in (1, 2, 3, 5, 8):
        num, den = control.pade(T, n)
        cases.append({"t": T, "n": n, "num": list(map(float, num)), "den": list(map(float, den))})
write("pade.json", {"cases": cases})
print("wrote", OUT)
