//! Lyapunov equations, continuous `A·X + X·Aᵀ + Q = 0` and discrete `A·X·Aᵀ − X + Q = 0`, by
//! Bartels–Stewart on the real Schur form of A, and in Cholesky-factor form (X = U·Uᵀ with U upper
//! triangular) by Hammarling's method, which never forms B·Bᵀ and so keeps the factor accurate
//! (S. J. Hammarling, "Numerical solution of the stable, non-negative definite Lyapunov equation",
//! IMA J. Numer. Anal. 2, 1982; the same convention as SLICOT SB03OD with TRANS = 'T').

// Index loops mirror the published block algorithms (dtrsyl, Hammarling) and read better here.
#![allow(clippy::needless_range_loop)]

use crate::dense::product_using_triangles;
use crate::error::{LinalgError, Result};
use crate::schur::{real_schur, Schur};
use crate::sylvester::{
    blocks, check_finite, check_square, pivot_floor, solve_quasi_triangular, solve_quasi_triangular_prepared, Kind,
};
use faer::{Mat, MatRef};

/// Solves the continuous Lyapunov equation A·X + X·Aᵀ + Q = 0 (X symmetric when Q is).
///
/// Needs λᵢ(A) + λⱼ(A) ≠ 0 for all i, j (A need not be stable); `NoSolution` otherwise.
pub fn lyap(a: MatRef<f64>, q: MatRef<f64>) -> Result<Mat<f64>> {
    lyap_general(a, q, Kind::Continuous)
}

/// Solves the discrete Lyapunov (Stein) equation A·X·Aᵀ − X + Q = 0 (X symmetric when Q is).
///
/// Needs λᵢ(A)·λⱼ(A) ≠ 1 for all i, j; `NoSolution` otherwise.
pub fn dlyap(a: MatRef<f64>, q: MatRef<f64>) -> Result<Mat<f64>> {
    lyap_general(a, q, Kind::Discrete)
}

/// Returns upper-triangular U (non-negative diagonal) with A·(U·Uᵀ) + (U·Uᵀ)·Aᵀ + B·Bᵀ = 0.
///
/// A must be stable (all eigenvalues in the open left half-plane); B is n×m with any m.
pub fn lyap_chol(a: MatRef<f64>, b: MatRef<f64>) -> Result<Mat<f64>> {
    check_factor_args(a, b)?;
    let s = real_schur(a)?;
    lyap_chol_schur(&s, b, Kind::Continuous)
}

/// Returns upper-triangular U (non-negative diagonal) with A·(U·Uᵀ)·Aᵀ − U·Uᵀ + B·Bᵀ = 0.
///
/// A must be Schur stable (all eigenvalues strictly inside the unit circle).
pub fn dlyap_chol(a: MatRef<f64>, b: MatRef<f64>) -> Result<Mat<f64>> {
    check_factor_args(a, b)?;
    let s = real_schur(a)?;
    lyap_chol_schur(&s, b, Kind::Discrete)
}

/// Hammarling's method when the real Schur form A = Q·T·Qᵀ is already known (the gramians of a
/// model share one Schur form of A between the controllability and observability factors through
/// [`lyap_chol_schur_t`]). `kind` selects continuous or discrete time.
pub fn lyap_chol_schur(s: &Schur, b: MatRef<f64>, kind: Kind) -> Result<Mat<f64>> {
    let n = s.t.nrows();
    if b.nrows() != n {
        return Err(LinalgError::Dimension(format!(
            "B must have {n} rows, got {}",
            b.nrows()
        )));
    }
    check_stable(s.t.as_ref(), kind)?;
    let bt = s.q.transpose() * b;
    let u = hammarling(s.t.as_ref(), bt.as_ref(), kind)?;
    Ok(upper_factor(product_using_triangles(s.q.as_ref(), u.as_ref()).as_ref()))
}

