//! Property tests of `tune`'s goal strings: random text is parsed or refused with a message naming
//! the goal; every well-formed goal within its documented range parses to exactly its bound; and
//! `tune` with random valid goals either refuses with a reason or returns gains whose reported goal
//! values agree with the loop's exact check and are "met" exactly when they satisfy the bound.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use proptest::prelude::*;
use skyloop::robust::structured::goals::{Bound, Requirement};
use skyloop::tune::{parse_goal, tune, Firmware, TuneRequest};

const QUANTITIES: &[&str] = &[
    "ms",
    "mt",
    "disk_margin",
    "gain_margin_db",
    "phase_margin_deg",
    "crossover_hz",
    "integral_corner",
    "MS",
    "ms2",
    "",
    "disk margin",
];
const OPERATORS: &[&str] = &["<=", ">=", "<", ">", "=", "==", "=<", "<=>=", ""];
const NUMBERS: &[&str] = &[
    "1.4", "0.6", "6", "45", "20", "0", "-1", "nan", "inf", "-inf", "1e308", "1e-320", "2", "1,4", "", "0x10", "1.4.1",
    " 1.4 ",
];

fn goal_text() -> impl Strategy<Value = String> {
    (
        prop::sample::select(QUANTITIES),
        prop::sample::select(OPERATORS),
        prop::sample::select(NUMBERS),
        "[ \t]{0,2}",
    )
        .prop_map(|(q, o, n, ws)| format!("{ws}{q}{ws}{o}{n}{ws}"))
}

/// A valid goal for the quantity at index `k`, with a bound drawn from `u` ∈ [0, 1) across its
/// documented range: (text, requirement, bound).
fn valid_goal(k: usize, u: f64) -> (String, Requirement, Bound) {
    match k % 6 {
        0 => {
            let b = 1.2 + 1.3 * u;
            (format!("ms<={b}"), Requirement::Ms, Bound::AtMost(b))
        }
        1 => {
            let b = 1.05 + 1.0 * u;
            (format!("mt<={b}"), Requirement::Mt, Bound::AtMost(b))
        }
        2 => {
            let b = 0.2 + 0.7 * u;
            (format!("disk_margin>={b}"), Requirement::DiskMargin, Bound::AtLeast(b))
        }
        3 => {
            let b = 2.0 + 8.0 * u;
            (
                format!("gain_margin_db>={b}"),
                Requirement::GainMarginDb,
                Bound::AtLeast(b),
            )
        }
        4 => {
            let b = 20.0 + 40.0 * u;
            (
                format!("phase_margin_deg>={b}"),
                Requirement::PhaseMarginDeg,
                Bound::AtLeast(b),
            )
        }
        _ => {
            let b = 1.0 + 20.0 * u;
            (
                format!("crossover_hz>={b}"),
                Requirement::CrossoverHz,
                Bound::AtLeast(b),
            )
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// Random goal text parses to a finite, validated bound, or is refused with the goal named.
    #[test]
    fn random_goal_text_parses_or_names_the_goal(text in goal_text()) {
        match parse_goal(&text) {
            Ok(g) => {
                let b = match g.bound { Bound::AtMost(b) | Bound::AtLeast(b) => b };
                prop_assert!(b.is_finite(), "{text}: bound {b}");
                prop_assert!(g.validate().is_ok());
            }
            Err(e) => {
                let m = e.to_string();
                prop_assert!(m.contains("goal") && !m.contains("{ "), "{text}: {m}");
            }
        }
    }

    /// Every goal within its documented range parses to exactly its quantity and bound.
    #[test]
    fn valid_goals_parse_to_their_bound(k in 0usize..6, u in 0.0f64..1.0) {
        let (text, req, bound) = valid_goal(k, u);
        let g = parse_goal(&text).unwrap();
        prop_assert_eq!(g.req, req);
        prop_assert_eq!(g.bound, bound);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10, ..ProptestConfig::default() })]

    /// `tune` with one or two random goals: a refusal names its reason; a proposal has feedback,
    /// reports every user goal, and each report agrees with the loop's exact check.
    #[test]
    fn tune_with_random_goals_is_consistent(
        goals in prop::collection::vec((0usize..6, 0.0f64..1.0), 1..3),
        betaflight in any::<bool>(),
    ) {
        let plant = skyloop::lti::expr::parse_model("exp(-0.004*s)*400/(s*(0.03*s+1))").unwrap();
        let fw = if betaflight { Firmware::Betaflight } else { Firmware::Generic };
        let mut req = TuneRequest::new(plant, fw);
        let texts: Vec<(String, Requirement, Bound)> = goals.iter().map(|&(k, u)| valid_goal(k, u)).collect();
        req.goals = texts.iter().map(|t| t.0.clone()).collect();
        req.starts = 1;
        let out = match tune(&req) {
            Ok(out) => out,
            Err(e) => {
                let m = e.to_string();
                prop_assert!(!m.is_empty() && !m.contains("{ "), "{m}");
                return Ok(());
            }
        };
        prop_assert!(out.margins.stable);
        let m = &out.margins;
        for (text, req, bound) in &texts {
            let r = out.goals.iter().find(|g| &g.label == text);
            prop_assert!(r.is_some(), "goal {text} not reported");
            let r = r.unwrap();
            let exact = match req {
                Requirement::Ms => m.ms,
                Requirement::Mt => m.mt,
                Requirement::DiskMargin => m.disk_alpha,
                Requirement::GainMarginDb => m.gain_margin_db,
                Requirement::PhaseMarginDeg => m.phase_margin_deg,
                _ => m.crossover_hz,
            };
            // The report's value is the worst over plants: here one plant, so the loop's own check.
            let close = (r.value - exact).abs() <= 1e-3 * exact.abs().max(1.0) || r.value == exact;
            prop_assert!(close, "{text}: reported {} vs loop check {}", r.value, exact);
            let holds = match bound {
                Bound::AtMost(b) => r.value <= b * (1.0 + 1e-6),
                Bound::AtLeast(b) => r.value >= b * (1.0 - 1e-6),
            };
            prop_assert_eq!(r.met, holds, "{}: value {} met {}", text, r.value, r.met);
        }
        // A proposal is a controller: not all gains zero.
        let gains: Vec<f64> = out.gains.as_object().unwrap().values().filter_map(serde_json::Value::as_f64).collect();
        prop_assert!(gains.iter().any(|g| *g > 0.0), "all-zero gains: {}", out.gains);
    }
}
