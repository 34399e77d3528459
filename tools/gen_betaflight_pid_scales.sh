#!/usr/bin/env bash
# Betaflight's PID scale factors as each version's source defines them (issue 43): PTERM_SCALE,
# ITERM_SCALE, DTERM_SCALE, FEEDFORWARD_SCALE from src/main/flight/pid.h, the divisor of F in
# Kf = FEEDFORWARD_SCALE·F/100 and the yaw I factor (pidCoefficient[FD_YAW].Ki *= 2.5f, 4.0 on)
# from pid_init.c (4.3 on) or pid.c, read from a git snapshot of betaflight/betaflight and written
# to crates/skyloop/tests/fixtures/betaflight/pid_scales.json with each tag's commit and files.
# The values are read, not compiled: they are preprocessor constants and one literal each.
#
# usage: tools/gen_betaflight_pid_scales.sh BETAFLIGHT_GIT_DIR [TAG...]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$1"; shift
tags=("$@"); [ ${#tags[@]} -gt 0 ] || tags=(3.5.7 4.0.6 4.2.11 4.3.2 4.4.3 4.5.5 2025.12.5)
out="$here/../crates/skyloop/tests/fixtures/betaflight/pid_scales.json"
{
  echo '{"firmware":"Betaflight","generator":"tools/gen_betaflight_pid_scales.sh","versions":['
  first=1
  for tag in "${tags[@]}"; do
    commit="$(git --git-dir="$repo" rev-parse "$tag^{commit}")"
    h="$(git --git-dir="$repo" show "$commit:src/main/flight/pid.h")"
    init=src/main/flight/pid_init.c
    git --git-dir="$repo" cat-file -e "$commit:$init" 2>/dev/null || init=src/main/flight/pid.c
    c="$(git --git-dir="$repo" show "$commit:$init")"
    val() { echo "$h" | sed -n "s/^#define $1 \([0-9.]*\)f.*/\1/p" | head -1; }
    yaw=1; echo "$c" | grep -q 'FD_YAW\]\.Ki \*= 2\.5f' && yaw=2.5
    fdiv="$(echo "$c" | sed -n 's/.*Kf = FEEDFORWARD_SCALE \* (pidProfile->pid\[axis\]\.F \(\/ 100\.0f\|\* 0\.01f\)).*/\1/p' | head -1)"
    case "$fdiv" in "/ 100.0f"|"* 0.01f") fdiv=100 ;; *) fdiv=null ;; esac
    [ $first = 1 ] || echo ','
    first=0
    printf '{"tag":"%s","commit":"%s","files":["src/main/flight/pid.h","%s"],"pterm_scale":%s,"iterm_scale":%s,"dterm_scale":%s,"feedforward_scale":%s,"f_divisor":%s,"yaw_i_factor":%s}' \
      "$tag" "$commit" "$init" "$(val PTERM_SCALE)" "$(val ITERM_SCALE)" "$(val DTERM_SCALE)" "$(val FEEDFORWARD_SCALE)" "$fdiv" "$yaw"
  done
  echo ']}'
} > "$out"
echo "wrote $out"
