//! Property tests of the inputs: random and mutated expressions and LTI JSON never panic (Ok, or
//! Err with a message), and random factored models realize to the expression's own values.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use proptest::prelude::*;
use skyloop_lti::c64;
use skyloop_lti::expr::{parse, parse_model};
use skyloop_lti::freqresp::evalfr;
use skyloop_lti::json::from_json_str;
use std::collections::HashMap;

/// Tokens that make up expressions (and some that do not belong).
fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("s".to_string()),
        Just("+".to_string()),
        Just("-".to_string()),
        Just("*".to_string()),
        Just("/".to_string()),
        Just("^".to_string()),
        Just("(".to_string()),
        Just(")".to_string()),
        Just("exp(".to_string()),
        Just("e".to_string()),
        Just(".".to_string()),
        Just(" ".to_string()),
        Just("K".to_string()),
        Just("#".to_string()),
        (0u32..1000).prop_map(|k| k.to_string()),
        (-400i32..400).prop_map(|e| format!("1e{e}")),
        (0.0f64..10.0).prop_map(|x| format!("{x}")),
    ]
}

fn valid_seed() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)".to_string()),
        Just("(10/(s*(s+2)))/(1 + (10/(s*(s+2)))*(1/(0.1*s+1)))".to_string()),
        Just("1/(s+1)^25 + 3/(s+2)".to_string()),
        Just("(s^2+0.1*s+4)/(s^2+2*s+4)^2".to_string()),
        Just("exp(-0.2*s)/(s+1) + exp(-0.2*s)".to_string()),
    ]
}

fn no_panic_check(text: &str) {
    match parse(text) {
        Ok(e) => {
            let _ = e.eval(c64::new(0.3, 1.7), &HashMap::new());
            let _ = e.to_tf(&HashMap::new());
            if let Err(err) = parse_model(text) {
                assert!(!err.to_string().is_empty());
            }
        }
        Err(err) => assert!(!err.to_string().is_empty()),
    }
}

/// A random factored model: gain, real and complex poles (stable or not), fewer zeros.
#[derive(Debug, Clone)]
struct Factored {
    gain: f64,
    poles: Vec<(f64, f64)>,
    zeros: Vec<(f64, f64)>,
    power: u32,
}

fn factored() -> impl Strategy<Value = Factored> {
    let root = (
        prop_oneof![-100.0f64..-0.01, 0.01f64..10.0],
        prop_oneof![Just(0.0), 0.05f64..50.0],
    );
    (
        prop_oneof![0.01f64..100.0, -100.0f64..-0.01],
        prop::collection::vec(root.clone(), 1..8),
        prop::collection::vec(root, 0..8),
        1u32..4,
    )
        .prop_map(|(gain, poles, mut zeros, power)| {
            let deg = |v: &[(f64, f64)]| v.iter().map(|r| if r.1 > 0.0 { 2 } else { 1 }).sum::<usize>();
            while deg(&zeros) > deg(&poles) * power as usize {
                zeros.pop();
            }
            Factored {
                gain,
                poles,
                zeros,
                power,
            }
        })
}

fn factor_text(r: &(f64, f64)) -> String {
    if r.1 > 0.0 {
        format!("(s^2 + {:e}*s + {:e})", -2.0 * r.0, r.0 * r.0 + r.1 * r.1)
    } else {
        format!("(s + {:e})", -r.0)
    }
}

impl Factored {
    fn text(&self) -> String {
        let num: Vec<String> = self.zeros.iter().map(factor_text).collect();
        let den: Vec<String> = self.poles.iter().map(factor_text).collect();
        let num = if num.is_empty() { "1".to_string() } else { num.join("*") };
        format!("{:e}*{num}/({})^{}", self.gain, den.join("*"), self.power)
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn random_token_strings_never_panic(toks in prop::collection::vec(token(), 0..40)) {
        no_panic_check(&toks.concat());
    }

    #[test]
    fn mutated_expressions_never_panic(
        seed in valid_seed(),
        edits in prop::collection::vec((0usize..200, 0u8..3, token()), 1..6),
    ) {
        let mut t: Vec<char> = seed.chars().collect();
        for (pos, kind, tok) in edits {
            let at = if t.is_empty() { 0 } else { pos % (t.len() + 1) };
            match kind {
                0 => { t.splice(at..at, tok.chars()); }
                1 => { if at < t.len() { t.remove(at); } }
                _ => { if at < t.len() { t.splice(at..at + 1, tok.chars()); } }
            }
        }
        no_panic_check(&t.iter().collect::<String>());
    }

    #[test]
    fn factored_models_match_the_expression(f in factored(), w in 0.01f64..100.0) {
        let text = f.text();
        let sys = parse_model(&text).unwrap();
        let e = parse(&text).unwrap();
        let s = c64::new(0.0, w);
        let want = e.eval(s, &HashMap::new()).unwrap();
        let got = evalfr(&sys, s);
        // At a pole on the axis the model may refuse; otherwise it must agree closely.
        if let Ok(g) = got {
            let g = g[(0, 0)];
            prop_assert!((g - want).norm() <= 1e-8 * want.norm() + 1e-300, "{text} at {w}: {g} vs {want}");
        }
    }

    #[test]
    fn lti_json_never_panics(
        rows in 0usize..4, cols in 0usize..4,
        vals in prop::collection::vec(prop_oneof![-1e3f64..1e3, Just(f64::MAX)], 0..40),
        delay in prop_oneof![Just(None), (-1.0f64..1.0).prop_map(Some)],
        cut in 0usize..400,
    ) {
        let m = |r: usize, c: usize, off: usize| -> String {
            let rows: Vec<String> = (0..r)
                .map(|i| {
                    let row: Vec<String> = (0..c).map(|j| format!("{:e}", vals.get(off + i * c + j).copied().unwrap_or(1.0))).collect();
                    format!("[{}]", row.join(","))
                })
                .collect();
            format!("[{}]", rows.join(","))
        };
        let mut text = format!(
            r#"{{"a":{},"b":{},"c":{},"d":{},"dt":0.0"#,
            m(rows, rows, 0), m(rows, cols, 5), m(cols, rows, 9), m(cols, cols, 13)
        );
        if let Some(t) = delay {
            text += &format!(r#","input_delay":[{t}]"#);
        }
        text += "}";
        let _ = from_json_str(&text);
        // Truncated JSON is an error, never a panic.
        let cut = cut.min(text.len());
        if let Err(e) = from_json_str(&text[..cut]) {
            prop_assert!(!e.to_string().is_empty());
        }
    }
}
