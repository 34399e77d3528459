//! CARE/DARE against scipy and SLICOT (python-control + slycot) fixtures from `tools/gen_riccati.py`,
//! the CAREX benchmark collection (table written to `tests/fixtures/riccati/carex_table.md` when
//! `SKYLOOP_WRITE_TABLES=1`), and error cases.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use faer::{Mat, MatRef};
use serde_json::Value;
use skyloop_linalg::riccati::{
    care, care_residual, care_with, dare, dare_residual, CareMethod, RiccatiOptions, RiccatiSolution,
};
use skyloop_linalg::LinalgError;

const FIXTURES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/riccati/");

fn mat(v: &Value) -> Option<Mat<f64>> {
    let rows = v.as_array()?;
    let n = rows.len();
    let m = rows.first().and_then(|r| r.as_array()).map(|r| r.len()).unwrap_or(0);
    Some(Mat::from_fn(n, m, |i, j| rows[i][j].as_f64().expect("number")))
}

fn cases(file: &str) -> Vec<Value> {
    let text = std::fs::read_to_string(format!("{FIXTURES}{file}")).expect("fixture file");
    let v: Value = serde_json::from_str(&text).expect("json");
    v["cases"].as_array().expect("cases").clone()
}

struct Problem {
    name: String,
    a: Mat<f64>,
    b: Mat<f64>,
    q: Mat<f64>,
    r: Mat<f64>,
    s: Option<Mat<f64>>,
    x_scipy: Option<Mat<f64>>,
    x_slycot: Option<Mat<f64>>,
    x_exact: Option<Mat<f64>>,
}

fn problem(c: &Value) -> Problem {
    Problem {
        name: c["name"].as_str().unwrap_or("?").to_string(),
        a: mat(&c["a"]).expect("a"),
        b: mat(&c["b"]).expect("b"),
        q: mat(&c["q"]).expect("q"),
        r: mat(&c["r"]).expect("r"),
        s: mat(&c["s"]),
        x_scipy: mat(&c["x_scipy"]),
        x_slycot: mat(&c["x_slycot"]),
        x_exact: mat(&c["x_exact"]),
    }
}

fn rel(x: MatRef<f64>, y: MatRef<f64>) -> f64 {
    (x - y).norm_l2() / y.norm_l2().max(f64::MIN_POSITIVE)
}

fn check_common(p: &Problem, sol: &RiccatiSolution, discrete: bool) {
    let n = p.a.nrows();
    assert_eq!(sol.x.nrows(), n);
    assert_eq!(
        rel(sol.x.as_ref(), sol.x.transpose()),
        0.0,
        "{}: X not symmetric",
        p.name
    );
    assert_eq!(sol.closed_loop_eigs.len(), n);
    for z in &sol.closed_loop_eigs {
        if discrete {
            assert!(z.norm() < 1.0, "{}: closed loop not stable: {z}", p.name);
        } else {
            assert!(z.re < 0.0, "{}: closed loop not stable: {z}", p.name);
        }
    }
}

#[test]
fn care_matches_scipy_and_slycot() {
    for c in cases("care.json") {
        let p = problem(&c);
        let sol = care(
            p.a.as_ref(),
            p.b.as_ref(),
            p.q.as_ref(),
            p.r.as_ref(),
            p.s.as_ref().map(|s| s.as_ref()),
        )
        .unwrap_or_else(|e| panic!("{}: {e}", p.name));
        check_common(&p, &sol, false);
        let s = p.s.as_ref().map(|s| s.as_ref());
        let res_scipy = care_residual(
            p.a.as_ref(),
            p.b.as_ref(),
            p.q.as_ref(),
            p.r.as_ref(),
            s,
            x_ref(&p.x_scipy),
        )
        .expect("residual");
        if c["hard"].as_bool().unwrap_or(false) {
            // Ill-conditioned X: as accurate as scipy, up to a small factor.
            assert!(
                sol.residual < 10.0 * res_scipy,
                "{}: residual {:e}, scipy {res_scipy:e}",
                p.name,
                sol.residual
            );
            // ...and Newton refinement brings the residual below the 1e-12 bar.
            let refined = care_with(
                p.a.as_ref(),
                p.b.as_ref(),
                p.q.as_ref(),
                p.r.as_ref(),
                s,
                &refine_opts(),
            )
            .expect("refined");
            assert!(
                refined.residual < 1e-12,
                "{}: refined residual {:e}",
                p.name,
                refined.residual
            );
        } else {
            assert!(sol.residual < 1e-13, "{}: residual {:e}", p.name, sol.residual);
        }
        let again = care_residual(
            p.a.as_ref(),
            p.b.as_ref(),
            p.q.as_ref(),
            p.r.as_ref(),
            s,
            sol.x.as_ref(),
        )
        .expect("residual");
        assert_eq!(again, sol.residual);
        // K = R⁻¹(BᵀX + Sᵀ)  ⇔  R·K = BᵀX + Sᵀ
        let mut rhs = p.b.transpose() * &sol.x;
        if let Some(s) = &p.s {
            rhs += s.transpose();
        }
        assert!(rel((&p.r * &sol.k).as_ref(), rhs.as_ref()) < 1e-12, "{}: K", p.name);
        let tol = if c["hard"].as_bool().unwrap_or(false) {
            1e-6
        } else {
            1e-10
        };
        for (who, x) in [("scipy", &p.x_scipy), ("slycot", &p.x_slycot)] {
            let e = rel(sol.x.as_ref(), x_ref(x));
            assert!(e < tol, "{}: X differs from {who} by {e:e}", p.name);
        }
    }
}

