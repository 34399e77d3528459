#!/usr/bin/env bash
# The docs as one static site: the README, the guides in docs/, the CLI reference (generated from
# clap's definitions, docs/reference/cli.md), the Python guide, and the browser page (web/dist, when
# web/build.sh has built it) under browser/, built by mdBook into target/book (open
# target/book/index.html). mdBook is installed from crates.io into target/mdbook-tool on first use
# (its search feature only: no server, no file watcher).
set -euo pipefail
cd "$(dirname "$0")/.."
MDBOOK_VERSION=0.4.52
tool="$PWD/target/mdbook-tool"
if [ ! -x "$tool/bin/mdbook" ] || ! "$tool/bin/mdbook" --version | grep -q "$MDBOOK_VERSION"; then
  cargo install --quiet --locked --root "$tool" --version "$MDBOOK_VERSION" --no-default-features --features search mdbook
fi
src="$(mktemp -d)"
trap 'rm -rf "$src"' EXIT
mkdir -p "$src/src"
# The site's pages are the repository's Markdown files, with links rewritten to the site's layout
# (docs/x.md → x.md, python/README.md → python.md); the files themselves are not changed.
relink() { sed -e 's#(docs/#(#g' -e 's#(python/README\.md)#(python.md)#g' -e 's#(\.\./python/README\.md)#(python.md)#g' -e 's#(DESIGN\.md)#(design.md)#g' -e 's#(\.\./README\.md)#(index.md)#g' "$1"; }
relink README.md > "$src/src/index.md"
for f in docs/*.md; do relink "$f" > "$src/src/$(basename "$f")"; done
relink python/README.md > "$src/src/python.md"
relink DESIGN.md > "$src/src/design.md"
mkdir -p "$src/src/reference" && cp docs/reference/cli.md "$src/src/reference/cli.md"
cp -r docs/img "$src/src/img"
cat > "$src/src/SUMMARY.md" <<'SUMMARY'
# Summary

[skyloop](index.md)

- [Tuning from your blackbox log](tuning.md)
- [Flight logs that identify well](flight-logs.md)
- [skyloop for MATLAB users](matlab.md)
- [The three papers reproduced](papers.md)
- [Python](python.md)
- [Command-line reference](reference/cli.md)
- [Architecture](design.md)
SUMMARY
cat > "$src/book.toml" <<'TOML'
[book]
title = "skyloop"
language = "en"
src = "src"

[output.html]
no-section-label = true
TOML
rm -rf target/book
"$tool/bin/mdbook" build "$src" --dest-dir "$PWD/target/book"
if [ -d web/dist ]; then
  cp -r web/dist target/book/browser
  echo "browser page: target/book/browser/index.html"
else
  echo "web/dist not built (web/build.sh): the site has no browser page" >&2
fi
echo "docs site: target/book/index.html"
