//! Property test of the C export: random controllers (gain, real zeros and poles, an integrator or
//! none, a pure gain) with random options (float or double, finite or infinite limits, loop period,
//! prefix, a source path with comment terminators and line breaks). Each header is compiled with the
//! system C compiler under `-std=c99 -Wall -Werror`, run on a random error sequence that drives the
//! output into its limits, and compared sample by sample with the library's discrete simulation
//! (`skyloop::control::SsController` with the same limits and Hanus anti-windup).
//!
//! Where no C compiler is on PATH the test says so and checks only that the header was written:
//! the build itself stays pure Rust (CI's `CC=/bin/false`).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use proptest::prelude::*;
use skyloop::control::SsController;
use skyloop::export::c_header::controller_header;
use std::path::PathBuf;
use std::process::Command;
use std::sync::OnceLock;

/// The first working C compiler on PATH.
fn compiler() -> Option<&'static str> {
    static CC: OnceLock<Option<&'static str>> = OnceLock::new();
    *CC.get_or_init(|| {
        ["gcc", "clang", "cc"].into_iter().find(|c| {
            Command::new(c)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        })
    })
}

#[derive(Debug, Clone)]
struct Case {
    gain: f64,
    zeros: Vec<f64>,
    poles: Vec<f64>,
    integrator: bool,
    double: bool,
    limits: (f64, f64),
    dt: f64,
    name: &'static str,
    source: String,
    inputs: Vec<f64>,
}

impl Case {
    /// The controller as an expression `skyloop::model::load_model` reads.
    fn expr(&self) -> String {
        let f = |r: &f64| format!("(s/{r:.6}+1)");
        let num: Vec<String> = self.zeros.iter().map(f).collect();
        let mut den: Vec<String> = self.poles.iter().map(f).collect();
        if self.integrator {
            den.push("s".into());
        }
        let num = if num.is_empty() { "1".into() } else { num.join("*") };
        let den = if den.is_empty() { "1".into() } else { den.join("*") };
        format!("{:.6}*{num}/({den})", self.gain)
    }
}

fn case() -> impl Strategy<Value = Case> {
    (
        (0.01f64..50.0, prop::collection::vec(0.5f64..400.0, 0..3)),
        (prop::collection::vec(0.5f64..400.0, 0..4), any::<bool>(), any::<bool>()),
        (
            prop_oneof![
                Just((f64::NEG_INFINITY, f64::INFINITY)),
                (0.05f64..5.0, 0.05f64..5.0).prop_map(|(a, b)| (-a, b)),
                (0.05f64..5.0).prop_map(|b| (f64::NEG_INFINITY, b)),
            ],
            1e-4f64..1e-2,
            prop::sample::select(vec!["roll", "pitch_rate", "k", "ctl_2"]),
            "[a-z/ *\\n\\r\"]{0,24}",
            prop::collection::vec(-3.0f64..3.0, 40..160),
        ),
    )
        .prop_map(
            |((gain, zeros), (mut poles, integrator, double), (limits, dt, name, source, inputs))| {
                // Proper: at least as many poles (with the integrator) as zeros.
                while poles.len() + usize::from(integrator) < zeros.len() {
                    poles.push(50.0);
                }
                Case {
                    gain,
                    zeros,
                    poles,
                    integrator,
                    double,
                    limits,
                    dt,
                    name,
                    source,
                    inputs,
                }
            },
        )
}

