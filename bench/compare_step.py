#!/usr/bin/env python3
"""Step response of a 20-state SISO system on 1000 points: skyloop vs python-control 0.10.2.

The system is the committed bench/step20.json (made once by python-control rss with seed 7; this
script reads it and never rewrites a tracked file), times
control.step_response on it, runs the criterion bench `cargo bench -p skyloop-lti --bench step`
(which reads the same file) and prints both times and the ratio. Target: skyloop >= 10x faster.
Run from the repository root: python3 bench/compare_step.py [--no-cargo]
"""
import json
import os
import subprocess
import sys
import timeit

import control
import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SYS_PATH = os.path.join(ROOT, "bench", "step20.json")

if not os.path.exists(SYS_PATH):
    np.random.seed(7)
    g = control.rss(20, 1, 1)
    with open(SYS_PATH, "w") as f:
        json.dump({"a": g.A.tolist(), "b": g.B.tolist(), "c": g.C.tolist(), "d": g.D.tolist(), "dt": 0.0,
                   "t_final_s": 10.0, "n_points": 1000}, f)
with open(SYS_PATH) as f:
    j = json.load(f)
s = control.ss(np.array(j["a"]), np.array(j["b"]), np.array(j["c"]), np.array(j["d"]))
t = np.linspace(0.0, j["t_final_s"], j["n_points"])

reps = 50
py_s = min(timeit.repeat(lambda: control.step_response(s, T=t), number=reps, repeat=3)) / reps
print(f"python-control step_response (20 states, 1000 points): {py_s * 1e6:10.1f} us")

if "--no-cargo" not in sys.argv:
    env = dict(os.environ)
    subprocess.run(["cargo", "bench", "-p", "skyloop-lti", "--bench", "step", "--", "--noplot"],
                   cwd=ROOT, env=env, check=True, stdout=subprocess.DEVNULL)
target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
est = os.path.join(target, "criterion", "step_20_states_1000_points", "new", "estimates.json")
with open(est) as f:
    rust_s = json.load(f)["mean"]["point_estimate"] * 1e-9
print(f"skyloop timeresp::step (criterion mean):                {rust_s * 1e6:10.1f} us")
print(f"ratio python-control / skyloop: {py_s / rust_s:.1f}x (target >= 10x)")
