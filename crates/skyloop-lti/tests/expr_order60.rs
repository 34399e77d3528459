//! Expressions of high order become accurate models: the realization built from the expression tree
//! is checked against the expression evaluated factor by factor at s = jω (`Expr::eval`, independent
//! of any realization), and poles against the factors' known roots.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use skyloop_lti::expr::{parse, parse_model};
use skyloop_lti::freqresp::evalfr;
use skyloop_lti::margins::allmargin;
use skyloop_lti::norms::hinf_norm;
use skyloop_lti::poles_zeros::poles;
use skyloop_lti::{c64, StateSpace};
use std::collections::HashMap;

const TOL: f64 = 1e-9;

fn reference(text: &str, w: f64) -> c64 {
    parse(text).unwrap().eval(c64::new(0.0, w), &HashMap::new()).unwrap()
}

fn model_at(sys: &StateSpace, w: f64) -> c64 {
    evalfr(sys, c64::new(0.0, w)).unwrap()[(0, 0)]
}

fn logspace(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| 10f64.powf(a + (b - a) * k as f64 / (n - 1) as f64))
        .collect()
}

/// Worst relative error of the model's response over a grid.
fn response_error(text: &str, sys: &StateSpace, lo: f64, hi: f64) -> f64 {
    let e = response_error_inner(text, sys, lo, hi);
    eprintln!("response error (relative) {e:e} for order {}", sys.nx());
    e
}

fn response_error_inner(text: &str, sys: &StateSpace, lo: f64, hi: f64) -> f64 {
    logspace(lo, hi, 400)
        .into_iter()
        .map(|w| {
            let (g, r) = (model_at(sys, w), reference(text, w));
            (g - r).norm() / r.norm()
        })
        .fold(0.0, f64::max)
}

/// Each expected pole matched by a distinct computed pole, to `TOL` relative.
fn poles_error(sys: &StateSpace, want: &[c64]) -> f64 {
    let mut got = poles(sys).unwrap();
    assert_eq!(got.len(), want.len());
    let mut worst = 0.0f64;
    for w in want {
        let (k, d) = got
            .iter()
            .enumerate()
            .map(|(k, z)| (k, (z - w).norm()))
            .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        worst = worst.max(d / w.norm());
        got.remove(k);
    }
    eprintln!("pole error (relative) {worst:e}");
    worst
}

/// Peak of |expression(jω)| by a dense grid and golden-section refinement (the reference H∞ norm).
fn reference_peak(text: &str, lo: f64, hi: f64) -> f64 {
    let f = |w: f64| reference(text, w).norm();
    let grid = logspace(lo, hi, 4000);
    let mut best = (0usize, f(grid[0]));
    for (k, &w) in grid.iter().enumerate() {
        let v = f(w);
        if v > best.1 {
            best = (k, v);
        }
    }
    let mut peak = best.1.max(f(0.0));
    let (mut a, mut b) = (grid[best.0.saturating_sub(1)], grid[(best.0 + 1).min(grid.len() - 1)]);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..200 {
        let (x1, x2) = (b - g * (b - a), a + g * (b - a));
        if f(x1) > f(x2) {
            b = x2;
        } else {
            a = x1;
        }
        peak = peak.max(f(x1)).max(f(x2));
    }
    peak
}

/// Every reported gain crossover lies on |L| = 1 and its phase margin matches arg L there.
fn check_margins(text: &str, sys: &StateSpace, expected_crossovers: usize) {
    let all = allmargin(sys).unwrap();
    assert_eq!(
        all.phase_margins.len(),
        expected_crossovers,
        "{text}: {:?}",
        all.phase_margins
    );
    for pm in &all.phase_margins {
        let l = reference(text, pm.w_rad_s);
        assert!((l.norm() - 1.0).abs() < TOL, "{text}: |L| = {} at crossover", l.norm());
        let want = (-l).arg().to_degrees();
        assert!(
            (pm.pm_deg - want).abs() < TOL * 180.0,
            "{text}: PM {} vs {want}",
            pm.pm_deg
        );
    }
    for gm in &all.gain_margins {
        let l = reference(text, gm.w_rad_s);
        assert!(
            l.im.abs() < TOL * l.norm() && l.re < 0.0,
            "{text}: phase crossover off -180°: {l}"
        );
        assert!((gm.gm_db + 20.0 * l.norm().log10()).abs() < TOL * gm.gm_db.abs().max(1.0));
    }
}