/// Hammarling's method for the transposed equation with the same Schur form: returns upper U with
/// Aᵀ·(U·Uᵀ) + (U·Uᵀ)·A + Cᵀ·C = 0 (continuous) or Aᵀ·(U·Uᵀ)·A − U·Uᵀ + Cᵀ·C = 0 (discrete),
/// where C is p×n. Aᵀ = (Q·J)·(J·Tᵀ·J)·(Q·J)ᵀ with the reversal J is again a real Schur form.
pub fn lyap_chol_schur_t(s: &Schur, c: MatRef<f64>, kind: Kind) -> Result<Mat<f64>> {
    let n = s.t.nrows();
    if c.ncols() != n {
        return Err(LinalgError::Dimension(format!(
            "C must have {n} columns, got {}",
            c.ncols()
        )));
    }
    check_stable(s.t.as_ref(), kind)?;
    let tr = reversed_transpose(s.t.as_ref());
    let qr = Mat::from_fn(n, n, |i, j| s.q[(i, n - 1 - j)]);
    let ct = qr.transpose() * c.transpose();
    let u = hammarling(tr.as_ref(), ct.as_ref(), kind)?;
    Ok(upper_factor(product_using_triangles(qr.as_ref(), u.as_ref()).as_ref()))
}

fn check_factor_args(a: MatRef<f64>, b: MatRef<f64>) -> Result<()> {
    check_square(a, "A")?;
    if b.nrows() != a.nrows() {
        return Err(LinalgError::Dimension(format!(
            "B must have {} rows like A, got {}",
            a.nrows(),
            b.nrows()
        )));
    }
    check_finite(a, "A")?;
    check_finite(b, "B")
}

fn lyap_general(a: MatRef<f64>, q: MatRef<f64>, kind: Kind) -> Result<Mat<f64>> {
    check_square(a, "A")?;
    let n = a.nrows();
    if q.nrows() != n || q.ncols() != n {
        return Err(LinalgError::Dimension(format!(
            "Q must be {n}x{n} like A, got {}x{}",
            q.nrows(),
            q.ncols()
        )));
    }
    check_finite(a, "A")?;
    check_finite(q, "Q")?;
    let s = real_schur(a)?;
    // In Schur coordinates T·Y + Y·Tᵀ = −F (or T·Y·Tᵀ − Y = −F), F = Qᵀ·Q·Q. Tᵀ is lower
    // quasi-triangular; reversing its order (J·Tᵀ·J) makes it upper, so Z = Y·J solves
    // T·Z + Z·(J·Tᵀ·J) = −F·J with the upper/upper kernel.
    let f = s.q.transpose() * q * &s.q;
    let rhs = Mat::from_fn(n, n, |i, j| -f[(i, n - 1 - j)]);
    let tb = reversed_transpose(s.t.as_ref());
    let z = solve_quasi_triangular(s.t.as_ref(), tb.as_ref(), rhs.as_ref(), kind)?;
    let y = Mat::from_fn(n, n, |i, j| z[(i, n - 1 - j)]);
    let mut x = &s.q * &y * s.q.transpose();
    if is_symmetric(q) {
        for j in 0..n {
            for i in 0..j {
                let v = 0.5 * (x[(i, j)] + x[(j, i)]);
                x[(i, j)] = v;
                x[(j, i)] = v;
            }
        }
    }
    Ok(x)
}

fn is_symmetric(q: MatRef<f64>) -> bool {
    (0..q.ncols()).all(|j| (0..j).all(|i| q[(i, j)] == q[(j, i)]))
}

/// J·Tᵀ·J: the transpose with both index orders reversed; upper quasi-triangular when T is.
pub(crate) fn reversed_transpose(t: MatRef<f64>) -> Mat<f64> {
    let n = t.nrows();
    Mat::from_fn(n, n, |i, j| t[(n - 1 - j, n - 1 - i)])
}

/// Eigenvalues of the diagonal blocks of a quasi-triangular T as (re, im) pairs.
fn block_eigs(t: MatRef<f64>, k0: usize, p: usize) -> [(f64, f64); 2] {
    if p == 1 {
        let v = t[(k0, k0)];
        return [(v, 0.0), (v, 0.0)];
    }
    let (a, b, c, d) = (t[(k0, k0)], t[(k0, k0 + 1)], t[(k0 + 1, k0)], t[(k0 + 1, k0 + 1)]);
    let half_tr = 0.5 * (a + d);
    let disc = 0.25 * (a - d) * (a - d) + b * c;
    if disc >= 0.0 {
        let r = disc.sqrt();
        [(half_tr + r, 0.0), (half_tr - r, 0.0)]
    } else {
        let r = (-disc).sqrt();
        [(half_tr, r), (half_tr, -r)]
    }
}

