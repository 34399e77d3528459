"""Logs and identification: read_log on committed flight logs, identify on a synthetic CSV."""
import numpy as np
import pytest

import skyloop as sk
from conftest import fixture_path


def test_read_log_ulog_channels():
    d = sk.read_log(fixture_path("testdata", "logs", "sample_px4_events.ulg"))
    p = d["vehicle_angular_velocity.xyz[0]"]
    t = d["vehicle_angular_velocity.time_s"]
    assert p.dtype == np.float64 and p.shape == t.shape and p.size > 10
    assert np.all(np.diff(t) >= 0) and np.all(np.abs(p) < 20)


def test_read_log_blackbox():
    d = sk.read_log(fixture_path("testdata", "logs", "btfl_001.bbl"))
    assert "gyroADC[0]" in d and "main.time_s" in d
    assert d["gyroADC[0]"].shape == d["main.time_s"].shape


def first_order_csv(path):
    """y = K/(tau s + 1) u with K = 2, tau = 0.05 s, exact ZOH at 1 kHz, driven by an exponential chirp."""
    dt, k, tau = 0.001, 2.0, 0.05
    a = np.exp(-dt / tau)
    t = np.arange(20000) * dt
    L = 20.0 / np.log(100.0)
    u = np.sin(2 * np.pi * 0.5 * L * (np.exp(t / L) - 1))
    y = np.zeros_like(u)
    for i in range(1, len(u)):
        y[i] = a * y[i - 1] + k * (1 - a) * u[i - 1]
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header="time_s,u,y", comments="")


def test_identify_first_order(tmp_path):
    p = tmp_path / "fo.csv"
    first_order_csv(p)
    r = sk.identify(str(p), "u", "y", fmin_hz=0.5, fmax_hz=40,
                    model="K/(tau*s+1)*(1-exp(-0.001*s))/(0.001*s)", init="K=1,tau=0.1",
                    bounds="K=0:10,tau=0.001:")
    assert len(r["frf"]["freq_hz"]) == 100
    k, tau = r["fit"]["params"]["K"], r["fit"]["params"]["tau"]
    assert abs(k - 2) < 0.01 and abs(tau - 0.05) < 5e-4
    assert r["fit"]["fit_percent"] > 99
    with pytest.raises(sk.SkyloopError, match="nope"):
        sk.identify(str(p), "u", "nope")


def test_identify_conditions_on_a_measured_disturbance():
    # y = G u + H d: the disturbance d (a throttle that torques the frame) is measured, so the
    # Welch estimate with d conditioned out is closer to G's gain than the plain one.
    rng = np.random.default_rng(3)
    t = np.arange(0, 40, 0.002)
    u = rng.standard_normal(t.size)
    d = rng.standard_normal(t.size)
    y = np.zeros_like(u)
    for i in range(1, len(u)):
        y[i] = 0.9 * y[i - 1] + 0.2 * u[i - 1] + 0.5 * d[i - 1]
    data = {"time_s": t, "u": u, "y": y, "d": d}
    kw = dict(method="welch", fmin_hz=0.5, fmax_hz=5)
    plain = sk.identify(data, "u", "y", **kw)
    cond = sk.identify(data, "u", "y", disturbance="d", **kw)
    assert plain.get("disturbance") is None and cond["disturbance"] == "d"

    def gain_error(r):
        z = np.exp(-2j * np.pi * np.asarray(r["frf"]["freq_hz"]) * 0.002)
        g = 0.2 * z / (1 - 0.9 * z)
        return float(np.median(np.abs(np.asarray(r["frf"]["mag"]) / np.abs(g) - 1)))

    assert gain_error(cond) < 0.5 * gain_error(plain)
    assert np.median(cond["frf"]["coherence"]) > np.median(plain["frf"]["coherence"])


def test_identify_from_arrays_equals_identify_from_the_file(tmp_path):
    p = tmp_path / "fo.csv"
    first_order_csv(p)
    t, u, y = np.loadtxt(p, delimiter=",", skiprows=1).T
    kw = dict(fmin_hz=0.5, fmax_hz=40, model="K/(tau*s+1)*(1-exp(-0.001*s))/(0.001*s)", init="K=1,tau=0.1")
    a = sk.identify({"time_s": t, "u": u, "y": y}, "u", "y", **kw)
    b = sk.identify(str(p), "u", "y", **kw)
    assert a["frf"] == b["frf"] and a["fit"] == b["fit"]
    assert abs(a["fit"]["params"]["K"] - 2) < 0.02
    with pytest.raises(sk.InputError, match="time_s"):
        sk.identify({"u": u, "y": y}, "u", "y")
