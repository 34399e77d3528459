//! All eigenvalues and the top eigenvectors of a small Hermitian matrix, for the σ̄ evaluations of
//! the μ upper bound (which need the whole spectrum only for its top cluster's vectors).
//!
//! Householder reduction to a Hermitian tridiagonal matrix, a diagonal unitary similarity making its
//! off-diagonal real (Golub & Van Loan, Matrix Computations, §8.3.1), eigenvalues by the implicit
//! symmetric QR step with Wilkinson shift (ibid. Alg. 8.3.2, no vector accumulation, O(n²)), then
//! the wanted eigenvectors by inverse iteration on the tridiagonal matrix with reorthogonalization
//! inside clusters (as LAPACK's xSTEIN) and the back-transformation. Everything is backward stable:
//! the eigenvalues are those of A + E with ‖E‖ = O(n ε ‖A‖), so the largest one is accurate to a few
//! ulps relative, the same guarantee as a full eigen-decomposition.

use faer::{c64, Mat, MatRef};

/// Eigenvalues (ascending) and the eigenvectors of the largest ones.
pub struct TopEigen {
    /// All eigenvalues, ascending.
    pub lam: Vec<f64>,
    /// Column c is a unit eigenvector for `lam[n − 1 − c]`; the columns are orthonormal.
    pub vecs: Mat<c64>,
}

/// Work space reused across calls (the μ upper bound evaluates hundreds of spectra of one size).
#[derive(Default)]
pub struct Workspace {
    a: Vec<c64>,
    v: Vec<c64>,
    tau: Vec<f64>,
    d: Vec<f64>,
    e: Vec<f64>,
    phase: Vec<c64>,
    p: Vec<c64>,
}

fn phase_of(x: c64) -> c64 {
    let n = x.norm();
    if n > 0.0 {
        x / n
    } else {
        c64::new(1.0, 0.0)
    }
}

/// Eigen-decomposition of the Hermitian `a` (only its lower triangle is read); `n_vecs(lam)` says how
/// many of the largest eigenvalues need vectors given all of them (ascending). `None` when the QR
/// iteration does not converge (not observed; callers fall back to a dense solver).
pub fn top_eigen(a: MatRef<c64>, ws: &mut Workspace, n_vecs: impl FnOnce(&[f64]) -> usize) -> Option<TopEigen> {
    let n = a.nrows();
    if n == 0 {
        return Some(TopEigen {
            lam: Vec::new(),
            vecs: Mat::zeros(0, 0),
        });
    }
    tridiagonalize(a, ws);
    let mut lam = ws.d.clone();
    let mut off = ws.e.clone();
    tridiagonal_eigenvalues(&mut lam, &mut off)?;
    lam.sort_by(f64::total_cmp);
    let k = n_vecs(&lam).min(n);
    let mut vecs = Mat::<c64>::zeros(n, k);
    let norm_t = ws.d.iter().fold(0.0_f64, |m, x| m.max(x.abs())) + 2.0 * ws.e.iter().fold(0.0_f64, |m, x| m.max(*x));
    if norm_t == 0.0 {
        // A = 0: every unit vector is an eigenvector.
        for c in 0..k {
            vecs[(c, c)] = c64::new(1.0, 0.0);
        }
        return Some(TopEigen { lam, vecs });
    }
    let mut cluster: Vec<Vec<f64>> = Vec::new();
    let mut prev: Option<(f64, f64)> = None; // (eigenvalue, shift used)
    for c in 0..k {
        let l = lam[n - 1 - c];
        let mut shift = l;
        match prev {
            Some((lp, sp)) if lp - l <= 1e-3 * norm_t => {
                // Equal shifts would give the same factorization: separate them slightly.
                let pert = 10.0 * f64::EPSILON * norm_t;
                if sp - shift < pert {
                    shift = sp - pert;
                }
            }
            _ => cluster.clear(),
        }
        prev = Some((l, shift));
        let y = inverse_iteration(&ws.d, &ws.e, l, shift, norm_t, &cluster, c as u64);
        // x = Q S y: undo the phase scaling, then the reflectors in reverse order.
        let mut x: Vec<c64> = y.iter().zip(&ws.phase).map(|(&yi, &s)| s * yi).collect();
        back_transform(ws, n, &mut x);
        for (i, xi) in x.iter().enumerate() {
            vecs[(i, c)] = *xi;
        }
        cluster.push(y);
    }
    Some(TopEigen { lam, vecs })
}

