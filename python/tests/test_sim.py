"""Simulation and Monte Carlo: determinism, seed ranges, thread counts, and Dask equality."""
import os
import re

import numpy as np
import pytest

import skyloop as sk
from conftest import fixture_path


@pytest.fixture(scope="module")
def scenario():
    with open(fixture_path("examples", "quadrotor-ssi.toml")) as f:
        text = f.read()
    text = re.sub(r"(?m)^duration_s = .*$", "duration_s = 1.5", text)
    return re.sub(r"(?m)^runs = .*$", "runs = 12", text)


def test_simulate_returns_metrics_and_trajectory():
    r = sk.simulate(fixture_path("examples", "quadrotor-ssi.toml"))
    m, t = r["metrics"], r["trajectory"]
    assert set(m) == {"max_abs_error", "rms_error", "settling_time_s", "saturated_fraction", "crashed"}
    assert m["crashed"] is False and m["settling_time_s"] is not None
    n = t["t_s"].shape[0]
    assert n > 1000 and t["pos_m"].shape == (n, 3) and t["u"].shape[0] == n and t["u"].shape[1] == 4
    # The roll step of 0.2 rad at t = 1 s is tracked.
    assert abs(t["tracked"][-1, 0] - 0.2) < 0.02
    np.testing.assert_allclose(t["reference"][-1, 0], 0.2)


def test_montecarlo_is_deterministic_and_splits(scenario):
    whole = sk.montecarlo(scenario)
    assert whole["seeds"] == list(range(12)) and whole["summary"]["runs"] == 12
    part = sk.montecarlo(scenario, range(4, 9), threads=1)
    assert part["runs"] == whole["runs"][4:9]
    assert sk.montecarlo(scenario, "4..9", threads=2)["runs"] == part["runs"]
    assert sk.summarize(whole["runs"]) == whole["summary"]
    # Runs differ from one another (noise and parameters are per run).
    assert len({r["rms_error"] for r in whole["runs"]}) == 12


def test_montecarlo_without_section_is_an_error(scenario):
    text = scenario[: scenario.index("[monte_carlo]")]
    with pytest.raises(sk.SkyloopError, match="monte_carlo"):
        sk.montecarlo(text, range(3))


def test_dask_local_cluster_equals_one_process(scenario):
    distributed = pytest.importorskip("distributed")
    import skyloop.dask

    seeds = list(range(3, 13))
    single = sk.montecarlo(scenario, seeds)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        merged = skyloop.dask.montecarlo(scenario, seeds, client, chunk_size=3)
        default_chunks = skyloop.dask.montecarlo(fixture_path_tmp(scenario), None, client)
    assert merged["seeds"] == seeds
    assert merged["runs"] == single["runs"]
    assert merged["summary"] == single["summary"]
    assert default_chunks["runs"] == sk.montecarlo(scenario)["runs"]


def fixture_path_tmp(text):
    """The scenario written to a file, to exercise the path form too."""
    import tempfile

    fd, path = tempfile.mkstemp(suffix=".toml")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    return path


def test_the_gil_is_released_during_a_computation(scenario):
    """A Python thread keeps running while skyloop computes (it would stall if the GIL were held)."""
    import threading
    import time

    stop, ticks = threading.Event(), [0]

    def spin():
        while not stop.is_set():
            ticks[0] += 1

    th = threading.Thread(target=spin)
    th.start()
    try:
        t0, k0 = time.perf_counter(), ticks[0]
        time.sleep(0.3)  # sleep releases the GIL: the spinner's free-running rate
        r_free = (ticks[0] - k0) / (time.perf_counter() - t0)
        t0, k0 = time.perf_counter(), ticks[0]
        sk.montecarlo(re.sub(r"(?m)^duration_s = .*$", "duration_s = 10.0", scenario), range(30), threads=1)
        dt = time.perf_counter() - t0
        r_call = (ticks[0] - k0) / dt
    finally:
        stop.set()
        th.join()
    assert dt > 0.05
    assert r_call > 0.2 * r_free, (r_call, r_free)
