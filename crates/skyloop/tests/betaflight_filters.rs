//! skyloop's Betaflight filters against the firmware's own filter code (issue 43): fixtures written
//! by `tools/gen_betaflight_filters.sh`, which compiles `src/main/common/filter.c` and `maths.c` of
//! Betaflight 4.2.11, 4.5.5 and 2025.12.5 for the host and drives PT1, PT2, PT3, the biquad lowpass
//! and the notch with an impulse, a step and a chirp at loop times of 125–1000 µs.
//!
//! Two models are checked: the firmware-exact one (`firmware::betaflight::filter_math`: the
//! firmware's single-precision arithmetic, polynomial sine, whole-microsecond loop time) sample by
//! sample to 1e-6, and the one the loop analysis uses (`FilterKind`, libm's sine, double
//! precision) in frequency response, to the error its doc states.
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

use serde_json::Value;
use skyloop::firmware::betaflight::filter_math::{
    biquad_coeffs, biquad_filter, butterworth_q, lag_filter, notch_q, pt1_gain, BiquadShape, PT2_CUTOFF_CORRECTION,
    PT3_CUTOFF_CORRECTION,
};
use skyloop_control::filter::FilterKind;

const TAGS: [&str; 3] = ["4.2.11", "4.5.5", "2025.12.5"];

fn fixture(tag: &str) -> Value {
    skyloop_fixtures::load(
        env!("CARGO_MANIFEST_DIR"),
        &format!("tests/fixtures/betaflight/filters_{tag}.json"),
    )
}

fn num(v: &Value, k: &str) -> f64 {
    v[k].as_f64().unwrap()
}

fn series(v: &Value, k: &str) -> Vec<f64> {
    v[k].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

/// The largest difference relative to the series' own peak (values near 0 are compared absolutely
/// at that scale).
fn rel_err(a: &[f64], b: &[f32]) -> f64 {
    let peak = a.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-30);
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - f64::from(*y)).abs() / peak)
        .fold(0.0, f64::max)
}

#[test]
fn fixtures_name_their_firmware_source() {
    for tag in TAGS {
        let fx = fixture(tag);
        assert_eq!(fx["firmware"], "Betaflight");
        assert_eq!(fx["tag"], tag);
        assert_eq!(fx["commit"].as_str().unwrap().len(), 40);
        let files = fx["files"].to_string();
        assert!(files.contains("src/main/common/filter.c") && files.contains("src/main/common/maths.c"));
        assert!(fx["filters"].as_array().unwrap().len() >= 50, "{tag}");
    }
}

