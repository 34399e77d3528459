//! CLI: `skyloop reproduce ducted-fan` (Pross, "H∞ and μ-synthesis of a ducted-fan VTOL micro-UAV").

use std::process::Command;
use std::time::Instant;

fn skyloop() -> Command {
    Command::new(env!("CARGO_BIN_EXE_skyloop"))
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("skyloop-cli-duct-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// The number printed after `key` on the line containing `key`.
fn number_after(text: &str, key: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.contains(key))
        .unwrap_or_else(|| panic!("no '{key}' in\n{text}"));
    let rest = &line[line.find(key).expect("key") + key.len()..];
    let num: String = rest
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | '-' | 'e'))
        .collect();
    num.parse()
        .unwrap_or_else(|_| panic!("no number after '{key}' in '{line}'"))
}

#[test]
fn reproduces_hinf_design_mu_analysis_and_nonlinear_steps() {
    let out = tmp("quick");
    let t = Instant::now();
    let o = skyloop()
        .args(["reproduce", "ducted-fan", "--quick", "--out"])
        .arg(&out)
        .output()
        .expect("runs");
    let secs = t.elapsed().as_secs_f64();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&o.stderr));
    // Budget for CI (the test profile is optimized): CPU time where the run reports it (a shared
    // machine stretches wall time), else wall time.
    let cpu = stdout
        .lines()
        .find(|l| l.contains("cpu "))
        .and_then(|l| l.split("cpu ").nth(1))
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse::<f64>().ok())
        .unwrap_or(secs);
    assert!(cpu < 60.0, "took {cpu:.1} s CPU ({secs:.1} s wall)");
    // hinfsyn's γ is finite and positive; the closed loop it verified is what the μ analysis measures
    // as nominal performance (checked inside the run, which fails otherwise).
    let gamma = number_after(&stdout, "γ =");
    assert!(gamma > 0.0 && gamma.is_finite());
    assert!(stdout.contains("[ok] K∞ stabilizes the linear plant"), "{stdout}");
    assert!(
        stdout.contains("[ok] H∞ nominal: the nonlinear x-step settles"),
        "{stdout}"
    );
    let rs = number_after(&stdout, "robust stability μ peak");
    let rp = number_after(&stdout, "robust performance μ peak");
    // RP adds a block to RS's structure, so its μ can only be larger (Packard & Doyle 1993).
    assert!(rp >= rs * (1.0 - 1e-3), "RP {rp} < RS {rs}");
    // μ-synthesis: its robust-performance μ below the H∞ design's (Fig. 4b), and its controller
    // keeps the nominal and perturbed nonlinear steps stable.
    assert!(
        stdout.contains("[ok] robust-performance μ of K_μ below K∞'s"),
        "{stdout}"
    );
    assert!(stdout.contains("[ok] K_μ stabilizes the linear plant"), "{stdout}");
    assert!(
        stdout.contains("[ok] μ perturbed: the nonlinear x-step stays stable"),
        "{stdout}"
    );
    // Controller reduction: fewer states than the DK-iteration's controller, RP μ within 2 % (checked
    // inside the run against the full controller's μ).
    assert!(stdout.contains("[ok] reduced K_μ ("), "{stdout}");
    let full = number_after(&stdout, "K_μ reduced:");
    let reduced = number_after(&stdout, "reduced K_μ (");
    assert!(reduced < full, "reduced {reduced} vs {full}");
    // Fig. 6 by the worst-case perturbation: the realized Δ sits on K∞'s margin, and at a size between
    // the two controllers' margins it destabilizes the H∞ loop but not the μ loop.
    assert!(stdout.contains("[ok] Δ_wc(s) is K∞'s margin"), "{stdout}");
    assert!(stdout.contains("[ok] Fig. 6 (worst-case Δ"), "{stdout}");
    let pct = number_after(&stdout, "Fig. 6 (worst-case Δ at");
    assert!(
        pct > 0.0 && pct < 100.0,
        "applied Δ {pct} % of the modelled uncertainty"
    );
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
    let first = number_after(&stdout, "iteration 1: γ =");
    assert!(first.is_finite() && first > 0.0);
    for f in [
        "mu_nominal.csv",
        "mu_perturbed.csv",
        "hinf_nominal.csv",
        "hinf_perturbed.csv",
        "fig4b_mu.svg",
        "fig5_6_x_step.svg",
        "fig6_worst_case_linear.csv",
        "mu_worst_case_actuator.csv",
        "hinf_worst_case_actuator.csv",
    ] {
        let p = out.join(f);
        assert!(p.exists(), "missing {}", p.display());
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
fn bad_invocations_exit_2() {
    let o = skyloop().args(["reproduce", "ducted-fans"]).output().expect("runs");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("ducted-fan"));
    // An output directory that cannot be created.
    let o = skyloop()
        .args(["reproduce", "ducted-fan", "--quick", "--out", "/proc/skyloop-no/such"])
        .output()
        .expect("runs");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot create"));
}
