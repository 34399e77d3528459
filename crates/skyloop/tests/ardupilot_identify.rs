//! `identify LOG --axis roll` on ArduPilot DataFlash logs: a closed rate loop simulated at
//! ArduCopter's 400 Hz (a known plant K·e^(−Td·s)/(s·(τs+1)) under a PID, the pilot's desired rate
//! as excitation) is written as RATE and CTUN messages with the DataFlash writer the reader's own
//! tests use, and identified through the firmware's channels (RATE.ROut → RATE.R, RATE.RDes as
//! instrument). The same flight logged at 10 Hz (ATTITUDE_MED) is refused with the logging
//! settings to change. `tune` on it reads the flown ATC_RAT_RLL_* from the PARM messages, rates the
//! flown tune as the true loop rates it, and prints `param set` lines whose margins, recomputed
//! here from the printed numbers on the true plant, are those it claims.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

#[path = "common/ardupilot_log.rs"]
mod ardupilot_log;
#[path = "../../skyloop-sysid/tests/common/dataflash_writer.rs"]
mod writer;

use skyloop::identify::{identify_bytes, IdentifyRequest};
use skyloop::tune::log::tune_from_log_bytes;
use std::f64::consts::PI;
#[path = "common/loop_margins.rs"]
mod common;

const K: f64 = 6000.0; // deg/s² per unit of RATE.ROut
const TAU: f64 = 0.03; // s
const TD: f64 = 0.01; // s

/// The simulated controller's P, I, D per deg/s (ArduPilot's per rad/s are these × 180/π).
const FLOWN_PER_DEG: (f64, f64, f64) = (0.004, 0.02, 0.00008);

/// 40 s of a 400 Hz rate loop: (time µs, desired, rate, output) per control step.
fn flight() -> Vec<(u64, f64, f64, f64)> {
    let mut rnd = ardupilot_log::lcg(12345u64);
    let mut des = 0.0;
    // Stick steps every 0.15 s plus a small random component and a 7 Hz sine: broadband excitation.
    let desired = move |k: u64, t: f64| {
        if k % 60 == 0 {
            des = 300.0 * rnd();
        }
        des + 20.0 * rnd() + 80.0 * (2.0 * std::f64::consts::PI * 7.0 * t).sin()
    };
    let (mut rate, mut acc) = (0.0f64, 0.0f64);
    // τ·ω̇' = K·u − ω̇': the angular acceleration lags the command by τ.
    let plant = move |ud: f64, h: f64| {
        acc += h * (K * ud - acc) / TAU;
        rate += h * acc;
        rate
    };
    ardupilot_log::fly_rate_loop(16_000, FLOWN_PER_DEG, TD, desired, plant)
}

/// The flight as a DataFlash log, RATE written every `every`-th control step.
fn log_bytes(every: usize) -> Vec<u8> {
    let (kp, ki, kd) = FLOWN_PER_DEG;
    let per_rad = 180.0 / PI;
    let params = [
        ("ATC_RAT_RLL_P", kp * per_rad),
        ("ATC_RAT_RLL_I", ki * per_rad),
        ("ATC_RAT_RLL_D", kd * per_rad),
        ("ATC_RAT_RLL_FF", 0.0),
        // The simulated loop filters nothing: FLTT and FLTE off; FLTD off leaves the discrete
        // derivative's own roll-off.
        ("ATC_RAT_RLL_FLTT", 0.0),
        ("ATC_RAT_RLL_FLTE", 0.0),
        ("ATC_RAT_RLL_FLTD", 0.0),
        ("SCHED_LOOP_RATE", 400.0),
    ];
    ardupilot_log::rate_log(&params, &flight(), every)
}