fn check_stable(t: MatRef<f64>, kind: Kind) -> Result<()> {
    for (k0, p) in blocks(t) {
        for (re, im) in block_eigs(t, k0, p) {
            let ok = match kind {
                Kind::Continuous => re < 0.0,
                Kind::Discrete => re.hypot(im) < 1.0,
            };
            if !ok {
                return Err(LinalgError::NoSolution(match kind {
                    Kind::Continuous => format!("A is not stable: eigenvalue {re}{im:+}i has real part >= 0"),
                    Kind::Discrete => format!("A is not Schur stable: eigenvalue {re}{im:+}i has modulus >= 1"),
                }));
            }
        }
    }
    Ok(())
}

/// Upper-triangular Û with non-negative diagonal and Û·Ûᵀ = M·Mᵀ (M n×k), from the QR
/// factorization of (J·M)ᵀ with the row reversal J: (J·M)ᵀ = Q·R gives M·Mᵀ = (J·Rᵀ·J)(J·Rᵀ·J)ᵀ.
pub fn upper_factor(m: MatRef<f64>) -> Mat<f64> {
    let (n, k) = (m.nrows(), m.ncols());
    let mut u = Mat::<f64>::zeros(n, n);
    if n == 0 || k == 0 {
        return u;
    }
    let w = Mat::from_fn(k, n, |i, j| m[(n - 1 - j, i)]);
    let qr = w.qr();
    let r = qr.thin_R();
    let rr = r.nrows();
    for c in 0..rr {
        let col = c + n - rr;
        for i in 0..=col {
            u[(i, col)] = r[(rr - 1 - c, n - 1 - i)];
        }
    }
    for j in 0..n {
        if u[(j, j)] < 0.0 {
            for i in 0..=j {
                u[(i, j)] = -u[(i, j)];
            }
        }
    }
    u
}

