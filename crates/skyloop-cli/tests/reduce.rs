//! CLI tests of `skyloop reduce` and `skyloop minreal` (models from the SLICOT fixtures of
//! skyloop-lti, written by tools/gen_reduce.py).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use serde_json::{json, Value};

mod common;
use common::skyloop;

fn fixture_case(name: &str) -> Value {
    // Read here rather than through skyloop-fixtures: the CLI depends on `skyloop` alone.
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../skyloop-lti/tests/fixtures/reduce/cases.json"
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(path).expect(path)).expect("fixture JSON");
    v["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == name)
        .expect("case")
        .clone()
}

/// Writes the case's model as LTI JSON into a per-test temporary file.
fn model_file(c: &Value, tag: &str) -> String {
    let path = std::env::temp_dir().join(format!("skyloop_reduce_{}_{tag}.json", std::process::id()));
    let m = json!({"a": c["a"], "b": c["b"], "c": c["c"], "d": c["d"], "dt": c["dt"]});
    std::fs::write(&path, m.to_string()).expect("temp file");
    path.to_string_lossy().into_owned()
}

#[test]
fn reduce_json_has_hsv_bound_and_model() {
    let c = fixture_case("rss_n10");
    let file = model_file(&c, "spa");
    let (code, out, err) = skyloop(&["reduce", &file, "--order", "4", "--method", "spa", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: Value = serde_json::from_str(&out).expect("one JSON object");
    let hsv: Vec<f64> = v["hankel_singular_values"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let href: Vec<f64> = c["hsv"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(hsv.len(), 10);
    for (h, r) in hsv.iter().zip(&href) {
        assert!((h - r).abs() <= 1e-8 * r, "HSV {h} vs SLICOT {r}");
    }
    let bound = 2.0 * hsv[4..].iter().sum::<f64>();
    assert!((v["error_bound"].as_f64().unwrap() - bound).abs() <= 1e-12 * bound);
    assert_eq!(v["model"]["a"].as_array().unwrap().len(), 4);
    let _ = std::fs::remove_file(file);
}

#[test]
fn reduce_keeps_unstable_poles_and_prints_a_table() {
    let c = fixture_case("unstable_n12");
    let file = model_file(&c, "unst");
    let (code, out, err) = skyloop(&["reduce", &file, "--order", "6"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("12 -> 6 states (3 unstable kept)"), "{out}");
    let plot = std::env::temp_dir().join(format!("skyloop-hsv-{}.svg", std::process::id()));
    let (code, _, err) = skyloop(&[
        "reduce",
        &file,
        "--order",
        "6",
        "--plot",
        plot.to_str().unwrap_or_default(),
    ]);
    assert_eq!(code, 0, "{err}");
    let svg = std::fs::read_to_string(&plot).expect("hsv plot written");
    assert!(
        svg.contains("discarded") && svg.contains("order 3"),
        "HSV plot lacks the kept/discarded split"
    );
    let _ = std::fs::remove_file(plot);
    // Fewer states than unstable poles is a clear error, exit 2.
    let (code, _, err) = skyloop(&["reduce", &file, "--order", "2"]);
    assert_eq!(code, 2);
    assert!(err.contains("unstable"), "{err}");
    let _ = std::fs::remove_file(file);
}

#[test]
fn reduce_bad_input_exits_2() {
    let c = fixture_case("rss_n4");
    let file = model_file(&c, "bad");
    for args in [
        vec!["reduce", file.as_str(), "--order", "2", "--method", "hankel"],
        vec!["reduce", file.as_str(), "--order", "9"],
        vec!["reduce", file.as_str(), "--order", "-1"],
        vec!["reduce", "missing_model.json", "--order", "2"],
        vec!["minreal", "missing_model.json"],
        vec!["minreal", file.as_str(), "--tol", "-1"],
    ] {
        let (code, out, err) = skyloop(&args);
        assert_eq!(code, 2, "{args:?}: {out} {err}");
        assert!(err.contains("error") || err.contains("invalid"), "{args:?}: {err}");
    }
    let _ = std::fs::remove_file(file);
}

#[test]
fn minreal_removes_a_cancelled_pole() {
    // (s+1)/((s+1)(s+2)) in controllable canonical form: one state is unobservable.
    let path = std::env::temp_dir().join(format!("skyloop_minreal_{}.json", std::process::id()));
    let m = json!({"a": [[-3.0, -2.0], [1.0, 0.0]], "b": [[1.0], [0.0]], "c": [[1.0, 1.0]], "d": [[0.0]]});
    std::fs::write(&path, m.to_string()).unwrap();
    let (code, out, err) = skyloop(&["minreal", path.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: Value = serde_json::from_str(&out).expect("LTI JSON");
    // One state left, with the remaining pole −2 (closed form of the cancellation).
    assert_eq!(v["a"].as_array().unwrap().len(), 1);
    assert!((v["a"][0][0].as_f64().unwrap() + 2.0).abs() < 1e-12);
    let _ = std::fs::remove_file(path);
}
