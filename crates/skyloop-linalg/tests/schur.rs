//! Real Schur decomposition, reordering and balancing against numpy/scipy fixtures
//! (`tools/gen_schur.py` → `tests/fixtures/schur/cases.json`).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use faer::{c64, Mat, MatRef};
use serde_json::Value;
use skyloop_linalg::balance::balance;
use skyloop_linalg::schur::{eigenvalues, eigenvalues_unbalanced, real_schur, reorder_schur, Schur};
use skyloop_linalg::LinalgError;

fn mat(v: &Value) -> Mat<f64> {
    let rows = v.as_array().expect("rows");
    let n = rows.len();
    let m = rows.first().map(|r| r.as_array().expect("row").len()).unwrap_or(0);
    Mat::from_fn(n, m, |i, j| rows[i][j].as_f64().expect("number"))
}

/// The numpy eigenvalues a fixture case holds (`eig_re`, `eig_im`).
fn numpy_eigenvalues(case: &Value) -> Vec<c64> {
    case["eig_re"]
        .as_array()
        .expect("re")
        .iter()
        .zip(case["eig_im"].as_array().expect("im"))
        .map(|(r, i)| c64::new(r.as_f64().expect("re"), i.as_f64().expect("im")))
        .collect()
}

fn fixtures() -> Vec<Value> {
    skyloop_fixtures::cases(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/schur/cases.json")
}

fn fro(a: MatRef<f64>) -> f64 {
    a.norm_l2()
}

/// Checks ‖A − QTQᵀ‖/‖A‖, ‖QᵀQ − I‖, quasi-triangularity and standardized 2×2 blocks.
fn check_schur(a: MatRef<f64>, s: &Schur, tol: f64) {
    let n = a.nrows();
    let recon = &s.q * &s.t * s.q.transpose();
    let err = fro((&recon - a).as_ref()) / fro(a).max(1e-300);
    assert!(err < tol, "‖A − QTQᵀ‖/‖A‖ = {err:e}");
    let orth = fro((s.q.transpose() * &s.q - Mat::<f64>::identity(n, n)).as_ref());
    assert!(orth < tol, "‖QᵀQ − I‖ = {orth:e}");
    let mut k = 0;
    while k < n {
        for i in k + 2..n {
            assert_eq!(s.t[(i, k)], 0.0, "T not quasi-triangular at ({i},{k})");
        }
        if k + 1 < n && s.t[(k + 1, k)] != 0.0 {
            assert_eq!(s.t[(k, k)], s.t[(k + 1, k + 1)], "2×2 block not standardized");
            assert!(
                s.t[(k, k + 1)] * s.t[(k + 1, k)] < 0.0,
                "2×2 block with real eigenvalues"
            );
            if k + 2 < n {
                assert_eq!(s.t[(k + 2, k + 1)], 0.0, "adjacent 2×2 blocks overlap");
            }
            k += 2;
        } else {
            k += 1;
        }
    }
}

/// Matches two eigenvalue lists (greedy nearest), returns the largest distance relative to scale.
fn eig_distance(ours: &[c64], reference: &[c64]) -> f64 {
    assert_eq!(ours.len(), reference.len());
    let scale = reference.iter().map(|z| z.norm()).fold(1.0, f64::max);
    let mut used = vec![false; reference.len()];
    let mut worst = 0.0f64;
    for z in ours {
        let (best, d) = reference
            .iter()
            .enumerate()
            .filter(|(i, _)| !used[*i])
            .map(|(i, r)| (i, (z - r).norm()))
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .expect("unmatched");
        used[best] = true;
        worst = worst.max(d / scale);
    }
    worst
}

#[test]
fn schur_matches_numpy_eigenvalues() {
    for case in fixtures() {
        let name = case["name"].as_str().unwrap_or("?");
        let a = mat(&case["a"]);
        let s = real_schur(a.as_ref()).unwrap_or_else(|e| panic!("{name}: {e}"));
        check_schur(a.as_ref(), &s, 1e-13 * (a.nrows() as f64).max(1.0));
        let reference = numpy_eigenvalues(&case);
        // Without balancing a badly scaled matrix has ill-conditioned eigenvalues: the Schur form is
        // still backward stable (checked above) but eigenvalues are compared after balancing.
        let d = eig_distance(&eigenvalues(a.as_ref()).expect("eigenvalues"), &reference);
        if name != "badly_scaled_10" {
            assert!(
                eig_distance(&s.eigenvalues(), &reference) < 1e3 * d.max(1e-14),
                "{name}"
            );
        }
        // Defective eigenvalues (Jordan block, companion with clustered roots) are only determined
        // to ~eps^(1/k); both we and LAPACK make backward-stable errors of that size.
        let tol = match name {
            "jordan_4" => 1e-3,
            "companion_roots_1_to_8" => 1e-7,
            _ => 1e-11,
        };
        assert!(d < tol, "{name}: eigenvalues differ from numpy by {d:e}");
    }
}

#[test]
fn balancing_matches_scipy() {
    for case in fixtures() {
        let name = case["name"].as_str().unwrap_or("?");
        let a = mat(&case["a"]);
        let reference = mat(&case["balanced"]);
        let b = balance(a.as_ref());
        // Balancing is a similarity by a permuted power-of-2 diagonal: undoing it is exact.
        assert_eq!(b.unbalance(b.a.as_ref()), a, "{name}");
        // Same 1-norm reduction as LAPACK dgebal (the permutation order may differ).
        let ours = fro(b.a.as_ref());
        let theirs = fro(reference.as_ref());
        assert!(
            ours <= 1.5 * theirs + 1e-300,
            "{name}: ‖B‖ = {ours:e}, scipy {theirs:e}"
        );
    }
}

fn random_matrix(n: usize, seed: u64) -> Mat<f64> {
    // Deterministic LCG so the test needs no fixture; values uniform in [-1, 1).
    let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    Mat::from_fn(n, n, |_, _| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    })
}