/// Householder reduction: fills ws.d, ws.e (real off-diagonal), ws.phase (diagonal S) and the
/// reflectors (ws.v packed, ws.tau) with A = Q S T Sᴴ Qᴴ.
fn tridiagonalize(a: MatRef<c64>, ws: &mut Workspace) {
    let n = a.nrows();
    ws.a.clear();
    // Column-major copy; only the lower triangle is used.
    for j in 0..n {
        for i in 0..n {
            ws.a.push(if i >= j { a[(i, j)] } else { c64::new(0.0, 0.0) });
        }
    }
    ws.v.clear();
    ws.tau.clear();
    ws.d.clear();
    ws.e.clear();
    ws.p.resize(n, c64::new(0.0, 0.0));
    let mut e_c = Vec::with_capacity(n.saturating_sub(1));
    let at = |j: usize, i: usize| j * n + i;
    for k in 0..n.saturating_sub(2) {
        ws.d.push(ws.a[at(k, k)].re);
        let m = n - k - 1;
        let x0 = ws.a[at(k, k + 1)];
        let tail: f64 = (k + 2..n).map(|i| ws.a[at(k, i)].norm_sqr()).sum();
        let v_off = ws.v.len();
        if tail == 0.0 {
            // Already tridiagonal in this column: H = I.
            e_c.push(x0);
            ws.tau.push(0.0);
            ws.v.extend((0..m).map(|_| c64::new(0.0, 0.0)));
            continue;
        }
        let xnorm = (x0.norm_sqr() + tail).sqrt();
        let alpha = -phase_of(x0) * xnorm;
        ws.v.push(x0 - alpha);
        for i in k + 2..n {
            ws.v.push(ws.a[at(k, i)]);
        }
        let vv = ws.v[v_off].norm_sqr() + tail;
        let tau = 2.0 / vv;
        ws.tau.push(tau);
        e_c.push(alpha);
        // Trailing block A22 ← H A22 H = A22 − v qᴴ − q vᴴ with p = τ A22 v, q = p − (τ vᴴp / 2) v.
        // Only the lower triangle of A22 is read and updated (column slices, symv/her2-style).
        let v = &ws.v[v_off..v_off + m];
        let p = &mut ws.p[..m];
        p.iter_mut().for_each(|x| *x = c64::new(0.0, 0.0));
        for c in 0..m {
            let j = k + 1 + c;
            let col = &ws.a[j * n + j..j * n + n];
            let vc = v[c];
            // Diagonal entry (real), then the strictly lower part feeds p_c (by symmetry) and p_i.
            let mut acc = col[0] * vc;
            for ((pi, aij), vi) in p[c + 1..].iter_mut().zip(&col[1..]).zip(&v[c + 1..]) {
                *pi += aij * vc;
                acc += aij.conj() * vi;
            }
            p[c] += acc;
        }
        let mut vp = 0.0;
        for (pr, vr) in p.iter_mut().zip(v) {
            *pr *= tau;
            vp += (vr.conj() * *pr).re;
        }
        let kk = 0.5 * tau * vp;
        for (pr, vr) in p.iter_mut().zip(v) {
            *pr -= vr * kk;
        }
        for c in 0..m {
            let j = k + 1 + c;
            let (vj, qj) = (v[c].conj(), p[c].conj());
            let col = &mut ws.a[j * n + j..j * n + n];
            for ((aij, vi), qi) in col.iter_mut().zip(&v[c..]).zip(&p[c..]) {
                *aij -= vi * qj + qi * vj;
            }
        }
    }
    if n >= 2 {
        ws.d.push(ws.a[at(n - 2, n - 2)].re);
        e_c.push(ws.a[at(n - 2, n - 1)]);
    }
    ws.d.push(ws.a[at(n - 1, n - 1)].re);
    // S = diag(s), s₀ = 1, s_{k+1} = s_k·phase(e_k): Sᴴ T S has the real off-diagonal |e_k|.
    ws.phase.clear();
    ws.phase.push(c64::new(1.0, 0.0));
    for (k, ek) in e_c.iter().enumerate() {
        let s = ws.phase[k] * phase_of(*ek);
        ws.phase.push(s);
        ws.e.push(ek.norm());
    }
}

