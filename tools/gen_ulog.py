#!/usr/bin/env python3
"""Writes crates/skyloop-sysid/tests/fixtures/ulog/pyulog.json: what pyulog reads from the ULog files in
testdata/logs (per topic instance: message count, first and last timestamp) and the data span that
skyloop's ULog reader must report, computed from pyulog's messages with the same rule.

Run: python3 -m venv /tmp/obvenv && /tmp/obvenv/bin/pip install pyulog==1.3.0
     /tmp/obvenv/bin/python tools/gen_ulog.py

The rule (mirrored in crates/skyloop-sysid/src/logs/ulog.rs):
- a message of a topic instance is *live* when its timestamp is non-zero and later than every earlier
  timestamp of that instance (zeros are never-published topics; repeats are stale snapshots);
- the logger starts at the file header's timestamp S; live messages stamped more than 1 s before S are
  snapshots published long before logging began (when S is 0 or after all data, there is no such cut);
- the span starts at the earliest remaining live timestamp and ends at the latest live timestamp of a
  topic instance with at least two live messages (a lone message cannot be told from a garbage stamp);
- a topic instance keeps its live messages inside the span; the duration is the span's length.

pyulog's own duration (last_timestamp - start_timestamp, from the header) is recorded for comparison.
"""

import json
import os

import numpy as np
from pyulog import ULog

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LOGS = os.path.join(ROOT, "testdata", "logs")
OUT = os.path.join(ROOT, "crates", "skyloop-sysid", "tests", "fixtures", "ulog", "pyulog.json")
PRE_START_US = 1_000_000


def live_mask(t):
    mask = np.zeros(len(t), dtype=bool)
    best = 0
    for k, x in enumerate(t):
        if x > 0 and x > best:
            mask[k] = True
        best = max(best, x)
    return mask


def record(path):
    u = ULog(path)
    header = int(u.start_timestamp)
    topics = []
    for d in u.data_list:
        t = d.data["timestamp"].astype(np.int64)
        topics.append((d.name, int(d.multi_id), t, live_mask(t)))
    all_live = [int(x) for _, _, t, m in topics for x in t[m]]
    cut = header - PRE_START_US if 0 < header <= max(all_live, default=0) else None
    starts = [x for x in all_live if cut is None or x >= cut]
    ends = [int(t[m].max()) for _, _, t, m in topics if m.sum() >= 2]
    start, end = min(starts), max(ends)
    out_topics = []
    for name, multi, t, m in topics:
        keep = m & (t >= start) & (t <= end)
        entry = {
            "name": name,
            "multi_id": multi,
            "messages": int(len(t)),
            "first_us": int(t[0]) if len(t) else None,
            "last_us": int(t[-1]) if len(t) else None,
            "kept": int(keep.sum()),
        }
        if keep.any():
            entry["kept_first_us"] = int(t[keep][0])
            entry["kept_last_us"] = int(t[keep][-1])
        out_topics.append(entry)
    return {
        "header_timestamp_us": header,
        "pyulog_last_timestamp_us": int(u.last_timestamp),
        "pyulog_duration_s": (u.last_timestamp - u.start_timestamp) / 1e6,
        "span_start_us": start,
        "span_end_us": end,
        "duration_s": (end - start) / 1e6,
        "dropouts": len(u.dropouts),
        "topics": out_topics,
    }


def main():
    files = sorted(f for f in os.listdir(LOGS) if f.endswith(".ulg"))
    out = {"generator": "tools/gen_ulog.py with pyulog 1.3.0", "files": {f: record(os.path.join(LOGS, f)) for f in files}}
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    with open(OUT, "w") as fh:
        json.dump(out, fh, indent=0, separators=(",", ":"))
        fh.write("\n")
    for f, r in out["files"].items():
        print(f"{f}: {r['duration_s']:.3f} s (pyulog header-to-last {r['pyulog_duration_s']:.3f} s)")
    print(OUT, os.path.getsize(OUT), "bytes")


if __name__ == "__main__":
    main()
