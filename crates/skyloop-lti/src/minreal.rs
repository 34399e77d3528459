//! Minimal realization: removes uncontrollable and then unobservable states with orthogonal
//! staircase transformations (the controllability staircase form of Van Dooren / SLICOT TB01UD,
//! applied to (A, B) and to the dual (Aᵀ, Cᵀ)), so the retained states are well conditioned.

use crate::error::{LtiError, Result};
use crate::ss::StateSpace;
use faer::Mat;

/// Default relative rank tolerance, as MATLAB's minreal: √ε.
pub const DEFAULT_TOL: f64 = 1.4901161193847656e-8;

/// Removes the uncontrollable and unobservable states of a model.
///
/// `tol` (relative, default √ε) decides the rank of each staircase block: singular values below
/// tol·max(‖A‖_F, ‖B‖_F) (resp. ‖C‖_F for the observability pass) count as zero.
pub fn minreal(sys: &StateSpace, tol: Option<f64>) -> Result<StateSpace> {
    sys.validate()?;
    let tol = tol.unwrap_or(DEFAULT_TOL);
    if !(tol.is_finite() && tol >= 0.0) {
        return Err(LtiError::InvalidArgument(format!(
            "tolerance must be finite and >= 0, got {tol}"
        )));
    }
    let (a, b, c) = controllable_part(&sys.a, &sys.b, &sys.c, tol)?;
    let (at, ct, bt) = controllable_part(
        &a.transpose().to_owned(),
        &c.transpose().to_owned(),
        &b.transpose().to_owned(),
        tol,
    )?;
    StateSpace::new(
        at.transpose().to_owned(),
        bt.transpose().to_owned(),
        ct.transpose().to_owned(),
        sys.d.clone(),
        sys.dt,
    )?
    .with_delays(sys.input_delay.clone(), sys.output_delay.clone())
}

/// Controllability staircase: an orthogonal Z with Zᵀ·B = [B₁; 0] and Zᵀ·A·Z block upper
/// Hessenberg; returns the leading (controllable) part of (ZᵀAZ, ZᵀB, CZ).
fn controllable_part(a: &Mat<f64>, b: &Mat<f64>, c: &Mat<f64>, tol: f64) -> Result<(Mat<f64>, Mat<f64>, Mat<f64>)> {
    let n = a.nrows();
    let mut a = a.clone();
    let mut b = b.clone();
    let mut c = c.clone();
    let thresh = tol * a.norm_l2().max(b.norm_l2());
    let mut k = 0;
    // The block whose range is reached next: first B, then the coupling A[k.., prev..k].
    let mut blk = b.clone();
    while k < n && blk.ncols() > 0 {
        let svd = blk
            .thin_svd()
            .map_err(|e| LtiError::Numerical(format!("SVD in the staircase failed: {e:?}")))?;
        let s = svd.S();
        let rank = (0..s.dim()).filter(|&i| s[i] > thresh).count();
        if rank == 0 {
            break;
        }
        // A full orthogonal basis whose first `rank` columns span the reached directions.
        let z = svd.U().get(.., ..rank).qr().compute_Q();
        let top = a.get(k.., ..).to_owned();
        let rows = z.transpose() * &top;
        a.get_mut(k.., ..).copy_from(&rows);
        let left = a.get(.., k..).to_owned();
        let cols = &left * &z;
        a.get_mut(.., k..).copy_from(&cols);
        let bk = z.transpose() * b.get(k.., ..);
        b.get_mut(k.., ..).copy_from(&bk);
        let ck = c.get(.., k..) * &z;
        c.get_mut(.., k..).copy_from(&ck);
        let next = k + rank;
        blk = a.get(next.., k..next).to_owned();
        k = next;
    }
    Ok((
        a.get(..k, ..k).to_owned(),
        b.get(..k, ..).to_owned(),
        c.get(.., ..k).to_owned(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn removes_a_cancelling_pole() {
        // (s+1)/((s+1)(s+2)) in controllable canonical form: one state cancels.
        let sys = StateSpace::from_rows(
            &[vec![-3.0, -2.0], vec![1.0, 0.0]],
            &[vec![1.0], vec![0.0]],
            &[vec![1.0, 1.0]],
            &[vec![0.0]],
            0.0,
        )
        .unwrap();
        let m = minreal(&sys, None).unwrap();
        assert_eq!(m.nx(), 1);
        // The remaining pole is −2 (closed form of the cancellation).
        assert!((m.a[(0, 0)] + 2.0).abs() < 1e-12);
    }

    #[test]
    fn static_gain_stays() {
        let g = StateSpace::gain(Mat::identity(2, 2), 0.0).unwrap();
        assert_eq!(minreal(&g, None).unwrap().nx(), 0);
    }

    #[test]
    fn negative_tolerance_is_an_error() {
        let g = StateSpace::gain(Mat::identity(1, 1), 0.0).unwrap();
        assert!(minreal(&g, Some(-1.0)).is_err());
    }
}
