//! Eigenvalues of a real Hamiltonian matrix by Van Loan's square-reduced method (C. Van Loan,
//! "A symplectic method for approximating all the eigenvalues of a Hamiltonian matrix", Linear
//! Algebra Appl. 61, 1984).
//!
//! H² is skew-Hamiltonian, [[A, G], [Q, Aᵀ]] with G and Q skew-symmetric. An orthogonal symplectic
//! similarity (Householder reflections diag(P, P) and symplectic Givens rotations, the Paige–Van Loan
//! reduction) brings it to [[W, G'], [0, Wᵀ]] with W upper Hessenberg, so the 2n eigenvalues of H are
//! ±√μ for the n eigenvalues μ of W. That is one n × n QR iteration instead of a 2n × 2n one (several
//! times cheaper) and keeps the ±λ pairing exact; the price is an absolute error of about
//! ε‖H‖²/|λ| in eigenvalues λ much smaller than ‖H‖, harmless for locating imaginary-axis crossings.

use crate::error::{LtiError, Result};
use faer::{c64, Mat, MatRef};

/// The 2n eigenvalues of the Hamiltonian matrix `h` (2n × 2n, [[A, G], [Q, −Aᵀ]] with G, Q
/// symmetric), as ± pairs: for each eigenvalue μ of the square-reduced form, √μ then −√μ.
pub fn hamiltonian_eigenvalues(h: MatRef<f64>) -> Result<Vec<c64>> {
    let nn = h.nrows();
    if h.ncols() != nn || nn % 2 != 0 {
        return Err(LtiError::InvalidArgument(format!(
            "a Hamiltonian matrix must be 2n x 2n, got {}x{}",
            h.nrows(),
            h.ncols()
        )));
    }
    let n = nn / 2;
    if n == 0 {
        return Ok(Vec::new());
    }
    let sq = h * h;
    // Column-major working copy: m[j * nn + i] = (H²)[i, j].
    let mut m: Vec<f64> = (0..nn * nn).map(|k| sq[(k % nn, k / nn)]).collect();
    if m.iter().any(|x| !x.is_finite()) {
        return Err(LtiError::Numerical("Hamiltonian matrix is not finite".into()));
    }
    let mut v = vec![0.0; n];
    let mut w = vec![0.0; nn];
    for k in 0..n.saturating_sub(1) {
        // (a) diag(P, P) zeroes Q(k+2.., k), i.e. rows n+k+2.. of column k.
        let len = n - k - 1;
        for (i, vi) in v[..len].iter_mut().enumerate() {
            *vi = m[k * nn + n + k + 1 + i];
        }
        if let Some(tau) = householder(&mut v[..len]) {
            apply_pp(&mut m, nn, n, k + 1, &v[..len], tau, &mut w);
        }
        // (b) Symplectic Givens rotation in the plane (k+1, n+k+1) zeroes Q(k+1, k).
        let (x, y) = (m[k * nn + k + 1], m[k * nn + n + k + 1]);
        let r = x.hypot(y);
        if y != 0.0 && r > 0.0 {
            let (c, s) = (x / r, y / r);
            let (p, q) = (k + 1, n + k + 1);
            for j in 0..nn {
                let (a, b) = (m[j * nn + p], m[j * nn + q]);
                m[j * nn + p] = c * a + s * b;
                m[j * nn + q] = -s * a + c * b;
            }
            for i in 0..nn {
                let (a, b) = (m[p * nn + i], m[q * nn + i]);
                m[p * nn + i] = c * a + s * b;
                m[q * nn + i] = -s * a + c * b;
            }
        }
        // (c) diag(P, P) zeroes A(k+2.., k), making the leading block upper Hessenberg.
        for (i, vi) in v[..len].iter_mut().enumerate() {
            *vi = m[k * nn + k + 1 + i];
        }
        if let Some(tau) = householder(&mut v[..len]) {
            apply_pp(&mut m, nn, n, k + 1, &v[..len], tau, &mut w);
        }
    }
    let wmat = Mat::from_fn(n, n, |i, j| if i <= j + 1 { m[j * nn + i] } else { 0.0 });
    let mu = skyloop_linalg::schur::eigenvalues(wmat.as_ref())?;
    let mut out = Vec::with_capacity(nn);
    for u in mu {
        let l = u.sqrt();
        out.push(l);
        out.push(-l);
    }
    Ok(out)
}

