//! Controllability and observability gramians of stable models and their Cholesky factors,
//! continuous (A·P + P·Aᵀ + B·Bᵀ = 0) and discrete (A·P·Aᵀ − P + B·Bᵀ = 0) time.
//!
//! The factors come straight from Hammarling's method on one shared real Schur form of A, so
//! Hankel singular values computed from them keep their small values accurate.

use crate::error::{LtiError, Result};
use crate::ss::StateSpace;
use faer::Mat;
use skyloop_linalg::lyapunov::{lyap_chol_schur, lyap_chol_schur_t};
use skyloop_linalg::schur::{real_schur, Schur};
use skyloop_linalg::sylvester::Kind;

/// Which gramian: controllability P (from B) or observability Q (from C).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Gramian {
    /// P with A·P + P·Aᵀ + B·Bᵀ = 0 (discrete: A·P·Aᵀ − P + B·Bᵀ = 0).
    Controllability,
    /// Q with Aᵀ·Q + Q·A + Cᵀ·C = 0 (discrete: Aᵀ·Q·A − Q + Cᵀ·C = 0).
    Observability,
}

/// The gramian of a stable model (symmetric positive semidefinite, n×n).
pub fn gram(sys: &StateSpace, which: Gramian) -> Result<Mat<f64>> {
    let u = gram_chol(sys, which)?;
    Ok(&u * u.transpose())
}

/// Upper-triangular U with gramian = U·Uᵀ, for a stable model.
pub fn gram_chol(sys: &StateSpace, which: Gramian) -> Result<Mat<f64>> {
    let s = schur_of(sys)?;
    factor(sys, &s, which)
}

/// Both gramian factors (Lc, Lo) with P = Lc·Lcᵀ and Q = Lo·Loᵀ, sharing one Schur form of A.
pub fn gram_chol_pair(sys: &StateSpace) -> Result<(Mat<f64>, Mat<f64>)> {
    let s = schur_of(sys)?;
    Ok((
        factor(sys, &s, Gramian::Controllability)?,
        factor(sys, &s, Gramian::Observability)?,
    ))
}

/// Both gramian factors when the real Schur form of `sys.a` is already known.
pub(crate) fn gram_chol_pair_schur(sys: &StateSpace, s: &Schur) -> Result<(Mat<f64>, Mat<f64>)> {
    Ok((
        factor(sys, s, Gramian::Controllability)?,
        factor(sys, s, Gramian::Observability)?,
    ))
}

fn schur_of(sys: &StateSpace) -> Result<Schur> {
    sys.validate()?;
    Ok(real_schur(sys.a.as_ref())?)
}

fn factor(sys: &StateSpace, s: &Schur, which: Gramian) -> Result<Mat<f64>> {
    let kind = if sys.is_continuous() {
        Kind::Continuous
    } else {
        Kind::Discrete
    };
    let r = match which {
        Gramian::Controllability => lyap_chol_schur(s, sys.b.as_ref(), kind),
        Gramian::Observability => lyap_chol_schur_t(s, sys.c.as_ref(), kind),
    };
    r.map_err(|e| match e {
        skyloop_linalg::LinalgError::NoSolution(m) => {
            LtiError::Unsupported(format!("gramians need a stable model: {m}"))
        }
        other => other.into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sys2(dt: f64) -> StateSpace {
        // A with a complex pair (discrete: scaled inside the unit circle).
        let f = if dt > 0.0 { 0.3 } else { 1.0 };
        StateSpace::from_rows(
            &[vec![-f, 2.0 * f, 0.0], vec![-3.0 * f, -f, f], vec![0.0, 0.0, -0.5 * f]],
            &[vec![1.0, 0.0], vec![0.5, 1.0], vec![0.0, 2.0]],
            &[vec![1.0, -1.0, 0.5]],
            &[vec![0.0, 0.0]],
            dt,
        )
        .unwrap()
    }

    #[test]
    fn gramians_satisfy_their_lyapunov_equations() {
        for dt in [0.0, 0.1] {
            let s = sys2(dt);
            let p = gram(&s, Gramian::Controllability).unwrap();
            let q = gram(&s, Gramian::Observability).unwrap();
            let bb = &s.b * s.b.transpose();
            let cc = s.c.transpose() * &s.c;
            let (rp, rq) = if dt == 0.0 {
                (
                    &s.a * &p + &p * s.a.transpose() + &bb,
                    s.a.transpose() * &q + &q * &s.a + &cc,
                )
            } else {
                (
                    &s.a * &p * s.a.transpose() - &p + &bb,
                    s.a.transpose() * &q * &s.a - &q + &cc,
                )
            };
            let na = s.a.norm_l2();
            assert!(
                rp.norm_l2() <= 1e-13 * (2.0 * na * p.norm_l2() + bb.norm_l2()),
                "dt={dt}"
            );
            assert!(
                rq.norm_l2() <= 1e-13 * (2.0 * na * q.norm_l2() + cc.norm_l2()),
                "dt={dt}"
            );
        }
    }

    #[test]
    fn unstable_model_is_an_error() {
        let s = StateSpace::from_rows(&[vec![1.0]], &[vec![1.0]], &[vec![1.0]], &[vec![0.0]], 0.0).unwrap();
        assert!(matches!(
            gram(&s, Gramian::Controllability),
            Err(LtiError::Unsupported(_))
        ));
    }
}