fn check_reordered(a: MatRef<f64>, s: &Schur, k: usize, select: impl Fn(c64) -> bool) {
    check_schur(a, s, 1e-12);
    let eigs = s.eigenvalues();
    for (i, z) in eigs.iter().enumerate() {
        assert_eq!(select(*z), i < k, "eigenvalue {z} at position {i}, leading block {k}");
    }
}

#[test]
fn reorder_left_half_plane_and_disc() {
    for (n, seed) in [(6usize, 1u64), (15, 2), (30, 3), (64, 4)] {
        let a = random_matrix(n, seed);
        let before = real_schur(a.as_ref()).expect("schur");
        let count = before.eigenvalues().iter().filter(|z| z.re < 0.0).count();
        let mut s = before.clone();
        let k = reorder_schur(&mut s, |z| z.re < 0.0).expect("reorder");
        assert_eq!(k, count);
        check_reordered(a.as_ref(), &s, k, |z| z.re < 0.0);
        // Eigenvalues are preserved by the swaps.
        assert!(eig_distance(&s.eigenvalues(), &before.eigenvalues()) < 1e-13);

        let mut s = before.clone();
        let k = reorder_schur(&mut s, |z| z.norm() < 0.8).expect("reorder disc");
        check_reordered(a.as_ref(), &s, k, |z| z.norm() < 0.8);
    }
}

