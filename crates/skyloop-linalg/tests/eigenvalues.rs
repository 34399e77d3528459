//! `schur::eigenvalues_unbalanced` (no balancing: for a matrix already balanced) against the
//! numpy eigenvalues of the Schur fixtures (`tools/gen_schur.py` → `tests/fixtures/schur/cases.json`)
//! and against the balancing `schur::eigenvalues`.
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

use faer::{c64, Mat};
use serde_json::Value;
use skyloop_linalg::balance::balance;
use skyloop_linalg::schur::{eigenvalues, eigenvalues_unbalanced};

fn mat(v: &Value) -> Mat<f64> {
    let rows = v.as_array().expect("rows");
    let n = rows.len();
    let m = rows.first().map(|r| r.as_array().expect("row").len()).unwrap_or(0);
    Mat::from_fn(n, m, |i, j| rows[i][j].as_f64().expect("number"))
}

/// Largest distance (relative to the spectrum's scale) between greedily matched eigenvalues.
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
fn balanced_block_eigenvalues_match_numpy() {
    for case in skyloop_fixtures::cases(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/schur/cases.json") {
        let name = case["name"].as_str().unwrap_or("?");
        let a = mat(&case["a"]);
        let reference: Vec<c64> = case["eig_re"]
            .as_array()
            .expect("re")
            .iter()
            .zip(case["eig_im"].as_array().expect("im"))
            .map(|(r, i)| c64::new(r.as_f64().expect("re"), i.as_f64().expect("im")))
            .collect();
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
