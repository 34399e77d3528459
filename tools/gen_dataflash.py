#!/usr/bin/env python3
"""A synthetic ArduCopter-like DataFlash log, written from ArduPilot's description of the format.

    python3 tools/gen_dataflash.py testdata/logs/synthetic_arducopter.bin

Python's standard library only (struct); independent of skyloop's reader and of its Rust test
writer. The log mimics ArduCopter's messages: FMT, FMTU, UNIT, MULT, PARM, MSG (banner and frame),
RATE at 400 Hz, IMU and GYR with two instances each (FMTU marks the instance field with '#'),
PIDR/PIDP/PIDY and RCOU, and one message (TST) using the format letters a real Copter log rarely
has (E, q, g, d, C, e, L, M, b). Deterministic: the same bytes every run.

Messages: a sync 0xA3 0x95, the type byte, then the fields little-endian as the type's FMT says.
FMT (type 128): Type B, Length B (whole message incl. the 3-byte header), Name n (char[4]),
Format N (char[16]), Columns Z (char[64]).
"""

import math
import struct
import sys

SIZES = {
    "b": "b", "B": "B", "M": "B", "h": "h", "H": "H", "i": "i", "I": "I", "q": "q", "Q": "Q",
    "f": "f", "d": "d", "g": "e", "c": "h", "C": "H", "e": "i", "E": "I", "L": "i",
    "n": "4s", "N": "16s", "Z": "64s", "a": "32h",
}


class Log:
    def __init__(self):
        self.out = bytearray()
        self.types = {}
        self.define(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns")

    def define(self, type_id, name, fmt, labels):
        st = "<" + "".join(SIZES[c] for c in fmt)
        length = 3 + struct.calcsize(st)
        self.types[name] = (type_id, fmt, st)
        self.out += bytes([0xA3, 0x95, 128]) + struct.pack(
            "<BB4s16s64s", type_id, length, name.encode(), fmt.encode(), labels.encode())

    def msg(self, name, *values):
        type_id, fmt, st = self.types[name]
        flat = []
        for c, v in zip(fmt, values):
            if c in "nNZ":
                flat.append(v.encode())
            elif c == "a":
                flat.extend(v)
            else:
                flat.append(v)
        self.out += bytes([0xA3, 0x95, type_id]) + struct.pack(st, *flat)


def build():
    log = Log()
    log.define(129, "FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds")
    log.define(130, "UNIT", "QbZ", "TimeUS,Id,Label")
    log.define(131, "MULT", "Qbd", "TimeUS,Id,Mult")
    log.define(132, "PARM", "QNff", "TimeUS,Name,Value,Default")
    log.define(133, "MSG", "QZ", "TimeUS,Message")
    log.define(134, "RATE", "Qffffffffffff", "TimeUS,RDes,R,ROut,PDes,P,POut,YDes,Y,YOut,ADes,A,AOut")
    log.define(135, "IMU", "QBffffffIIfBBHH", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz")
    log.define(136, "GYR", "QBQfff", "TimeUS,I,SampleUS,GyrX,GyrY,GyrZ")
    for t, n in ((137, "PIDR"), (138, "PIDP"), (139, "PIDY")):
        log.define(t, n, "QffffffffffB", "TimeUS,Tar,Act,Err,P,I,D,FF,DFF,Dmod,SRate,Flags")
    log.define(140, "RCOU", "QHHHHHHHHHHHHHH", "TimeUS,C1,C2,C3,C4,C5,C6,C7,C8,C9,C10,C11,C12,C13,C14")
    log.define(141, "TST", "QbEqgdCeLMa", "TimeUS,B8,E32,Q64,G16,D64,C16,E16,Lat,Mode,Arr")
    for i, (u, label) in enumerate([("s", "s"), ("E", "rad/s"), ("o", "m/s/s"), ("k", "deg/s"), ("#", "instance"),
                                    ("-", ""), ("O", "degC")]):
        log.msg("UNIT", 0, ord(u), label)
    for m, v in ((ord("F"), 1e-6), (ord("-"), 0.0), (ord("0"), 1.0), (ord("B"), 1e-2)):
        log.msg("MULT", 0, m, v)
    log.msg("FMTU", 0, 134, "skkk-kkk-kkk-", "F000-000-000-")
    log.msg("FMTU", 0, 135, "s#EEEooo--O--zz", "F-000000--0----")
    log.msg("FMTU", 0, 136, "s#sEEE", "F-F000")
    for t in (137, 138, 139):
        log.msg("FMTU", 0, t, "skk-----------", "F00----------")
    log.msg("FMTU", 0, 140, "sYYYYYYYYYYYYYY", "F--------------")
    params = [("ATC_RAT_RLL_P", 0.135), ("ATC_RAT_RLL_I", 0.135), ("ATC_RAT_RLL_D", 0.0036),
              ("ATC_RAT_RLL_FF", 0.0), ("ATC_RAT_RLL_FLTT", 20.0), ("ATC_RAT_RLL_FLTE", 0.0),
              ("ATC_RAT_RLL_FLTD", 20.0), ("ATC_RAT_PIT_P", 0.135), ("ATC_RAT_YAW_P", 0.18),
              ("INS_GYRO_FILTER", 20.0), ("INS_HNTCH_ENABLE", 1.0), ("INS_HNTCH_FREQ", 80.0),
              ("INS_HNTCH_BW", 40.0), ("SCHED_LOOP_RATE", 400.0)]
    for name, v in params:
        log.msg("PARM", 1000, name, v, v)
    for text in ("ArduCopter V4.3.7 (e1a9a5a3)", "ChibiOS: 38022f4f", "Frame: QUAD/X"):
        log.msg("MSG", 2000, text)
    t0 = 10_000_000
    for k in range(800):  # 2 s at 400 Hz
        t = t0 + 2500 * k
        x = 2 * math.pi * 3.0 * k / 400.0
        des = 30.0 * math.sin(x)
        act = 28.0 * math.sin(x - 0.3)
        log.msg("RATE", t, des, act, 0.1 * (des - act), 0, 0, 0, 0, 0, 0, 0, 0, 0)
        for inst in (0, 1):
            g = math.radians(act) + 0.01 * inst
            log.msg("IMU", t + 100 + inst, inst, g, -g, 0.5 * g, 0.1, 0.2, -9.8, 0, 0, 45.0, 1, 1, 400, 400)
            log.msg("GYR", t + 200 + inst, inst, t + 150, g, 0.0, -g)
        if k % 4 == 0:
            for n in ("PIDR", "PIDP", "PIDY"):
                log.msg(n, t + 300, math.radians(des), math.radians(act), math.radians(des - act),
                        0.1, 0.01, 0.001, 0.0, 0.0, 1.0, 0.0, 0)
            log.msg("RCOU", t + 400, *[1500 + (k // 4) % 100 + j for j in range(14)])
        if k % 40 == 0:
            s = 1 if k % 80 == 0 else -1
            log.msg("TST", t + 500, -100 * s, 4_000_000_000 + k, -(2 ** 60) * s, 1.5 * s,
                    math.pi * s, 65000, -123456 * s, 473977439 * s, 5,
                    [j * 100 * s for j in range(32)])
    return bytes(log.out)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    data = build()
    with open(sys.argv[1], "wb") as f:
        f.write(data)
    print(f"wrote {sys.argv[1]}: {len(data)} bytes")
