#!/usr/bin/env python3
"""Monte Carlo throughput: 1000 flights of 20 s of the SSI-PI quadrotor (RK4 at 1 kHz, motors, gyro,
controllers in the loop) through `skyloop simulate --monte-carlo`.

Target (issue 6): the study uses both cores, i.e. CPU time / wall time close to the core count, and
the per-core physics rate stays near the single-core benchmark (`cargo bench -p skyloop-sim --bench
step`, target >= 2 M steps/s). python-control has no 6-DOF simulator, so there is no ratio here.
Run from the repository root: python3 bench/montecarlo.py [--runs N]
"""
import os
import re
import resource
import subprocess
import sys
import tempfile
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
RUNS = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else 1000
DURATION_S = 20.0

subprocess.run(["cargo", "build", "--release", "-q", "-p", "skyloop-cli"], cwd=ROOT, check=True)
target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
exe = os.path.join(target, "release", "skyloop")

with open(os.path.join(ROOT, "examples", "quadrotor-ssi.toml")) as f:
    text = f.read()
text = re.sub(r"(?m)^duration_s = .*$", f"duration_s = {DURATION_S}", text)
text = re.sub(r"(?m)^runs = .*$", f"runs = {RUNS}", text)
physics_hz = float(re.search(r"(?m)^physics_hz = (.*)$", text).group(1))

with tempfile.TemporaryDirectory() as tmp:
    spec = os.path.join(tmp, "mc.toml")
    with open(spec, "w") as f:
        f.write(text)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([exe, "simulate", spec, "--monte-carlo", "--json", "--out", tmp], check=True,
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)

cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
steps = RUNS * DURATION_S * physics_hz
print(f"{RUNS} flights x {DURATION_S:.0f} s at {physics_hz:.0f} Hz = {steps / 1e6:.0f} M physics steps")
print(f"wall {wall:8.2f} s   cpu {cpu:8.2f} s   cores used {cpu / wall:4.2f} of {os.cpu_count()}")
print(f"throughput {steps / wall / 1e6:6.2f} M steps/s total, {steps / cpu / 1e6:6.2f} M steps/s per core")
print(f"load average at the end: {os.getloadavg()[0]:.1f} (numbers above are only meaningful near 0)")