#[test]
fn firmware_exact_filters_match_the_firmware_sample_by_sample() {
    let mut checked = 0;
    for tag in TAGS {
        for case in fixture(tag)["filters"].as_array().unwrap() {
            let kind = case["kind"].as_str().unwrap();
            let (fc, f0) = (num(case, "cutoff_hz") as f32, num(case, "center_hz") as f32);
            let us = case["looptime_us"].as_u64().unwrap() as u32;
            let dt = us as f32 * 1e-6;
            let mut filter = match kind {
                "pt1" | "pt2" | "pt3" => {
                    let order = kind.as_bytes()[2] - b'0';
                    let corr = [1.0, PT2_CUTOFF_CORRECTION, PT3_CUTOFF_CORRECTION][usize::from(order - 1)];
                    let k = pt1_gain(fc * corr, dt);
                    assert!(
                        (f64::from(k) / num(case, "k") - 1.0).abs() < 1e-6,
                        "{tag} {kind} {fc} Hz {us} us: k {k}"
                    );
                    lag_filter(order, fc, us).unwrap()
                }
                "biquad" | "notch" => {
                    let (shape, f, q) = if kind == "biquad" {
                        (BiquadShape::Lowpass, fc, butterworth_q())
                    } else {
                        let q = notch_q(f0, fc);
                        assert!((f64::from(q) / num(case, "q") - 1.0).abs() < 1e-6, "{tag} notch Q");
                        (BiquadShape::Notch, f0, q)
                    };
                    let (b, a) = biquad_coeffs(shape, f, us, q);
                    let (fb, fa) = (series(case, "b"), series(case, "a"));
                    for (mine, theirs) in b.iter().chain(&a).zip(fb.iter().chain(&fa)) {
                        assert!(
                            (f64::from(*mine) - theirs).abs() <= 1e-6 * theirs.abs().max(1e-3),
                            "{tag} {kind} {f} Hz {us} us: {b:?} {a:?} vs {fb:?} {fa:?}"
                        );
                    }
                    biquad_filter(shape, f, us, q).unwrap()
                }
                other => panic!("unknown kind {other}"),
            };
            let chirp = series(case, "chirp_input");
            for input in ["impulse", "step", "chirp"] {
                let want = series(case, input);
                filter.reset();
                let got: Vec<f32> = (0..want.len())
                    .map(|i| {
                        let x = match input {
                            "impulse" => f32::from(u8::from(i == 0)),
                            "step" => 1.0,
                            _ => chirp[i] as f32,
                        };
                        filter.apply(x)
                    })
                    .collect();
                let e = rel_err(&want, &got);
                assert!(
                    e < 1e-6,
                    "{tag} {kind} cutoff {fc} centre {f0} at {us} us, {input}: {e:e}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 600, "{checked}");
}

/// The response of a fixture's coefficients at `f` Hz (double precision), as (dB, degrees).
fn fixture_response(case: &Value, f: f64) -> (f64, f64) {
    let dt = case["looptime_us"].as_f64().unwrap() * 1e-6;
    let z1 = num_complex::Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * f * dt);
    let h = if case.get("k").is_some() {
        let k = num(case, "k");
        let order = i32::from(case["kind"].as_str().unwrap().as_bytes()[2] - b'0');
        (k / (1.0 - (1.0 - k) * z1)).powi(order)
    } else {
        let (b, a) = (series(case, "b"), series(case, "a"));
        (b[0] + b[1] * z1 + b[2] * z1 * z1) / (1.0 + a[0] * z1 + a[1] * z1 * z1)
    };
    (20.0 * h.norm().log10(), h.arg().to_degrees())
}

/// The analysis model's deliberate simplification, measured: libm's sine instead of the firmware's
/// polynomial and double instead of single precision change each stage's response by less than
/// 0.03 dB and 0.12° up to 0.45 of the loop rate (away from a notch's centre, where the gain is a
/// deep null and dB differences mean nothing): a margin moves by as much, at most.
#[test]
fn analysis_model_is_within_its_stated_error() {
    let (mut worst_db, mut worst_deg) = (0.0f64, 0.0f64);
    let mut worst_case = String::new();
    // The same over the cutoffs pilots set (50 Hz and up).
    let mut usual = (0.0f64, 0.0f64);
    for tag in TAGS {
        for case in fixture(tag)["filters"].as_array().unwrap() {
            let kind = case["kind"].as_str().unwrap();
            let (fc, f0) = (num(case, "cutoff_hz"), num(case, "center_hz"));
            let dt = case["looptime_us"].as_f64().unwrap() * 1e-6;
            let model = match kind {
                "pt1" => FilterKind::Pt1(fc),
                "pt2" => FilterKind::Pt2(fc),
                "pt3" => FilterKind::Pt3(fc),
                "biquad" => FilterKind::BiquadLowpass(fc),
                _ => FilterKind::Notch {
                    center: f0,
                    q: skyloop_control::filter::notch_q(f0, fc),
                },
            };
            for k in 1..200 {
                let f = 0.45 / dt * f64::from(k) / 200.0;
                if kind == "notch" && (f / f0 - 1.0).abs() < 0.05 {
                    continue;
                }
                let (re, im) = model.response(f, dt).unwrap();
                let mine = num_complex::Complex64::new(re, im);
                let (db, deg) = fixture_response(case, f);
                let ddb = (20.0 * mine.norm().log10() - db).abs();
                let mut ddeg = (mine.arg().to_degrees() - deg).abs();
                if ddeg > 180.0 {
                    ddeg = 360.0 - ddeg;
                }
                if fc.max(f0) >= 50.0 {
                    usual = (usual.0.max(ddb), usual.1.max(ddeg));
                }
                if ddb > worst_db || ddeg > worst_deg {
                    worst_case = format!("{tag} {kind} cutoff {fc} centre {f0} at {dt:e} s, {f:.1} Hz");
                }
                worst_db = worst_db.max(ddb);
                worst_deg = worst_deg.max(ddeg);
            }
        }
    }
    // Measured: 0.026 dB and 0.11° at worst (a 20 Hz biquad at 8 kHz, where the firmware's cosine
    // error is largest against 1 − cos ω), 0.015 dB and 0.02° from 50 Hz up.
    assert!(
        worst_db < 0.03 && worst_deg < 0.12,
        "worst {worst_db} dB, {worst_deg} deg ({worst_case})"
    );
    assert!(usual.0 < 0.02 && usual.1 < 0.03, "from 50 Hz up: {usual:?}");
}

/// The PID scale factors and the yaw I factor of every version against what its source defines
/// (`tools/gen_betaflight_pid_scales.sh`): the loop's C_fb is P·PTERM_SCALE + I·ITERM_SCALE(·yaw)/s
/// + D·DTERM_SCALE·s, and Kf = F·FEEDFORWARD_SCALE/100.
#[test]
fn pid_scales_and_yaw_i_factor_are_each_versions() {
    use skyloop::firmware::betaflight as bf;
    let fx = skyloop_fixtures::load(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/betaflight/pid_scales.json");
    let versions = fx["versions"].as_array().unwrap();
    assert!(versions.len() >= 7);
    for v in versions {
        let tag = v["tag"].as_str().unwrap();
        assert_eq!(v["commit"].as_str().unwrap().len(), 40);
        assert_eq!(num(v, "pterm_scale"), bf::PTERM_SCALE, "{tag}");
        assert_eq!(num(v, "iterm_scale"), bf::ITERM_SCALE, "{tag}");
        assert_eq!(num(v, "dterm_scale"), bf::DTERM_SCALE, "{tag}");
        assert_eq!(num(v, "feedforward_scale"), bf::FTERM_SCALE, "{tag}");
        assert_eq!(num(v, "f_divisor"), 100.0, "{tag}");
        let major: u32 = tag.split('.').next().unwrap().parse().unwrap();
        assert_eq!(bf::yaw_i_factor(Some(major), false), num(v, "yaw_i_factor"), "{tag}");
    }
}

/// The five rate curves against the firmware's own `apply*Rates` functions of 4.2.11, 4.5.5 and
/// 2025.12.5 (`tools/gen_betaflight_rates.sh`), at 201 stick deflections per setting, to 1e-6
/// (the firmware computes in single precision, skyloop in double).
#[test]
fn rate_curves_match_the_firmware() {
    use skyloop::firmware::betaflight::{header::Rates, stick_rate_deg_s};
    let mut n = 0;
    for tag in TAGS {
        let fx = skyloop_fixtures::load(
            env!("CARGO_MANIFEST_DIR"),
            &format!("tests/fixtures/betaflight/rates_{tag}.json"),
        );
        assert_eq!(fx["commit"].as_str().unwrap().len(), 40);
        for c in fx["curves"].as_array().unwrap() {
            let ty = ["betaflight", "raceflight", "kiss", "actual", "quick"]
                .iter()
                .position(|t| c["type"] == *t)
                .unwrap();
            let r = Rates {
                rc_rate: num(c, "rc_rate"),
                super_rate: num(c, "super_rate"),
                expo: num(c, "expo"),
                rates_type: Some(ty as f64),
                // A version without the setting ignores the harness's flag (a header of it has none).
                quick_rc_expo: c["quick_rc_expo"] == 1 && fx["has_quick_rc_expo"] == true,
            };
            let (xs, want) = (series(c, "deflection"), series(c, "deg_s"));
            let peak = want.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            for (x, w) in xs.iter().zip(&want) {
                let got = stick_rate_deg_s(*x, &r);
                assert!(
                    (got - w).abs() <= 1e-6 * peak,
                    "{tag} {} {r:?} at {x}: {got} vs {w}",
                    c["type"]
                );
                n += 1;
            }
        }
    }
    assert!(n > 20_000, "{n}");
}
