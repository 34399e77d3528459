//! CLI tests for models given as expressions, and the LTI commands (c2d, poles, zeros).

use std::process::Command;

fn skyloop(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_skyloop"))
        .args(args)
        .output()
        .expect("the skyloop binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

const BICOPTER: &str = "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)";

#[test]
fn expression_model_loads_with_its_delay() {
    let (code, out, err) = skyloop(&["show", BICOPTER, "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    assert_eq!(v["a"].as_array().map(|a| a.len()), Some(4));
    assert_eq!(v["input_delay"][0].as_f64(), Some(0.032));
}

#[test]
fn malformed_expression_exits_2_with_column() {
    let (code, out, err) = skyloop(&["show", "1/(s+*2)"]);
    assert_eq!(code, 2);
    assert!(out.is_empty());
    assert!(err.contains("column 6") && err.contains("expected"), "{err}");
}