/// Newton refinement down to rounding level (the defaults stop at a residual of 1e-13).
fn refine_opts() -> RiccatiOptions {
    RiccatiOptions {
        newton_steps: 3,
        refine_above: 2.0 * f64::EPSILON,
        ..Default::default()
    }
}

fn x_ref(x: &Option<Mat<f64>>) -> MatRef<'_, f64> {
    x.as_ref().expect("reference solution in fixture").as_ref()
}

#[test]
fn dare_matches_scipy_and_slycot() {
    for c in cases("dare.json") {
        let p = problem(&c);
        let sol = dare(
            p.a.as_ref(),
            p.b.as_ref(),
            p.q.as_ref(),
            p.r.as_ref(),
            p.s.as_ref().map(|s| s.as_ref()),
        )
        .unwrap_or_else(|e| panic!("{}: {e}", p.name));
        check_common(&p, &sol, true);
        assert!(sol.residual < 1e-13, "{}: residual {:e}", p.name, sol.residual);
        // K = (R + BᵀXB)⁻¹(BᵀXA + Sᵀ)
        let lhs = (&p.r + p.b.transpose() * &sol.x * &p.b) * &sol.k;
        let mut rhs = p.b.transpose() * &sol.x * &p.a;
        if let Some(s) = &p.s {
            rhs += s.transpose();
        }
        assert!(rel(lhs.as_ref(), rhs.as_ref()) < 1e-12, "{}: K", p.name);
        for (who, x) in [("scipy", &p.x_scipy), ("slycot", &p.x_slycot)] {
            let x = x.as_ref().expect("reference");
            let e = rel(sol.x.as_ref(), x.as_ref());
            assert!(e < 1e-10, "{}: X differs from {who} by {e:e}", p.name);
        }
    }
}

fn fmt(v: Option<f64>) -> String {
    match v {
        Some(v) => format!("{v:.1e}"),
        None => "—".to_string(),
    }
}