/// x ← Q x with Q = H₀ H₁ ⋯ H_{n−3} (reflector k acts on entries k+1..n).
fn back_transform(ws: &Workspace, n: usize, x: &mut [c64]) {
    let mut offsets = Vec::with_capacity(ws.tau.len());
    let mut off = 0;
    for k in 0..ws.tau.len() {
        offsets.push(off);
        off += n - k - 1;
    }
    for k in (0..ws.tau.len()).rev() {
        let tau = ws.tau[k];
        if tau == 0.0 {
            continue;
        }
        let v = &ws.v[offsets[k]..offsets[k] + n - k - 1];
        let xs = &mut x[k + 1..];
        let dot = v
            .iter()
            .zip(xs.iter())
            .fold(c64::new(0.0, 0.0), |acc, (vi, xi)| acc + vi.conj() * xi);
        let f = dot * tau;
        for (xi, vi) in xs.iter_mut().zip(v) {
            *xi -= vi * f;
        }
    }
}

/// Eigenvalues of the symmetric tridiagonal (d, e) in place in `d` (unordered); `None` if the QR
/// iteration fails to converge in 30 n steps.
fn tridiagonal_eigenvalues(d: &mut [f64], e: &mut [f64]) -> Option<()> {
    let n = d.len();
    let mut hi = n.saturating_sub(1);
    let mut steps = 0;
    let negligible = |e: f64, a: f64, b: f64| e.abs() <= f64::EPSILON * (a.abs() + b.abs()) || e == 0.0;
    while hi > 0 {
        if negligible(e[hi - 1], d[hi - 1], d[hi]) {
            e[hi - 1] = 0.0;
            hi -= 1;
            continue;
        }
        let mut lo = hi - 1;
        while lo > 0 && !negligible(e[lo - 1], d[lo - 1], d[lo]) {
            lo -= 1;
        }
        steps += 1;
        if steps > 30 * n {
            return None;
        }
        qr_step(d, e, lo, hi);
    }
    Some(())
}

/// One implicit symmetric QR step with Wilkinson shift on the unreduced block lo..=hi
/// (Golub & Van Loan Alg. 8.3.2), chasing the bulge down the band.
fn qr_step(d: &mut [f64], e: &mut [f64], lo: usize, hi: usize) {
    let dd = 0.5 * (d[hi - 1] - d[hi]);
    let eh = e[hi - 1];
    let sgn = if dd >= 0.0 { 1.0 } else { -1.0 };
    let h2 = dd * dd + eh * eh;
    let h = if h2.is_normal() { h2.sqrt() } else { dd.hypot(eh) };
    let mu = d[hi] - eh * eh / (dd + sgn * h);
    let mut x = d[lo] - mu;
    let mut z = e[lo];
    for k in lo..hi {
        // libm's hypot is the bottleneck here; its overflow guard is only needed far from unit scale.
        let r2 = x * x + z * z;
        let r = if r2.is_normal() { r2.sqrt() } else { x.hypot(z) };
        let (c, s) = if r == 0.0 { (1.0, 0.0) } else { (x / r, z / r) };
        if k > lo {
            // The rotation zeroes the bulge at (k+1, k−1).
            e[k - 1] = r;
        }
        let (a, b, cc) = (d[k], e[k], d[k + 1]);
        d[k] = c * c * a + 2.0 * c * s * b + s * s * cc;
        d[k + 1] = s * s * a - 2.0 * c * s * b + c * c * cc;
        e[k] = c * s * (cc - a) + (c * c - s * s) * b;
        if k + 1 < hi {
            let bulge = s * e[k + 1];
            e[k + 1] *= c;
            x = e[k];
            z = bulge;
        }
    }
}

