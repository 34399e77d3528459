//! Test-only helpers shared by the μ tests.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(dead_code)]

use faer::{c64, Mat};

/// Deterministic pseudo-random complex matrix (xorshift), entries in [−0.5, 0.5] + j[−0.5, 0.5].
pub fn pseudo_random(nr: usize, nc: usize, seed: u64) -> Mat<c64> {
    let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    Mat::from_fn(nr, nc, |_, _| c64::new(next(), next()))
}