#[test]
fn carex_benchmark_table() {
    let mut table = String::new();
    table.push_str(
        "# CAREX benchmark (Benner, Laub & Mehrmann, SPC 95_22; data as SLICOT BB01AD)\n\n\
         Generated by `SKYLOOP_WRITE_TABLES=1 cargo test -p skyloop-linalg --test riccati carex`.\n\
         Relative residual ‖Res‖_F / (‖Q‖ + 2‖AᵀX‖ + ‖XB‖‖K‖) of each solver's X evaluated by the same code;\n\
         error = ‖X − X_exact‖_F/‖X_exact‖_F where the collection gives a closed form.\n\
         skyloop = `riccati::care` (default options: doubling from n = 16 on, Laub's Schur method below;\n\
         Newton steps only while the residual > 1e-13),\n\
         +N = Newton refinement down to rounding level (`newton_steps: 3, refine_above: 2·eps`);\n\
         scipy = `solve_continuous_are`; SLICOT = SB02MD via python-control.\n\n\
         | ex. | parameter | n | residual skyloop | skyloop+N | scipy | SLICOT | error skyloop | skyloop+N | scipy | SLICOT |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut failures = Vec::new();
    for c in cases("carex.json") {
        let p = problem(&c);
        let param = c["param"]
            .as_f64()
            .map(|v| format!("{v:e}"))
            .unwrap_or_else(|| "—".into());
        let res =
            |x: &Mat<f64>| care_residual(p.a.as_ref(), p.b.as_ref(), p.q.as_ref(), p.r.as_ref(), None, x.as_ref()).ok();
        let ours = care(p.a.as_ref(), p.b.as_ref(), p.q.as_ref(), p.r.as_ref(), None);
        let (our_res, our_err) = match &ours {
            Ok(sol) => (
                Some(sol.residual),
                p.x_exact.as_ref().map(|xe| rel(sol.x.as_ref(), xe.as_ref())),
            ),
            Err(e) => {
                failures.push(format!("{} ({param}): {e}", p.name));
                (None, None)
            }
        };
        let err_of = |x: &Option<Mat<f64>>| match (x, &p.x_exact) {
            (Some(x), Some(xe)) => Some(rel(x.as_ref(), xe.as_ref())),
            _ => None,
        };
        let refined = care_with(
            p.a.as_ref(),
            p.b.as_ref(),
            p.q.as_ref(),
            p.r.as_ref(),
            None,
            &refine_opts(),
        )
        .ok();
        let ref_res = refined.as_ref().map(|s| s.residual);
        let ref_err = match (&refined, &p.x_exact) {
            (Some(s), Some(xe)) => Some(rel(s.x.as_ref(), xe.as_ref())),
            _ => None,
        };
        let (sp_res, sl_res) = (p.x_scipy.as_ref().and_then(res), p.x_slycot.as_ref().and_then(res));
        let (sp_err, sl_err) = (err_of(&p.x_scipy), err_of(&p.x_slycot));
        table.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            p.name,
            param,
            p.a.nrows(),
            fmt(our_res),
            fmt(ref_res),
            fmt(sp_res),
            fmt(sl_res),
            fmt(our_err),
            fmt(ref_err),
            fmt(sp_err),
            fmt(sl_err)
        ));
        // Accuracy comparable to the references: within 100× of the better of scipy/SLICOT
        // (or at rounding level).
        let what = format!("{} ({param})", p.name);
        check_vs_references(&mut failures, &what, "residual", our_res, [sp_res, sl_res], 1e-13);
        check_vs_references(&mut failures, &what, "error", our_err, [sp_err, sl_err], 1e-12);
    }
    if std::env::var("SKYLOOP_WRITE_TABLES").is_ok() {
        std::fs::write(format!("{FIXTURES}carex_table.md"), &table).expect("write table");
    }
    eprintln!("{table}");
    assert!(failures.is_empty(), "CAREX failures:\n{}", failures.join("\n"));
}

#[test]
fn care_without_stabilizing_solution_is_an_error() {
    // Undamped oscillator, no input: Hamiltonian eigenvalues ±i (closed form), on the axis.
    let a = Mat::from_fn(2, 2, |i, j| [[0.0, 1.0], [-1.0, 0.0]][i][j]);
    let b = Mat::<f64>::zeros(2, 1);
    let q = Mat::<f64>::zeros(2, 2);
    let r = Mat::<f64>::identity(1, 1);
    let e = care(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None).expect_err("no solution");
    assert!(matches!(e, LinalgError::NoSolution(_)), "{e}");

    // Unstabilizable: an unstable mode (eigenvalue 1) that B cannot reach.
    let a = Mat::from_fn(2, 2, |i, j| [[1.0, 0.0], [0.0, -1.0]][i][j]);
    let b = Mat::from_fn(2, 1, |i, _| [0.0, 1.0][i]);
    let q = Mat::<f64>::identity(2, 2);
    let e = care(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None).expect_err("unstabilizable");
    assert!(matches!(e, LinalgError::NoSolution(_)), "{e}");
    let e = dare(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None);
    // Discrete: eigenvalue 1 is on the unit circle and unreachable.
    assert!(matches!(e, Err(LinalgError::NoSolution(_))), "{e:?}");
}

/// Doubling and the Schur method, each forced, on every CARE fixture (orders 2 to 50, cross
/// terms, indefinite R): both stabilizing, both at the references' accuracy.
#[test]
fn care_methods_agree_on_every_fixture() {
    for c in cases("care.json") {
        let p = problem(&c);
        let tol = if c["hard"].as_bool().unwrap_or(false) {
            1e-6
        } else {
            1e-10
        };
        let mut xs = Vec::new();
        for method in [CareMethod::Schur, CareMethod::Doubling] {
            let opts = RiccatiOptions {
                care_method: method,
                ..Default::default()
            };
            let s = p.s.as_ref().map(|s| s.as_ref());
            let sol = care_with(p.a.as_ref(), p.b.as_ref(), p.q.as_ref(), p.r.as_ref(), s, &opts)
                .unwrap_or_else(|e| panic!("{} by {method:?}: {e}", p.name));
            check_common(&p, &sol, false);
            assert!(
                sol.residual < 1e-12,
                "{} by {method:?}: residual {:e}",
                p.name,
                sol.residual
            );
            let e = rel(sol.x.as_ref(), x_ref(&p.x_slycot));
            assert!(e < tol, "{} by {method:?}: X differs from slycot by {e:e}", p.name);
            xs.push(sol.x);
        }
        let e = rel(xs[1].as_ref(), xs[0].as_ref());
        assert!(e < tol, "{}: the methods differ by {e:e}", p.name);
    }
}