#[test]
fn power_25_at_1_hz_and_power_60() {
    let t = "1/(s+1)^25";
    let sys = parse_model(t).unwrap();
    let w = 2.0 * std::f64::consts::PI;
    let (g, r) = (model_at(&sys, w), reference(t, w));
    assert!((g - r).norm() < TOL * r.norm(), "{g} vs {r}");

    // K/(s+1)^60: |L| = 1 at ω = √(K^(1/30) − 1), PM = 180° − 60·atan ω (closed form).
    let t = "10/(s+1)^60";
    let sys = parse_model(t).unwrap();
    assert_eq!(sys.nx(), 60);
    let e = response_error(t, &sys, -2.0, 2.0);
    assert!(e < TOL, "response error {e:e}");
    let want = vec![c64::new(-1.0, 0.0); 60];
    let pe = poles_error(&sys, &want);
    assert!(pe < TOL, "pole error {pe:e}");
    let (n, _) = hinf_norm(&sys).unwrap();
    assert!((n - 10.0).abs() < TOL * 10.0, "H∞ {n}");
    check_margins(t, &sys, 1);
    let wc = (10f64.powf(1.0 / 30.0) - 1.0).sqrt();
    let all = allmargin(&sys).unwrap();
    assert!((all.phase_margins[0].w_rad_s - wc).abs() < TOL * wc);
}

#[test]
fn norm_of_power_40_is_finite() {
    let sys = parse_model("1/(s+1)^40").unwrap();
    let (n, w) = hinf_norm(&sys).unwrap();
    assert!((n - 1.0).abs() < TOL && w == 0.0, "{n} at {w}");
}

#[test]
fn sum_of_30_first_order_terms_is_stable() {
    let t: String = (1..=30).map(|k| format!("{k}/(s+{k})")).collect::<Vec<_>>().join(" + ");
    let sys = parse_model(&t).unwrap();
    let want: Vec<c64> = (1..=30).map(|k| c64::new(-(k as f64), 0.0)).collect();
    assert!(poles_error(&sys, &want) < TOL);
    assert!(response_error(&t, &sys, -2.0, 3.0) < TOL);
    let (n, _) = hinf_norm(&sys).unwrap();
    assert!((n - 30.0).abs() < TOL * 30.0, "H∞ {n}");
}

#[test]
fn sum_of_60_distinct_poles() {
    let t: String = (1..=60)
        .map(|k| format!("{}/(s+{})", 1.0 + 0.1 * k as f64, 0.5 * 1.07f64.powi(k)))
        .collect::<Vec<_>>()
        .join(" + ");
    let sys = parse_model(&t).unwrap();
    assert_eq!(sys.nx(), 60);
    let want: Vec<c64> = (1..=60).map(|k| c64::new(-0.5 * 1.07f64.powi(k), 0.0)).collect();
    assert!(poles_error(&sys, &want) < TOL);
    let e = response_error(&t, &sys, -2.0, 3.0);
    assert!(e < TOL, "response error {e:e}");
    let (n, _) = hinf_norm(&sys).unwrap();
    let r = reference_peak(&t, -3.0, 3.0);
    eprintln!("H-inf relative error {:e}", (n - r).abs() / r);
    assert!((n - r).abs() < TOL * r, "H∞ {n} vs {r}");
    // Loop 0.05·Σ: one gain crossover.
    let tl = format!("0.05*({t})");
    check_margins(&tl, &parse_model(&tl).unwrap(), 1);
}

/// Π over 30 lightly damped pairs w²/(s² + 2ζws + w²) with zeros at some of them: order 60.
fn product_60() -> (String, Vec<c64>) {
    let mut t = String::from("1.2");
    let mut p = Vec::new();
    for k in 0..30 {
        let w = 0.3 * 1.12f64.powi(k);
        let z = 0.05 + 0.01 * k as f64;
        if k % 3 == 0 {
            t += &format!("*({:.17e}*s+1)", 1.0 / (2.5 * w));
        }
        t += &format!("*{:.17e}/(s^2+{:.17e}*s+{:.17e})", w * w, 2.0 * z * w, w * w);
        let (re, im) = (-z * w, w * (1.0 - z * z).sqrt());
        p.push(c64::new(re, im));
        p.push(c64::new(re, -im));
    }
    (t, p)
}

