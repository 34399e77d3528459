#!/usr/bin/env python3
"""Reference values for skyloop's ArduPilot DataFlash reader, from pymavlink's DFReader.

pymavlink (LGPL-3.0) is a reference tool only, never a dependency of skyloop:

    python3 -m venv /tmp/dfvenv && /tmp/dfvenv/bin/pip install pymavlink
    /tmp/dfvenv/bin/python tools/dataflash_reference.py LOG.bin OUT.json MSG.Field [MSG[k].Field ...]

For every requested field it writes, row for row in file order, the message's TimeUS in seconds
and the field's value as pymavlink returns it (format-letter scaling of c C e E L applied, FMTU
multipliers not). `MSG[k].Field` selects instance k of a message whose FMTU marks an instance field
(pymavlink's `instance_field`); `MSG.Field` of such a message selects instance 0, as skyloop names
them. It also records every PARM (name, value) and every MSG text.
"""

import json
import re
import sys

from pymavlink import DFReader


def parse_spec(spec):
    m = re.fullmatch(r"([A-Za-z0-9_]+)(?:\[([^\]]+)\])?\.(.+)", spec)
    if not m:
        raise SystemExit(f"bad field spec {spec!r} (MSG.Field or MSG[k].Field)")
    return m.group(1), m.group(2), m.group(3)


def main():
    if len(sys.argv) < 4:
        raise SystemExit(__doc__)
    path, out, specs = sys.argv[1], sys.argv[2], sys.argv[3:]
    wanted = [parse_spec(s) for s in specs]
    rows = {s: {"time_s": [], "values": []} for s in specs}
    params, texts = [], []
    r = DFReader.DFReader_binary(path, zero_time_base=False)
    while True:
        m = r.recv_msg()
        if m is None:
            break
        name = m.get_type()
        if name == "PARM":
            v = float(m.Value)
            params.append([m.Name, v if v == v else None])
        elif name == "MSG":
            texts.append(m.Message)
        for spec, (msg, inst, field) in zip(specs, wanted):
            if name != msg:
                continue
            ifield = m.fmt.instance_field
            if ifield is not None:
                have = getattr(m, ifield)
                want = inst if inst is not None else "0"
                if str(have) != want:
                    continue
            elif inst is not None:
                continue
            rows[spec]["time_s"].append(m.TimeUS / 1e6)
            v = float(getattr(m, field))
            # JSON has no NaN: null stands for it.
            rows[spec]["values"].append(v if v == v else None)
    try:
        import importlib.metadata as md

        version = md.version("pymavlink")
    except Exception:  # pragma: no cover
        version = "unknown"
    doc = {
        "generator": "tools/dataflash_reference.py",
        "reader": f"pymavlink {version} DFReader_binary",
        "log": path.split("/")[-1],
        "fields": rows,
        "params": params,
        "messages": texts,
    }
    with open(out, "w") as f:
        json.dump(doc, f, separators=(",", ":"), allow_nan=False)
        f.write("\n")
    print(f"wrote {out}: " + ", ".join(f"{s} {len(v['values'])} rows" for s, v in rows.items()))


if __name__ == "__main__":
    main()
