//! The tests' own margin computation, independent of skyloop's: a loop given as L(jω) in closed
//! form, its gain crossover found by bisection and its phase margin read there.

use skyloop::lti::c64;
use std::f64::consts::PI;

/// (crossover Hz, phase margin deg) of a loop whose |L(jω)| falls through 1 once between `lo` and
/// `hi` rad/s (asserted), by bisection on a log scale.
pub fn crossover_and_phase_margin(l: impl Fn(f64) -> c64, lo: f64, hi: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (lo, hi);
    assert!(
        l(lo).norm() > 1.0 && l(hi).norm() < 1.0,
        "|L| does not cross 1 in the bracket"
    );
    for _ in 0..200 {
        let mid = (lo * hi).sqrt();
        if l(mid).norm() > 1.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo / (2.0 * PI), 180.0 + l(lo).arg().to_degrees())
}

/// (K, τ, Td) of an identification's parametric fit.
pub fn fitted(id: &skyloop::identify::Identification) -> (f64, f64, f64) {
    let fit = &id.fit.as_ref().expect("a parametric fit").1;
    (fit.params["K"], fit.params["tau"], fit.params["Td"])
}
