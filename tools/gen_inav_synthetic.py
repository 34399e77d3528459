#!/usr/bin/env python3
"""Writes testdata/logs/synthetic_inav_9.TXT: a simulated INAV 9 multirotor flight as a blackbox log
with the header conventions of a real INAV 9.0.1 log (the GPL log in ../shared/data/logs, which is
not committed; only its conventions are followed): `Firmware revision:INAV 9.0.1 ...`, `Firmware
type:Cleanflight`, the rate target logged as `axisRate[i]` (no `setpoint`), `rollPID:P,I,D,CD`,
`motorOutput:1080,2000`, `minthrottle`, `looptime:500` (2 kHz PID), `P interval:1/2` (1 kHz
logging), `dterm_lpf_hz`/`dterm_lpf_type`, `gyro_lpf_hz`.

The flight: 40 s at hover throttle, each axis driven by stick steps and a small broadband part,
through INAV's multicopter rate PID as its pid.c documents it (P = e·P/31, I += e·I/4·dT,
D = −Δgyro/dT·D/1905 after a PT1 D-term lowpass, on the measurement; CD = 0) into the plant
K·e^(−Td·s)/(s·(τs+1)) of each axis (roll K 150, pitch K 130, yaw K 60 deg/s² per PID unit,
τ 20 ms, Td 4 ms). The mixer spreads the PID sums over four motors around hover.

Frames: an I-frame every 32 logged frames, P-frames between them, every field predicted from the
previous frame (predictor 1) and written as a signed variable-length integer (encoding 0), so the
encoder is a few lines; the decoders read predictor and encoding from the header.

Run from the repository root:  python3 tools/gen_inav_synthetic.py   (needs numpy)
"""
import os

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "testdata", "logs", "synthetic_inav_9.TXT")

PID_HZ = 2000.0
LOG_EVERY = 2
DURATION_S = 40.0
K = (150.0, 130.0, 60.0)
TAU = 0.02
TD = 0.004
GAINS = ((32, 82, 32, 0), (35, 90, 35, 0), (40, 84, 0, 0))  # P, I, D, CD per axis
DTERM_LPF_HZ = 110.0  # PT1 (dterm_lpf_type 0)
MOTOR_MIN, MOTOR_MAX = 1080, 2000
HOVER = 1450.0

FIELDS = (
    ["loopIteration", "time"]
    + [f"axisRate[{i}]" for i in range(3)]
    + [f"axisP[{i}]" for i in range(3)]
    + [f"axisI[{i}]" for i in range(3)]
    + [f"axisD[{i}]" for i in range(2)]
    + [f"axisF[{i}]" for i in range(3)]
    + [f"rcCommand[{i}]" for i in range(4)]
    + [f"gyroADC[{i}]" for i in range(3)]
    + [f"motor[{i}]" for i in range(4)]
)


def zigzag_vb(v):
    u = (v << 1) ^ (v >> 31) if v < 0 else v << 1
    u &= 0xFFFFFFFF
    out = bytearray()
    while u >= 0x80:
        out.append((u & 0x7F) | 0x80)
        u >>= 7
    out.append(u)
    return bytes(out)


def header():
    n = len(FIELDS)
    signed = ",".join("0" if f in ("loopIteration", "time") or f.startswith("motor") else "1" for f in FIELDS)
    lines = [
        "Product:Blackbox flight data recorder by Nicholas Sherlock",
        "Data version:2",
        "I interval:32",
        "Field I name:" + ",".join(FIELDS),
        "Field I signed:" + signed,
        "Field I predictor:" + ",".join(["0"] * n),
        "Field I encoding:" + ",".join(["0"] * n),
        "Field P predictor:" + ",".join(["1"] * n),
        "Field P encoding:" + ",".join(["0"] * n),
        "Firmware type:Cleanflight",
        "Firmware revision:INAV 9.0.1 (00000000) SYNTHETIC",
        "Firmware date:Jan  1 2026 00:00:00",
        "Craft name:SYNTHETIC",
        "P interval:1/2",
        f"minthrottle:{MOTOR_MIN}",
        f"maxthrottle:{MOTOR_MAX}",
        "gyro_scale:0x3f800000",
        f"motorOutput:{MOTOR_MIN},{MOTOR_MAX}",
        "acc_1G:2048",
        "looptime:500",
        "rc_rate:100",
        "rc_expo:70",
        "rc_yaw_expo:70",
        "thr_mid:50",
        "thr_expo:0",
        "tpa_rate:0",
        "tpa_breakpoint:1500",
        "rates:60,60,50",
        "rollPID:" + ",".join(map(str, GAINS[0])),
        "pitchPID:" + ",".join(map(str, GAINS[1])),
        "yawPID:" + ",".join(map(str, GAINS[2])),
        "yaw_lpf_hz:0",
        f"dterm_lpf_hz:{DTERM_LPF_HZ:.0f}",
        "dterm_lpf_type:0",
        "deadband:2",
        "yaw_deadband:2",
        "gyro_lpf:0",
        "gyro_lpf_hz:250",
        "motor_pwm_protocol:6",
        "debug_mode:0",
    ]
    return "".join(f"H {l}\n" for l in lines).encode()


