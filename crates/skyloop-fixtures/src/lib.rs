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

/// Seconds of CPU time consumed by the calling thread (wall time where that clock is unavailable).
/// The timing examples measure with it, as `bench/compare.py` measures the references with
/// Python's `time.thread_time`: on a busy machine, wall time is mostly waiting for a core.
#[allow(unsafe_code)] // one libc call; std has no per-thread CPU clock
pub fn thread_cpu_seconds() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: clock_gettime only writes the timespec it is given.
        if unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0 {
            return ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9;
        }
    }
    use std::sync::OnceLock;
    static T0: OnceLock<std::time::Instant> = OnceLock::new();
    T0.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
}

/// The smallest thread CPU time (s) of `repeats` calls of `f` (at least one), after one warm-up call.
pub fn best_cpu_seconds<T>(repeats: usize, mut f: impl FnMut() -> T) -> f64 {
    std::hint::black_box(f());
    let mut best = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let t = thread_cpu_seconds();
        std::hint::black_box(f());
        best = best.min(thread_cpu_seconds() - t);
    }
    best
}

/// The 64-bit LCG x ← 6364136223846793005·x + 1442695040888963407 from `seed`: each call gives the
/// next state's top 53 bits as a number uniform in [0, 1).
pub fn lcg(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A `rows`×`cols` matrix (as rows) uniform in [−1, 1), filled column by column from [`lcg`]
/// starting at `seed`. `bench/compare.py` reproduces it bit for bit, so both sides of a timing see
/// the same matrix.
pub fn lcg_matrix(rows: usize, cols: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut next = lcg(seed);
    let mut out = vec![vec![0.0; cols]; rows];
    for j in 0..cols {
        for row in out.iter_mut() {
            row[j] = next() * 2.0 - 1.0;
        }
    }
    out
}
