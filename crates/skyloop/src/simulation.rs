//! Simulation workflows: a scenario file → the nonlinear 6-DOF run's trajectory CSV, trace plot and
//! metrics, or its Monte Carlo study.

use crate::error::{Error, Result};
use skyloop_sim::montecarlo::Summary;
use skyloop_sim::{sim, Metrics, Sample, Scenario};
use std::path::{Path, PathBuf};

/// Reads and parses a scenario file.
///
/// # Errors
/// An unreadable file, or TOML that is not a valid scenario (the message names the file).
pub fn load_scenario(path: &Path) -> Result<Scenario> {
    let text = skyloop_lti::json::read_text_file(path).map_err(|e| Error::read(path, e))?;
    Scenario::from_toml(&text).map_err(|e| Error::Spec(format!("{}: {e}", path.display())))
}

/// Writes trajectory.csv and traces.svg for one run into `dir`, with file names prefixed by `stem`.
///
/// # Errors
/// A file that cannot be written.
pub fn write_run(dir: &Path, stem: &str, title: &str, trace: &[Sample], nu: usize) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    let csv = dir.join(format!("{stem}.csv"));
    let mut f = std::io::BufWriter::new(std::fs::File::create(&csv).map_err(|e| Error::write(&csv, e))?);
    sim::write_csv(&mut f, trace, nu).map_err(|e| Error::write(&csv, e))?;
    let t: Vec<f64> = trace.iter().map(|s| s.t).collect();
    let tr = |label: &str, f: &dyn Fn(&Sample) -> f64| skyloop_plot::traces::Trace {
        label: label.into(),
        t: t.clone(),
        y: trace.iter().map(f).collect(),
    };
    let panels = vec![
        skyloop_plot::traces::TracePanel {
            y_label: "tracked quantity (by mode: attitude rad, position m, rate rad/s)".into(),
            traces: vec![
                tr("reference, axis 1", &|s| s.reference[0]),
                tr("tracked, axis 1", &|s| s.tracked[0]),
                tr("reference, axis 2", &|s| s.reference[1]),
                tr("tracked, axis 2", &|s| s.tracked[1]),
                tr("tracked, axis 3", &|s| s.tracked[2]),
            ],
            references: vec![],
        },
        skyloop_plot::traces::TracePanel {
            y_label: "body rates [rad/s]".into(),
            traces: vec![
                tr("p", &|s| s.rates[0]),
                tr("q", &|s| s.rates[1]),
                tr("r", &|s| s.rates[2]),
            ],
            references: vec![],
        },
        skyloop_plot::traces::TracePanel {
            y_label: "torque command [N·m]".into(),
            traces: vec![
                tr("Mx", &|s| s.torque[0]),
                tr("My", &|s| s.torque[1]),
                tr("Mz", &|s| s.torque[2]),
            ],
            references: vec![],
        },
    ];
    let svg = dir.join(format!("{stem}.svg"));
    Ok(skyloop_plot::traces::plot_traces(&svg, title, &panels)?)
}

/// Runs `scn` once and writes `trajectory.csv`, `trajectory.svg` and `metrics.json` into `out`;
/// `progress` is called with (physics steps done, steps in all) every 65 536 steps.
///
/// # Errors
/// The simulation failing (an invalid vehicle or controller) or a file that cannot be written.
pub fn simulate_to(scn: &Scenario, out: &Path, progress: &mut dyn FnMut(u64, u64)) -> Result<Metrics> {
    std::fs::create_dir_all(out).map_err(|e| Error::create(out, e))?;
    let (trace, m) = skyloop_sim::simulate_with_progress(scn, progress)?;
    let nu = scn.vehicle.resolve().and_then(|v| v.build())?.nu();
    write_run(out, "trajectory", &scn.name, &trace, nu)?;
    let mpath = out.join("metrics.json");
    std::fs::write(&mpath, serde_json::to_string(&m)?).map_err(|e| Error::write(&mpath, e))?;
    Ok(m)
}

/// Runs the scenario's `[monte_carlo]` study in parallel and writes `monte_carlo.json` (summary and
/// every run's metrics) into `out`; `progress` is called with (runs done, runs in all).
///
/// # Errors
/// A scenario without `[monte_carlo]`, a failed run, or a file that cannot be written.
pub fn monte_carlo_to(
    scn: &Scenario,
    out: &Path,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Summary, PathBuf)> {
    std::fs::create_dir_all(out).map_err(|e| Error::create(out, e))?;
    let mc = scn
        .monte_carlo
        .as_ref()
        .ok_or_else(|| Error::Spec(format!("scenario '{}' has no [monte_carlo] section", scn.name)))?;
    let (runs, summary) = skyloop_sim::montecarlo::run(scn, mc, progress)?;
    let path = out.join("monte_carlo.json");
    let body = serde_json::json!({ "summary": summary, "runs": runs });
    std::fs::write(&path, body.to_string()).map_err(|e| Error::write(&path, e))?;
    Ok((summary, path))
}

