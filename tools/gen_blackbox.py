#!/usr/bin/env python3
"""Writes crates/skyloop-sysid/tests/fixtures/blackbox/orangebox.json: what orangebox decodes from the
Betaflight logs in testdata/logs, as integers, for skyloop's own blackbox decoder to be checked against.

Run: python3 -m venv /tmp/obvenv && /tmp/obvenv/bin/pip install "pip<24" && /tmp/obvenv/bin/pip install orangebox==0.5.0
     /tmp/obvenv/bin/python tools/gen_blackbox.py

Per session the fixture holds the main-frame field names, the number of main frames, per-field integer
sums over all main frames, and the values of selected fields in selected frames (the first frames after
I-frames, evenly spaced frames, and frames named in EXTRA_ITERATIONS).

Known orangebox 0.5.0 behaviours, cross-checked by hand against the bytes (see the decoder's docs):
- When a session's data starts with an event frame (`E`, as every btfl_all.bbl session does: a
  LOGGING_RESUME event), orangebox's header reader swallows the data up to the first 0x0A byte and then
  decodes P-frames against an empty history until it meets an I-frame. Those frames are garbage, so the
  fixture starts at the first I-frame orangebox yields (`first_iteration`) and counts from there.
- A session without data after its headers (only a disarm and a log-end event) makes orangebox fail
  while splitting the file; such sessions are recorded with `error` and no frames.
- The last frame of a session that ends without a log-end event is not yielded (orangebox looks at the
  byte after it); `ended_by` says whether the session's frames ended on a log-end event or an exception.

Read in orangebox 0.5.0 and checked against the format documentation, without effect on these three
logs (the comparison is exact) but not to be bent to: a TAG2_3S32 field of 4 bytes is not sign-extended;
predictor 10 (GPS time from the last main frame) reads the main frame before last, at the GPS field's
index; a TAG8_8SVB group that ends the field list is read one field short; after a damaged frame, P-frames
go on being predicted from the history before the damage, and its time check can never fire. GPS and
slow frames are only compared indirectly (orangebox merges them into the main rows).
"""

import json
import logging
import os
import sys

from orangebox import Parser

logging.disable(logging.CRITICAL)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LOGS = os.path.join(ROOT, "testdata", "logs")
OUT = os.path.join(ROOT, "crates", "skyloop-sysid", "tests", "fixtures", "blackbox", "orangebox.json")
FILES = ["btfl_001.bbl", "LOG00037.BFL", "btfl_all.bbl"]
SELECTED = (
    ["loopIteration", "time"]
    + [f"gyroADC[{i}]" for i in range(3)]
    + [f"motor[{i}]" for i in range(4)]
    + [f"axis{k}[{i}]" for k in "PIDF" for i in range(3)]
    + [f"rcCommand[{i}]" for i in range(4)]
    + [f"setpoint[{i}]" for i in range(4)]
)
# Stretches worth pinning beyond the automatic choice: (file, session) -> (from, to) in seconds after
# the session's first main frame (the LOGGING_RESUME event that opens it). btfl_all.bbl session 35 at
# 0.3589-0.3669 s is where blackbox-log 0.4.3 predicted a P-frame from the frame before an I-frame and
# motor[1] wrapped to 4294967253 and nearby values.
EXTRA_WINDOWS_S = {("btfl_all.bbl", 35): (0.340, 0.380)}


def resume_time_us(path, index):
    """The time of the LOGGING_RESUME event (E, 14) that opens a session's data, or None."""
    data = open(path, "rb").read()
    marker = b"H Product:Blackbox flight data recorder by Nicholas Sherlock\n"
    starts = []
    i = data.find(marker)
    while i >= 0:
        starts.append(i)
        i = data.find(marker, i + 1)
    pos = starts[index - 1]
    while data[pos : pos + 1] == b"H":
        pos = data.index(b"\n", pos) + 1
    if data[pos : pos + 2] != b"E\x0e":
        return None
    pos += 2
    values = []
    for _ in range(2):
        v, shift = 0, 0
        while True:
            b = data[pos]
            pos += 1
            v |= (b & 0x7F) << shift
            shift += 7
            if b < 0x80:
                break
        values.append(v)
    return values[1]


def main_field_names(parser):
    from orangebox.types import FrameType

    return [f.name for f in parser.reader.field_defs[FrameType.INTRA]]


def session_record(path, index):
    rec = {"index": index}
    try:
        parser = Parser.load(path, index)
        names = main_field_names(parser)
    except Exception as e:  # noqa: BLE001 - orangebox raises bare exceptions
        rec["error"] = type(e).__name__
        return rec
    rec["firmware"] = str(parser.headers.get("Firmware revision", ""))
    rec["fields"] = names
    n = len(names)
    frames = []
    kinds = []
    ended_by = "log end"
    try:
        started = False
        for f in parser.frames():
            if not started:
                if f.type.value != "I":
                    continue
                started = True
            frames.append([int(v) for v in f.data[:n]])
            kinds.append(f.type.value)
    except Exception as e:  # noqa: BLE001
        ended_by = type(e).__name__
    rec["ended_by"] = ended_by
    rec["frames"] = len(frames)
    rec["i_frames"] = kinds.count("I")
    if not frames:
        return rec
    rec["first_iteration"] = frames[0][0]
    rec["sums"] = {name: sum(fr[i] for fr in frames) for i, name in enumerate(names)}
    chosen = set()
    i_positions = [k for k, t in enumerate(kinds) if t == "I"]
    for k in i_positions[:12] + i_positions[len(i_positions) // 2 : len(i_positions) // 2 + 4] + i_positions[-4:]:
        chosen.update(j for j in (k - 1, k, k + 1, k + 2) if 0 <= j < len(frames))
    spaced = 150 if len(frames) > 5000 else 30
    step = max(1, len(frames) // spaced)
    chosen.update(range(0, len(frames), step))
    chosen.add(len(frames) - 1)
    window = EXTRA_WINDOWS_S.get((os.path.basename(path), index))
    t0 = resume_time_us(path, index) if window else None
    if t0 is not None:
        ti = names.index("time")
        lo, hi = t0 + window[0] * 1e6, t0 + window[1] * 1e6
        pinned = [k for k, fr in enumerate(frames) if lo <= fr[ti] <= hi]
        rec["pinned"] = pinned
        chosen.update(pinned)
    cols = [names.index(s) for s in SELECTED if s in names]
    rec["selected_fields"] = [names[c] for c in cols]
    rec["selected"] = [[k, kinds[k]] + [frames[k][c] for c in cols] for k in sorted(chosen)]
    return rec


def main():
    out = {"generator": "tools/gen_blackbox.py with orangebox 0.5.0", "files": {}}
    for name in FILES:
        path = os.path.join(LOGS, name)
        count = Parser.load(path).reader.log_count
        out["files"][name] = {"sessions": [session_record(path, i) for i in range(1, count + 1)]}
        print(name, [(s["index"], s.get("frames"), s.get("error")) for s in out["files"][name]["sessions"]], file=sys.stderr)
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    with open(OUT, "w") as f:
        json.dump(out, f, separators=(",", ":"))
        f.write("\n")
    print(OUT, os.path.getsize(OUT), "bytes", file=sys.stderr)


if __name__ == "__main__":
    main()
