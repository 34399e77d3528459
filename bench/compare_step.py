"""Group `compare_step` of bench/compare.py: step response of a 20-state SISO model at 1000 points,
skyloop vs python-control's step_response (issue 15's target: >= 10x).

The model is the committed bench/step20.json (python-control rss, seed 7: made once, never rewritten).
"""
import json
import os

import numpy as np

from workflow_times import ROOT, ours, thread_best


def comparisons(run):
    del run  # timed by the time_workflows example, not the CLI
    import control

    with open(os.path.join(ROOT, "bench", "step20.json")) as f:
        j = json.load(f)
    s = control.ss(np.array(j["a"]), np.array(j["b"]), np.array(j["c"]), np.array(j["d"]))
    t = np.linspace(0.0, j["t_final_s"], j["n_points"])
    ref = thread_best(lambda: control.step_response(s, T=t), 50)
    return [("step 20 states 1000 points (control.step_response)", ours()["step_20_states_1000_points"], ref, 10.0)]