/// Unit eigenvector of the symmetric tridiagonal (d, e) for the eigenvalue `lam` by inverse iteration
/// with `shift`, orthogonal to the (unit, mutually orthogonal) vectors of its cluster.
fn inverse_iteration(
    d: &[f64],
    e: &[f64],
    lam: f64,
    shift: f64,
    norm_t: f64,
    cluster: &[Vec<f64>],
    seed: u64,
) -> Vec<f64> {
    let n = d.len();
    if n == 1 {
        return vec![1.0];
    }
    let f = TridiagLu::new(d, e, shift, norm_t);
    let mut state = 0x9E37_79B9_7F4A_7C15u64 ^ seed.wrapping_mul(0xD1B5_4A32_D192_ED03);
    let mut y: Vec<f64> = (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let tol = 8.0 * n as f64 * f64::EPSILON * norm_t;
    let mut extra = false;
    for _ in 0..8 {
        f.solve(&mut y);
        for _ in 0..2 {
            for q in cluster {
                let dot: f64 = q.iter().zip(&y).map(|(a, b)| a * b).sum();
                for (yi, qi) in y.iter_mut().zip(q) {
                    *yi -= dot * qi;
                }
            }
        }
        let nrm = y.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(nrm > 1e-150 && nrm.is_finite()) {
            // The iterate fell into the span of the cluster (or overflowed): any unit vector
            // orthogonal to the cluster is as good an approximation of this eigenvalue's vector.
            return orthogonal_complement_vector(cluster, n);
        }
        y.iter_mut().for_each(|x| *x /= nrm);
        if extra {
            break;
        }
        // Residual ‖(T − λ) y‖ with the unperturbed eigenvalue.
        let mut res = 0.0;
        for i in 0..n {
            let mut r = (d[i] - lam) * y[i];
            if i > 0 {
                r += e[i - 1] * y[i - 1];
            }
            if i + 1 < n {
                r += e[i] * y[i + 1];
            }
            res += r * r;
        }
        if res.sqrt() <= tol {
            // One more step, as xSTEIN does, to polish the vector.
            extra = true;
        }
    }
    y
}

/// A unit vector orthogonal to the orthonormal `cluster` (Gram–Schmidt of the best coordinate axis).
fn orthogonal_complement_vector(cluster: &[Vec<f64>], n: usize) -> Vec<f64> {
    let mut best = (f64::NEG_INFINITY, vec![0.0; n]);
    for i in 0..n {
        let mut y = vec![0.0; n];
        y[i] = 1.0;
        for _ in 0..2 {
            for q in cluster {
                let dot: f64 = q.iter().zip(&y).map(|(a, b)| a * b).sum();
                for (yi, qi) in y.iter_mut().zip(q) {
                    *yi -= dot * qi;
                }
            }
        }
        let nrm = y.iter().map(|x| x * x).sum::<f64>().sqrt();
        if nrm > best.0 {
            best = (nrm, y.iter().map(|x| x / nrm).collect());
        }
        if nrm > 0.5 {
            break;
        }
    }
    best.1
}

/// LU factorization with partial pivoting of T − σI for a symmetric tridiagonal T (U has two
/// superdiagonals); zero pivots are replaced by ε‖T‖ so inverse iteration can proceed.
struct TridiagLu {
    u0: Vec<f64>,
    u1: Vec<f64>,
    u2: Vec<f64>,
    l: Vec<f64>,
    swap: Vec<bool>,
}

impl TridiagLu {
    fn new(d: &[f64], e: &[f64], shift: f64, norm_t: f64) -> Self {
        let n = d.len();
        let (mut u0, mut u1, mut u2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let (mut l, mut swap) = (vec![0.0; n], vec![false; n]);
        let tiny = f64::EPSILON * norm_t;
        // Current row i: entries at columns i, i+1, i+2.
        let mut cur = (d[0] - shift, e[0], 0.0);
        for i in 0..n - 1 {
            let next = (e[i], d[i + 1] - shift, if i + 2 < n { e[i + 1] } else { 0.0 });
            let new;
            if cur.0.abs() >= next.0.abs() {
                let piv = if cur.0 == 0.0 { tiny } else { cur.0 };
                let m = next.0 / piv;
                u0[i] = piv;
                u1[i] = cur.1;
                u2[i] = cur.2;
                l[i] = m;
                new = (next.1 - m * cur.1, next.2 - m * cur.2);
            } else {
                let m = cur.0 / next.0;
                u0[i] = next.0;
                u1[i] = next.1;
                u2[i] = next.2;
                l[i] = m;
                swap[i] = true;
                new = (cur.1 - m * next.1, cur.2 - m * next.2);
            }
            cur = (new.0, new.1, 0.0);
        }
        u0[n - 1] = if cur.0.abs() < tiny {
            if cur.0 < 0.0 {
                -tiny
            } else {
                tiny
            }
        } else {
            cur.0
        };
        for p in u0.iter_mut() {
            if p.abs() < tiny {
                *p = if *p < 0.0 { -tiny } else { tiny };
            }
        }
        TridiagLu { u0, u1, u2, l, swap }
    }

    /// x ← (T − σI)⁻¹ x, rescaled to avoid overflow (only the direction matters).
    fn solve(&self, x: &mut [f64]) {
        let n = x.len();
        for i in 0..n - 1 {
            if self.swap[i] {
                x.swap(i, i + 1);
            }
            x[i + 1] -= self.l[i] * x[i];
        }
        for i in (0..n).rev() {
            let mut r = x[i];
            if i + 1 < n {
                r -= self.u1[i] * x[i + 1];
            }
            if i + 2 < n {
                r -= self.u2[i] * x[i + 2];
            }
            x[i] = r / self.u0[i];
            if !x[i].is_finite() || x[i].abs() > 1e150 {
                let s = x[i..]
                    .iter()
                    .fold(0.0_f64, |m, v| if v.is_finite() { m.max(v.abs()) } else { m });
                let s = if s > 0.0 { s } else { 1.0 };
                for v in x[i..].iter_mut() {
                    *v = if v.is_finite() { *v / s } else { 1.0 };
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Side;

    fn random_hermitian(n: usize, seed: u64, spectrum: Option<&[f64]>) -> Mat<c64> {
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let g = Mat::from_fn(n, n, |_, _| c64::new(next(), next()));
        match spectrum {
            None => &g + g.adjoint(),
            Some(lam) => {
                // Q diag(lam) Qᴴ with Q unitary from a QR factorization.
                let q = g.qr().compute_Q();
                let dl = Mat::from_fn(n, n, |i, j| c64::new(if i == j { lam[i] } else { 0.0 }, 0.0));
                let a = &q * dl * q.adjoint();
                Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)].conj()))
            }
        }
    }

    fn check(a: &Mat<c64>, k: usize) {
        let n = a.nrows();
        let mut ws = Workspace::default();
        let te = top_eigen(a.as_ref(), &mut ws, |_| k).expect("converged");
        let reference = a.self_adjoint_eigenvalues(Side::Lower).expect("evd");
        let scale = reference.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        for (x, y) in te.lam.iter().zip(&reference) {
            assert!((x - y).abs() <= 1e-13 * scale, "eigenvalue {x} vs faer {y}");
        }
        for c in 0..k {
            let l = te.lam[n - 1 - c];
            let v = te.vecs.col(c);
            let av = a * v;
            let rn = (0..n).map(|i| (av[i] - v[i] * l).norm_sqr()).sum::<f64>().sqrt();
            assert!(rn <= 1e-12 * scale, "residual {rn} for eigenvalue {l}");
            for c2 in 0..k {
                let ip = te.vecs.col(c).adjoint() * te.vecs.col(c2);
                let want = if c == c2 { 1.0 } else { 0.0 };
                assert!(
                    (ip - c64::new(want, 0.0)).norm() <= 1e-12,
                    "not orthonormal: {ip:?} {c} {c2} n={n} lam={:?}",
                    te.lam
                );
            }
        }
    }

    #[test]
    fn matches_dense_eigen_decomposition() {
        for (n, seed) in [(1, 1), (2, 2), (3, 3), (7, 4), (20, 5), (33, 6)] {
            let a = random_hermitian(n, seed, None);
            check(&a, n.min(5));
            check(&a, n);
        }
    }

    #[test]
    fn multiple_and_clustered_top_eigenvalues() {
        // The μ optimum typically has a multiple largest singular value.
        let mut lam: Vec<f64> = (0..20).map(|i| i as f64 / 10.0).collect();
        lam[19] = 5.0;
        lam[18] = 5.0;
        lam[17] = 5.0 - 1e-9;
        lam[16] = 4.9;
        check(&random_hermitian(20, 9, Some(&lam)), 6);
        let zeros = vec![0.0; 6];
        check(&random_hermitian(6, 10, Some(&zeros)), 6);
        let mut one = vec![0.0; 8];
        one[7] = 1.0;
        check(&random_hermitian(8, 11, Some(&one)), 3);
        // Already diagonal (all reflectors trivial).
        let dg = Mat::from_fn(5, 5, |i, j| c64::new(if i == j { (i * i) as f64 } else { 0.0 }, 0.0));
        check(&dg, 5);
    }
}
