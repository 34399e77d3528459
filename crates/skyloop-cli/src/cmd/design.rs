//! `skyloop design SPEC.toml [--out DIR] [--json]`: the whole controller design of a spec
//! (synthesis → boost → reduction → Tustin), its summary, and with `--out` the controllers (LTI
//! JSON), SOS coefficients, plots (L full vs reduced, C full vs reduced, S, T, 1/|T|, step) and an
//! HTML report.

use crate::output::print_json;
use skyloop::design::report::write_outputs;
use skyloop::design::{design, table::console_table};
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
    crate::output::bench(a.bench, || design(&spec).map_err(|e| format!("design: {e}")))?;
    let r = design(&spec).map_err(|e| format!("design: {e}"))?;
    if let Some(dir) = &a.out {
        write_outputs(&r, dir)?;
        eprintln!("wrote {}", dir.display());
    }
    if a.json {
        return print_json(&r.summary);
    }
    for n in &r.summary.notes {
        eprintln!("note: {n}");
    }
    print!("{}", console_table(&r.summary));
    Ok(())
}
