//! Li, Qin, Xu & Zhang, bicopter roll-rate H∞ loop shaping ("Modeling, Identification, and Control of Non-minimum Phase Dynamics of Bi-copter UAVs",
//! Section IV): runs examples/bicopter.toml and sets every number the section prints beside ours,
//! including the comparison PID's ([`super::bicopter_pid`]).

use super::Reproduction;
use crate::design::design;
use crate::error::Result;
use crate::model::real_factors;
use crate::spec::design::DesignSpec;
use skyloop_lti::c64;
use skyloop_lti::zpk::Zpk;
use std::path::Path;

const SPEC: &str = include_str!("../../../../examples/bicopter.toml");

/// Runs the reproduction, writing `bicopter_summary.json` to `out`.
///
/// # Errors
/// The embedded spec or the design failing, or `out` not writable.
pub fn run(out: &Path) -> Result<Reproduction> {
    let spec = DesignSpec::from_toml_str(SPEC, Path::new(".")).map_err(|e| format!("embedded spec: {e}"))?;
    let r = design(&spec).map_err(|e| format!("design: {e}"))?;
    let s = &r.summary;
    let mut c = Reproduction::new("bicopter");
    c.note("Bicopter roll rate, H∞ loop shaping (Li, Qin, Xu & Zhang, Section IV): examples/bicopter.toml");
    let gmin = s.gamma_min.ok_or("the example must use ncfsyn")?;
    // Printed to 3 decimals.
    c.number("Step 2: γ of ncfsyn with 3rd-order Padé", 1.748, gmin, 5e-4);
    c.number("Step 3: order of W1·K∞·W2", 12.0, r.full.nx() as f64, 0.0);
    let red = s.stages.last().ok_or("no stages")?;
    c.number("Step 3: order of the reduced controller", 5.0, red.order as f64, 0.0);
    c.number(
        "Step 3: final γ after boost and reduction",
        2.862,
        red.gamma.unwrap_or(f64::NAN),
        0.005,
    );
    let m = &red.margins;
    // The paper prints one decimal; the rounding of eq. (12)'s coefficients alone moves PM by 0.08°.
    c.number("Step 4: phase margin, deg", 65.8, m.phase_margin_deg, 0.2);
    c.number("Step 4: gain crossover, Hz", 1.47, m.crossover_hz, 0.005);
    c.number("Step 4: gain margin, dB", 7.25, m.gain_margin_db, 0.05);
    c.number(
        "Step 4: unstable zero of P, Hz",
        6.68,
        s.limits.rhp_zero_hz.unwrap_or(f64::NAN),
        0.005,
    );
    c.note(format!(
        "  crossover {:.3} Hz < RHP-zero limit |z|/2 = {:.3} Hz (paper: 'lower than the unstable zero')",
        m.crossover_hz,
        s.limits.rhp_zero_limit_hz.unwrap_or(f64::NAN)
    ));

    // Eq. (12): C = 24.02 (s+54.01)(s+0.2474)(s²+139.3s+2.624e4) / (s (s²+24.14s+8544)(s²+232.4s+7.041e4)).
    let reduced = r.reduced.as_ref().ok_or("the example must reduce")?;
    let z = Zpk::from_ss(reduced)?;
    // A far zero comes from the tiny feedthrough D the residualized fast mode leaves (eq. (12) is
    // strictly proper): zeros beyond 100x the fastest pole are listed apart, not compared.
    let pmax = z.p[0][0].iter().map(|p| p.norm()).fold(0.0, f64::max);
    let (near, far): (Vec<c64>, Vec<c64>) = z.z[0][0].iter().partition(|q| q.norm() <= 100.0 * pmax);
    let (zr, zq) = real_factors(&near);
    let (pr, pq) = real_factors(&z.p[0][0]);
    if zr.len() == 2 && zq.len() == 1 && pr.len() == 1 && pq.len() == 2 {
        // Four significant digits printed: 0.5% relative.
        let mut eq = |what: &str, paper: f64, ours: f64| c.number(what, paper, ours, 5e-3 * paper.abs());
        // Below the far zeros, k·Π(s − z_far) ≈ k·Π(−z_far): the gain eq. (12) would show.
        let k = far.iter().fold(c64::new(z.k[0][0], 0.0), |acc, q| acc * (-q)).re;
        eq("eq. (12) gain", 24.02, k);
        eq("eq. (12) zero s + 54.01", 54.01, -zr[0]);
        eq("eq. (12) zero s + 0.2474", 0.2474, -zr[1]);
        eq("eq. (12) zeros s² + 139.3 s", 139.3, zq[0][0]);
        eq("eq. (12) zeros s² + ... + 2.624e4", 2.624e4, zq[0][1]);
        eq("eq. (12) poles s² + 24.14 s", 24.14, pq[0][0]);
        eq("eq. (12) poles s² + ... + 8544", 8544.0, pq[0][1]);
        eq("eq. (12) poles s² + 232.4 s", 232.4, pq[1][0]);
        eq("eq. (12) poles s² + ... + 7.041e4", 7.041e4, pq[1][1]);
        c.note(format!("  eq. (12) integrator: ours at {:.2e}", pr[0]));
        for q in &far {
            c.note(format!(
                "  ours has a far zero at {:.3e} rad/s (feedthrough D = {:.3e}; eq. (12) has none)",
                q.re,
                reduced.d[(0, 0)]
            ));
        }
    } else {
        c.check(
            false,
            format!("eq. (12) structure: zeros {:?}, poles {:?}", z.z[0][0], z.p[0][0]),
        );
    }
    if let Some(d) = &s.discrete {
        c.note(format!(
            "  Step 5: Tustin at {} Hz; up to {} Hz the discrete controller is within {:.2} dB and {:.2}° of the \
             continuous one (frequency warping; exact on the warped axis to {:.1e})",
            d.rate_hz,
            d.vs_continuous.to_hz,
            d.vs_continuous.max_mag_error_db,
            d.vs_continuous.max_phase_error_deg,
            d.vs_warped.max_rel_error
        ));
    }
    // Step 4's comparison PID (Fig. 10–12), tuned on the same plant with its exact delay.
    let (pid, mut pid_figures) = super::bicopter_pid::compare(&mut c, &r.plant, reduced, out)?;
    // Section V's flight tests in the nonlinear model, both controllers.
    pid_figures.extend(super::bicopter_flight::fly_tests(&mut c, pid.gains, out)?);
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let path = out.join("bicopter_summary.json");
    let text = serde_json::to_string_pretty(s)?;
    std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    c.note(format!("wrote {}", path.display()));
    c.artifact(&path);
    // The design's own files and figures (controllers, L, C, S/T, 1/|T|, step) beside the claims.
    let design_dir = out.join("design");
    crate::design::report::write_outputs(&r, &design_dir)?;
    for name in ["controller", "loop", "sensitivity", "uncertainty", "step"] {
        c.artifact(&design_dir.join(format!("{name}.svg")));
    }
    for p in &pid_figures {
        c.artifact(p);
    }
    super::write_report(
        &mut c,
        "Bicopter roll rate, H∞ loop shaping (Li, Qin, Xu & Zhang, Section IV)",
        out,
    )?;
    Ok(c)
}
