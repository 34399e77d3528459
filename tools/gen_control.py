#!/usr/bin/env python3
"""Reference outputs for skyloop-control: continuous designs discretized with scipy, run with dlsim.

Writes crates/skyloop-control/tests/fixtures/control/control.json. Run from the repo root:
    python3 tools/gen_control.py
"""
import json
import numpy as np
from scipy import signal

rng = np.random.default_rng(6)
N = 400
out = {}

# 1) Bicopter H-infinity controller, eq. (12) of Li et al. (000_...txt), Tustin at 250 Hz (Step 5 of the paper).
dt = 1.0 / 250.0
k = 24.02
z = [-54.01, -0.2474] + list(np.roots([1, 139.3, 2.624e4]))
p = [0.0] + list(np.roots([1, 24.14, 8544])) + list(np.roots([1, 232.4, 7.041e4]))
num, den = signal.zpk2tf(z, p, k)
a, b, c, d = signal.tf2ss(num, den)
ad, bd, cd, dd, _ = signal.cont2discrete((a, b, c, d), dt, method="bilinear")
e = rng.standard_normal(N) * 0.5
_, y, _ = signal.dlsim((ad, bd, cd, dd, dt), e)
zd, pd, kd, _ = signal.cont2discrete((z, p, k), dt, method="bilinear")
sos = signal.zpk2sos(zd, pd, kd)
out["hinf_bicopter"] = {
    "source": "eq. (12) of 000_72ec9ee75feda2b7.txt, scipy cont2discrete bilinear dt=1/250, dlsim",
    "dt": dt,
    "a": ad.tolist(), "b": bd.tolist(), "c": cd.tolist(), "d": dd.tolist(),
    "sos": sos.tolist(),
    "input": e.tolist(),
    "output": y[:, 0].tolist(),
}

# 2) PID: kp*e + ki/s*e (forward Euler) + kd*s/(tf*s+1) applied to -y (Tustin).
kp, ki, kd_, tf = 0.15, 0.2, 0.003, 0.01
dt2 = 1.0 / 1000.0
r = np.where(np.arange(N) >= 50, 1.0, 0.0)
ymeas = np.sin(np.arange(N) * 0.05) * 0.3 + rng.standard_normal(N) * 0.01
err = r - ymeas
# integrator, forward Euler: ki*dt/(z-1)
_, yi = signal.dlsim(([0.0, ki * dt2], [1.0, -1.0], dt2), err)
# derivative filter, Tustin
nd, dd2, _ = signal.cont2discrete(([kd_, 0.0], [tf, 1.0]), dt2, method="bilinear")
nd = np.atleast_1d(np.squeeze(nd))
# first sample: derivative history starts at the first measurement (no kick), so run on -(y - y0)
_, yd = signal.dlsim((nd, dd2, dt2), -(ymeas - ymeas[0]))
u = kp * err + yi[:, 0] + yd[:, 0]
out["pid"] = {
    "source": "scipy: forward-Euler integrator ki*dt/(z-1) + bilinear kd*s/(tf*s+1) on -y, dlsim",
    "kp": kp, "ki": ki, "kd": kd_, "tf": tf, "dt": dt2,
    "r": r.tolist(), "y": ymeas.tolist(), "u": u.tolist(),
}

# 3) SSI-PI eq. (31): u = Kp e + Ki Kp int(e) - Ki Jm w, forward Euler.
Kp, Ki, Jm = 0.08, 20.0, 0.004
wr = np.where(np.arange(N) >= 20, 0.5, 0.0)
w = np.cumsum(rng.standard_normal(N)) * 0.01
e3 = wr - w
_, yi3 = signal.dlsim(([0.0, Ki * Kp * dt2], [1.0, -1.0], dt2), e3)
u3 = Kp * e3 + yi3[:, 0] - Ki * Jm * w
out["ssi_pi"] = {
    "source": "eq. (31) of 003_4324fd0aa39b850c.txt, integral by forward Euler via scipy dlsim",
    "kp": Kp, "ki": Ki, "jm": Jm, "dt": dt2,
    "w_ref": wr.tolist(), "w": w.tolist(), "u": u3.tolist(),
}

with open("crates/skyloop-control/tests/fixtures/control/control.json", "w") as f:
    json.dump(out, f)
print("wrote control.json")