/// Parses a run range `A..B` (runs A, A+1, .., B−1 of a scenario's Monte Carlo study; run i uses
/// noise seed `monte_carlo.seed + i`), or a single run `A`.
///
/// # Errors
/// Text that is not `A..B` with integers A < B (or one integer).
pub fn parse_seed_range(text: &str) -> Result<Vec<usize>> {
    let bad = || Error::Input(format!("--seeds: expected A..B with integers 0 <= A < B, got '{text}'"));
    let t = text.trim();
    let (a, b) = match t.split_once("..") {
        Some((a, b)) => (
            a.trim().parse::<usize>().map_err(|_| bad())?,
            b.trim().parse::<usize>().map_err(|_| bad())?,
        ),
        None => {
            let a = t.parse::<usize>().map_err(|_| bad())?;
            (a, a + 1)
        }
    };
    if a >= b {
        return Err(bad());
    }
    // Checked before the index list is allocated.
    let max = skyloop_sim::montecarlo::MAX_RUNS;
    if b - a > max {
        return Err(Error::Input(format!(
            "--seeds {text}: {} runs, more than the {max} one call may run; split the range",
            b - a
        )));
    }
    Ok((a..b).collect())
}

/// Runs the runs `seeds` (indices into the scenario's `[monte_carlo]` study, see
/// [`parse_seed_range`]) in parallel on `threads` threads (`None`: all cores) and summarizes them;
/// the metrics come back in the order of `seeds`, so splitting a campaign into ranges and
/// concatenating the parts gives the same runs and summary as one call.
///
/// # Errors
/// A scenario without `[monte_carlo]`, no seed, zero threads, or a failed run.
pub fn monte_carlo_runs(
    scn: &Scenario,
    seeds: &[usize],
    threads: Option<usize>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Vec<Metrics>, Summary)> {
    let mc = scn
        .monte_carlo
        .as_ref()
        .ok_or_else(|| Error::Spec(format!("scenario '{}' has no [monte_carlo] section", scn.name)))?;
    let go = || skyloop_sim::montecarlo::run_indices(scn, mc, seeds, progress);
    let runs = match threads {
        None => go()?,
        Some(0) => return Err(Error::Input("threads must be at least 1".into())),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| Error::Failed(format!("cannot start {n} threads: {e}")))?
            .install(go)?,
    };
    let summary = skyloop_sim::montecarlo::summarize(&runs);
    Ok((runs, summary))
}

/// Writes one CSV line per run: `run,seed,max_abs_error,rms_error,settling_time_s,saturated_fraction,crashed`
/// (seed = `monte_carlo.seed + run`; settling_time_s empty when the run never settled; floats in
/// shortest round-trip form, so the file reads back bit for bit).
///
/// # Errors
/// A file that cannot be written.
pub fn write_runs_csv(path: &Path, base_seed: u64, seeds: &[usize], runs: &[Metrics]) -> Result<()> {
    use std::io::Write;
    let mut text = String::from("run,seed,max_abs_error,rms_error,settling_time_s,saturated_fraction,crashed\n");
    for (i, m) in seeds.iter().zip(runs) {
        let settle = m.settling_time_s.map(|t| format!("{t:?}")).unwrap_or_default();
        text.push_str(&format!(
            "{i},{},{:?},{:?},{settle},{:?},{}\n",
            base_seed.wrapping_add(*i as u64),
            m.max_abs_error,
            m.rms_error,
            m.saturated_fraction,
            m.crashed
        ));
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    }
    let mut f = std::fs::File::create(path).map_err(|e| Error::write(path, e))?;
    f.write_all(text.as_bytes()).map_err(|e| Error::write(path, e))
}

