"""The Python blocks the docs show run as written: every fenced ``python`` block in README.md and
docs/*.md whose preceding line is a ``<!-- run ... -->`` comment is executed in a temporary
directory, and a ``figure=PRODUCED:COMMITTED`` in the comment compares the figure it saves with the
committed one (the Rust side, crates/skyloop-cli/tests/docs.rs, does the same for the ``sh`` blocks).

matplotlib's rasterizer differs slightly between versions, so figures are compared by their pixels
with a tolerance, not byte for byte; ``SKYLOOP_BLESS=1`` writes the new figure over the committed
one (tools/docs_figures.sh).
"""
import glob
import os
import re

import numpy as np
import pytest

from conftest import ROOT

MARKER = re.compile(r"^<!-- run(?P<args>.*)-->$")


def python_blocks():
    """(doc, line, code, figures) of every runnable python block of the docs."""
    docs = [os.path.join(ROOT, "README.md")] + sorted(glob.glob(os.path.join(ROOT, "docs", "*.md")))
    out = []
    for doc in docs:
        lines = open(doc, encoding="utf-8").read().splitlines()
        for i in range(len(lines) - 1):
            m = MARKER.match(lines[i].strip())
            if not m or lines[i + 1].strip() != "```python":
                continue
            end = next(j for j in range(i + 2, len(lines)) if lines[j].strip() == "```")
            figures = [w[len("figure="):].split(":", 1) for w in m.group("args").split() if w.startswith("figure=")]
            out.append((os.path.relpath(doc, ROOT), i + 1, "\n".join(lines[i + 2:end]), figures))
    return out


BLOCKS = python_blocks()


def test_the_readme_has_a_runnable_python_path():
    assert any(doc == "README.md" for doc, *_ in BLOCKS)


def _pixels_differ(a_path, b_path):
    """The fraction of pixels that differ visibly (more than 0.19 in a channel); 1 on a size change."""
    import matplotlib.image as mpimg

    a, b = mpimg.imread(a_path)[..., :3], mpimg.imread(b_path)[..., :3]
    if a.shape != b.shape:
        return 1.0
    return float(np.mean(np.any(np.abs(a - b) > 0.19, axis=-1)))


@pytest.mark.parametrize("doc,line,code,figures", BLOCKS, ids=[f"{d}:{n}" for d, n, *_ in BLOCKS])
def test_doc_block_runs(doc, line, code, figures, tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, f"{doc}:{line}", "exec"), {"__name__": "__docs__"})
    for produced, committed in figures:
        assert os.path.exists(produced), f"{doc}:{line}: the block did not write {produced}"
        target = os.path.join(ROOT, committed)
        if os.environ.get("SKYLOOP_BLESS") == "1":
            os.makedirs(os.path.dirname(target), exist_ok=True)
            with open(produced, "rb") as src, open(target, "wb") as dst:
                dst.write(src.read())
            continue
        differ = _pixels_differ(produced, target)
        assert differ < 0.02, (f"{doc}:{line}: {committed} is not what the block draws today "
                               f"({100 * differ:.1f} % of its pixels differ): run tools/docs_figures.sh")
