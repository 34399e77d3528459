"""Group `compare_reduce` of bench/compare.py: balanced reduction of a 100-state 2x2 model to order
10 (rss_n100 of crates/skyloop-lti/tests/fixtures/reduce/cases.json, tools/gen_reduce.py) against
python-control + slycot: balanced truncation (AB09AD; target >= 2x, issue 16's balred row) and the
singular perturbation approximation (matchdc, AB09ND; no slower).
"""
import json
import os

import numpy as np

from workflow_times import ROOT, ours, thread_best


def comparisons(run):
    del run
    import control

    fix = os.path.join(ROOT, "crates", "skyloop-lti", "tests", "fixtures", "reduce", "cases.json")
    with open(fix) as f:
        case = next(c for c in json.load(f)["cases"] if c["name"] == "rss_n100")
    a, b, c, d = (np.array(case[k]) for k in "abcd")
    g = control.ss(a, b, c, d)
    rows = [
        ("balred BT 100 -> 10 (control, AB09AD)", ours()["balred_100_2x2_to_10"],
         thread_best(lambda: control.balanced_reduction(g, 10, "truncate"), 7), 3.0),
        ("balred SPA 100 -> 10 (control, AB09ND)", ours()["balred_spa_100_2x2_to_10"],
         thread_best(lambda: control.balanced_reduction(g, 10, "matchdc"), 7), 1.0),
    ]
    try:
        import slycot

        # SLICOT alone, without python-control's wrapper.
        rows.append(("balred BT 100 -> 10 (slycot AB09AD only)", ours()["balred_100_2x2_to_10"],
                     thread_best(lambda: slycot.ab09ad("C", "B", "N", 100, 2, 2, a, b, c, nr=10, tol=0.0), 7), 3.0))
        # n = 1000 (issue 15): the LCG model of the time_workflows example, reproduced bit for bit.
        from compare import lcg

        a1k = lcg(1000, 1000, 11) - np.sqrt(1000) * np.eye(1000)
        b1k, c1k = lcg(1000, 2, 12), lcg(2, 1000, 13)
        rows.append(("balred BT 1000 -> 10 (slycot AB09AD)", ours()["balred_1000_2x2_to_10"],
                     thread_best(lambda: slycot.ab09ad("C", "B", "N", 1000, 2, 2, a1k.copy(), b1k.copy(), c1k.copy(),
                                                       nr=10, tol=0.0), 1), 2.0))
    except ImportError:
        print("compare_reduce: slycot not installed, the AB09AD-only row is skipped")
    return rows
