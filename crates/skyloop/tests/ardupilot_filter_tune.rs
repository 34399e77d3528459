//! `tune --tune-filters` on an ArduPilot log whose true loop is known: a 400 Hz rate loop around
//! K·e^(−Td·s)/(s·(τs+1)), the gyro (with white sensor noise) through `INS_GYRO_FILTER` (a biquad)
//! before both the controller and the log, and the D term through `ATC_RAT_RLL_FLTD` (first order).
//! The proposal may move both cutoffs. The claims are checked against the true loop with the
//! printed gains *and* the printed filters, computed here in closed form (no state space): the gyro
//! lowpass de-embedding (P·G_new/G_flown) must predict what the true plant behind the new filter
//! does. And every rule of the issue holds: each change has its reason and its `param set` line,
//! no moved cutoff below 1.5× the crossover, the predicted noise within the budget.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

#[path = "common/ardupilot_log.rs"]
#[allow(dead_code)] // `fly_rate_loop` is for the tests that simulate a 400 Hz loop
mod ardupilot_log;
#[path = "common/loop_margins.rs"]
#[allow(dead_code)] // `fitted` is for the identification tests
mod common;
#[path = "../../skyloop-sysid/tests/common/dataflash_writer.rs"]
mod writer;

use skyloop::lti::c64;
use skyloop::tune::log::tune_from_log_bytes;
use std::f64::consts::{PI, SQRT_2};

const K: f64 = 6000.0; // deg/s² per unit of RATE.ROut
const TAU: f64 = 0.03; // s
const TD: f64 = 0.004; // s
const GYRO_HZ: f64 = 15.0; // INS_GYRO_FILTER, deliberately low: its phase lag costs the loop
const FLTD_HZ: f64 = 20.0; // ATC_RAT_RLL_FLTD
const LOOP_HZ: f64 = 400.0;
/// P, I, D per deg/s (the parameters are these × 180/π).
const FLOWN_PER_DEG: (f64, f64, f64) = (0.004, 0.01, 0.00006);

/// 40 s of the loop: (time µs, desired, logged rate, output) per control step.
fn flight() -> Vec<(u64, f64, f64, f64)> {
    let dt = 1.0 / LOOP_HZ;
    let sub = 20;
    let h = dt / f64::from(sub);
    let delay_steps = (TD / h).round() as usize;
    let (kp, ki, kd) = FLOWN_PER_DEG;
    let (wg, wd) = (2.0 * PI * GYRO_HZ, 2.0 * PI * FLTD_HZ);
    let mut buf = vec![0.0; delay_steps + 1];
    let (mut rate, mut acc) = (0.0f64, 0.0f64);
    let (mut g1, mut g2) = (0.0f64, 0.0f64); // the gyro biquad's states
    let (mut integ, mut prev_e, mut dfilt) = (0.0f64, 0.0f64, 0.0f64);
    let mut rnd = ardupilot_log::lcg(987_654_321u64);
    let mut des = 0.0;
    let mut out = Vec::new();
    let mut u = 0.0;
    for k in 0..16_000u64 {
        let t = k as f64 * dt;
        if k % 60 == 0 {
            des = 300.0 * rnd();
        }
        let desired = des + 20.0 * rnd() + 80.0 * (2.0 * PI * 5.0 * t).sin();
        let e = desired - g1;
        integ += e * dt;
        let d = (e - prev_e) / dt;
        prev_e = e;
        // FLTD: a first-order lowpass on the derivative, discretized at the loop rate.
        dfilt += (d - dfilt) * (wd * dt / (1.0 + wd * dt));
        u = (kp * e + ki * integ + kd * dfilt).clamp(-1.0, 1.0);
        out.push(((1_000_000.0 + t * 1e6) as u64, desired, g1, u));
        for _ in 0..sub {
            buf.rotate_right(1);
            buf[0] = u;
            acc += h * (K * buf[delay_steps] - acc) / TAU;
            rate += h * acc;
            // The gyro sees the rate plus sensor noise, then INS_GYRO_FILTER.
            let meas = rate + 8.0 * rnd();
            g2 += h * (wg * wg * (meas - g1) - SQRT_2 * wg * g2);
            g1 += h * g2;
        }
    }
    let _ = u;
    out
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
        ("ATC_RAT_RLL_FLTD", FLTD_HZ),
        ("INS_GYRO_FILTER", GYRO_HZ),
        ("SCHED_LOOP_RATE", LOOP_HZ),
    ];
    ardupilot_log::rate_log(&params, &flight(), 1)
}

