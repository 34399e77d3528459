//! `tune LOG` where the preset's first model is wrong around the flown crossover: a simulated
//! ArduCopter roll loop at 400 Hz whose plant has a second lag (K·e^(−Td·s)/(s·(τ₁s+1)(τ₂s+1)),
//! which the rate-loop model K·e^(−Td·s)/(s·(τs+1)) can follow in a band but not over a wide one),
//! flown with broadband stick input. The model fitted over the whole supported band misses |S| near
//! the flown crossover; tune fits it again within half to twice that crossover, says so, and the
//! refitted model rates the flown tune as the true loop does.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

#[path = "common/ardupilot_log.rs"]
mod ardupilot_log;
#[path = "common/loop_margins.rs"]
#[allow(dead_code)] // `fitted` is for the identification tests
mod common;
#[path = "../../skyloop-sysid/tests/common/dataflash_writer.rs"]
mod writer;

use skyloop::tune::log::tune_from_log_bytes;
use std::f64::consts::PI;

const K: f64 = 6000.0; // deg/s² per unit of RATE.ROut
const TAU1: f64 = 0.03; // s
const TAU2: f64 = 0.008; // s
const TD: f64 = 0.004; // s
const FLOWN_PER_DEG: (f64, f64, f64) = (0.02, 0.1, 0.0003);

fn flight() -> Vec<(u64, f64, f64, f64)> {
    let mut rnd = ardupilot_log::lcg(777u64);
    let mut hold = 0.0;
    // Stick steps every 0.125 s and a new small random value every step: broadband, unsaturated.
    let desired = move |k: u64, _t: f64| {
        if k % 50 == 0 {
            hold = 40.0 * rnd();
        }
        hold + 8.0 * rnd()
    };
    let (mut rate, mut acc, mut m) = (0.0f64, 0.0f64, 0.0f64);
    // Two lags: the ESC and motor (τ₂), then the rotor's spin-up (τ₁).
    let plant = move |ud: f64, h: f64| {
        m += h * (ud - m) / TAU2;
        acc += h * (K * m - acc) / TAU1;
        rate += h * acc;
        rate
    };
    ardupilot_log::fly_rate_loop(24_000, FLOWN_PER_DEG, TD, desired, plant)
}

fn log_bytes() -> Vec<u8> {
    let (kp, ki, kd) = FLOWN_PER_DEG;
    let per_rad = 180.0 / PI;
    let params = [
        ("ATC_RAT_RLL_P", kp * per_rad),
        ("ATC_RAT_RLL_I", ki * per_rad),
        ("ATC_RAT_RLL_D", kd * per_rad),
        ("ATC_RAT_RLL_FF", 0.0),
        ("ATC_RAT_RLL_FLTT", 0.0),
        ("ATC_RAT_RLL_FLTE", 0.0),
        ("ATC_RAT_RLL_FLTD", 0.0),
        ("SCHED_LOOP_RATE", 400.0),
    ];
    ardupilot_log::rate_log(&params, &flight(), 1)
}

/// (crossover Hz, phase margin deg) of the loop the flown P, I, D (per deg/s) close around the true
/// plant, from L(jω) in closed form: the discrete derivative's roll-off at a quarter of the 400 Hz
/// loop and half a period of hold beside the delay (as `ardupilot_identify.rs` rates its loop).
fn true_margins() -> (f64, f64) {
    let (kp, ki, kd) = FLOWN_PER_DEG;
    let l = |w: f64| {
        let s = skyloop::lti::c64::new(0.0, w);
        let wd = 2.0 * PI * 100.0;
        let c = kp + ki / s + kd * s / (s / wd + 1.0);
        c * K * (-s * (TD + 0.5 / 400.0)).exp() / (s * (TAU1 * s + 1.0) * (TAU2 * s + 1.0))
    };
    common::crossover_and_phase_margin(l, 1.0, 5000.0)
}

#[test]
fn a_model_wrong_at_the_crossover_is_fitted_again_there() {
    let req = ardupilot_log::roll_request("sim-copter-two-lags.bin");
    let out = tune_from_log_bytes(&req, &log_bytes()).unwrap();
    let note = out
        .notes
        .iter()
        .find(|n| n.starts_with("the first model (fitted 2.0–200.0 Hz) disagreed with the flight"))
        .unwrap_or_else(|| panic!("no refit note in {:#?}", out.notes));
    assert!(note.contains("fitted again within"), "{note}");
    // The refit's band is half to twice the first model's flown crossover, around the mode's skirt.
    let (lo, hi) = out.identification.fit_band_hz.unwrap();
    assert!((hi / lo - 4.0).abs() < 1e-6 && lo > 2.0 && hi < 25.0, "{lo} .. {hi}");
    // It passes the checks the first one failed, and the step check.
    let c = out.crossover_check.as_ref().unwrap();
    assert!(!c.disagrees(), "{:?} vs {:?}", c.measured_peak(), c.predicted_peak());
    assert!(out.causal_step_rms.unwrap() <= 0.25, "{:?}", out.causal_step_rms);
    // The refitted model's |S| of the flown loop is the flight's (the first model's was 4.3 dB
    // low), and it rates the flown loop as the true plant does.
    let (m, _, me) = c.measured_peak();
    let (p, _) = c.predicted_peak();
    assert!(
        (m - p).abs() < 1.0 + 2.0 * me,
        "|S| measured {m:.1} ± {me:.1} dB, refit {p:.1} dB"
    );
    let cur = &out.current.as_ref().unwrap().margins;
    let (xo, pm) = true_margins();
    eprintln!(
        "{note}\nflown: refitted model {:.2} Hz PM {:.1}°, true {xo:.2} Hz PM {pm:.1}°; verdict {}",
        cur.crossover_hz, cur.phase_margin_deg, out.verdict.text
    );
    assert!(
        (cur.crossover_hz / xo - 1.0).abs() < 0.15,
        "crossover {} vs {xo}",
        cur.crossover_hz
    );
    assert!(
        (cur.phase_margin_deg - pm).abs() < 8.0,
        "PM {} vs {pm}",
        cur.phase_margin_deg
    );
}
