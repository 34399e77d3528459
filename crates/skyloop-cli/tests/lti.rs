//! CLI tests for models given as expressions, and the LTI commands (c2d, poles, zeros).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

mod common;
use common::skyloop;

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

#[test]
fn a_huge_bad_expression_is_quoted_short() {
    // 5,000 nested parentheses: refused at the nesting limit, and the message quotes the input's ends
    // (not all 10,001 characters) next to the column.
    let text = format!("{}s{}", "(".repeat(5000), ")".repeat(5000));
    let (code, _, err) = skyloop(&["poles", &text]);
    assert_eq!(code, 2);
    assert!(
        err.contains("nests deeper") && err.contains("10001 characters"),
        "{}",
        &err[..err.len().min(400)]
    );
    assert!(err.len() < 600, "{} bytes of message", err.len());
}

#[test]
fn an_empty_log_is_named_as_empty_not_as_csv() {
    let dir = std::env::temp_dir().join(format!("skyloop-empty-log-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("flight.ulg");
    std::fs::write(&path, b"").expect("write");
    let (code, _, err) = skyloop(&["log", "info", path.to_str().expect("utf-8 path")]);
    assert_eq!(code, 2);
    assert!(
        err.contains("flight.ulg") && err.contains("empty") && !err.contains("CSV"),
        "{err}"
    );
}

#[test]
fn inverted_ranges_and_unwritable_outputs_are_named() {
    for (args, want) in [
        (
            &["identify", "no-such-log.bbl", "--from", "10", "--to", "5"][..],
            "--from 10 must be below --to 5",
        ),
        (
            &["identify", "no-such-log.bbl", "--fmin-hz", "50", "--fmax-hz", "5"][..],
            "--fmin-hz 50 must be below --fmax-hz 5",
        ),
        (
            &["bode", "1/(s+1)", "--out", "/nonexistent-skyloop-dir/x.png"][..],
            "No such file or directory",
        ),
    ] {
        let (code, _, err) = skyloop(args);
        assert_eq!(code, 2, "{args:?}");
        assert!(err.contains(want) && !err.contains("Os {"), "{args:?}: {err}");
    }
}

#[test]
fn ill_posed_feedback_is_said() {
    // (1−s)/(1+s): 1 + L(∞) = 0, the closed loop (1−s)/2 is improper.
    let (code, _, err) = skyloop(&["margins", "(1-s)/(1+s)"]);
    assert_eq!(code, 2);
    assert!(err.contains("ill-posed"), "{err}");
}

#[test]
fn c2d_json_matches_closed_form() {
    // 1/(s+1) with zoh at 0.1 s: a = e^{-0.1} (closed form).
    let (code, out, err) = skyloop(&["c2d", "1/(s+1)", "--dt", "0.1", "--method", "zoh", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    let a = v["a"][0][0].as_f64().expect("a");
    assert!((a - (-0.1f64).exp()).abs() < 1e-15);
    assert_eq!(v["dt"].as_f64(), Some(0.1));
    let (code, out, err) = skyloop(&[
        "c2d",
        "1/(s+1)",
        "--dt",
        "0.1",
        "--method",
        "tustin",
        "--prewarp-hz",
        "1",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(serde_json::from_str::<serde_json::Value>(&out).is_ok());
}

#[test]
fn c2d_bad_input_exits_2() {
    let (code, _, err) = skyloop(&["c2d", "1/(s+1)", "--dt", "0.1", "--method", "bogus"]);
    assert_eq!(code, 2);
    assert!(err.contains("unknown discretization method"), "{err}");
    let (code, _, err) = skyloop(&["c2d", "1/(s+1)", "--dt", "-1"]);
    assert_eq!(code, 2, "{err}");
    let (code, _, err) = skyloop(&["c2d", "1/(s+1)", "--dt", "0.1", "--method", "zoh", "--prewarp-hz", "3"]);
    assert_eq!(code, 2, "{err}");
}

#[test]
fn poles_and_zeros_json() {
    // Bicopter eq. (8): zeros ±42 rad/s (from (42^2 - s^2)), a pole at 0 among four.
    let (code, out, err) = skyloop(&["zeros", BICOPTER, "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    let mut re: Vec<f64> = v["re"]
        .as_array()
        .expect("re")
        .iter()
        .filter_map(|x| x.as_f64())
        .collect();
    re.sort_by(f64::total_cmp);
    assert_eq!(re.len(), 2);
    assert!((re[0] + 42.0).abs() < 1e-8 && (re[1] - 42.0).abs() < 1e-8, "{re:?}");
    let (code, out, err) = skyloop(&["poles", BICOPTER, "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    assert_eq!(v["im"].as_array().map(|a| a.len()), Some(4));
    let (code, out, _) = skyloop(&["poles", "1/(s+2)"]);
    assert_eq!(code, 0);
    assert!(out.contains("damping"));
}

#[test]
fn bad_model_json_exits_2() {
    let dir = std::env::temp_dir().join(format!("skyloop-lti-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("nonsquare.json");
    std::fs::write(&path, r#"{"a":[[1.0,2.0]],"b":[[1.0]],"c":[[1.0]],"d":[[0.0]]}"#).expect("write");
    let p = path.to_str().expect("utf-8 path");
    for cmd in ["poles", "zeros", "c2d"] {
        let (code, out, err) = skyloop(&[cmd, p, "--dt", "0.1"][..if cmd == "c2d" { 4 } else { 2 }]);
        assert_eq!(code, 2, "{cmd}: {err}");
        assert!(out.is_empty() && err.contains("square"), "{cmd}: {err}");
    }
    let (code, _, err) = skyloop(&["zeros", "exp(-s)+1"]);
    assert_eq!(code, 2);
    assert!(err.contains("different delays"), "{err}");
}

/// A reader that stops early (`| head`) ends the program quietly with status 0; a full disk is an
/// error with status 2 and one line on stderr, never a Rust panic message.
#[test]
fn closed_or_full_stdout_is_handled_without_a_panic() {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_skyloop"))
        .args(["freqresp", "1/(s+1)", "--logspace-hz", "0.01,100,20000"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    // Close the read end at once: every later write sees a broken pipe.
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.status.code() == Some(0), "status {:?}: {err}", out.status);
    if std::path::Path::new("/dev/full").exists() {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .expect("/dev/full");
        let out = Command::new(env!("CARGO_BIN_EXE_skyloop"))
            .args(["show", "1/(s+1)"])
            .stdout(full)
            .output()
            .expect("run");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.starts_with("error: ") && !err.contains("panicked"), "{err}");
    }
}
