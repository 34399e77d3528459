#!/usr/bin/env python3
"""Hankel singular values of a 1000-state stable model (issue 15: reduction of large models) from
SLICOT AB09AD via slycot: A = LCG(1000, 1000, seed 11) - sqrt(1000)*I, B = LCG(1000, 2, 12),
C = LCG(2, 1000, 13), the 64-bit LCG of skyloop_fixtures::lcg_matrix (uniform in [-1, 1), filled
column by column). Writes crates/skyloop-lti/tests/fixtures/reduce/lcg_n1000.json.
Run: python3 tools/gen_reduce_large.py  (numpy, slycot)
"""
import json
import os
import sys

import numpy as np
import slycot

# The LCG of skyloop_fixtures::lcg_matrix, as bench/compare.py reproduces it.
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
from compare import lcg  # noqa: E402

OUT = os.path.join(os.path.dirname(__file__), "..", "crates", "skyloop-lti", "tests", "fixtures", "reduce",
                   "lcg_n1000.json")


def main():
    n = 1000
    a = lcg(n, n, 11) - np.sqrt(n) * np.eye(n)
    b, c = lcg(n, 2, 12), lcg(2, n, 13)
    out = slycot.ab09ad("C", "B", "N", n, 2, 2, a, b, c, nr=10, tol=0.0)
    hsv = np.asarray(out[-1])
    with open(OUT, "w") as f:
        json.dump({"source": "slycot AB09AD (balanced truncation, order 10)", "n": n,
                   "check": [a[3, 2], b[999, 1], c[1, 999]], "hsv": hsv[:10].tolist()}, f, indent=1)
    print(hsv[:10])


if __name__ == "__main__":
    main()