/// Hammarling's recursion on the Schur form: T upper quasi-triangular and stable, B n×m.
/// Returns U with T·UUᵀ + UUᵀ·Tᵀ + B·Bᵀ = 0 (or the discrete analogue); U is upper triangular up
/// to the row swaps of split double eigenvalues, and callers re-triangularize Q·U anyway.
///
/// Partition T = [T1 t; 0 S], U = [U1 u; 0 V], G = [G1 g; 0 Γ] (G upper, G·Gᵀ = B·Bᵀ) on the last
/// diagonal block. Then V solves the small equation S·VVᵀ + VVᵀ·Sᵀ + ΓΓᵀ = 0, and with
/// K1 = V⁻¹SV, K2 = V⁻¹Γ, u solves T1·u + u·K1ᵀ = −(t·V + g·K2ᵀ) (discrete:
/// T1·u·K1ᵀ − u = −(t·V·K1ᵀ + g·K2ᵀ)), and the leading problem keeps the form with G1·G1ᵀ + y·yᵀ,
/// y = g − u·K2 (discrete: y = [T1·u + t·V, g]·K⊥ᵀ, K⊥ the orthonormal complement of [K1 K2]).
fn hammarling(t: MatRef<f64>, b: MatRef<f64>, kind: Kind) -> Result<Mat<f64>> {
    let n = t.nrows();
    // A 2×2 block [a b; c d] with complex eigenvalues whose imaginary part is below a few ε·‖block‖
    // is a split double real eigenvalue (repeated poles). Its 2×2 factor would come from an X22 that
    // is singular to working precision, losing half the digits. Zeroing the smaller of b and c
    // (a change ≤ |Im λ|, a backward error of the order of the Schur form's own) gives a real
    // double eigenvalue handled by two accurate 1×1 steps; when b is the smaller, the two states
    // are swapped so that the block stays upper triangular, and U's rows are swapped back at the end.
    let mut tt = t.to_owned();
    let mut bb = b.to_owned();
    let mut swapped = Vec::new();
    for (k0, p) in blocks(t) {
        if p != 2 {
            continue;
        }
        let im = block_eigs(t, k0, 2)[0].1.abs();
        let (bq, c) = (t[(k0, k0 + 1)], t[(k0 + 1, k0)]);
        let size = t[(k0, k0)].abs() + bq.abs() + c.abs() + t[(k0 + 1, k0 + 1)].abs();
        if im == 0.0 || im > 64.0 * f64::EPSILON * size {
            continue;
        }
        if c.abs() <= bq.abs() {
            tt[(k0 + 1, k0)] = 0.0;
        } else {
            tt[(k0, k0 + 1)] = 0.0;
            for j in 0..n {
                let v = tt[(k0, j)];
                tt[(k0, j)] = tt[(k0 + 1, j)];
                tt[(k0 + 1, j)] = v;
            }
            for i in 0..n {
                let v = tt[(i, k0)];
                tt[(i, k0)] = tt[(i, k0 + 1)];
                tt[(i, k0 + 1)] = v;
            }
            for j in 0..bb.ncols() {
                let v = bb[(k0, j)];
                bb[(k0, j)] = bb[(k0 + 1, j)];
                bb[(k0 + 1, j)] = v;
            }
            swapped.push(k0);
        }
    }
    let t = tt.as_ref();
    let b = bb.as_ref();
    let mut g = upper_factor(b);
    // A trailing Γ below 1e-100·max|G| contributes nothing at working precision, but its square
    // underflows and the 2×2 factor's inverse then overflows to inf/NaN (seen at n = 1000 with
    // two inputs, where the factor decays geometrically). Such a block is treated as unexcited.
    let floor = 1e-100
        * (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max(g[(i, j)].abs()));
    let mut u = Mat::<f64>::zeros(n, n);
    let bl = blocks(t);
    // lead_max[k] = max |T[..k, ..k]|: the leading part's largest entry, for the pivot floor of
    // each step's solve (the same floor a scan of T1 would give: the entry T[k, k−1] below a
    // block boundary k is zero).
    let mut lead_max = vec![0.0f64; n + 1];
    for j in 0..n {
        let col = (0..(j + 2).min(n)).fold(0.0f64, |m, i| m.max(t[(i, j)].abs()));
        lead_max[j + 1] = lead_max[j].max(col);
    }
    for (bi, &(k0, s)) in bl.iter().enumerate().rev() {
        // The loop is scalar code between faer calls (see `clear_upper_simd`).
        crate::dense::clear_upper_simd();
        let mut sm = [[0.0; 2]; 2];
        let mut gam = [[0.0; 2]; 2];
        for i in 0..s {
            for j in 0..s {
                sm[i][j] = t[(k0 + i, k0 + j)];
                gam[i][j] = g[(k0 + i, k0 + j)];
            }
        }
        let Some(fac) = small_factor(&sm, &gam, s, kind, floor) else {
            // Γ = 0: this block carries no excitation, so P12 = 0 and P22 = 0; with u = 0 the
            // leading problem keeps G1·G1ᵀ + g·gᵀ.
            let y = Mat::from_fn(k0, s, |i, j| g[(i, k0 + j)]);
            retriangularize(&mut g, k0, y);
            continue;
        };
        let SmallFactor { v, k1, k2, kperp } = fac;
        for i in 0..s {
            for j in i..s {
                u[(k0 + i, k0 + j)] = v[i][j];
            }
        }
        if k0 == 0 {
            break;
        }
        let t1 = t.get(..k0, ..k0);
        // rhs = −(t·V + g·K2ᵀ), with t·V·K1ᵀ in place of t·V in discrete time.
        let tv = Mat::from_fn(k0, s, |i, j| (0..s).map(|q| t[(i, k0 + q)] * v[q][j]).sum::<f64>());
        let tv_eff = match kind {
            Kind::Continuous => tv.clone(),
            Kind::Discrete => Mat::from_fn(k0, s, |i, j| (0..s).map(|q| tv[(i, q)] * k1[j][q]).sum::<f64>()),
        };
        let rhs = Mat::from_fn(k0, s, |i, j| {
            -(tv_eff[(i, j)] + (0..s).map(|q| g[(i, k0 + q)] * k2[j][q]).sum::<f64>())
        });
        let k1t = Mat::from_fn(s, s, |i, j| k1[j][i]);
        let k1max = k1.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let smin = pivot_floor(lead_max[k0].max(k1max));
        let uu = solve_quasi_triangular_prepared(t1, k1t.as_ref(), rhs.as_ref(), kind, &bl[..bi], smin)?;
        for i in 0..k0 {
            for j in 0..s {
                u[(i, k0 + j)] = uu[(i, j)];
            }
        }
        let y = match kind {
            Kind::Continuous => Mat::from_fn(k0, s, |i, j| {
                g[(i, k0 + j)] - (0..s).map(|q| uu[(i, q)] * k2[q][j]).sum::<f64>()
            }),
            Kind::Discrete => {
                let z = t1 * &uu + &tv;
                Mat::from_fn(k0, s, |i, j| {
                    (0..s)
                        .map(|q| z[(i, q)] * kperp[j][q] + g[(i, k0 + q)] * kperp[j][s + q])
                        .sum::<f64>()
                })
            }
        };
        retriangularize(&mut g, k0, y);
    }
    for &k0 in &swapped {
        for j in 0..n {
            let v = u[(k0, j)];
            u[(k0, j)] = u[(k0 + 1, j)];
            u[(k0 + 1, j)] = v;
        }
    }
    Ok(u)
}

