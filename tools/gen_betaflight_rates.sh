#!/usr/bin/env bash
# Reference setpoints of Betaflight's own rate curves (issue 43): extracts the five rate functions
# (applyBetaflightRates, applyRaceFlightRates, applyKissRates, applyActualRates, applyQuickRates)
# and the constants they use from src/main/fc/rc.c of a git snapshot of betaflight/betaflight,
# unchanged, compiles them for the host against a stub of the rate profile
# (tools/betaflight_ref/rates_stub.h) and the firmware's common/maths.h and maths.c (powerf), drives them over stick
# deflections -1..1 (tools/betaflight_ref/rates_harness.c) and writes
# crates/skyloop/tests/fixtures/betaflight/rates_<tag>.json with the tag, commit and files.
# The firmware is GPL-3: its sources stay in a temporary directory and are deleted.
#
# usage: tools/gen_betaflight_rates.sh BETAFLIGHT_GIT_DIR [TAG...]   (default tags 4.2.11 4.5.5 2025.12.5)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$1"; shift
tags=("$@"); [ ${#tags[@]} -gt 0 ] || tags=(4.2.11 4.5.5 2025.12.5)
out="$here/../crates/skyloop/tests/fixtures/betaflight"
mkdir -p "$out"
for tag in "${tags[@]}"; do
  tmp="$(mktemp -d)"
  commit="$(git --git-dir="$repo" rev-parse "$tag^{commit}")"
  mkdir -p "$tmp/common"
  for f in maths.h maths.c axis.h; do
    git --git-dir="$repo" show "$commit:src/main/common/$f" > "$tmp/common/$f"
  done
  git --git-dir="$repo" show "$commit:src/main/fc/rc.c" > "$tmp/rc.c"
  {
    echo '#include "rates_stub.h"'
    grep -E '^#define (RC_RATE_INCREMENTAL|SETPOINT_RATE_LIMIT)' "$tmp/rc.c"
    # each function from its signature to its first closing brace at column 0; `static` dropped
    # so the harness can call it (the body is untouched)
    for f in Betaflight RaceFlight Kiss Actual Quick; do
      awk -v name="apply${f}Rates\\\\(const int axis" '
        $0 ~ name && $0 !~ /;$/ { on = 1; sub(/^static /, "") }
        on { print }
        on && /^}/ { on = 0 }' "$tmp/rc.c"
    done
  } > "$tmp/rates.c"
  gcc -std=gnu11 -O1 -ffp-contract=off -fsingle-precision-constant \
    -I "$here/betaflight_ref" -I "$tmp" "$here/betaflight_ref/rates_harness.c" "$tmp/rates.c" "$tmp/common/maths.c" -lm -o "$tmp/harness"
  # QUICK's `quickrates_rc_expo` exists from 4.3 on; before, the harness's flag is not read.
  has_qre=false; grep -q quickRatesRcExpo "$tmp/rc.c" && has_qre=true
  {
    printf '{"firmware":"Betaflight","tag":"%s","commit":"%s","has_quick_rc_expo":%s,"files":["src/main/fc/rc.c","src/main/common/maths.h","src/main/common/maths.c"],"generator":"tools/gen_betaflight_rates.sh (tools/betaflight_ref/rates_harness.c)","curves":' "$tag" "$commit" "$has_qre"
    "$tmp/harness"
    printf '}\n'
  } > "$out/rates_$tag.json"
  rm -rf "$tmp"
  echo "wrote $out/rates_$tag.json"
done
