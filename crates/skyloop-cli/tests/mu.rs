//! `skyloop mu`: JSON output against closed forms, and exit status 2 on bad input.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use std::process::Command;

fn skyloop(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_skyloop"))
        .args(args)
        .output()
        .expect("runs")
}

fn tmp_model(name: &str, json: &str) -> String {
    let dir = std::env::temp_dir().join(format!("skyloop-mu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp dir");
    let p = dir.join(name);
    std::fs::write(&p, json).expect("write model");
    p.to_string_lossy().into_owned()
}

fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

#[test]
fn rank_one_static_gain_matches_the_closed_form() {
    // D = u vᵀ with u = [1, 2], v = [3, −1]: μ for two complex scalars is Σ|uᵢ||vᵢ| = 3 + 2 = 5
    // at every frequency (Packard & Doyle 1993, rank-one case); unstructured σ̄ = ‖u‖‖v‖ = 7.07.
    let model = tmp_model(
        "rank1.json",
        r#"{"a": [], "b": [], "c": [], "d": [[3.0, -1.0], [6.0, -2.0]], "dt": 0.0}"#,
    );
    let out = skyloop(&["mu", &model, "--blocks", "c1x1,c1x1", "--hz", "0.1,1,10", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let (up, lo, hz) = (floats(&v["upper"]), floats(&v["lower"]), floats(&v["freq_hz"]));
    assert_eq!(hz, vec![0.1, 1.0, 10.0]);
    for k in 0..3 {
        assert!(
            (up[k] - 5.0).abs() < 1e-4 * 5.0 && (lo[k] - 5.0).abs() < 1e-4 * 5.0,
            "{} {}",
            up[k],
            lo[k]
        );
    }
    assert!((v["peak"]["margin_lower"].as_f64().expect("margin") - 0.2).abs() < 1e-4);
}

#[test]
fn siso_expression_is_its_gain() {
    // One scalar block: μ = |G(jω)| = 1/√(1 + ω²) for G = 1/(s+1) (closed form).
    let out = skyloop(&["mu", "1/(s+1)", "--blocks", "c1x1", "--hz", "0,0.5", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let up = floats(&v["upper"]);
    let w = std::f64::consts::PI; // 0.5 Hz in rad/s
    assert!((up[0] - 1.0).abs() < 1e-9);
    assert!((up[1] - 1.0 / (1.0 + w * w).sqrt()).abs() < 1e-9);
}

#[test]
fn real_scalar_block_uses_the_dg_bound() {
    // One real scalar block: 1 − δG(jω) = 0 needs a real δ = 1/G(jω), so μ = |G(0)| = 1 at 0 Hz and
    // μ = 0 wherever G(jω) is not real (closed form); the complex-only bound would give |G(jω)| = 0.30
    // at 0.5 Hz.
    let out = skyloop(&["mu", "1/(s+1)", "--blocks", "r1", "--hz", "0,0.5", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let (up, lo) = (floats(&v["upper"]), floats(&v["lower"]));
    assert!(
        (up[0] - 1.0).abs() < 1e-6 && (lo[0] - 1.0).abs() < 1e-9,
        "{} {}",
        up[0],
        lo[0]
    );
    assert!(up[1] <= 1e-6 && lo[1] <= up[1], "{} {}", up[1], lo[1]);
}

#[test]
fn bad_input_exits_2() {
    let model = tmp_model(
        "gain.json",
        r#"{"a": [], "b": [], "c": [], "d": [[1.0, 0.0], [0.0, 1.0]], "dt": 0.0}"#,
    );
    for args in [
        vec!["mu", &model, "--blocks", "c1x1,q2", "--hz", "1"],
        vec!["mu", &model, "--blocks", "f0x2", "--hz", "1"],
        vec!["mu", &model, "--blocks", "c1x1,c1x1,c1x1", "--hz", "1"],
        vec!["mu", &model, "--blocks", "c1x1,c1x1", "--hz", "2,1"],
        vec!["mu", &model, "--blocks", "c1x1,c1x1", "--hz", "1,abc"],
        vec!["mu", "/nonexistent/model.json", "--blocks", "c1x1", "--hz", "1"],
    ] {
        let out = skyloop(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("error"), "{args:?}");
    }
}