struct SmallFactor {
    v: [[f64; 2]; 2],
    k1: [[f64; 2]; 2],
    k2: [[f64; 2]; 2],
    /// Rows of the orthonormal complement of [K1 K2] (discrete time only), s × 2s.
    kperp: [[f64; 4]; 2],
}

/// Factor V of the s×s equation and the derived K1 = V⁻¹SV, K2 = V⁻¹Γ; `None` when Γ = 0.
fn small_factor(sm: &[[f64; 2]; 2], gam: &[[f64; 2]; 2], s: usize, kind: Kind, floor: f64) -> Option<SmallFactor> {
    let gnorm = gam.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if gnorm <= floor {
        return None;
    }
    let mut out = SmallFactor {
        v: [[0.0; 2]; 2],
        k1: [[0.0; 2]; 2],
        k2: [[0.0; 2]; 2],
        kperp: [[0.0; 4]; 2],
    };
    if s == 1 {
        let tau = sm[0][0];
        let gamma = gam[0][0];
        // Closed forms of the scalar equations 2τν² + γ² = 0 and τ²ν² − ν² + γ² = 0.
        let root = match kind {
            Kind::Continuous => (-2.0 * tau).sqrt(),
            Kind::Discrete => ((1.0 - tau) * (1.0 + tau)).sqrt(),
        };
        out.v[0][0] = gamma.abs() / root;
        out.k1[0][0] = tau;
        out.k2[0][0] = gamma.signum() * root;
        out.kperp[0] = [-out.k2[0][0], out.k1[0][0], 0.0, 0.0];
        return Some(out);
    }
    // 2×2 block: X22 from the 3 unknowns of the symmetric small equation, then V = upper factor.
    let mut ggt = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            ggt[i][j] = -(0..2).map(|q| gam[i][q] * gam[j][q]).sum::<f64>();
        }
    }
    let x = small_lyap2(sm, &ggt, kind)?;
    if x[1][1].is_nan() || x[1][1] <= 0.0 {
        return None;
    }
    let v22 = x[1][1].sqrt();
    let v12 = x[0][1] / v22;
    let d = x[0][0] - v12 * v12;
    let v11 = if d > 0.0 { d.sqrt() } else { f64::EPSILON * v22 };
    out.v = [[v11, v12], [0.0, v22]];
    // V⁻¹ for upper triangular V.
    let vi = [[1.0 / v11, -v12 / (v11 * v22)], [0.0, 1.0 / v22]];
    let mul = |a: &[[f64; 2]; 2], b: &[[f64; 2]; 2]| {
        let mut c = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
            }
        }
        c
    };
    out.k1 = mul(&mul(&vi, sm), &out.v);
    out.k2 = mul(&vi, gam);
    if kind == Kind::Discrete {
        out.kperp = complement(&out.k1, &out.k2);
    }
    Some(out)
}

