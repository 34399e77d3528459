//! The paper reproductions, checked on their `Reproduction`: every claim the papers make and the
//! numbers measured on the way, not parsed console text.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use skyloop::papers::{reproduce, Reproduction};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("skyloop-papers-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn held(r: &Reproduction, prefix: &str) -> bool {
    r.claim(prefix)
        .unwrap_or_else(|| panic!("no claim '{prefix}' in\n{}", r.lines().join("\n")))
        .reproduced
}

fn value(r: &Reproduction, name: &str) -> f64 {
    r.value(name).unwrap_or_else(|| panic!("no value '{name}'"))
}

#[test]
fn bicopter_section_iv_reproduces_the_hinf_design_and_checks_the_pid() {
    let out = tmp("bicopter");
    let r = reproduce("bicopter", &out, false).expect("runs");
    // Every number of the H∞ design holds; the comparison PID's outcomes (GM, |T| peak, |S| gap)
    // and Section V's flights are reported with their verdicts, whichever they are.
    let is_pid = |w: &str| w.starts_with("Step 4 PID") || w.starts_with("Fig. 1") || w.starts_with("Sec. V");
    let failed: Vec<&str> = r
        .not_reproduced()
        .filter(|c| !is_pid(&c.what))
        .map(|c| c.line.as_str())
        .collect();
    assert!(failed.is_empty(), "{failed:?}");
    assert!(r.claims.len() >= 20, "{} claims", r.claims.len());
    let g = r.claim("Step 2: γ of ncfsyn").expect("γ claim");
    assert_eq!(g.paper, Some(1.748));
    assert!((g.ours.expect("ours") - 1.748).abs() <= 5e-4);
    let n_ok = r.reproduced_count();
    if n_ok == r.claims.len() {
        assert_eq!(r.summary_line(), format!("all {} claims reproduced", r.claims.len()));
    } else {
        assert!(r
            .summary_line()
            .starts_with(&format!("{n_ok} of {} claims reproduced", r.claims.len())));
    }
    // The PID was tuned to the printed PM and crossover (its goals), and the checks ran.
    assert!(held(&r, "Step 4 PID: phase margin"));
    assert!(held(&r, "Step 4 PID: gain crossover"));
    for prefix in [
        "Step 4 PID: gain margin",
        "Fig. 11: the PID's |T|",
        "Fig. 11: the H∞",
        "Fig. 12: H∞",
    ] {
        assert!(r.claim(prefix).is_some(), "no claim {prefix}");
    }
    assert!(value(&r, "pid_ki") > 0.0 && value(&r, "pid_kp") > 0.0);
    for prefix in [
        "Sec. V-A: both",
        "Sec. V-A: the PID",
        "Sec. V-B",
        "Sec. V-C: with the bottle H∞",
        "Sec. V-C: with the bottle the PID",
    ] {
        assert!(r.claim(prefix).is_some(), "no claim {prefix}");
    }
    for f in [
        "bicopter_summary.json",
        "report.html",
        "design/loop.svg",
        "design/controller_reduced.json",
        "pid_vs_hinf_loop.svg",
        "pid_vs_hinf_sensitivity.svg",
        "sec5a_nominal.svg",
        "sec5b_pendulum.svg",
        "sec5c_bottle.svg",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let html = std::fs::read_to_string(out.join("report.html")).expect("report");
    assert!(html.contains("Step 4: phase margin") && html.contains("Step 4 PID") && html.matches("<svg").count() >= 7);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn quadrotor_ssi_claims_hold() {
    let out = tmp("ssi");
    let r = reproduce("quadrotor-ssi", &out, false).expect("runs");
    let failed: Vec<&str> = r.not_reproduced().map(|c| c.line.as_str()).collect();
    assert!(failed.is_empty(), "{failed:?}");
    assert!(held(&r, "no crash with Jm = J or Jm = 0.5·J"));
    assert!(out.join("fig6_8_roll.svg").is_file() && out.join("report.html").is_file());
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn ducted_fan_hinf_mu_analysis_dk_iteration_and_steps() {
    let out = tmp("duct");
    let r = reproduce("ducted-fan", &out, true).expect("runs");
    // hinfsyn's γ is finite and positive; the closed loop it verified is what the μ analysis measures
    // as nominal performance.
    let gamma = value(&r, "hinf_gamma");
    assert!(gamma > 0.0 && gamma.is_finite());
    assert!(held(&r, "K∞ stabilizes the linear plant"));
    assert!(held(&r, "μ upper bound ≥ lower bound at every frequency"));
    assert!(held(
        &r,
        "nominal performance of lft(G, K∞) equals hinfsyn's closed-loop norm"
    ));
    assert!(held(&r, "H∞ nominal: the nonlinear x-step settles"));
    // RP adds a block to RS's structure, so its μ can only be larger (Packard & Doyle 1993).
    let (rs, rp) = (value(&r, "hinf_rs_mu_peak"), value(&r, "hinf_rp_mu_peak"));
    assert!(rp >= rs * (1.0 - 1e-3), "RP {rp} < RS {rs}");
    // μ-synthesis: RP μ below the H∞ design's (Fig. 4b); its controller keeps the nominal and
    // perturbed nonlinear steps stable.
    assert!(held(&r, "robust-performance μ of K_μ below K∞'s"));
    assert!(held(&r, "K_μ stabilizes the linear plant"));
    assert!(held(&r, "μ perturbed: the nonlinear x-step stays stable"));
    let first = value(&r, "musyn_first_gamma");
    assert!(first.is_finite() && first > 0.0);
    // Reduction: fewer states, RP μ within 2 % (checked in the claim).
    assert!(held(&r, "reduced K_μ ("));
    assert!(value(&r, "k_mu_reduced_order") < value(&r, "k_mu_order"));
    // Fig. 6 by the worst-case perturbation.
    assert!(held(&r, "Δ_wc(s) is K∞'s margin"));
    assert!(held(&r, "Fig. 6 (worst-case Δ"));
    let pct = value(&r, "fig6_delta_percent");
    assert!(pct > 0.0 && pct < 100.0, "applied Δ {pct} %");
    // A claim that does not hold is counted, and the final line never says "all" then.
    let n = r.reproduced_count();
    if n < r.claims.len() {
        assert!(r.summary_line().starts_with(&format!("{n} of {}", r.claims.len())));
    }
    let csv = std::fs::read_to_string(out.join("fig6_worst_case_linear.csv")).expect("csv");
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().expect("number")).collect())
        .collect();
    // Columns: t, H∞ nominal, H∞ worst case, μ nominal, μ worst case.
    let last = rows.last().expect("rows");
    assert!((last[1] - 0.5).abs() < 0.02 && (last[3] - 0.5).abs() < 0.02 && (last[4] - 0.5).abs() < 0.02);
    let h_peak = rows.iter().fold(0.0f64, |m, r| m.max(r[2].abs()));
    assert!(h_peak > 0.75, "H∞ worst-case step peaks at {h_peak} m");
    for f in [
        "mu_nominal.csv",
        "mu_perturbed.csv",
        "hinf_nominal.csv",
        "hinf_perturbed.csv",
        "fig4b_mu.svg",
        "fig5_6_x_step.svg",
        "mu_worst_case_actuator.csv",
        "hinf_worst_case_actuator.csv",
        "report.html",
    ] {
        assert!(out.join(f).exists(), "missing {f}");
        assert!(r.artifacts.contains(&out.join(f)), "{f} not listed as an artifact");
    }
    // The nominal trace ends at the 0.5 m step.
    let csv = std::fs::read_to_string(out.join("hinf_nominal.csv")).expect("csv");
    let header: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
    let ix = header.iter().position(|h| *h == "x_m").expect("x_m column");
    let last: Vec<f64> = csv
        .lines()
        .last()
        .expect("row")
        .split(',')
        .map(|v| v.parse().expect("number"))
        .collect();
    assert!((last[ix] - 0.5).abs() < 0.02, "final x {}", last[ix]);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn unknown_paper_is_an_input_error() {
    let e = reproduce("ducted-fans", &tmp("none"), true).expect_err("unknown");
    assert!(matches!(e, skyloop::Error::Input(_)), "{e:?}");
    assert!(e.to_string().contains("ducted-fan"));
}

#[test]
fn summary_line_counts_claims_and_says_all_only_when_all_held() {
    let mut r = Reproduction::new("t");
    r.number("a", 1.0, 1.0, 0.0);
    r.check(true, "b".into());
    assert_eq!(r.summary_line(), "all 2 claims reproduced");
    r.number("c", 2.0, 2.5, 0.1);
    assert_eq!(
        r.summary_line(),
        "2 of 3 claims reproduced, 1 not reproduced (see above)"
    );
    let lines = r.lines();
    assert!(lines[2].starts_with("  [not reproduced] c"), "{lines:?}");
    assert!(!lines.iter().any(|l| l.contains("all ")));
}