#[test]
fn reorder_clustered_eigenvalues() {
    // Q·diag-blocks·Qᵀ with eigenvalues clustered within 1e-6 of each other and complex pairs
    // of nearly equal modulus: all swaps must still succeed and be accurate.
    let n = 12;
    let mut d = Mat::<f64>::zeros(n, n);
    let vals = [1.0, 1.0 + 1e-6, 1.0 - 1e-6, -1.0, -1.0 + 1e-7, 2.0];
    for (i, v) in vals.iter().enumerate() {
        d[(i, i)] = *v;
    }
    for (p, (re, im)) in [(6usize, (-1.0, 1.0)), (8, (-1.0, 1.0 + 1e-6)), (10, (1.0, 1e-3))] {
        d[(p, p)] = re;
        d[(p + 1, p + 1)] = re;
        d[(p, p + 1)] = im;
        d[(p + 1, p)] = -im;
    }
    for i in 0..n {
        for j in i + 1..n {
            if !(j == i + 1 && d[(j, i)] != 0.0) {
                d[(i, j)] += 0.3 * ((i * 7 + j * 3) % 5) as f64;
            }
        }
    }
    let q = real_schur(random_matrix(n, 9).as_ref()).expect("orthogonal factor").q;
    let a = &q * &d * q.transpose();
    let mut s = real_schur(a.as_ref()).expect("schur");
    let k = reorder_schur(&mut s, |z| z.re < 0.0).expect("reorder");
    // From the construction: eigenvalues -1, -1+1e-7 and the two pairs at re = -1.
    assert_eq!(k, 6);
    check_reordered(a.as_ref(), &s, k, |z| z.re < 0.0);
    let mut s2 = s.clone();
    let k2 = reorder_schur(&mut s2, |z| z.re > 0.0).expect("reorder back");
    assert_eq!(k2, n - 6);
    check_reordered(a.as_ref(), &s2, k2, |z| z.re > 0.0);
}

#[test]
fn reorder_ill_conditioned_swap_is_accurate_or_rejected() {
    // A nearly defective pair 1 ± 1e-8i next to the real eigenvalue 1 with coupling 1e8: the
    // swap's Sylvester equation is ill-conditioned. dlaexc's test either accepts an accurate
    // swap or rejects it with an error; never a silently wrong Schur form.
    let mut t = Mat::<f64>::zeros(3, 3);
    t[(0, 0)] = 1.0;
    t[(0, 1)] = 1e8;
    t[(0, 2)] = 1e8;
    t[(1, 1)] = 1.0;
    t[(2, 2)] = 1.0;
    t[(1, 2)] = 1e-8;
    t[(2, 1)] = -1e-8;
    let mut s = Schur {
        t: t.clone(),
        q: Mat::identity(3, 3),
    };
    match reorder_schur(&mut s, |z| z.im != 0.0) {
        Err(LinalgError::NoSolution(msg)) => assert!(msg.contains("lose accuracy"), "{msg}"),
        Ok(k) => {
            // If accepted, the result must be accurate.
            check_reordered(t.as_ref(), &s, k, |z| z.im != 0.0);
        }
        Err(e) => panic!("unexpected error {e}"),
    }
    // Whatever happened, s is still a Schur form of the same matrix.
    check_schur(t.as_ref(), &s, 1e-12);
}

#[test]
fn bad_input_is_an_error() {
    assert!(matches!(
        real_schur(Mat::<f64>::zeros(2, 3).as_ref()),
        Err(LinalgError::Dimension(_))
    ));
    let mut a = Mat::<f64>::identity(3, 3);
    a[(1, 2)] = f64::INFINITY;
    assert!(matches!(real_schur(a.as_ref()), Err(LinalgError::InvalidArgument(_))));
    let s = real_schur(Mat::<f64>::zeros(0, 0).as_ref()).expect("empty");
    assert!(s.eigenvalues().is_empty());
    let mut bad = Schur {
        t: Mat::zeros(2, 2),
        q: Mat::zeros(3, 3),
    };
    assert!(matches!(
        reorder_schur(&mut bad, |_| true),
        Err(LinalgError::Dimension(_))
    ));
}

/// `D·R·D` with `D = diag(10^(−decades·i/n))`: entries graded over `2·decades` orders of magnitude,
/// the case where the multishift code's deflation criteria matter most.
fn graded_matrix(n: usize, seed: u64, decades: f64) -> Mat<f64> {
    let r = random_matrix(n, seed);
    let d = |i: usize| 10f64.powf(-decades * i as f64 / n as f64);
    Mat::from_fn(n, n, |i, j| d(i) * r[(i, j)] * d(j))
}

