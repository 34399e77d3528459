//! `skyloop design SPEC.toml [--out DIR] [--json]`: the whole controller design of a spec
//! (synthesis → boost → reduction → Tustin), its summary, and with `--out` the controllers (LTI
//! JSON), SOS coefficients, plots (L full vs reduced, C full vs reduced, S, T, 1/|T|, step) and an
//! HTML report.

use crate::output::print_json;
use skyloop::design::report::{fmt_opt as opt, write_outputs};
use skyloop::design::{design, DesignResult};
use skyloop::spec::design::DesignSpec;
use std::path::PathBuf;

/// Arguments of `skyloop design`.
#[derive(clap::Args)]
pub struct Args {
    /// Design spec (TOML), e.g. examples/bicopter.toml.
    spec: PathBuf,
    /// Directory for controllers (LTI JSON), SOS coefficients, summary.json, plots and report.html.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the summary as one JSON object instead of a table.
    #[arg(long)]
    json: bool,
    /// Repeat the design (no files, no plots) N times and print the fastest wall time on stderr.
    #[arg(long)]
    bench: Option<usize>,
}

/// Runs the design and writes/prints what was asked for.
pub fn run(a: Args) -> skyloop::Result<()> {
    let spec = DesignSpec::from_file(&a.spec)?;
    if let Some(n) = a.bench {
        let mut best = f64::INFINITY;
        for _ in 0..n.max(1) {
            let t = std::time::Instant::now();
            design(&spec).map_err(|e| format!("design: {e}"))?;
            best = best.min(t.elapsed().as_secs_f64());
        }
        eprintln!("bench_seconds {best:e}");
    }
    let r = design(&spec).map_err(|e| format!("design: {e}"))?;
    if let Some(dir) = &a.out {
        write_outputs(&r, dir)?;
        eprintln!("wrote {}", dir.display());
    }
    if a.json {
        return print_json(&r.summary);
    }
    print_table(&r);
    Ok(())
}

fn print_table(r: &DesignResult) {
    let s = &r.summary;
    if !s.name.is_empty() {
        println!("{}", s.name);
    }
    println!(
        "method {}   gamma_min {}   factor {}",
        s.method,
        opt(s.gamma_min, 6),
        opt(s.factor, 6)
    );
    println!(
        "boost gain {:.6}   fast controller modes residualized {}",
        s.boost_gain, s.fast_modes_removed
    );
    for n in &s.notes {
        eprintln!("note: {n}");
    }
    println!(
        "{:<10} {:>5} {:>9} {:>8} {:>9} {:>9} {:>9} {:>9} {:>10} {:>9} {:>7} {:>7}",
        "step", "order", "gamma", "b(P,C)", "PM deg", "fc Hz", "GM dB", "fGM Hz", "disk alpha", "DM ms", "Ms", "Mt"
    );
    for st in &s.stages {
        let m = &st.margins;
        println!(
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
            println!(
                "{}: the loop crosses 0 dB {} times, at {} Hz",
                st.stage,
                list.len(),
                list.join(", ")
            );
        }
    }
    if let Some(c) = &s.reduced_vs_full {
        println!(
            "reduced vs full over {:.3}..{:.3} Hz: max rel. error {:.4} ({:.3} dB, {:.2} deg)",
            c.from_hz, c.to_hz, c.max_rel_error, c.max_mag_error_db, c.max_phase_error_deg
        );
    }
    if let Some(d) = &s.discrete {
        let c = &d.vs_continuous;
        println!(
            "Tustin at {} Hz vs continuous up to {} Hz: max rel. error {:.4} ({:.3} dB, {:.2} deg); vs warped {:.1e}",
            d.rate_hz, c.to_hz, c.max_rel_error, c.max_mag_error_db, c.max_phase_error_deg, d.vs_warped.max_rel_error
        );
    }
    let l = &s.limits;
    println!(
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
}