#[test]
fn product_of_60_distinct_poles() {
    let (t, want) = product_60();
    let sys = parse_model(&t).unwrap();
    assert_eq!(sys.nx(), 60);
    let pe = poles_error(&sys, &want);
    assert!(pe < TOL, "pole error {pe:e}");
    let e = response_error(&t, &sys, -2.0, 2.5);
    assert!(e < TOL, "response error {e:e}");
    let (n, _) = hinf_norm(&sys).unwrap();
    let r = reference_peak(&t, -2.0, 2.5);
    eprintln!("H-inf relative error {:e}", (n - r).abs() / r);
    assert!((n - r).abs() < TOL * r, "H∞ {n} vs {r}");
    check_margins(&t, &sys, allmargin(&sys).unwrap().phase_margins.len());
}

#[test]
fn power_of_a_complex_pair() {
    let t = "1/(s^2+0.4*s+1)^30";
    let sys = parse_model(t).unwrap();
    let want: Vec<c64> = (0..60)
        .map(|k| c64::new(-0.2, if k % 2 == 0 { 0.96f64.sqrt() } else { -(0.96f64.sqrt()) }))
        .collect();
    let pe = poles_error(&sys, &want);
    assert!(pe < TOL, "pole error {pe:e}");
    let e = response_error(t, &sys, -1.0, 0.5);
    assert!(e < TOL, "response error {e:e}");
}

#[test]
fn feedback_form_and_quotients() {
    let s = |w: f64| c64::new(0.0, w);
    for t in [
        "(10/(s*(s+2)))/(1 + (10/(s*(s+2)))*(1/(0.1*s+1)))",
        "(1/(s+1))/(1 + 1/(s+1))",
        "(s+3)/(s+1)/((s+2)/(s+5))",
        "1/(1 + 1/(s+1) + 1/(s+2))",
        "(s + 1/(s+1))/(s+2)^2",
    ] {
        let sys = parse_model(t).unwrap();
        for w in [0.01, 0.3, 1.0, 7.0, 100.0] {
            let (g, r) = (model_at(&sys, w), reference(t, w));
            assert!((g - r).norm() < 1e-12 * r.norm().max(1e-300), "{t} at {w}: {g} vs {r}");
        }
        let _ = s;
    }
    // The feedback form keeps each state once: 2 + 1.
    assert_eq!(
        parse_model("(10/(s*(s+2)))/(1 + (10/(s*(s+2)))*(1/(0.1*s+1)))")
            .unwrap()
            .nx(),
        3
    );
    assert_eq!(parse_model("(1/(s+1))/(1 + 1/(s+1))").unwrap().nx(), 1);
}

/// 30 sections (s + z)/(s² + 0.6·z·s + 1.5·z²), z spread over 1..30 in a shuffled order: order 60
/// with 30 real zeros and no real pole. Two real zeros share a complex pole pair; paired with the
/// pair farthest in magnitude (as they once were), 15 such sections lost 5e-6 of the response at
/// 0.1 Hz through the cancellation D + C(−A)⁻¹B ≈ z₁z₂/ω².
#[test]
fn real_zeros_over_complex_pairs_order_60() {
    let t: String = (0..30)
        .map(|k| {
            let z = 1.0 + ((k * 17) % 30) as f64;
            format!("((s+{z})/(s^2+{}*s+{}))", 0.6 * z, 1.5 * z * z)
        })
        .collect::<Vec<_>>()
        .join("*");
    let sys = parse_model(&t).unwrap();
    assert_eq!(sys.nx(), 60);
    let e = response_error(&t, &sys, -3.0, 2.5);
    assert!(e < TOL, "response error {e:e}");
}

/// A chain of 1000 integrators: |L| = ω^-1000 overflows below 0.5 rad/s (NaN in the computed
/// response), which once read as a gain crossover at 0.078 Hz with a NaN phase margin. The only
/// crossover is at 1 rad/s, where L = (−j)^1000 = +1: PM 180°, no phase crossover, unstable.
#[test]
fn margins_of_a_thousand_integrators_find_the_one_crossover() {
    let l = skyloop_lti::expr::parse_model("1/s^1000").unwrap();
    let all = skyloop_lti::margins::allmargin(&l).unwrap();
    assert!(!all.stable);
    assert_eq!(all.phase_margins.len(), 1, "{all:?}");
    let pm = all.phase_margins[0];
    assert!((pm.w_rad_s - 1.0).abs() < 1e-9 && pm.pm_deg == 180.0, "{pm:?}");
    assert!(all.gain_margins.is_empty(), "{all:?}");
}

