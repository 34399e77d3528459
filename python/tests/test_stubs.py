"""The type stubs cover the public API: every name in skyloop.__all__ is declared in __init__.pyi."""
import ast
import os

import skyloop as sk


def test_every_public_name_has_a_stub():
    path = os.path.join(os.path.dirname(sk.__file__), "__init__.pyi")
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read())
    declared = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    declared |= {t.id for n in tree.body if isinstance(n, (ast.Assign, ast.AnnAssign))
                 for t in (n.targets if isinstance(n, ast.Assign) else [n.target]) if isinstance(t, ast.Name)}
    missing = [n for n in sk.__all__ if n not in declared]
    assert not missing, missing
    for n in sk.__all__:
        assert getattr(sk, n).__doc__, f"{n} has no docstring"
