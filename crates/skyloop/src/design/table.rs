//! The design summary as the console table `skyloop design` prints: one row per step (γ, b(P,C),
//! PM/GM with their frequencies, disk α, delay margin, Ms, Mt), every gain crossover where there
//! are several, the reduced-vs-full and Tustin errors, and the crossover limits.

use std::fmt::Write as _;

use super::report::fmt_opt as opt;
use super::DesignSummary;

/// The summary as aligned text lines (units in the header: deg, Hz, dB, ms), ending in a newline.
/// The spec's notes are not included: the CLI prints them on stderr as `note:` lines.
pub fn console_table(s: &DesignSummary) -> String {
    let mut out = String::new();
    if !s.name.is_empty() {
        let _ = writeln!(out, "{}", s.name);
    }
    let _ = writeln!(
        out,
        "method {}   gamma_min {}   factor {}",
        s.method,
        opt(s.gamma_min, 6),
        opt(s.factor, 6)
    );
    let _ = writeln!(
        out,
        "boost gain {:.6}   fast controller modes residualized {}",
        s.boost_gain, s.fast_modes_removed
    );
    let _ = writeln!(
        out,
        "{:<10} {:>5} {:>9} {:>8} {:>9} {:>9} {:>9} {:>9} {:>10} {:>9} {:>7} {:>7}",
        "step", "order", "gamma", "b(P,C)", "PM deg", "fc Hz", "GM dB", "fGM Hz", "disk alpha", "DM ms", "Ms", "Mt"
    );
    for st in &s.stages {
        let m = &st.margins;
        let _ = writeln!(
            out,
            "{:<10} {:>5} {:>9} {:>8.4} {:>9.2} {:>9.4} {:>9.3} {:>9.4} {:>10.4} {:>9.1} {:>7.3} {:>7.3}{}",
            st.stage,
            st.order,
            opt(st.gamma, 4),
            st.ncf_margin,
            m.phase_margin_deg,
            m.crossover_hz,
            m.gain_margin_db,
            m.gain_margin_freq_hz,
            m.disk_alpha,
            1e3 * m.delay_margin_s,
            m.ms,
            m.mt,
            if m.stable { "" } else { "  UNSTABLE" }
        );
    }
    for st in &s.stages {
        let m = &st.margins;
        if m.gain_crossovers_hz.len() > 1 {
            let list: Vec<String> = m.gain_crossovers_hz.iter().map(|f| format!("{f:.3}")).collect();
            let _ = writeln!(
                out,
                "{}: the loop crosses 0 dB {} times, at {} Hz",
                st.stage,
                list.len(),
                list.join(", ")
            );
        }
    }
    if let Some(c) = &s.reduced_vs_full {
        let _ = writeln!(
            out,
            "reduced vs full over {:.3}..{:.3} Hz: max rel. error {:.4} ({:.3} dB, {:.2} deg)",
            c.from_hz, c.to_hz, c.max_rel_error, c.max_mag_error_db, c.max_phase_error_deg
        );
    }
    if let Some(d) = &s.discrete {
        let c = &d.vs_continuous;
        let _ = writeln!(
            out,
            "Tustin at {} Hz vs continuous up to {} Hz: max rel. error {:.4} ({:.3} dB, {:.2} deg); vs warped {:.1e}",
            d.rate_hz, c.to_hz, c.max_rel_error, c.max_mag_error_db, c.max_phase_error_deg, d.vs_warped.max_rel_error
        );
    }
    let l = &s.limits;
    let _ = writeln!(
        out,
        "crossover {:.4} Hz; RHP zero {} Hz -> limit |z|/2 = {} Hz; delay {:.4} s -> limit 1/theta = {} Hz; {}",
        l.crossover_hz,
        opt(l.rhp_zero_hz, 3),
        opt(l.rhp_zero_limit_hz, 3),
        l.delay_s,
        opt(l.delay_limit_hz, 3),
        if l.within_limits {
            "within limits"
        } else {
            "BEYOND A LIMIT"
        }
    );
    out
}
