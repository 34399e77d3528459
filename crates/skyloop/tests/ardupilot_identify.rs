//! `identify LOG --axis roll` on ArduPilot DataFlash logs: a closed rate loop simulated at
//! ArduCopter's 400 Hz (a known plant K·e^(−Td·s)/(s·(τs+1)) under a PID, the pilot's desired rate
//! as excitation) is written as RATE and CTUN messages with the DataFlash writer the reader's own
//! tests use, and identified through the firmware's channels (RATE.ROut → RATE.R, RATE.RDes as
//! instrument). The same flight logged at 10 Hz (ATTITUDE_MED) is refused with the logging
//! settings to change.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

#[path = "../../skyloop-sysid/tests/common/dataflash_writer.rs"]
#[allow(dead_code)]
mod writer;

use skyloop::identify::{identify_bytes, IdentifyRequest};
use writer::{Writer, V};

const K: f64 = 1500.0; // deg/s² per unit of RATE.ROut
const TAU: f64 = 0.03; // s
const TD: f64 = 0.01; // s

/// 40 s of a 400 Hz rate loop: (time µs, desired, rate, output) per control step.
fn flight() -> Vec<(u64, f64, f64, f64)> {
    let dt = 1.0 / 400.0;
    let sub = 20;
    let h = dt / sub as f64;
    let delay_steps = (TD / h).round() as usize;
    let (kp, ki, kd) = (0.004, 0.02, 0.00008);
    let mut buf = vec![0.0; delay_steps + 1];
    let (mut rate, mut acc, mut u, mut integ, mut prev_e) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut des = 0.0;
    let mut out = Vec::new();
    for k in 0..16_000u64 {
        let t = k as f64 * dt;
        // Stick steps every 0.1–0.4 s plus a small random component: broadband excitation.
        if k % 60 == 0 {
            des = 300.0 * rnd();
        }
        let desired = des + 20.0 * rnd() + 80.0 * (2.0 * std::f64::consts::PI * 7.0 * t).sin();
        let e = desired - rate;
        integ += e * dt;
        let d = (e - prev_e) / dt;
        prev_e = e;
        u = (kp * e + ki * integ + kd * d).clamp(-1.0, 1.0);
        out.push(((1_000_000.0 + t * 1e6) as u64, desired, rate, u));
        for _ in 0..sub {
            buf.rotate_right(1);
            buf[0] = u;
            let ud = buf[delay_steps];
            // τ·ω̇' = K·u − ω̇': the angular acceleration lags the command by τ.
            acc += h * (K * ud - acc) / TAU;
            rate += h * acc;
        }
    }
    let _ = u;
    out
}

/// The flight as a DataFlash log, RATE written every `every`-th control step.
fn log_bytes(every: usize) -> Vec<u8> {
    let mut w = Writer::new();
    w.define_units();
    w.define(133, "MSG", "QZ", "TimeUS,Message");
    w.define(135, "RATE", "Qfffffffff", "TimeUS,RDes,R,ROut,PDes,P,POut,YDes,Y,YOut");
    w.define(136, "CTUN", "Qf", "TimeUS,ThO");
    w.units(0, 135, "skkk-kk-kk", "F000000000");
    w.units(0, 136, "s-", "F0");
    w.msg("UNIT", &[V::I(0), V::N(f64::from(b's')), V::T("s".into())]);
    w.msg("MULT", &[V::I(0), V::N(f64::from(b'F')), V::N(1e-6)]);
    w.msg("MSG", &[V::I(100), V::T("ArduCopter V4.5.7 (2a3dc4b7)".into())]);
    for (k, (t, des, r, u)) in flight().into_iter().enumerate() {
        if k % every != 0 {
            continue;
        }
        let z = V::N(0.0);
        w.msg(
            "RATE",
            &[
                V::I(t.into()),
                V::N(des),
                V::N(r),
                V::N(u),
                z.clone(),
                z.clone(),
                z.clone(),
                z.clone(),
                z.clone(),
                z,
            ],
        );
        if k % 40 == 0 {
            w.msg("CTUN", &[V::I(t.into()), V::N(0.45)]);
        }
    }
    w.bytes
}

#[test]
fn a_400_hz_ardupilot_log_identifies_the_rate_loop() {
    let req = IdentifyRequest {
        data: "sim-copter.bin".into(),
        axis: Some("roll".into()),
        ..Default::default()
    };
    let id = identify_bytes(&log_bytes(1), &req).unwrap();
    let fit = &id.fit.as_ref().unwrap().1;
    let (k, tau, td) = (fit.params["K"], fit.params["tau"], fit.params["Td"]);
    eprintln!(
        "identified K {k:.1} (true {K}), tau {tau:.4} ({TAU}), Td {td:.4} ({TD}); input {}",
        id.input
    );
    assert!((k / K - 1.0).abs() < 0.15, "K {k} vs {K}");
    assert!((tau - TAU).abs() < 0.3 * TAU, "tau {tau} vs {TAU}");
    // The logged rate is read before the step's command: up to one 2.5 ms period more delay.
    assert!(td > TD - 0.002 && td < TD + 0.004, "Td {td} vs {TD}");
}

#[test]
fn a_10_hz_ardupilot_log_is_refused_with_the_settings_to_change() {
    let req = IdentifyRequest {
        data: "sim-copter.bin".into(),
        axis: Some("roll".into()),
        ..Default::default()
    };
    let e = identify_bytes(&log_bytes(40), &req).unwrap_err().to_string();
    assert!(
        e.contains("RATE is logged at 10 Hz") && e.contains("LOG_BITMASK"),
        "{e}"
    );
}
