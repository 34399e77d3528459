#!/usr/bin/env python3
"""hinfsyn on a 12-state generalized plant: skyloop vs python-control 0.10.2 `hinfsyn` (SLICOT sb10ad).

The plant is random but fixed (numpy default_rng(1), A shifted to be stable; 12 states, 2 disturbances + 1 control, 2 errors +
1 measurement, D11 and D22 nonzero), written as LTI JSON. python-control is timed in a child
process with OPENBLAS_NUM_THREADS=1 set before numpy is imported (threads only thrash on the shared
2-core machine, and bench/compare.py has already imported numpy in this process); skyloop through
`skyloop hinfsyn PLANT --nmeas 1 --ncon 1 --bench N` (fastest of N in-process repetitions).
Both solve to their default tolerance (python-control: sb10ad's; skyloop: relative 1e-4) and both
γ are printed. Target: skyloop ≥ 20× faster.

Loaded by bench/compare.py via `comparisons(skyloop)`; also runs alone:
    python3 bench/compare_hinf.py   (uses the release binary under $CARGO_TARGET_DIR or ./target)
"""
import json
import os
import subprocess
import sys
import tempfile

CHILD = r"""
import os, sys, json, time
os.environ["OPENBLAS_NUM_THREADS"] = "1"
os.environ["OMP_NUM_THREADS"] = "1"
import numpy as np, control
d = json.load(open(sys.argv[1]))
p = control.ss(np.array(d["a"]), np.array(d["b"]), np.array(d["c"]), np.array(d["d"]))
k, cl, gam, rcond = control.hinfsyn(p, 1, 1)
best = float("inf")
for _ in range(int(sys.argv[2])):
    t = time.perf_counter()
    control.hinfsyn(p, 1, 1)
    best = min(best, time.perf_counter() - t)
print(json.dumps({"seconds": best, "gamma": float(gam)}))
"""


def plant(path):
    import numpy as np

    rng = np.random.default_rng(1)
    n, m1, m2, p1, p2 = 12, 2, 1, 2, 1
    a = rng.standard_normal((n, n)) / np.sqrt(n)
    # Shifted stable: on this plant with its unstable A, sb10ad did not finish in 20 s.
    a -= (max(np.linalg.eigvals(a).real) + 0.5) * np.eye(n)
    b = rng.standard_normal((n, m1 + m2))
    c = rng.standard_normal((p1 + p2, n))
    d = np.zeros((p1 + p2, m1 + m2))
    d[:p1, :m1] = 0.3 * rng.standard_normal((p1, m1))
    d[:p1, m1:] = rng.standard_normal((p1, m2))
    d[p1:, :m1] = rng.standard_normal((p2, m1))
    d[p1:, m1:] = 0.5 * rng.standard_normal((p2, m2))
    with open(path, "w") as f:
        json.dump({"a": a.tolist(), "b": b.tolist(), "c": c.tolist(), "d": d.tolist(), "dt": 0.0}, f)


def reference(path, repeat=20):
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", CHILD, path, str(repeat)], capture_output=True, text=True, env=env)
    if out.returncode != 0:
        raise RuntimeError(f"python-control hinfsyn failed: {out.stderr}")
    return json.loads(out.stdout)


def our_gamma(path):
    root = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
    binary = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(root, "target")), "release", "skyloop")
    out = subprocess.run([binary, "hinfsyn", path, "--nmeas", "1", "--ncon", "1", "--json"], capture_output=True, text=True)
    return json.loads(out.stdout)["gamma"] if out.returncode == 0 else float("nan")


def comparisons(skyloop):
    path = os.path.join(tempfile.mkdtemp(prefix="skyloop-hinf-bench-"), "plant12.json")
    plant(path)
    ref = reference(path)
    ours = skyloop(["hinfsyn", path, "--nmeas", "1", "--ncon", "1"], 20)
    print(f"hinfsyn 12 states: gamma python-control/sb10ad {ref['gamma']:.6f}, skyloop {our_gamma(path):.6f}")
    return [("hinfsyn 12 states (python-control/sb10ad)", ours, ref["seconds"], 20.0)]


def main():
    root = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
    binary = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(root, "target")), "release", "skyloop")

    def skyloop(args, repeat=20):
        p = subprocess.run([binary, *args, "--bench", str(repeat)], capture_output=True, text=True)
        if p.returncode != 0:
            raise RuntimeError(p.stderr)
        for line in p.stderr.splitlines():
            if line.startswith("bench_seconds"):
                return float(line.split()[1])
        raise RuntimeError(p.stderr)

    ok = True
    for name, ours, ref, target in comparisons(skyloop):
        ratio = ref / ours
        ok &= ratio >= target
        print(f"{name:<44} skyloop {ours * 1e3:8.3f} ms  reference {ref * 1e3:8.3f} ms  ratio {ratio:6.1f}x (target {target}x)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