/// Householder vector for x (overwritten with v, v[0] = 1) and τ such that (I − τvvᵀ)x = βe₁;
/// `None` when x is already a multiple of e₁.
fn householder(x: &mut [f64]) -> Option<f64> {
    let tail: f64 = x[1..].iter().map(|t| t * t).sum::<f64>();
    if tail == 0.0 {
        return None;
    }
    let alpha = x[0];
    let norm = (alpha * alpha + tail).sqrt();
    let beta = if alpha > 0.0 { -norm } else { norm };
    let v0 = alpha - beta;
    for t in x[1..].iter_mut() {
        *t /= v0;
    }
    x[0] = 1.0;
    Some((beta - alpha) / beta)
}

/// M ← diag(P, P)·M·diag(P, P) with P = I − τvvᵀ acting on indices `from..n` of each half.
/// Columns before `from − 1` are skipped on the left: the reduction has already zeroed their
/// entries in the rows P touches (below the Hessenberg subdiagonal, and in the Q block).
fn apply_pp(m: &mut [f64], nn: usize, n: usize, from: usize, v: &[f64], tau: f64, w: &mut [f64]) {
    for off in [from, n + from] {
        // Left: rows off..off+len of the columns that can be non-zero there.
        for j in (from - 1..n).chain(n..nn) {
            let col = &mut m[j * nn + off..j * nn + off + v.len()];
            let s = crate::freqresp::dot(col, v) * tau;
            for (a, b) in col.iter_mut().zip(v) {
                *a -= s * b;
            }
        }
        // Right: columns off..off+len, as w = M·v then M −= τ·w·vᵀ on contiguous columns.
        w.fill(0.0);
        for (jj, &vj) in v.iter().enumerate() {
            let col = &m[(off + jj) * nn..(off + jj + 1) * nn];
            for (wi, ci) in w.iter_mut().zip(col) {
                *wi += vj * ci;
            }
        }
        for (jj, &vj) in v.iter().enumerate() {
            let f = tau * vj;
            let col = &mut m[(off + jj) * nn..(off + jj + 1) * nn];
            for (ci, wi) in col.iter_mut().zip(w.iter()) {
                *ci -= f * wi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_hamiltonian(n: usize, seed: u64) -> Mat<f64> {
        let mut r = rand::rngs::StdRng::seed_from_u64(seed);
        let a = Mat::from_fn(n, n, |_, _| r.gen_range(-1.0..1.0));
        let g0 = Mat::from_fn(n, n, |_, _| r.gen_range(-1.0..1.0));
        let q0 = Mat::from_fn(n, n, |_, _| r.gen_range(-1.0..1.0));
        let g = &g0 + g0.transpose();
        let q = &q0 + q0.transpose();
        Mat::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
            (true, true) => a[(i, j)],
            (true, false) => g[(i, j - n)],
            (false, true) => q[(i - n, j)],
            (false, false) => -a[(j - n, i - n)],
        })
    }

    #[test]
    fn matches_a_dense_eigenvalue_solver() {
        for (n, seed) in [(1usize, 1u64), (2, 2), (5, 3), (17, 4), (40, 5)] {
            let h = random_hamiltonian(n, seed);
            let ours = hamiltonian_eigenvalues(h.as_ref()).unwrap();
            let reference = h.eigenvalues().unwrap();
            assert_eq!(ours.len(), 2 * n);
            let scale = h.norm_l2();
            // Every reference eigenvalue has one of ours within the method's ε‖H‖²/|λ| error.
            for l in &reference {
                let d = ours.iter().map(|o| (o - l).norm()).fold(f64::INFINITY, f64::min);
                let tol = 1e-13 * scale * scale / l.norm().max(1e-3 * scale) + 1e-12 * scale;
                assert!(d <= tol, "n={n}: {l} missed by {d:e}");
            }
        }
    }

    #[test]
    fn finds_imaginary_pair_of_a_closed_form() {
        // H = [[0, 1], [−ω², 0]]: eigenvalues ±jω (closed form).
        let w = 3.0;
        let h = Mat::from_fn(2, 2, |i, j| match (i, j) {
            (0, 1) => 1.0,
            (1, 0) => -w * w,
            _ => 0.0,
        });
        let e = hamiltonian_eigenvalues(h.as_ref()).unwrap();
        assert!(e.iter().any(|l| (l - c64::new(0.0, w)).norm() < 1e-14), "{e:?}");
        assert!(hamiltonian_eigenvalues(Mat::<f64>::zeros(3, 3).as_ref()).is_err());
    }
}