/// Solves the 2×2 symmetric equation S·X + X·Sᵀ = R or S·X·Sᵀ − X = R (R symmetric).
fn small_lyap2(sm: &[[f64; 2]; 2], r: &[[f64; 2]; 2], kind: Kind) -> Option<[[f64; 2]; 2]> {
    // Unknowns (x11, x12, x22); rows are the (1,1), (1,2), (2,2) entries of the equation.
    let (a, b, c, d) = (sm[0][0], sm[0][1], sm[1][0], sm[1][1]);
    let m = match kind {
        Kind::Continuous => [[2.0 * a, 2.0 * b, 0.0], [c, a + d, b], [0.0, 2.0 * c, 2.0 * d]],
        Kind::Discrete => [
            [a * a - 1.0, 2.0 * a * b, b * b],
            [a * c, a * d + b * c - 1.0, b * d],
            [c * c, 2.0 * c * d, d * d - 1.0],
        ],
    };
    let rhs = [r[0][0], r[0][1], r[1][1]];
    let sol = solve3(m, rhs)?;
    Some([[sol[0], sol[1]], [sol[1], sol[2]]])
}

/// Gaussian elimination with partial pivoting on a 3×3 system.
fn solve3(mut m: [[f64; 3]; 3], mut r: [f64; 3]) -> Option<[f64; 3]> {
    for s in 0..3 {
        let p = (s..3).max_by(|&i, &j| m[i][s].abs().total_cmp(&m[j][s].abs()))?;
        m.swap(s, p);
        r.swap(s, p);
        if m[s][s] == 0.0 {
            return None;
        }
        for i in s + 1..3 {
            let f = m[i][s] / m[s][s];
            for j in s..3 {
                m[i][j] -= f * m[s][j];
            }
            r[i] -= f * r[s];
        }
    }
    let mut x = [0.0; 3];
    for s in (0..3).rev() {
        let v = r[s] - (s + 1..3).map(|j| m[s][j] * x[j]).sum::<f64>();
        x[s] = v / m[s][s];
    }
    Some(x)
}

/// Two orthonormal rows spanning the complement of the (orthonormal) rows of [K1 K2] in R⁴,
/// by Gram–Schmidt on the unit vectors, taking the two with the largest residuals.
fn complement(k1: &[[f64; 2]; 2], k2: &[[f64; 2]; 2]) -> [[f64; 4]; 2] {
    let mut basis: Vec<[f64; 4]> = (0..2).map(|i| [k1[i][0], k1[i][1], k2[i][0], k2[i][1]]).collect();
    // Re-orthonormalize the given rows (they are orthonormal only up to rounding).
    for i in 0..2 {
        for j in 0..i {
            let d: f64 = (0..4).map(|q| basis[i][q] * basis[j][q]).sum();
            for q in 0..4 {
                basis[i][q] -= d * basis[j][q];
            }
        }
        let nrm = basis[i].iter().map(|v| v * v).sum::<f64>().sqrt();
        for q in 0..4 {
            basis[i][q] /= nrm;
        }
    }
    let mut out = [[0.0; 4]; 2];
    for slot in 0..2 {
        let mut best = ([0.0; 4], -1.0);
        for e in 0..4 {
            let mut v = [0.0; 4];
            v[e] = 1.0;
            for _ in 0..2 {
                for bvec in basis.iter() {
                    let d: f64 = (0..4).map(|q| v[q] * bvec[q]).sum();
                    for q in 0..4 {
                        v[q] -= d * bvec[q];
                    }
                }
            }
            let nrm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            if nrm > best.1 {
                best = (v, nrm);
            }
        }
        let mut v = best.0;
        for x in v.iter_mut() {
            *x /= best.1;
        }
        out[slot] = v;
        basis.push(v);
    }
    out
}