/// Orders on both sides of the multishift crossover (75), through the size where faer's blocked
/// Hessenberg reduction takes over (256): backward error and orthogonality as tight as the
/// double-shift code gives, for random, graded, symmetric-ish and block-structured matrices.
#[test]
fn schur_multishift_random_and_graded() {
    for (n, seed) in [(74usize, 11u64), (76, 12), (101, 13), (150, 14), (260, 15), (300, 16)] {
        let tol = 1e-14 * n as f64;
        let a = random_matrix(n, seed);
        let s = real_schur(a.as_ref()).unwrap();
        check_schur(a.as_ref(), &s, tol);
        let g = graded_matrix(n, seed, 6.0);
        let s = real_schur(g.as_ref()).unwrap();
        check_schur(g.as_ref(), &s, tol);
        // The eigenvalues of the graded matrix agree with those of its balanced Schur form.
        let ours = s.eigenvalues();
        let bal = eigenvalues(g.as_ref()).unwrap();
        assert!(eig_distance(&ours, &bal) < 1e-10, "n={n}");
        // Symmetric plus a small skew part: clustered real eigenvalues with a few close pairs.
        let sy = Mat::from_fn(n, n, |i, j| a[(i, j)] + a[(j, i)] + 1e-3 * (a[(i, j)] - a[(j, i)]));
        check_schur(sy.as_ref(), &real_schur(sy.as_ref()).unwrap(), tol);
    }
    // Block upper triangular with repeated diagonal blocks: many exactly equal eigenvalues.
    let n = 120;
    let b = random_matrix(6, 3);
    let r = random_matrix(n, 4);
    let m = Mat::from_fn(n, n, |i, j| {
        if i / 6 == j / 6 {
            b[(i % 6, j % 6)]
        } else if i / 6 < j / 6 {
            r[(i, j)]
        } else {
            0.0
        }
    });
    check_schur(m.as_ref(), &real_schur(m.as_ref()).unwrap(), 1e-14 * n as f64);
}

/// The n = 1000 check of issue 19 (slow in a debug build; run by hand with
/// `cargo test --release -p skyloop-linalg --test schur -- --ignored`).
#[test]
#[ignore]
fn schur_n1000_backward_error() {
    for (name, a) in [
        ("random", random_matrix(1000, 21)),
        ("graded", graded_matrix(1000, 22, 6.0)),
    ] {
        let s = real_schur(a.as_ref()).unwrap();
        let n = a.nrows();
        let recon = &s.q * &s.t * s.q.transpose();
        let berr = fro((&recon - &a).as_ref()) / fro(a.as_ref());
        let orth = fro((s.q.transpose() * &s.q - Mat::<f64>::identity(n, n)).as_ref());
        println!("n=1000 {name}: ‖A − QTQᵀ‖/‖A‖ = {berr:.2e}, ‖QᵀQ − I‖ = {orth:.2e}");
        check_schur(a.as_ref(), &s, 1e-14 * n as f64);
    }
}

