//! `skyloop log compare A B`: a log against itself (no change, no header difference), two different
//! Betaflight logs (the gains that differ, named A → B), a log without airborne time (its parts
//! "not identified", the command still succeeds), and a file that cannot be read (exit 2, named).
#![allow(clippy::unwrap_used)]

mod common;
use common::skyloop;
use serde_json::Value;

fn log(name: &str) -> String {
    format!("{}/../../testdata/logs/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn out_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("skyloop-compare-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn compare(a: &str, b: &str, extra: &[&str], name: &str) -> (Value, std::path::PathBuf) {
    let dir = out_dir(name);
    let d = dir.display().to_string();
    let mut args = vec!["log", "compare", a, b, "--out", d.as_str(), "--json"];
    args.extend_from_slice(extra);
    let (code, out, err) = skyloop(&args);
    assert_eq!(code, 0, "{err}");
    (serde_json::from_str(&out).unwrap(), dir)
}

/// LOG00037 against itself: every curve is equal, so nothing is distinguishable, no header key
/// differs and the verdict says "no change"; the outputs are written.
#[test]
fn a_log_compared_with_itself_shows_no_change() {
    let l = log("LOG00037.BFL");
    let (v, dir) = compare(&l, &l, &[], "self");
    assert_eq!(v["header_diffs"].as_array().unwrap().len(), 0, "{}", v["header_diffs"]);
    let verdict: Vec<&str> = v["verdict"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    assert!(verdict.last().unwrap().starts_with("no change"), "{verdict:?}");
    let axes = v["axes"].as_array().unwrap();
    assert_eq!(axes.len(), 3);
    for a in axes {
        assert_eq!(a["changed"], false, "{}", a["verdict"]);
        assert!(!a["verdict"].as_str().unwrap().contains('→'), "{}", a["verdict"]);
        // This log's tracking response is measured on every axis (LOG00037: roll −3 dB at 10 Hz).
        let t = &a["a"]["tracking"];
        assert!(t["freq_hz"].as_array().is_some(), "{t}");
        assert_eq!(a["tracking_diff"]["magnitude_db"]["significant"], 0);
        assert_eq!(a["tracking_diff"]["magnitude_db"]["max_abs"], 0.0);
    }
    let bw = v["axes"][0]["a"]["tracking"]["bandwidth_hz"].as_f64().unwrap();
    assert!((5.0..20.0).contains(&bw), "{bw}");
    for f in [
        "compare.json",
        "compare.txt",
        "roll_compare.png",
        "roll_compare.svg",
        "yaw_compare.png",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// LOG00037 (Betaflight 4.2.0) against session 12 of btfl_all (4.2.8, another craft and tune):
/// the gains that differ are listed A → B and named in the verdict; session 12 is too short for
/// the causal step, which is said per axis instead of failing.
#[test]
fn two_betaflight_logs_list_the_gains_that_differ() {
    let (v, dir) = compare(
        &log("LOG00037.BFL"),
        &log("btfl_all.bbl"),
        &["--session-b", "12"],
        "two",
    );
    let diffs = v["header_diffs"].as_array().unwrap();
    let roll_p = diffs.iter().find(|d| d["key"] == "pidf.roll.p").unwrap();
    assert_eq!(roll_p["a"], "77");
    assert_eq!(roll_p["b"], "35");
    assert!(!diffs.iter().any(|d| d["key"] == "pidf.yaw.d"), "yaw D is 0 in both");
    let verdict = v["verdict"].to_string();
    assert!(verdict.contains("roll P 77 → 35"), "{verdict}");
    let b_step = &v["axes"][0]["b"]["step"]["not_identified"];
    assert!(b_step.as_str().unwrap().contains("causal step"), "{b_step}");
    assert!(v["axes"][0]["verdict"]
        .as_str()
        .unwrap()
        .contains("step not measured in B"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// btfl_001's longest session never leaves idle throttle: tracking, step and plant are "not
/// identified" with the reason, in the JSON and in the text, and the command succeeds.
#[test]
fn a_log_without_flight_is_reported_part_by_part() {
    let dir = out_dir("idle");
    let d = dir.display().to_string();
    let (code, out, err) = skyloop(&[
        "log",
        "compare",
        &log("btfl_001.bbl"),
        &log("LOG00037.BFL"),
        "--out",
        &d,
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("A tracking: not identified:"), "{out}");
    assert!(out.contains("no airborne segment"), "{out}");
    assert!(out.contains("PIDs changed: "), "{out}");
    let json: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("compare.json")).unwrap()).unwrap();
    assert!(json["axes"][0]["a"]["tracking"]["not_identified"].is_string());
    assert!(json["axes"][0]["b"]["tracking"]["freq_hz"].is_array());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unreadable_file_exits_2_naming_it() {
    let dir = out_dir("bad");
    let d = dir.display().to_string();
    let (code, _, err) = skyloop(&[
        "log",
        "compare",
        "/nonexistent/a.bbl",
        &log("LOG00037.BFL"),
        "--out",
        &d,
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("/nonexistent/a.bbl"), "{err}");
    let not_a_log = log("SOURCES.md");
    let (code, _, err) = skyloop(&["log", "compare", &log("LOG00037.BFL"), &not_a_log, "--out", &d]);
    assert_eq!(code, 2);
    assert!(err.contains("SOURCES.md"), "{err}");
}