/// Writes the runs as a Parquet file with the columns of [`write_runs_csv`]: `run`, `seed` (INT64),
/// `max_abs_error`, `rms_error` (DOUBLE), `settling_time_s` (DOUBLE, null when the run never
/// settled), `saturated_fraction` (DOUBLE) and `crashed` (BOOLEAN); one row group, uncompressed,
/// readable by pandas, Polars, DuckDB, Spark and Dask.
///
/// # Errors
/// A file that cannot be written.
pub fn write_runs_parquet(path: &Path, base_seed: u64, seeds: &[usize], runs: &[Metrics]) -> Result<()> {
    use parquet::data_type::{BoolType, DoubleType, Int64Type};
    use parquet::file::properties::WriterProperties;
    use parquet::file::writer::SerializedFileWriter;
    use std::sync::Arc;
    const SCHEMA: &str = "message monte_carlo_runs {
        REQUIRED INT64 run; REQUIRED INT64 seed; REQUIRED DOUBLE max_abs_error; REQUIRED DOUBLE rms_error;
        OPTIONAL DOUBLE settling_time_s; REQUIRED DOUBLE saturated_fraction; REQUIRED BOOLEAN crashed; }";
    let fail = |e: parquet::errors::ParquetError| Error::Failed(format!("cannot write {}: {e}", path.display()));
    let schema = Arc::new(parquet::schema::parser::parse_message_type(SCHEMA).map_err(fail)?);
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    }
    let file = std::fs::File::create(path).map_err(|e| Error::write(path, e))?;
    let mut writer =
        SerializedFileWriter::new(file, schema, Arc::new(WriterProperties::builder().build())).map_err(fail)?;
    let n = seeds.len().min(runs.len());
    let (seeds, runs) = (&seeds[..n], &runs[..n]);
    let floats = |f: fn(&Metrics) -> f64| -> Vec<f64> { runs.iter().map(f).collect() };
    let run_col: Vec<i64> = seeds.iter().map(|&i| i as i64).collect();
    // The seed as the CSV prints it (u64), stored in INT64's bits: every seed below 2^63 reads back as is.
    let seed_col: Vec<i64> = seeds.iter().map(|&i| base_seed.wrapping_add(i as u64) as i64).collect();
    let settled: Vec<f64> = runs.iter().filter_map(|m| m.settling_time_s).collect();
    let settle_def: Vec<i16> = runs.iter().map(|m| i16::from(m.settling_time_s.is_some())).collect();
    let crashed: Vec<bool> = runs.iter().map(|m| m.crashed).collect();
    let mut rg = writer.next_row_group().map_err(fail)?;
    let mut k = 0;
    while let Some(mut col) = rg.next_column().map_err(fail)? {
        match k {
            0 => col.typed::<Int64Type>().write_batch(&run_col, None, None),
            1 => col.typed::<Int64Type>().write_batch(&seed_col, None, None),
            2 => col
                .typed::<DoubleType>()
                .write_batch(&floats(|m| m.max_abs_error), None, None),
            3 => col
                .typed::<DoubleType>()
                .write_batch(&floats(|m| m.rms_error), None, None),
            4 => col.typed::<DoubleType>().write_batch(&settled, Some(&settle_def), None),
            5 => col
                .typed::<DoubleType>()
                .write_batch(&floats(|m| m.saturated_fraction), None, None),
            _ => col.typed::<BoolType>().write_batch(&crashed, None, None),
        }
        .map_err(fail)?;
        col.close().map_err(fail)?;
        k += 1;
    }
    rg.close().map_err(fail)?;
    writer.close().map_err(fail)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Parquet file reads back (with the same crate's reader) row by row as the runs went in,
    /// a null where a run never settled.
    #[test]
    fn parquet_runs_read_back() {
        use parquet::file::reader::{FileReader, SerializedFileReader};
        use parquet::record::Field;
        let runs = vec![
            Metrics {
                max_abs_error: 0.5,
                rms_error: 0.125,
                settling_time_s: Some(1.75),
                saturated_fraction: 0.0,
                crashed: false,
            },
            Metrics {
                max_abs_error: 3.0,
                rms_error: 1.0 / 3.0,
                settling_time_s: None,
                saturated_fraction: 0.25,
                crashed: true,
            },
        ];
        let path = std::env::temp_dir().join(format!("skyloop-runs-{}.parquet", std::process::id()));
        write_runs_parquet(&path, 100, &[4, 9], &runs).unwrap();
        let reader = SerializedFileReader::new(std::fs::File::open(&path).unwrap()).unwrap();
        let rows: Vec<Vec<(String, Field)>> = reader
            .get_row_iter(None)
            .unwrap()
            .map(|r| {
                r.unwrap()
                    .get_column_iter()
                    .map(|(k, v)| (k.clone(), v.clone()))
                    .collect()
            })
            .collect();
        let _ = std::fs::remove_file(&path);
        assert_eq!(rows.len(), 2);
        let names: Vec<&str> = rows[0].iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(
            names,
            [
                "run",
                "seed",
                "max_abs_error",
                "rms_error",
                "settling_time_s",
                "saturated_fraction",
                "crashed"
            ]
        );
        assert_eq!(rows[0][1].1, Field::Long(104));
        assert_eq!(rows[1][0].1, Field::Long(9));
        assert_eq!(rows[1][3].1, Field::Double(1.0 / 3.0));
        assert_eq!(rows[0][4].1, Field::Double(1.75));
        assert_eq!(rows[1][4].1, Field::Null);
        assert_eq!(rows[1][6].1, Field::Bool(true));
    }

    #[test]
    fn seed_ranges() {
        assert_eq!(parse_seed_range("3..6").unwrap(), vec![3, 4, 5]);
        assert_eq!(parse_seed_range("7").unwrap(), vec![7]);
        assert!(parse_seed_range("6..3").is_err());
        assert!(parse_seed_range("a..b").is_err());
        assert!(parse_seed_range("5..5").is_err());
    }
}
