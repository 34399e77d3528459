#!/usr/bin/env bash
# Reference outputs of Betaflight's own filter code (issue 43): compiles the firmware's
# src/main/common/filter.c and maths.c for the host, from a git snapshot of betaflight/betaflight,
# with only the placement-attribute headers stubbed (tools/betaflight_ref/*.h), drives PT1, PT2, PT3,
# the biquad lowpass and the notch with an impulse, a step and a chirp (tools/betaflight_ref/harness.c)
# and writes crates/skyloop/tests/fixtures/betaflight/filters_<tag>.json with the firmware, tag,
# commit and source files in its header.
#
# The firmware is GPL-3: its sources are read from the snapshot into a temporary directory, compiled
# and deleted; only this script, the harness (skyloop's own code) and the outputs are committed.
#
# usage: tools/gen_betaflight_filters.sh BETAFLIGHT_GIT_DIR [TAG...]
#   BETAFLIGHT_GIT_DIR: e.g. the bare repository the search tool's fetch verb gives
#   (github:betaflight/betaflight); default tags: 4.2.11 4.5.5 2025.12.5
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$here/.."
repo="$1"; shift
tags=("$@"); [ ${#tags[@]} -gt 0 ] || tags=(4.2.11 4.5.5 2025.12.5)
out="$root/crates/skyloop/tests/fixtures/betaflight"
mkdir -p "$out"
for tag in "${tags[@]}"; do
  tmp="$(mktemp -d)"
  commit="$(git --git-dir="$repo" rev-parse "$tag^{commit}")"
  mkdir -p "$tmp/src/main/common"
  files=(filter.c filter.h maths.c maths.h utils.h axis.h)
  used=()
  for f in "${files[@]}"; do
    if git --git-dir="$repo" show "$commit:src/main/common/$f" > "$tmp/src/main/common/$f" 2>/dev/null; then
      used+=("src/main/common/$f")
    else
      rm -f "$tmp/src/main/common/$f"
    fi
  done
  defs=()
  grep -q 'pt2FilterGain' "$tmp/src/main/common/filter.h" && defs+=(-DHAVE_PT2)
  grep -q 'biquadFilterInit(.*float weight' "$tmp/src/main/common/filter.h" && defs+=(-DBIQUAD_WEIGHT)
  # The firmware's own flags for these files: single-precision constants, no fast-math, so the
  # host's IEEE float arithmetic is the MCU's FPU arithmetic (Cortex-M4/M7 single precision).
  gcc -std=gnu11 -O1 -ffp-contract=off -fsingle-precision-constant -Wno-implicit-function-declaration \
    -I "$here/betaflight_ref" -I "$tmp/src/main" -I "$tmp/src/main/common" "${defs[@]}" \
    "$here/betaflight_ref/harness.c" "$tmp/src/main/common/filter.c" "$tmp/src/main/common/maths.c" \
    -lm -o "$tmp/harness"
  {
    printf '{"firmware":"Betaflight","tag":"%s","commit":"%s","files":[' "$tag" "$commit"
    printf '"%s",' "${used[@]}" | sed 's/,$//'
    printf '],"generator":"tools/gen_betaflight_filters.sh (tools/betaflight_ref/harness.c)","filters":'
    "$tmp/harness"
    printf '}\n'
  } > "$out/filters_$tag.json"
  rm -rf "$tmp"
  echo "wrote $out/filters_$tag.json ($(git --git-dir="$repo" log -1 --format=%cs "$commit"))"
done