/// The C program's outputs for the case's inputs (None: no compiler).
fn run_c(case: &Case, header: &str, dir: &PathBuf) -> Option<Vec<f64>> {
    let cc = compiler()?;
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("ctl.h"), header).unwrap();
    let ty = if case.double { "double" } else { "float" };
    // In float, each input printed as its float value, so the compiler's decimal → float
    // conversion and the library's f64 → f32 one give the same number.
    let exact = |v: f64| if case.double { v } else { f64::from(v as f32) };
    let data: Vec<String> = case.inputs.iter().map(|&v| format!("{:.17e}", exact(v))).collect();
    let main = format!(
        "#include <stdio.h>\n#include \"ctl.h\"\nstatic const {ty} in[] = {{{}}};\nint main(void) {{\n  {n}_state_t s; {n}_reset(&s);\n  for (unsigned i = 0; i < sizeof in / sizeof in[0]; ++i) {{ {ty} u[1]; {n}_step(&s, &in[i], u); printf(\"%.17e\\n\", (double)u[0]); }}\n  return 0;\n}}\n",
        data.join(","),
        n = case.name
    );
    std::fs::write(dir.join("main.c"), main).unwrap();
    let exe = dir.join("ctl");
    let o = Command::new(cc)
        .args(["-std=c99", "-Wall", "-Werror", "-o"])
        .arg(&exe)
        .arg(dir.join("main.c"))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{cc} rejected the header:\n{}\n{header}",
        String::from_utf8_lossy(&o.stderr)
    );
    let o = Command::new(&exe).output().unwrap();
    assert!(o.status.success());
    Some(
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .map(|l| l.parse().unwrap())
            .collect(),
    )
}

/// The library's discrete simulation of the same controller, limits and anti-windup, in the
/// header's scalar type (`T` = f32 for `float`: a controller whose saturated dynamics are marginal,
/// Hanus conditioning with Tustin's zeros at z = −1, amplifies rounding, so float is compared with
/// float).
fn run_rust<T: skyloop::control::Real>(case: &Case, d: &skyloop::lti::StateSpace) -> Vec<f64> {
    let flat = |m: &skyloop::linalg::Mat<f64>| -> Vec<T> {
        (0..m.nrows())
            .flat_map(|i| (0..m.ncols()).map(move |j| T::from_f64(m[(i, j)])))
            .collect()
    };
    let c = SsController::<T, 8, 1, 1>::new(d.nx(), 1, 1, &flat(&d.a), &flat(&d.b), &flat(&d.c), &flat(&d.d))
        .unwrap()
        .with_limits(&[T::from_f64(case.limits.0)], &[T::from_f64(case.limits.1)])
        .unwrap();
    // The header's rule: Hanus conditioning L = B/D where D ≠ 0 (the quotient taken in double and
    // then rounded, as the header's literals are), none otherwise.
    let dd = d.d[(0, 0)];
    let mut c = if dd.abs() > 1e-12 {
        let l: Vec<T> = (0..d.nx()).map(|i| T::from_f64(d.b[(i, 0)] / dd)).collect();
        c.with_aw_gain(&l).unwrap()
    } else {
        c
    };
    case.inputs
        .iter()
        .map(|&e| c.step_siso(T::from_f64(e)).to_f64())
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    /// The header compiles and its step function reproduces the library's simulation: to 1e-9 of the
    /// output's scale in double, 1e-4 in float.
    #[test]
    fn exported_headers_compile_and_match_the_library(case in case()) {
        let sys = skyloop::model::load_model(&case.expr()).unwrap();
        let ty = if case.double { "double" } else { "float" };
        let (header, d) = controller_header(&sys, case.dt, case.name, ty, case.limits.0, case.limits.1, &case.source).unwrap();
        let step_fn = format!("{}_step", case.name);
        prop_assert!(header.contains(&step_fn), "no {} in the header", step_fn);
        let dir = std::env::temp_dir().join(format!("skyloop-cprop-{}", std::process::id()));
        let Some(got) = run_c(&case, &header, &dir) else {
            eprintln!("no C compiler on PATH: headers are not compiled");
            return Ok(());
        };
        let want = if case.double { run_rust::<f64>(&case, &d) } else { run_rust::<f32>(&case, &d) };
        prop_assert_eq!(got.len(), want.len());
        let scale = want.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let tol = if case.double { 1e-9 } else { 1e-4 };
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            prop_assert!((g - w).abs() <= tol * scale, "sample {}: C {} vs library {} ({})", k, g, w, case.expr());
        }
    }
}
