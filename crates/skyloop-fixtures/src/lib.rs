//! The one fixture loader of the tests: reference values made by the scripts in `tools/`
//! (python-control + slycot, scipy, orangebox, pyulog) and committed as JSON under each crate's
//! `tests/fixtures/`. A missing or malformed fixture fails the test with the path in the message.
#![allow(clippy::unwrap_used)] // dev-only: a panic is how a test reports a broken fixture

use serde_json::Value;
use std::path::Path;

/// The JSON file `rel` (relative to `manifest_dir`, which callers pass as
/// `env!("CARGO_MANIFEST_DIR")`).
///
/// # Panics
/// When the file cannot be read or is not JSON; the message names the path.
pub fn load(manifest_dir: &str, rel: &str) -> Value {
    let path = Path::new(manifest_dir).join(rel);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("fixture {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("fixture {} is not JSON: {e}", path.display()))
}

/// The `"cases"` array of the fixture `rel`.
///
/// # Panics
/// As [`load`], or when the file has no `"cases"` array.
pub fn cases(manifest_dir: &str, rel: &str) -> Vec<Value> {
    load(manifest_dir, rel)["cases"]
        .as_array()
        .unwrap_or_else(|| panic!("fixture {rel} has no \"cases\" array"))
        .clone()
}

/// A JSON array of numbers as `Vec<f64>`.
///
/// # Panics
/// When `v` is not an array of numbers.
pub fn f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("expected an array of numbers, got {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap_or_else(|| panic!("expected a number, got {x}")))
        .collect()
}