/// Structured matrices of multishift order that stall or trivialize QR: zero, identity, the cyclic
/// shift (all eigenvalues on the unit circle: needs exceptional shifts), a nilpotent Jordan block
/// (one defective eigenvalue) and a Hamiltonian-like block matrix with ± pairs.
#[test]
fn schur_multishift_structured() {
    let n = 100;
    let zero = Mat::<f64>::zeros(n, n);
    let s = real_schur(zero.as_ref()).unwrap();
    assert_eq!(s.t, zero);
    let eye = Mat::<f64>::identity(n, n);
    check_schur(eye.as_ref(), &real_schur(eye.as_ref()).unwrap(), 1e-13);
    let cyclic = Mat::from_fn(n, n, |i, j| if i == (j + 1) % n { 1.0 } else { 0.0 });
    let s = real_schur(cyclic.as_ref()).unwrap();
    check_schur(cyclic.as_ref(), &s, 1e-12);
    assert!(s.eigenvalues().iter().all(|z| (z.norm() - 1.0).abs() < 1e-10));
    let jordan = Mat::from_fn(n, n, |i, j| if i == j + 1 { 1.0 } else { 0.0 });
    check_schur(jordan.as_ref(), &real_schur(jordan.as_ref()).unwrap(), 1e-12);
    let a = random_matrix(50, 31);
    let g = random_matrix(50, 32);
    let ham = Mat::from_fn(n, n, |i, j| match (i < 50, j < 50) {
        (true, true) => a[(i, j)],
        (true, false) => g[(i, j - 50)] + g[(j - 50, i)],
        (false, true) => -(a[(i - 50, j)] * a[(j, i - 50)]),
        (false, false) => -a[(j - 50, i - 50)],
    });
    check_schur(ham.as_ref(), &real_schur(ham.as_ref()).unwrap(), 1e-12);
}

/// `schur::eigenvalues_unbalanced` (no balancing: for a matrix already balanced) on the balanced
/// block of each fixture, against numpy's eigenvalues.
#[test]
fn balanced_block_eigenvalues_match_numpy() {
    for case in fixtures() {
        let name = case["name"].as_str().unwrap_or("?");
        let a = mat(&case["a"]);
        let reference = numpy_eigenvalues(&case);
        // As skyloop-lti's pole computation uses it: the isolated eigenvalues are the diagonal
        // entries outside the balanced block, the rest come from the block without rebalancing.
        let bal = balance(a.as_ref());
        let n = a.nrows();
        let mut ours: Vec<c64> = (0..bal.ilo)
            .chain(bal.ihi + 1..n)
            .map(|i| c64::new(bal.a[(i, i)], 0.0))
            .collect();
        if n > 0 && bal.ihi + 1 > bal.ilo {
            let m = bal.ihi + 1 - bal.ilo;
            let block = bal.a.as_ref().submatrix(bal.ilo, bal.ilo, m, m);
            ours.extend(eigenvalues_unbalanced(block).unwrap_or_else(|e| panic!("{name}: {e}")));
        }
        // Defective eigenvalues are determined only to ~eps^(1/k) (as in tests/schur.rs).
        let tol = match name {
            "jordan_4" => 1e-3,
            "companion_roots_1_to_8" => 1e-7,
            _ => 1e-11,
        };
        let d = eig_distance(&ours, &reference);
        assert!(d < tol, "{name}: eigenvalues differ from numpy by {d:e}");
    }
}

#[test]
fn same_eigenvalues_as_the_balancing_routine_on_a_balanced_matrix() {
    // On a matrix with entries of one size (uniform in [-1, 1)) balancing changes little, so both
    // routines agree to well within the eigenvalues' condition. Orders 30 and 90 take the
    // double-shift and the multishift paths.
    for (n, seed) in [(30usize, 3u64), (90, 4)] {
        let rows = skyloop_fixtures::lcg_matrix(n, n, seed);
        let a = Mat::from_fn(n, n, |i, j| rows[i][j]);
        let (x, y) = (
            eigenvalues_unbalanced(a.as_ref()).unwrap(),
            eigenvalues(a.as_ref()).unwrap(),
        );
        let d = eig_distance(&x, &y);
        assert!(d < 1e-10, "n = {n}: {d:e}");
    }
    // Bad input is an error, not a panic.
    assert!(eigenvalues_unbalanced(Mat::<f64>::zeros(2, 3).as_ref()).is_err());
    let nan = Mat::from_fn(2, 2, |i, j| if i == j { f64::NAN } else { 1.0 });
    assert!(eigenvalues_unbalanced(nan.as_ref()).is_err());
    assert!(eigenvalues_unbalanced(Mat::<f64>::zeros(0, 0).as_ref())
        .unwrap()
        .is_empty());
}
