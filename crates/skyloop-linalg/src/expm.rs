//! Matrix exponential by scaling and squaring with Padé approximants (Higham 2005, Algorithm 2.3).
//!
//! N. J. Higham, "The scaling and squaring method for the matrix exponential revisited",
//! SIAM J. Matrix Anal. Appl. 26(4), 2005: the degree m ∈ {3, 5, 7, 9, 13} is the smallest whose
//! bound θ_m covers ‖A‖₁; otherwise A is scaled by 2^-s into the degree-13 range and squared back.

use crate::error::{LinalgError, Result};
use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef};

/// θ_m of Higham (2005), Table 2.3: the largest ‖A‖₁ for which the [m/m] Padé approximant
/// has backward error below the unit roundoff in double precision.
const THETA: [(usize, f64); 4] = [
    (3, 1.495585217958292e-2),
    (5, 2.53939833006323e-1),
    (7, 9.504178996162932e-1),
    (9, 2.097847961257068e0),
];
const THETA13: f64 = 5.371920351148152e0;

/// Padé numerator coefficients b_0..b_m (Higham 2005, eq. (2.12) and Algorithm 2.3).
fn pade_coeffs(m: usize) -> &'static [f64] {
    match m {
        3 => &[120.0, 60.0, 12.0, 1.0],
        5 => &[30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0],
        7 => &[17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0],
        9 => &[
            17643225600.0,
            8821612800.0,
            2075673600.0,
            302702400.0,
            30270240.0,
            2162160.0,
            110880.0,
            3960.0,
            90.0,
            1.0,
        ],
        _ => &[
            64764752532480000.0,
            32382376266240000.0,
            7771770303897600.0,
            1187353796428800.0,
            129060195264000.0,
            10559470521600.0,
            670442572800.0,
            33522128640.0,
            1323241920.0,
            40840800.0,
            960960.0,
            16380.0,
            182.0,
            1.0,
        ],
    }
}

fn norm1(a: MatRef<f64>) -> f64 {
    (0..a.ncols())
        .map(|j| (0..a.nrows()).map(|i| a[(i, j)].abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// e^A for a square matrix A.
pub fn expm(a: MatRef<f64>) -> Result<Mat<f64>> {
    let n = a.nrows();
    if a.ncols() != n {
        return Err(LinalgError::Dimension(format!(
            "expm needs a square matrix, got {}x{}",
            n,
            a.ncols()
        )));
    }
    let nrm = norm1(a);
    if !nrm.is_finite() {
        return Err(LinalgError::InvalidArgument(
            "expm: matrix has non-finite entries".into(),
        ));
    }
    let eye = Mat::<f64>::identity(n, n);
    let a2 = a * a;
    for &(m, theta) in &THETA {
        if nrm <= theta {
            let b = pade_coeffs(m);
            // Powers A^0, A^2, A^4, ... up to A^(m-1).
            let mut pows = vec![eye.clone(), a2.clone()];
            while pows.len() < m.div_ceil(2) {
                let next = pows[pows.len() - 1].as_ref() * a2.as_ref();
                pows.push(next);
            }
            let mut u = Mat::<f64>::zeros(n, n);
            let mut v = Mat::<f64>::zeros(n, n);
            for (k, p) in pows.iter().enumerate() {
                u += p * faer::Scale(b[2 * k + 1]);
                v += p * faer::Scale(b[2 * k]);
            }
            let u = a * u;
            return solve_pade(&u, &v);
        }
    }
    let s = ((nrm / THETA13).log2().ceil()).max(0.0) as i32;
    let scale = 2f64.powi(-s);
    let a1 = a * faer::Scale(scale);
    let a2 = &a1 * &a1;
    let a4 = &a2 * &a2;
    let a6 = &a2 * &a4;
    let b = pade_coeffs(13);
    let sc = faer::Scale;
    let u_inner = &a6 * (&a6 * sc(b[13]) + &a4 * sc(b[11]) + &a2 * sc(b[9]))
        + &a6 * sc(b[7])
        + &a4 * sc(b[5])
        + &a2 * sc(b[3])
        + &eye * sc(b[1]);
    let u = &a1 * u_inner;
    let v = &a6 * (&a6 * sc(b[12]) + &a4 * sc(b[10]) + &a2 * sc(b[8]))
        + &a6 * sc(b[6])
        + &a4 * sc(b[4])
        + &a2 * sc(b[2])
        + &eye * sc(b[0]);
    let mut r = solve_pade(&u, &v)?;
    for _ in 0..s {
        r = &r * &r;
    }
    Ok(r)
}

/// r_m = (V − U)⁻¹ (V + U).
fn solve_pade(u: &Mat<f64>, v: &Mat<f64>) -> Result<Mat<f64>> {
    let q = v - u;
    let p = v + u;
    let r = q.partial_piv_lu().solve(&p);
    if r.col_iter()
        .flat_map(|c| c.iter().copied().collect::<Vec<_>>())
        .any(|x| !x.is_finite())
    {
        return Err(LinalgError::Singular("expm: Padé denominator is singular".into()));
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn max_diff(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
        let mut m = 0.0f64;
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                m = m.max((a[(i, j)] - b[(i, j)]).abs());
            }
        }
        m
    }

    #[test]
    fn rotation_closed_form() {
        // exp([[0, w], [-w, 0]]) = [[cos w, sin w], [-sin w, cos w]], for norms hitting every degree.
        for w in [1e-3, 0.1, 0.5, 1.5, 3.0, 40.0] {
            let a = Mat::from_fn(2, 2, |i, j| match (i, j) {
                (0, 1) => w,
                (1, 0) => -w,
                _ => 0.0,
            });
            let e = expm(a.as_ref()).unwrap();
            let want = Mat::from_fn(2, 2, |i, j| match (i, j) {
                (0, 1) => w.sin(),
                (1, 0) => -w.sin(),
                _ => w.cos(),
            });
            assert!(max_diff(&e, &want) < 1e-13 * (1.0 + w), "w = {w}");
        }
    }

    #[test]
    fn jordan_block_closed_form() {
        // exp([[l, 1], [0, l]]) = e^l [[1, 1], [0, 1]].
        let l = -7.0;
        let a = Mat::from_fn(2, 2, |i, j| {
            if i == j {
                l
            } else if j > i {
                1.0
            } else {
                0.0
            }
        });
        let e = expm(a.as_ref()).unwrap();
        let want = Mat::from_fn(2, 2, |i, j| if j >= i { l.exp() } else { 0.0 });
        assert!(max_diff(&e, &want) < 1e-15);
    }

    #[test]
    fn bad_input() {
        assert!(expm(Mat::<f64>::zeros(2, 3).as_ref()).is_err());
        let a = Mat::from_fn(1, 1, |_, _| f64::NAN);
        assert!(expm(a.as_ref()).is_err());
    }
}
