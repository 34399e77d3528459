#!/usr/bin/env python3
"""Reference γ of mixsyn (S/KS mixed sensitivity) on the rate-loop problem of issue 14: plant
800*exp(-0.012 s)/(0.04 s + 1) with the delay as a Padé approximant, a performance weight W1 on S
(strictly proper and biproper forms) and a constant weight W2 on K·S, from python-control's mixsyn
(augw + SLICOT SB10AD). The plant and weights are stored as state-space matrices, so the Rust test
builds the same realization and no Padé convention can differ.

Run: python3 tools/gen_mixsyn.py  (numpy, control, slycot) -> crates/skyloop-robust/tests/fixtures/mixsyn/rate_loop.json
"""
import json
import os

import control
import numpy as np

OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-robust", "tests", "fixtures", "mixsyn",
                   "rate_loop.json")


def mats(sys_):
    a, b, c, d = (np.atleast_2d(np.asarray(m, dtype=float)) for m in control.ssdata(control.ss(sys_)))
    return {"a": a.tolist(), "b": b.tolist(), "c": c.tolist(), "d": d.tolist()}


def main():
    s = control.tf("s")
    cases = []
    for npade in (2, 4):
        num, den = control.pade(0.012, npade)
        g = control.ss(control.tf([800.0], [0.04, 1.0]) * control.tf(num, den))
        weights = [
            ("w1 strictly proper", 6.283 / (s + 0.006283), 1.0 / 800.0),
            ("w1 strictly proper, heavier KS", 6.283 / (s + 0.006283), 0.1),
            ("w1 biproper", (0.5 * s + 6.283) / (s + 0.006283), 0.01),
            ("w1 biproper, wider band", (0.5 * s + 31.4) / (s + 0.0314), 0.01),
        ]
        for label, w1, wks in weights:
            w2 = control.ss([], [], [], [[wks]])
            _, cl, info = control.mixsyn(g, w1=w1, w2=w2)
            gamma = float(info[0])
            # The closed loop SLICOT's controller achieves: a reference that does not meet its own γ
            # would be no reference (see DESIGN on sb10ad).
            achieved = float(control.linfnorm(cl)[0])
            cases.append({"name": f"pade{npade}, {label}", "plant": mats(g), "w1": mats(w1), "w2": mats(w2),
                          "gamma": gamma, "achieved": achieved})
            print(f"pade{npade} {label:34s} gamma {gamma:.6f} achieved {achieved:.6f}")
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    with open(OUT, "w") as f:
        json.dump({"source": f"python-control {control.__version__} mixsyn (SLICOT SB10AD)", "cases": cases}, f,
                  indent=1)


if __name__ == "__main__":
    main()
