"""Shared helpers: seeded random models (skyloop and python-control twins) and repository paths."""
import os

import numpy as np
import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def random_ss(rng, n, ny, nu, dt=0.0, strictly_proper=False):
    """A random stable realization (continuous: eigenvalues left of -0.1; discrete: inside radius 0.95)."""
    a = rng.standard_normal((n, n))
    ev = np.linalg.eigvals(a)
    if dt == 0:
        a = a - (ev.real.max() + 0.1 + rng.random()) * np.eye(n)
    else:
        a = a * (0.95 * rng.uniform(0.3, 1.0) / np.abs(ev).max())
    b = rng.standard_normal((n, nu))
    c = rng.standard_normal((ny, n))
    d = np.zeros((ny, nu)) if strictly_proper else rng.standard_normal((ny, nu))
    return a, b, c, d


@pytest.fixture
def rng():
    return np.random.default_rng(20261201)


def fixture_path(*parts):
    return os.path.join(ROOT, *parts)
