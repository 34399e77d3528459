"""Bad input raises SkyloopError subclasses with the Rust message; nothing crashes the interpreter."""
import numpy as np
import pytest

import skyloop as sk


def test_exception_hierarchy():
    for e in (sk.ModelError, sk.RobustError, sk.LinalgError, sk.SysidError, sk.SimError, sk.InputError,
              sk.FileError, sk.InternalError):
        assert issubclass(e, sk.SkyloopError) and issubclass(e, Exception)


def test_bad_models():
    with pytest.raises(sk.ModelError, match="column|expected|unexpected|parse|end"):
        sk.tf("1/(s+")
    with pytest.raises(sk.ModelError):
        sk.ss(np.eye(2), np.ones((3, 1)), np.ones((1, 2)), [[0]])  # B has 3 rows for 2 states
    with pytest.raises(sk.ModelError):
        sk.ss([[np.nan]], [[1]], [[1]], [[0]])
    with pytest.raises(sk.InputError):
        sk.ss(np.zeros((2, 2, 2)), [[1]], [[1]], [[0]])
    with pytest.raises(sk.InputError, match="sample time"):
        sk.ss([[0.5]], [[1]], [[1]], [[0]], dt=True)


def test_bad_operations():
    g = sk.tf("1/(s+1)")
    mimo = sk.ss(-np.eye(2), np.eye(2), np.eye(2), np.zeros((2, 2)))
    with pytest.raises(sk.ModelError, match="dimension|match|1|2"):
        _ = g * mimo
    with pytest.raises(sk.ModelError):
        _ = g + sk.ss([[0.5]], [[1]], [[1]], [[0]], dt=0.1)  # continuous + discrete
    with pytest.raises(sk.SkyloopError):
        sk.margins(mimo)
    with pytest.raises(sk.InputError, match="method"):
        sk.c2d(g, 0.1, "nonsense")
    with pytest.raises(sk.InputError, match="prewarp"):
        sk.c2d(g, 0.1, "zoh", prewarp=3.0)
    with pytest.raises(sk.SkyloopError):
        sk.c2d(g, -0.1)
    with pytest.raises(sk.SkyloopError):
        sk.balred(g, 5)
    with pytest.raises(sk.InputError, match="reduction method"):
        sk.balred(g, 1, "magic")
    with pytest.raises(sk.InputError, match="StateSpace"):
        sk.hinf_norm(object())
    with pytest.raises(sk.SkyloopError):
        sk.freqresp(g, [1.0, np.nan])
    with pytest.raises(sk.SkyloopError):
        sk.tf("exp(-0.1*s)/(s+1)").pade(0)


def test_bad_synthesis():
    p = sk.ss(-np.eye(2), np.ones((2, 2)), np.ones((2, 2)), np.zeros((2, 2)))
    with pytest.raises(sk.SkyloopError):
        sk.hinfsyn(p, 3, 1)   # more measurements than outputs
    with pytest.raises(sk.RobustError):
        sk.hinfsyn(p, 1, 1)   # D12 = 0: rank condition fails
    with pytest.raises(sk.InputError, match="blocks"):
        sk.mu(np.eye(2, dtype=complex), "q9")
    with pytest.raises(sk.SkyloopError):
        sk.mu(np.eye(3, dtype=complex), "c1x1,c1x1")  # structure is 2x2, M is 3x3
    with pytest.raises(sk.SkyloopError):
        sk.ncfsyn(sk.tf("1/(s+1)"), factor=0.5)


def test_files_and_scenarios(tmp_path):
    with pytest.raises(sk.FileError):
        sk.simulate(str(tmp_path / "missing.toml"))
    with pytest.raises(sk.InputError, match="scenario"):
        sk.simulate("this is = = not toml\n")
    with pytest.raises(sk.SkyloopError):
        sk.read_log(str(tmp_path / "nope.ulg"))
    with pytest.raises(sk.InputError, match="seeds"):
        sk.montecarlo("name='x'\n", "a..b")


def test_a_panic_is_an_exception_not_a_crash():
    with pytest.raises(sk.InternalError, match="deliberate test panic"):
        sk._skyloop._panic_for_test()
    # The interpreter and the module still work afterwards.
    assert sk.h2_norm(sk.tf("1/(s+1)")) > 0