/// Replaces the leading k0×k0 block of G by an upper-triangular Ĝ with Ĝ·Ĝᵀ = G1·G1ᵀ + y·yᵀ,
/// rotating each column of y into G1 with Givens rotations from the bottom row up.
fn retriangularize(g: &mut Mat<f64>, k0: usize, mut y: Mat<f64>) {
    for c in 0..y.ncols() {
        for i in (0..k0).rev() {
            let (a, b) = (g[(i, i)], y[(i, c)]);
            if b == 0.0 {
                continue;
            }
            let r = a.hypot(b);
            let (cs, sn) = (a / r, b / r);
            for row in 0..=i {
                let (gi, yi) = (g[(row, i)], y[(row, c)]);
                g[(row, i)] = cs * gi + sn * yi;
                y[(row, c)] = -sn * gi + cs * yi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sylvester::tests::quasi_tri;
    use rand::{rngs::StdRng, Rng, SeedableRng};

    fn schur_identity(t: Mat<f64>) -> Schur {
        let n = t.nrows();
        Schur {
            t,
            q: Mat::identity(n, n),
        }
    }

    fn is_upper(u: &Mat<f64>) -> bool {
        (0..u.ncols()).all(|j| (j + 1..u.nrows()).all(|i| u[(i, j)] == 0.0))
    }

    #[test]
    fn hammarling_continuous_on_schur_form() {
        let mut rng = StdRng::seed_from_u64(3);
        for (m, pairs) in [(1usize, vec![0usize, 3, 7]), (3, vec![2, 5]), (12, vec![])] {
            let t = quasi_tri(10, &pairs, -2.5, &mut rng);
            let b = Mat::from_fn(10, m, |_, _| rng.gen_range(-1.0..1.0));
            let u = lyap_chol_schur(&schur_identity(t.clone()), b.as_ref(), Kind::Continuous).unwrap();
            assert!(is_upper(&u));
            let p = &u * u.transpose();
            let bbt = &b * b.transpose();
            let res = &t * &p + &p * t.transpose() + &bbt;
            let scale = 2.0 * t.norm_l2() * p.norm_l2() + bbt.norm_l2();
            assert!(
                res.norm_l2() <= 1e-13 * scale,
                "m={m}: residual {}",
                res.norm_l2() / scale
            );
        }
    }

    #[test]
    fn hammarling_discrete_on_schur_form() {
        let mut rng = StdRng::seed_from_u64(4);
        for (m, pairs) in [(1usize, vec![0usize, 3, 7]), (2, vec![1, 5]), (11, vec![])] {
            let mut t = quasi_tri(10, &pairs, 0.0, &mut rng);
            // Shrink so the spectral radius is below 1 (entries of [a b; c a] up to 2 in size).
            for j in 0..10 {
                for i in 0..10 {
                    t[(i, j)] *= 0.3;
                }
            }
            let b = Mat::from_fn(10, m, |_, _| rng.gen_range(-1.0..1.0));
            let u = lyap_chol_schur(&schur_identity(t.clone()), b.as_ref(), Kind::Discrete).unwrap();
            assert!(is_upper(&u));
            let p = &u * u.transpose();
            let bbt = &b * b.transpose();
            let res = &t * &p * t.transpose() - &p + &bbt;
            let scale = t.norm_l2() * t.norm_l2() * p.norm_l2() + p.norm_l2() + bbt.norm_l2();
            assert!(
                res.norm_l2() <= 1e-13 * scale,
                "m={m}: residual {}",
                res.norm_l2() / scale
            );
        }
    }

    #[test]
    fn hammarling_transposed_equation() {
        let mut rng = StdRng::seed_from_u64(5);
        let t = quasi_tri(7, &[1, 4], -1.5, &mut rng);
        let c = Mat::from_fn(2, 7, |_, _| rng.gen_range(-1.0..1.0));
        let u = lyap_chol_schur_t(&schur_identity(t.clone()), c.as_ref(), Kind::Continuous).unwrap();
        let p = &u * u.transpose();
        let ctc = c.transpose() * &c;
        let res = t.transpose() * &p + &p * &t + &ctc;
        let scale = 2.0 * t.norm_l2() * p.norm_l2() + ctc.norm_l2();
        assert!(res.norm_l2() <= 1e-13 * scale, "residual {}", res.norm_l2() / scale);
    }

    #[test]
    fn unstable_factor_equation_is_an_error() {
        let t = Mat::from_fn(2, 2, |i, j| {
            if i == j {
                0.5 - i as f64
            } else {
                1.0 * (j > i) as u8 as f64
            }
        });
        let b = Mat::from_fn(2, 1, |_, _| 1.0);
        let e = lyap_chol_schur(&schur_identity(t), b.as_ref(), Kind::Continuous);
        assert!(matches!(e, Err(LinalgError::NoSolution(_))));
    }
}