/// (1e-200·s + 1)² has a leading coefficient 1e-400 beyond the floating-point range, but its
/// realization does not: the H∞ norm is 1 (at DC) and the H2 norm 1/(2·sqrt(τ)) = 5e99.
#[test]
fn extreme_time_constants_realize_and_have_their_norms() {
    for (expr, hinf, h2) in [
        ("1/(1e-200*s+1)^2", 1.0, 5e99),
        ("1/(1e200*s+1)^2", 1.0, 5e-101),
        ("-3/(1e-200*s+1)^3", 3.0, f64::NAN),
    ] {
        let g = skyloop_lti::expr::parse_model(expr).unwrap();
        let (n, _) = skyloop_lti::norms::hinf_norm(&g).unwrap();
        assert!((n - hinf).abs() < 1e-9 * hinf, "{expr}: {n}");
        if h2.is_finite() {
            let n2 = skyloop_lti::norms::h2_norm(&g).unwrap();
            assert!((n2 / h2 - 1.0).abs() < 1e-9, "{expr}: {n2}");
        }
    }
    let e = skyloop_lti::expr::parse_model("1e300*1e300/(s+1)")
        .map(|_| ())
        .unwrap_err();
    assert!(
        e.to_string().contains("floating-point range") || e.to_string().contains("1e300"),
        "{e}"
    );
}

/// `@FILE.json` reads an LTI JSON model into an expression: the product with (s+1) matches the
/// file's model times (s+1) at every frequency, delays included; unquoted paths end at `.json`,
/// quoted ones take any name; MIMO, discrete and missing files are named errors with the column.
#[test]
fn file_references_stand_for_their_models() {
    let dir = std::env::temp_dir().join(format!("skyloop-expr-at-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let c = skyloop_lti::expr::parse_model("exp(-0.01*s)*5*(s+3)/((s+10)*(s^2+2*s+50))").unwrap();
    let path = dir.join("C.json");
    std::fs::write(&path, skyloop_lti::json::to_json_string(&c)).unwrap();
    let odd = dir.join("C model.txt");
    std::fs::write(&odd, skyloop_lti::json::to_json_string(&c)).unwrap();
    let p = path.display().to_string();
    let q = odd.display().to_string();
    for (text, factor) in [
        (format!("@{p}*(s+1)"), "(s+1)"),
        (format!("(s+1)*@{p}"), "(s+1)"),
        (format!("@{p}/s"), "1/s"),
        (format!("@\"{q}\"/(s+2)"), "1/(s+2)"),
    ] {
        let g = skyloop_lti::expr::parse_model(&text).unwrap();
        let f = skyloop_lti::expr::parse(factor).unwrap();
        let e = skyloop_lti::expr::parse(&text).unwrap();
        for w in [0.1, 1.0, 7.0, 60.0] {
            let s = skyloop_lti::c64::new(0.0, w);
            let want =
                skyloop_lti::freqresp::freqresp(&c, &[w]).unwrap()[0][(0, 0)] * f.eval(s, &Default::default()).unwrap();
            let got = skyloop_lti::freqresp::freqresp(&g, &[w]).unwrap()[0][(0, 0)];
            assert!(
                (got - want).norm() <= 1e-9 * want.norm(),
                "{text} at {w}: {got} vs {want}"
            );
            let ev = e.eval(s, &Default::default()).unwrap();
            assert!((ev - want).norm() <= 1e-9 * want.norm(), "{text} eval at {w}");
        }
        assert_eq!(g.input_delay, vec![0.01], "{text}");
    }
    let mimo = dir.join("M.json");
    std::fs::write(
        &mimo,
        skyloop_lti::json::to_json_string(
            &skyloop_lti::StateSpace::gain(skyloop_lti::Mat::from_fn(2, 2, |i, j| (i + j) as f64), 0.0).unwrap(),
        ),
    )
    .unwrap();
    for (text, says) in [
        (format!("@{}*2", mimo.display()), "SISO"),
        ("2*@nope/missing.json".to_string(), "cannot read"),
        ("@C.txt*2".to_string(), ".json"),
        ("@\"open".to_string(), "closing"),
    ] {
        let e = skyloop_lti::expr::parse_model(&text).unwrap_err().to_string();
        assert!(e.contains(says) && e.contains("column"), "{text}: {e}");
    }
}
