#!/usr/bin/env bash
# Regenerates what the docs show from what the commands print today: the figures under docs/img/
# (each drawn by the runnable block that names it, see crates/skyloop-cli/tests/docs.rs) and the
# CLI reference docs/reference/cli.md (from clap's definitions, `skyloop --markdown-help`).
# The Python figure needs the Python module: `pip install './python[plot]'` first, or it is skipped.
set -euo pipefail
cd "$(dirname "$0")/.."
SKYLOOP_BLESS=1 cargo test --release -p skyloop-cli --test docs
if python3 -c "import skyloop, matplotlib" 2>/dev/null; then
  SKYLOOP_BLESS=1 MPLBACKEND=Agg python3 -m pytest -q python/tests/test_readme.py
else
  echo "skyloop (Python) or matplotlib not importable: docs/img/python-bode.png left as it is" >&2
fi
git status --short docs/
