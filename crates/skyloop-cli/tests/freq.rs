//! CLI tests of `freqresp`, `margins` and `norm`: JSON shapes, the bicopter golden margins, bad input.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

mod common;
use common::skyloop;

fn json(out: &str) -> serde_json::Value {
    serde_json::from_str(out).expect("exactly one JSON object on stdout")
}

/// L = P·C of the bicopter paper (seeds/000): P from eq. (8), C from eq. (12).
const BICOPTER_L: &str = "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5) \
    * 24.02*(s+54.01)*(s+0.2474)*(s^2+139.3*s+2.624e4)/(s*(s^2+24.14*s+8544)*(s^2+232.4*s+7.041e4))";

#[test]
fn freqresp_json_is_indexed_frequency_output_input() {
    // 1/(s+1) with a 0.1 s delay at 0 and 1 Hz: closed form e^{-jω·0.1}/(jω + 1).
    let (code, out, err) = skyloop(&["freqresp", "exp(-0.1*s)/(s+1)", "--hz", "0,1", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v = json(&out);
    assert_eq!(v["freq_hz"], serde_json::json!([0.0, 1.0]));
    let w = 2.0 * std::f64::consts::PI;
    let (c, s) = ((0.1 * w).cos(), (0.1 * w).sin());
    // (c − js)/(1 + jw) = ((c − s·w) − j(s + c·w))/(1 + w²)
    let re = (c - s * w) / (1.0 + w * w);
    let im = -(s + c * w) / (1.0 + w * w);
    assert!((v["re"][0][0][0].as_f64().expect("re") - 1.0).abs() < 1e-14);
    assert!((v["re"][1][0][0].as_f64().expect("re") - re).abs() < 1e-14);
    assert!((v["im"][1][0][0].as_f64().expect("im") - im).abs() < 1e-14);
}

#[test]
fn bicopter_margins_golden() {
    // The paper (section IV) prints PM 65.8° at 1.47 Hz and GM 7.25 dB; Fig. 10 has three gain crossovers.
    let (code, out, err) = skyloop(&["margins", BICOPTER_L, "--json"]);
    assert_eq!(code, 0, "{err}");
    let v = json(&out);
    let f = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
    assert!((f("phase_margin_deg") - 65.8).abs() <= 0.3, "{v}");
    assert!((f("phase_margin_freq_hz") - 1.47).abs() <= 0.02, "{v}");
    assert!((f("gain_margin_db") - 7.25).abs() <= 0.1, "{v}");
    assert_eq!(v["closed_loop_stable"], true);
    assert_eq!(v["all_phase_margins"].as_array().map(|a| a.len()), Some(3), "{v}");
    for k in ["gain_margin_freq_hz", "delay_margin_s"] {
        assert!(f(k) > 0.0, "{k}");
    }
    let dm = &v["disk_margin"];
    for k in ["alpha", "phase_deg", "freq_hz"] {
        assert!(dm[k].as_f64().is_some(), "disk_margin.{k} in {v}");
    }
    assert_eq!(dm["gain_db"].as_array().map(|a| a.len()), Some(2));
    assert!(v["all_gain_margins"][0]["gm_db"].as_f64().is_some());
    // The readable table says the same.
    let (code, table, _) = skyloop(&["margins", BICOPTER_L]);
    assert_eq!(code, 0);
    assert!(table.contains("gain crossovers (3)"), "{table}");
}

#[test]
fn margins_without_phase_crossover_report_null_gain_margin() {
    // 1/(s+1): phase never reaches −180°, |L| < 1 above DC: GM infinite, no gain crossover.
    let (code, out, err) = skyloop(&["margins", "1/(s+1)", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v = json(&out);
    assert!(
        v["gain_margin_db"].is_null() && v["gain_margin_freq_hz"].is_null(),
        "{v}"
    );
    assert!(v["phase_margin_deg"].is_null() && v["delay_margin_s"].is_null(), "{v}");
    assert_eq!(v["closed_loop_stable"], true);
}

#[test]
fn bad_input_exits_2_without_panic() {
    for args in [
        vec!["freqresp", "1/(s+1)", "--hz", "1,abc"],
        vec!["freqresp", "1/(s+1)", "--hz", "-1"],
        vec!["freqresp", "1/s", "--hz", "0", "--json"],
        vec!["freqresp", "1/(s+", "--hz", "1"],
        vec!["margins", "1/(s+*1)"],
        vec!["margins", "missing_file.json"],
    ] {
        let (code, out, err) = skyloop(&args);
        assert_eq!(code, 2, "{args:?}: {out} {err}");
        assert!(
            err.starts_with("error:") && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn margins_of_mimo_model_is_a_clear_error() {
    let dir = std::env::temp_dir().join(format!("skyloop-freq-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("mimo.json");
    std::fs::write(
        &path,
        r#"{"a":[[-1.0]],"b":[[1.0,1.0]],"c":[[1.0],[2.0]],"d":[[0.0,0.0],[0.0,0.0]]}"#,
    )
    .expect("write");
    let (code, _, err) = skyloop(&["margins", path.to_str().expect("utf8")]);
    assert_eq!(code, 2);
    assert!(err.contains("SISO"), "{err}");
}

#[test]
fn absurd_grid_sizes_are_refused_by_name() {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_skyloop"))
        .args(["freqresp", "1/(s+1)", "--logspace-hz", "0.1,1,1e11"])
        .output()
        .expect("runs");
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--logspace-hz") && err.contains("limit"), "{err}");
}

#[test]
fn all_pass_loops_and_extreme_poles_print_sanely() {
    let run = |args: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_skyloop"))
            .args(args)
            .output()
            .expect("runs");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let text = run(&["margins", "(s-1)/(s+1)"]);
    assert!(
        text.contains("gain crossovers (0)") && text.contains("|L| = 1 on the whole band"),
        "{text}"
    );
    let v: serde_json::Value = serde_json::from_str(&run(&["margins", "(s-1)/(s+1)", "--json"])).expect("json");
    assert!(v["unit_gain_band_hz"].is_array(), "{v}");
    let text = run(&["poles", "1/(s+1e300)"]);
    assert!(text.lines().all(|l| l.len() < 80), "{text}");
}