#[test]
fn a_400_hz_ardupilot_log_identifies_the_rate_loop() {
    let req = IdentifyRequest {
        data: "sim-copter.bin".into(),
        axis: Some("roll".into()),
        ..Default::default()
    };
    let id = identify_bytes(&log_bytes(1), &req).unwrap();
    let (k, tau, td) = common::fitted(&id);
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

/// (crossover Hz, phase margin deg) of the loop the printed ATC_RAT_RLL_{P,I,D} (per rad/s) close
/// around the true plant (deg/s), from the numbers alone and L(jω) in closed form, no state space:
/// C(jω) = (π/180)·(P + I/(jω) + D·jω/(jω/ω_d + 1)) with the discrete derivative's roll-off ω_d at a
/// quarter of the 400 Hz loop, and half a period of hold beside the plant's delay.
fn true_margins(p: f64, i: f64, d: f64) -> (f64, f64) {
    let l = |w: f64| {
        let s = skyloop::lti::c64::new(0.0, w);
        let wd = 2.0 * PI * 100.0;
        let c = (PI / 180.0) * (p + i / s + d * s / (s / wd + 1.0));
        let g = K * (-s * (TD + 0.5 / 400.0)).exp() / (s * (TAU * s + 1.0));
        c * g
    };
    // |L| falls through 1 once on this loop: bisect on a log scale between 1 and 5000 rad/s.
    common::crossover_and_phase_margin(l, 1.0, 5000.0)
}

#[test]
fn tune_from_an_ardupilot_log_rates_the_flown_tune_and_prints_param_set_lines() {
    let req = ardupilot_log::roll_request("sim-copter.bin");
    let out = tune_from_log_bytes(&req, &log_bytes(1)).unwrap();
    let cur = out.current.as_ref().expect("the flown ATC_RAT_RLL_* are read");
    let (kp, ki, kd) = FLOWN_PER_DEG;
    let truth = true_margins(kp * 180.0 / PI, ki * 180.0 / PI, kd * 180.0 / PI);
    eprintln!(
        "flown: model crossover {:.2} Hz PM {:.1} deg; true {:.2} Hz PM {:.1} deg; verdict {}",
        cur.margins.crossover_hz, cur.margins.phase_margin_deg, truth.0, truth.1, out.verdict.text
    );
    assert!((cur.margins.crossover_hz / truth.0 - 1.0).abs() < 0.15);
    assert!((cur.margins.phase_margin_deg - truth.1).abs() < 8.0);
    // PARM holds a float32.
    let p_read = cur.gains["ATC_RAT_RLL_P"].as_f64().unwrap();
    assert!((p_read / (kp * 180.0 / PI) - 1.0).abs() < 1e-7, "{p_read}");
    // The lines load ATC_RAT_RLL_P, _I, _D, _FF, and their numbers are the analysed gains.
    let lines = &out.proposed.cli;
    let value = |n: &str| -> f64 {
        let l = lines
            .iter()
            .find(|l| l.starts_with(&format!("param set {n} ")))
            .unwrap();
        l.rsplit(' ').next().unwrap().parse().unwrap()
    };
    let (p, i, d) = (value("ATC_RAT_RLL_P"), value("ATC_RAT_RLL_I"), value("ATC_RAT_RLL_D"));
    assert!(
        lines.iter().any(|l| l.starts_with("param set ATC_RAT_RLL_FF ")),
        "{lines:?}"
    );
    let pa = &out.proposed_analysis;
    let t = true_margins(p, i, d);
    eprintln!(
        "proposed P {p} I {i} D {d}: claimed {:.2} Hz PM {:.1} deg; true plant {:.2} Hz PM {:.1} deg",
        pa.margins.crossover_hz, pa.margins.phase_margin_deg, t.0, t.1
    );
    assert!(t.1 > 30.0, "the printed gains on the true plant: PM {}", t.1);
    assert!((pa.margins.crossover_hz / t.0 - 1.0).abs() < 0.15);
    assert!((pa.margins.phase_margin_deg - t.1).abs() < 8.0);
    // The page's sliders: ArduPilot's keys, FLTD off leaves no cutoff to move, and a second
    // cutoff is refused by name.
    let live = out.live.as_ref().unwrap();
    let knobs = skyloop::tune::live::LiveLoop::knobs(&live.flown);
    assert_eq!(knobs["dterm"].as_array().unwrap().len(), 0, "{knobs}");
    let g = live.gains(&serde_json::json!({"ATC_RAT_RLL_P": 0.3})).unwrap();
    assert!(g.cli()[0] == "param set ATC_RAT_RLL_P 0.3", "{:?}", g.cli());
    let e = live
        .gains(&serde_json::json!({"dterm_hz": [20, 30]}))
        .unwrap_err()
        .to_string();
    assert!(e.contains("ATC_RAT_RLL_FLTD"), "{e}");
}