/// Without a stabilizing solution doubling stops with an error within its step limit (no hang),
/// and the default method then reports what the Schur method finds.
#[test]
fn care_doubling_without_solution_is_an_error() {
    // 20 undamped oscillators with no input: every Hamiltonian eigenvalue on the imaginary axis.
    let n = 20;
    let a = Mat::from_fn(n, n, |i, j| {
        let w = (1 + i / 2) as f64;
        match (i % 2, j) {
            (0, j) if j == i + 1 => w,
            (1, j) if j + 1 == i => -w,
            _ => 0.0,
        }
    });
    let b = Mat::<f64>::zeros(n, 1);
    let q = Mat::<f64>::identity(n, n);
    let r = Mat::<f64>::identity(1, 1);
    for method in [CareMethod::Doubling, CareMethod::Auto] {
        let opts = RiccatiOptions {
            care_method: method,
            ..Default::default()
        };
        let e = care_with(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None, &opts).expect_err("no solution");
        assert!(matches!(e, LinalgError::NoSolution(_)), "{method:?}: {e}");
        if method == CareMethod::Auto {
            assert!(e.to_string().contains("imaginary axis"), "{e}");
        }
    }
}

#[test]
fn bad_input_is_an_error() {
    let a = Mat::<f64>::identity(2, 2);
    let b = Mat::<f64>::identity(2, 1);
    let q = Mat::<f64>::identity(2, 2);
    let r = Mat::<f64>::identity(1, 1);
    let non_square = Mat::<f64>::zeros(2, 3);
    assert!(matches!(
        care(non_square.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None),
        Err(LinalgError::Dimension(_))
    ));
    assert!(matches!(
        care(a.as_ref(), b.as_ref(), q.as_ref(), q.as_ref(), None),
        Err(LinalgError::Dimension(_))
    ));
    let wrong_s = Mat::<f64>::zeros(3, 1);
    assert!(matches!(
        dare(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), Some(wrong_s.as_ref())),
        Err(LinalgError::Dimension(_))
    ));
    let mut qn = q.clone();
    qn[(0, 1)] = f64::NAN;
    assert!(matches!(
        care(a.as_ref(), b.as_ref(), qn.as_ref(), r.as_ref(), None),
        Err(LinalgError::InvalidArgument(_))
    ));
    let mut qa = q.clone();
    qa[(0, 1)] = 1.0;
    assert!(matches!(
        care(a.as_ref(), b.as_ref(), qa.as_ref(), r.as_ref(), None),
        Err(LinalgError::InvalidArgument(_))
    ));
    let r0 = Mat::<f64>::zeros(1, 1);
    assert!(matches!(
        care(a.as_ref(), b.as_ref(), q.as_ref(), r0.as_ref(), None),
        Err(LinalgError::Singular(_))
    ));
    assert!(matches!(
        dare(a.as_ref(), b.as_ref(), q.as_ref(), r0.as_ref(), None),
        Err(LinalgError::Singular(_))
    ));
}

#[test]
fn scalar_closed_form() {
    // Scalar CARE 2ax − b²x²/r + q = 0: x = (a + √(a² + b²q/r))·r/b² (closed form).
    let (a, b, q, r) = (1.5f64, 2.0f64, 3.0f64, 0.5f64);
    let x = (a + (a * a + b * b * q / r).sqrt()) * r / (b * b);
    let m = |v: f64| Mat::from_fn(1, 1, |_, _| v);
    let sol = care(m(a).as_ref(), m(b).as_ref(), m(q).as_ref(), m(r).as_ref(), None).expect("care");
    assert!((sol.x[(0, 0)] - x).abs() < 1e-14 * x);
    // Scalar DARE x = a²x − a²b²x²/(r + b²x) + q, i.e. b²x² + (r − a²r − qb²)x − qr = 0.
    let (a, b, q, r) = (1.2f64, 0.7f64, 2.0f64, 0.3f64);
    let bb = r - a * a * r - q * b * b;
    let x = (-bb + (bb * bb + 4.0 * b * b * q * r).sqrt()) / (2.0 * b * b);
    let sol = dare(m(a).as_ref(), m(b).as_ref(), m(q).as_ref(), m(r).as_ref(), None).expect("dare");
    assert!((sol.x[(0, 0)] - x).abs() < 1e-14 * x, "{} vs {x}", sol.x[(0, 0)]);
    let again = dare_residual(
        m(a).as_ref(),
        m(b).as_ref(),
        m(q).as_ref(),
        m(r).as_ref(),
        None,
        sol.x.as_ref(),
    )
    .expect("res");
    assert_eq!(again, sol.residual);
}

