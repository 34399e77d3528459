#!/usr/bin/env bash
# Builds the static page into web/dist/ (GitHub-Pages-ready: relative paths, index.html, .nojekyll):
# skyloop-web for wasm32-unknown-unknown (profile `wasm`: the release build sized down), then
# wasm-bindgen (the CLI pinned to the wasm-bindgen crate version in Cargo.lock, installed where
# missing), the page, its vendored uPlot and the demo log. No C compiler and no npm are needed.
#   web/build.sh && python3 -m http.server -d web/dist   # then open http://localhost:8000/?demo=1
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
out=web/dist

if ! rustup target list --installed 2>/dev/null | grep -qx wasm32-unknown-unknown; then
  echo "the wasm32-unknown-unknown target is missing: running rustup target add wasm32-unknown-unknown" >&2
  rustup target add wasm32-unknown-unknown
fi

# The wasm-bindgen CLI must be exactly the version of the wasm-bindgen crate the module links.
ver=$(awk '$0 == "name = \"wasm-bindgen\"" { getline; gsub(/"/, "", $3); print $3; exit }' Cargo.lock)
if [ -z "$ver" ]; then
  echo "no wasm-bindgen in Cargo.lock" >&2
  exit 1
fi
bindgen=$(command -v wasm-bindgen || true)
if [ -z "$bindgen" ] || ! "$bindgen" --version | grep -qx "wasm-bindgen $ver"; then
  echo "installing wasm-bindgen-cli $ver (cargo install wasm-bindgen-cli --version $ver --locked)" >&2
  # Its own build scripts may compile C (the TLS of its test-runner downloads): a CC set to
  # /bin/false for the skyloop build does not apply to this tool.
  env -u CC -u CXX cargo install wasm-bindgen-cli --version "$ver" --locked \
    || env -u CC -u CXX cargo install wasm-bindgen-cli --version "$ver"
  bindgen="${CARGO_HOME:-$HOME/.cargo}/bin/wasm-bindgen"
fi

cargo build --profile wasm --target wasm32-unknown-unknown -p skyloop-web
rm -rf "$out"
mkdir -p "$out/pkg" "$out/vendor" "$out/testdata"
"$bindgen" --target web --no-typescript --out-dir "$out/pkg" target/wasm32-unknown-unknown/wasm/skyloop_web.wasm
cp web/index.html web/app.js web/plots.js web/worker.js web/style.css "$out/"
cp -r web/vendor/uplot "$out/vendor/"
# ?demo=1 tunes this Betaflight 4.2.8 acro flight (session 4 of fc-blackbox's btfl_all.bbl, MIT OR
# Apache-2.0: testdata/logs/SOURCES.md).
cp testdata/logs/btfl_all.bbl "$out/testdata/demo.bbl"
cp testdata/logs/SOURCES.md "$out/testdata/SOURCES.md"
touch "$out/.nojekyll"
size=$(stat -c %s "$out/pkg/skyloop_web_bg.wasm")
echo "built $root/$out: skyloop_web_bg.wasm $((size / 1024)) KiB ($size bytes)"
if [ "$size" -gt $((5 * 1024 * 1024)) ]; then
  echo "the wasm module is above 5 MB" >&2
  exit 1
fi
