//! Property tests of the TOML specs (design, musyn, scenario) and CSV logs: random mutations of the
//! shipped examples never panic. A mutation either parses (and a parsed scenario then runs for a
//! short while without a panic) or is refused with a message.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use proptest::prelude::*;
use skyloop::sim::Scenario;
use skyloop::spec::design::DesignSpec;
use skyloop::spec::musyn::MusynSpec;
use std::path::Path;

const DESIGN: &str = include_str!("../../../examples/bicopter.toml");
const MUSYN: &str = include_str!("../../../examples/musyn-distillation.toml");
const SCENARIO: &str = include_str!("../../../examples/quadrotor-ssi.toml");

/// Values that probe the validation: non-finite, negative, zero, huge, wrong type.
const PROBES: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "-1.0",
    "0",
    "0.0",
    "1e308",
    "-1e308",
    "1e-320",
    "99999999999",
    "\"x\"",
    "[]",
    "[1.0]",
    "true",
];

#[derive(Debug, Clone)]
enum Mutation {
    /// Replace the value of the k-th `key = value` line.
    Value(usize, usize),
    /// Delete the k-th line.
    DeleteLine(usize),
    /// Cut the text at a fraction of its length.
    Truncate(f64),
    /// Duplicate the k-th line (a repeated key).
    DuplicateLine(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (0usize..200, 0..PROBES.len()).prop_map(|(k, p)| Mutation::Value(k, p)),
        1 => (0usize..200).prop_map(Mutation::DeleteLine),
        1 => (0.0f64..1.0).prop_map(Mutation::Truncate),
        1 => (0usize..200).prop_map(Mutation::DuplicateLine),
    ]
}

fn mutate(text: &str, muts: &[Mutation]) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for m in muts {
        let n = lines.len().max(1);
        match *m {
            Mutation::Value(k, p) => {
                let assigns: Vec<usize> = (0..lines.len()).filter(|&i| lines[i].contains(" = ")).collect();
                if let Some(&i) = assigns.get(k % assigns.len().max(1)) {
                    let key = lines[i].split(" = ").next().unwrap_or("").to_string();
                    lines[i] = format!("{key} = {}", PROBES[p]);
                }
            }
            Mutation::DeleteLine(k) => {
                if !lines.is_empty() {
                    lines.remove(k % n);
                }
            }
            Mutation::Truncate(f) => {
                let keep = (lines.len() as f64 * f) as usize;
                lines.truncate(keep);
            }
            Mutation::DuplicateLine(k) => {
                if !lines.is_empty() {
                    let l = lines[k % n].clone();
                    lines.insert(k % n, l);
                }
            }
        }
    }
    lines.join("\n")
}

fn base() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples"))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 120, ..ProptestConfig::default() })]

    #[test]
    fn mutated_design_specs_parse_or_say_why(muts in prop::collection::vec(mutation(), 1..4)) {
        let text = mutate(DESIGN, &muts);
        if let Err(e) = DesignSpec::from_toml_str(&text, base()) {
            prop_assert!(!e.to_string().is_empty());
        }
    }

    #[test]
    fn mutated_musyn_specs_parse_or_say_why(muts in prop::collection::vec(mutation(), 1..4)) {
        let text = mutate(MUSYN, &muts);
        match MusynSpec::from_toml_str(&text, base()) {
            // The derived pieces are validated lazily: each must also be Ok or a message.
            Ok(spec) => {
                for r in [spec.plant().map(|_| ()), spec.structure().map(|_| ()), spec.options().map(|_| ())] {
                    if let Err(e) = r {
                        prop_assert!(!e.to_string().is_empty());
                    }
                }
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }

    #[test]
    fn mutated_scenarios_parse_and_run_or_say_why(muts in prop::collection::vec(mutation(), 1..4)) {
        let text = mutate(SCENARIO, &muts);
        match Scenario::from_toml(&text) {
            Ok(mut scn) => {
                // A short run exercises the limits (clamps, saturations) the mutation may have set.
                scn.sim.duration_s = scn.sim.duration_s.min(0.05);
                scn.monte_carlo = None;
                if let Err(e) = skyloop::sim::simulate(&scn) {
                    prop_assert!(!e.to_string().is_empty());
                }
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }

    #[test]
    fn random_csv_logs_read_or_say_why(
        header in prop::collection::vec(prop_oneof![Just("time_s"), Just("t"), Just("u"), Just(""), Just("y,z"), Just("\"q\"")], 0..4),
        rows in prop::collection::vec(prop::collection::vec(prop_oneof![
            Just("0".to_string()), Just("nan".to_string()), Just("-inf".to_string()), Just("".to_string()),
            Just("1e308".to_string()), Just("x".to_string()), (-1e3f64..1e3).prop_map(|v| v.to_string()),
        ], 0..5), 0..30),
    ) {
        let mut text = header.join(",");
        for r in &rows {
            text.push('\n');
            text.push_str(&r.join(","));
        }
        match skyloop::sysid::logs::csv::read_str(&text, "random.csv", None) {
            Ok(log) => {
                for g in &log.groups {
                    prop_assert!(g.channels.iter().all(|c| c.values.len() == g.time_s.len()));
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("random.csv"), "{}", e),
        }
    }
}