/// (crossover Hz, phase margin deg) of the true loop with gains per rad/s and the two cutoffs, in
/// closed form: C = (π/180)·(P + I/s + D·s·ω_d/(s + ω_d)), the plant with half a period of hold,
/// the gyro biquad at `gyro_hz`.
fn true_margins(p: f64, i: f64, d: f64, gyro_hz: f64, fltd_hz: f64) -> (f64, f64) {
    let l = |w: f64| {
        let s = c64::new(0.0, w);
        let (wg, wd) = (2.0 * PI * gyro_hz, 2.0 * PI * fltd_hz);
        let c = (PI / 180.0) * (p + i / s + d * s * wd / (s + wd));
        let gyro = wg * wg / (s * s + SQRT_2 * wg * s + wg * wg);
        let g = K * (-s * (TD + 0.5 / LOOP_HZ)).exp() / (s * (TAU * s + 1.0));
        c * g * gyro
    };
    common::crossover_and_phase_margin(l, 1.0, 2000.0)
}

#[test]
fn gyro_and_dterm_cutoffs_tuned_on_an_ardupilot_log_hold_on_the_true_loop() {
    let mut req = ardupilot_log::roll_request("sim-filters.bin");
    req.tune_filters = true;
    // A pilot who accepts more motor noise for pace (`--noise-budget 3`): the phase a low gyro
    // lowpass costs is then worth buying back.
    req.noise_budget = 3.0;
    let out = tune_from_log_bytes(&req, &log_bytes()).unwrap();
    let cur = out.current.as_ref().unwrap();
    let per_rad = 180.0 / PI;
    let (kp, ki, kd) = FLOWN_PER_DEG;
    let truth = true_margins(kp * per_rad, ki * per_rad, kd * per_rad, GYRO_HZ, FLTD_HZ);
    eprintln!(
        "flown: model {:.2} Hz PM {:.1}°, true {:.2} Hz PM {:.1}°; verdict {}",
        cur.margins.crossover_hz, cur.margins.phase_margin_deg, truth.0, truth.1, out.verdict.text
    );
    for c in &out.filter_changes {
        eprintln!("change {} {} → {}: {}", c.name, c.flown_hz, c.proposed_hz, c.reason);
    }
    let lines = &out.proposed.cli;
    eprintln!("{lines:?}");
    let value = |n: &str, flown: f64| -> f64 {
        lines
            .iter()
            .find(|l| l.starts_with(&format!("param set {n} ")))
            .map_or(flown, |l| l.rsplit(' ').next().unwrap().parse().unwrap())
    };
    let gyro_hz = value("INS_GYRO_FILTER", GYRO_HZ);
    let fltd_hz = value("ATC_RAT_RLL_FLTD", FLTD_HZ);
    assert!(
        !out.filter_changes.is_empty() && gyro_hz != GYRO_HZ,
        "a 15 Hz gyro lowpass under a loop this slow costs phase: the proposal should move it"
    );
    let xo = out.proposed_analysis.margins.crossover_hz;
    for c in &out.filter_changes {
        assert!(c.reason.contains("crossover"), "{}", c.reason);
        // INS_GYRO_FILTER acts on every axis, FLTD on roll only: the reason says which.
        assert_eq!(
            c.reason.contains("every axis"),
            c.name == "INS_GYRO_FILTER",
            "{}",
            c.reason
        );
        assert!(
            lines
                .iter()
                .any(|l| l == &format!("param set {} {}", c.name, c.proposed_hz)),
            "{lines:?}"
        );
        assert!(
            c.proposed_hz >= 1.5 * xo,
            "{} {} Hz below 1.5 × {xo:.2} Hz",
            c.name,
            c.proposed_hz
        );
    }
    let noise = out.noise.as_ref().unwrap();
    assert!(noise.ratio() <= req.noise_budget + 1e-9, "noise ×{}", noise.ratio());
    // The printed numbers on the true loop: what the proposal claims.
    let (p, i, d) = (
        value("ATC_RAT_RLL_P", 0.0),
        value("ATC_RAT_RLL_I", 0.0),
        value("ATC_RAT_RLL_D", 0.0),
    );
    let t = true_margins(p, i, d, gyro_hz, fltd_hz);
    let pa = &out.proposed_analysis.margins;
    eprintln!(
        "proposed P {p} I {i} D {d}, gyro {gyro_hz} Hz, FLTD {fltd_hz} Hz: claimed {:.2} Hz PM {:.1}°; true {:.2} Hz PM {:.1}°",
        pa.crossover_hz, pa.phase_margin_deg, t.0, t.1
    );
    assert!((pa.crossover_hz / t.0 - 1.0).abs() < 0.15);
    assert!((pa.phase_margin_deg - t.1).abs() < 8.0);
    // The flown tune's own model error bounds the proposal's: no worse than it.
    let flown_err = (cur.margins.phase_margin_deg - truth.1).abs();
    assert!((pa.phase_margin_deg - t.1).abs() <= flown_err + 3.0);
    // Not slower and less robust than the flown tune, on the true loop.
    assert!(t.0 >= truth.0 * 0.97 || t.1 >= truth.1, "true {t:?} vs flown {truth:?}");
}