def simulate():
    dt = 1.0 / PID_HZ
    sub = 10
    h = dt / sub
    n = int(DURATION_S * PID_HZ)
    rng = np.random.default_rng(9)
    delay = int(round(TD / h))
    rows = []
    rate = np.zeros(3)
    acc = np.zeros(3)
    integ = np.zeros(3)
    dfilt = np.zeros(3)
    prev_gyro = np.zeros(3)
    buf = np.zeros((delay + 1, 3))
    target = np.zeros(3)
    hold = np.zeros(3)
    alpha = dt / (1.0 / (2 * np.pi * DTERM_LPF_HZ) + dt)
    amp = np.array([250.0, 200.0, 120.0])
    for k in range(n):
        t = k * dt
        # Stick steps every 0.1-0.3 s, per axis, and a little broadband input on top.
        for ax in range(3):
            if k % int(PID_HZ * (0.1 + 0.05 * ax)) == 0:
                hold[ax] = amp[ax] * rng.uniform(-1, 1)
        target = np.round(hold + 0.1 * amp * rng.uniform(-1, 1, 3))
        gyro = np.round(rate)
        e = target - gyro
        out = np.zeros((3, 4))
        for ax in range(3):
            p, i, d, _ = GAINS[ax]
            pt = e[ax] * p / 31.0
            integ[ax] = np.clip(integ[ax] + e[ax] * i / 4.0 * dt, -200, 200)
            draw = -(gyro[ax] - prev_gyro[ax]) / dt * d / 1905.0
            dfilt[ax] += alpha * (draw - dfilt[ax])
            out[ax] = (pt, integ[ax], dfilt[ax], 0.0)
        prev_gyro = gyro
        u = np.clip(out.sum(axis=1), -500, 500)
        if k % LOG_EVERY == 0:
            mix = np.array([[-1, 1, -1], [-1, -1, 1], [1, 1, 1], [1, -1, -1]])  # quad X, INAV order
            motors = np.clip(HOVER + 0.5 * mix @ u, MOTOR_MIN, MOTOR_MAX)
            rc = [int(target[0] / 2), int(target[1] / 2), int(target[2] / 2), int(HOVER)]
            row = (
                [k, int(round(1_000_000 + t * 1e6))]
                + [int(x) for x in target]
                + [int(round(out[ax, 0])) for ax in range(3)]
                + [int(round(out[ax, 1])) for ax in range(3)]
                + [int(round(out[ax, 2])) for ax in range(2)]
                + [0, 0, 0]
                + rc
                + [int(x) for x in gyro]
                + [int(round(m)) for m in motors]
            )
            rows.append(row)
        for _ in range(sub):
            buf = np.roll(buf, 1, axis=0)
            buf[0] = u
            ud = buf[delay]
            acc += h * (np.array(K) * ud - acc) / TAU
            rate += h * acc
    return rows


def main():
    rows = simulate()
    out = bytearray(header())
    prev = None
    for j, row in enumerate(rows):
        if j % 32 == 0:
            out += b"I" + b"".join(zigzag_vb(v) for v in row)
        else:
            out += b"P" + b"".join(zigzag_vb(v - pv) for v, pv in zip(row, prev))
        prev = row
    out += b"E\xff" + b"End of log\x00"
    with open(OUT, "wb") as f:
        f.write(out)
    print(f"wrote {OUT}: {len(rows)} frames, {len(out)} bytes")


if __name__ == "__main__":
    main()
