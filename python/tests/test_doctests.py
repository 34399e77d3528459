"""Every public function's docstring example runs (pytest's doctest module over skyloop's modules)."""
import doctest
import inspect

import pytest

import skyloop as sk
import skyloop._model
import skyloop.plot
from conftest import ROOT

MODULES = [sk, skyloop._model, skyloop.plot]


@pytest.mark.parametrize("mod", MODULES, ids=[m.__name__ for m in MODULES])
def test_docstring_examples_run(mod, monkeypatch):
    """The examples use the repository's example files by relative path (examples/*.toml)."""
    monkeypatch.chdir(ROOT)
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = [t for t in finder.find(mod, mod.__name__) if t.examples]
    assert tests
    for t in tests:
        runner.run(t)
    res = runner.summarize(verbose=False)
    assert res.failed == 0, f"{res.failed} doctest failures in {mod.__name__}"


def test_every_public_function_has_an_example():
    missing = []
    for name in sk.__all__:
        obj = getattr(sk, name)
        if inspect.isclass(obj) and issubclass(obj, Exception):
            continue
        if ">>>" not in (obj.__doc__ or ""):
            missing.append(name)
    for name in skyloop.plot.__all__:
        if ">>>" not in (getattr(skyloop.plot, name).__doc__ or ""):
            missing.append("plot." + name)
    assert not missing, missing
