//! CLI tests of `skyloop hinfsyn` and `skyloop ncfsyn`: JSON output, and exit 2 on ill-posed problems.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

mod common;
use common::skyloop;

fn write(name: &str, text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("skyloop-hinf-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp dir");
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p.to_string_lossy().into_owned()
}

const FIXTURE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../skyloop-robust/tests/fixtures/hinf/hinfsyn_random.json"
);

#[test]
fn hinfsyn_json_matches_slicot_gamma() {
    // First fixture case (tools/gen_hinf.py, SLICOT sb10ad gamma).
    let f: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(FIXTURE).expect("fixture")).expect("json");
    let case = &f["cases"][0];
    let plant = write("p0.json", &case["plant"].to_string());
    let (code, out, err) = skyloop(&["hinfsyn", &plant, "--nmeas", "1", "--ncon", "1", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json out");
    let g = v["gamma"].as_f64().expect("gamma");
    let g_ref = case["gamma_slicot"].as_f64().expect("ref");
    assert!((g - g_ref).abs() < 1e-2 * g_ref, "{g} vs {g_ref}");
    assert!(v["controller"]["a"].is_array());
}

#[test]
fn hinfsyn_rank_deficient_d12_exits_2() {
    let plant = write(
        "bad.json",
        r#"{"a":[[1.0]],"b":[[1.0,1.0]],"c":[[1.0],[1.0]],"d":[[0.0,0.0],[1.0,0.0]],"dt":0.0}"#,
    );
    let (code, _, err) = skyloop(&["hinfsyn", &plant, "--nmeas", "1", "--ncon", "1", "--json"]);
    assert_eq!(code, 2);
    assert!(err.contains("D12"), "{err}");
}

#[test]
fn hinfsyn_unreachable_gamma_range_exits_2() {
    let plant = write(
        "ok.json",
        r#"{"a":[[1.0]],"b":[[1.0,1.0]],"c":[[1.0],[1.0]],"d":[[0.0,1.0],[1.0,0.0]],"dt":0.0}"#,
    );
    let (code, _, err) = skyloop(&["hinfsyn", &plant, "--nmeas", "1", "--ncon", "1", "--gamma-max", "0.5"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("gamma"), "{err}");
}

/// Bicopter paper, Section IV: γ_min = 1.748 (3rd-order Padé, W1 eq. (9), W2 eq. (10)).
#[test]
fn ncfsyn_bicopter_gamma_min() {
    let (code, out, err) = skyloop(&[
        "ncfsyn",
        "--plant",
        "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s * 2.221e5/(s^2 + 666.4*s + 2.221e5)",
        "--w1",
        "0.03511*(s+0.3419)/s",
        "--w2",
        "307.5*(s+3.816)/((s+11.35)*(s+103.4))",
        "--pade",
        "3",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("json out");
    let gmin = v["gamma_min"].as_f64().expect("gamma_min");
    assert!((gmin - 1.748).abs() < 5e-4, "{gmin}");
    let g = v["gamma"].as_f64().expect("gamma");
    assert!(g >= gmin && g <= 1.1 * gmin * 1.001, "{g}");
}

#[test]
fn ncfsyn_bad_factor_exits_2() {
    let (code, _, err) = skyloop(&["ncfsyn", "--plant", "1/(s+1)", "--factor", "0.5"]);
    assert_eq!(code, 2);
    assert!(err.contains("factor"), "{err}");
}

/// Synthesis failures say what about the plant or weights causes them, with the solver's own words
/// on a second line (before: "care: …"/"balance: matrix has NaN or infinite entries" alone).
#[test]
fn synthesis_failures_name_the_model_property() {
    for (args, first) in [
        (
            vec!["ncfsyn", "1/(s+1)", "--w1", "1e200"],
            "the shaped plant W2·P·W1 has state-space entries",
        ),
        (
            vec!["ncfsyn", "1/((1e-8*s+1)*(1e8*s+1))"],
            "the shaped plant W2·P·W1 has poles from",
        ),
        // A weight's pole cancelled by the plant's zero on the axis: the mode, its frequency and
        // both models are named (before: the shaped plant "is not detectable" alone).
        (
            vec!["ncfsyn", "(s^2+4)/(s+1)^3", "--w1", "1/(s^2+4)"],
            "the mode at s = 0.000000+2.000000i (0.3183 Hz) is a pole of the weight W1 cancelled by a zero of the plant P",
        ),
    ] {
        let (code, _, err) = skyloop(&args);
        assert_eq!(code, 2, "{args:?}");
        let mut lines = err.lines();
        assert!(lines.next().is_some_and(|l| l.contains(first)), "{args:?}: {err}");
        assert!(
            lines.next().is_some_and(|l| l.trim_start().starts_with("(solver: ")),
            "{args:?}: {err}"
        );
    }
}