#[test]
fn darex_benchmark_table() {
    let mut table = String::new();
    table.push_str(
        "# DAREX benchmark (Benner, Laub & Mehrmann, SPC 95_23; data as SLICOT BB02AD)\n\n\
         Generated by `SKYLOOP_WRITE_TABLES=1 cargo test -p skyloop-linalg --test riccati darex`.\n\
         Relative residual of each solver's X evaluated by the same code (`riccati::dare_residual`);\n\
         error = ‖X − X_exact‖_F/‖X_exact‖_F where the collection gives a closed form.\n\
         skyloop = `riccati::dare` (structure-preserving doubling, default options: Newton steps only\n\
         while the residual > 1e-13); scipy = `solve_discrete_are`;\n\
         SLICOT = SB02MD via python-control.\n\n\
         | ex. | parameter | n | residual skyloop | scipy | SLICOT | error skyloop | scipy | SLICOT |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    let mut failures = Vec::new();
    for c in cases("darex.json") {
        let p = problem(&c);
        let param = c["param"]
            .as_f64()
            .map(|v| format!("{v:e}"))
            .unwrap_or_else(|| "—".into());
        let res =
            |x: &Mat<f64>| dare_residual(p.a.as_ref(), p.b.as_ref(), p.q.as_ref(), p.r.as_ref(), None, x.as_ref()).ok();
        let err_of = |x: &Mat<f64>| p.x_exact.as_ref().map(|xe| rel(x.as_ref(), xe.as_ref()));
        let ours = dare(p.a.as_ref(), p.b.as_ref(), p.q.as_ref(), p.r.as_ref(), None);
        let (our_res, our_err, our_txt) = match &ours {
            Ok(sol) => (Some(sol.residual), err_of(&sol.x), fmt(Some(sol.residual))),
            Err(LinalgError::Singular(_)) => (None, None, "R singular: unsupported".to_string()),
            Err(e) => {
                failures.push(format!("{} ({param}): {e}", p.name));
                (None, None, "error".to_string())
            }
        };
        // The reference residual needs R⁻¹ too; with a singular R only the error column is shown.
        let (sp_res, sl_res) = (p.x_scipy.as_ref().and_then(res), p.x_slycot.as_ref().and_then(res));
        let (sp_err, sl_err) = (
            p.x_scipy.as_ref().and_then(err_of),
            p.x_slycot.as_ref().and_then(err_of),
        );
        table.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            p.name,
            param,
            p.a.nrows(),
            our_txt,
            fmt(sp_res),
            fmt(sl_res),
            fmt(our_err),
            fmt(sp_err),
            fmt(sl_err)
        ));
        let what = format!("{} ({param})", p.name);
        check_vs_references(&mut failures, &what, "residual", our_res, [sp_res, sl_res], 1e-13);
        check_vs_references(&mut failures, &what, "error", our_err, [sp_err, sl_err], 1e-12);
    }
    if std::env::var("SKYLOOP_WRITE_TABLES").is_ok() {
        std::fs::write(format!("{FIXTURES}darex_table.md"), &table).expect("write table");
    }
    eprintln!("{table}");
    assert!(failures.is_empty(), "DAREX failures:\n{}", failures.join("\n"));
}

/// Records a failure when our `quantity` exceeds 100× the better of the scipy/SLICOT references (or
/// `floor`, the rounding level): accuracy comparable to the references.
fn check_vs_references(
    failures: &mut Vec<String>,
    what: &str,
    quantity: &str,
    ours: Option<f64>,
    refs: [Option<f64>; 2],
    floor: f64,
) {
    if let (Some(ours), Some(best)) = (ours, refs.into_iter().flatten().reduce(f64::min)) {
        if ours > (100.0 * best).max(floor) {
            failures.push(format!("{what}: {quantity} {ours:e} vs best reference {best:e}"));
        }
    }
}
