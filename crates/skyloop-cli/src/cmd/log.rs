//! `skyloop log info FILE`: topics/fields, rates, duration and the firmware's tuning of a ULog,
//! blackbox, ArduPilot DataFlash or CSV log; `skyloop log export FILE --fields .. --out F.csv`: raw channels as CSV;
//! `skyloop log plot FILE --fields .. --out F.png|svg`: channels against time, airborne segments shaded;
//! `skyloop log compare A B [--out DIR] [--json]`: two flights side by side (`skyloop::compare`).

use std::path::{Path, PathBuf};

use skyloop::firmware::FirmwareTuning;
use skyloop::flightlog::{export_csv, info_json, plot_fields};
use skyloop::sysid::logs::{blackbox, detect, Log, LogFormat, OpenOptions};

use crate::output::print_json;

/// Arguments of `skyloop log`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    action: Action,
}

#[derive(clap::Subcommand)]
enum Action {
    /// List groups (topics), their fields, sample rates and the duration.
    Info {
        /// The log file (.ulg, blackbox .bbl/.bfl, ArduPilot DataFlash .bin, or CSV).
        file: PathBuf,
        /// Blackbox session (counted from 1); default: the longest.
        #[arg(long)]
        session: Option<usize>,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Write time_s (the flight controller's clock, s) and the fields as CSV, one row per logged
    /// frame, values as decoded (no resampling); the fields must share one group (ULog: one topic;
    /// DataFlash: one message and instance, as `RATE.R,RATE.RDes` or `IMU[1].GyrX`).
    Export {
        /// The log file.
        file: PathBuf,
        /// Blackbox session (counted from 1); default: the longest.
        #[arg(long)]
        session: Option<usize>,
        /// Comma-separated field names, as `log info` lists them.
        #[arg(long, value_delimiter = ',', required = true)]
        fields: Vec<String>,
        /// Output CSV file.
        #[arg(long)]
        out: PathBuf,
    },
    /// Plot fields against time (s from the log start), one panel each, with the airborne segments
    /// that `identify --axis` would use shaded.
    Plot {
        /// The log file.
        file: PathBuf,
        /// Blackbox session (counted from 1); default: the longest.
        #[arg(long)]
        session: Option<usize>,
        /// Comma-separated field names (sums such as axisP[0]+axisI[0] allowed).
        #[arg(long, value_delimiter = ',', required = true)]
        fields: Vec<String>,
        /// Output .png or .svg.
        #[arg(long)]
        out: PathBuf,
    },
    /// Two flights of one craft side by side, before (A) and after (B) a change: per axis the
    /// tracking response setpoint → gyro, the identified plant, the step and the gyro noise of
    /// both, the header settings that differ, and a verdict that names only differences beyond
    /// the estimates' uncertainty.
    Compare {
        /// Log A (before the change).
        a: PathBuf,
        /// Log B (after the change).
        b: PathBuf,
        /// Blackbox session of A (counted from 1); default: the longest.
        #[arg(long)]
        session_a: Option<usize>,
        /// Blackbox session of B (counted from 1); default: the longest.
        #[arg(long)]
        session_b: Option<usize>,
        /// Write compare.json, compare.txt and the figures (PNG and SVG) here.
        #[arg(long, default_value = "skyloop-compare")]
        out: PathBuf,
        /// Print the JSON object (as compare.json) instead of the summary.
        #[arg(long)]
        json: bool,
    },
}

fn open(file: &Path, session: Option<usize>) -> skyloop::Result<Log> {
    Ok(Log::open(
        file,
        &OpenOptions {
            session,
            ..Default::default()
        },
    )?)
}

/// Runs a `log` action.
pub fn run(a: Args) -> skyloop::Result<()> {
    match a.action {
        Action::Info { file, session, json } => info(&file, session, json),
        Action::Export {
            file,
            session,
            fields,
            out,
        } => {
            let log = open(&file, session)?;
            let rows = export_csv(&log, &fields, &out)?;
            eprintln!(
                "wrote {} ({rows} rows; time_s is the flight controller's clock: log time + {:.6} s, as identify's clock_origin_s)",
                out.display(),
                log.clock_origin_s
            );
            Ok(())
        }
        Action::Plot {
            file,
            session,
            fields,
            out,
        } => {
            let log = open(&file, session)?;
            let spans = plot_fields(&log, &fields, &out)?;
            eprintln!("wrote {} ({} airborne segments shaded)", out.display(), spans.len());
            Ok(())
        }
        Action::Compare {
            a,
            b,
            session_a,
            session_b,
            out,
            json,
        } => compare(&a, &b, session_a, session_b, &out, json),
    }
}

fn show_compare(stage: &str) {
    match crate::cmd::tune::spinner() {
        Some(b) => b.set_message(format!("compare: {stage}")),
        None => eprintln!("[compare] {stage} …"),
    }
}

/// Compares two logs, writes the outputs and prints the summary (or the JSON).
fn compare(
    a: &Path,
    b: &Path,
    session_a: Option<usize>,
    session_b: Option<usize>,
    out: &Path,
    json: bool,
) -> skyloop::Result<()> {
    let req = skyloop::compare::CompareRequest {
        a,
        b,
        session_a,
        session_b,
        progress: Some(show_compare),
    };
    let c = skyloop::compare::compare_logs(&req);
    if let Some(bar) = crate::cmd::tune::spinner() {
        bar.finish_and_clear();
    }
    let c = c?;
    let written = skyloop::compare::figures::write_outputs(&c, out)?;
    eprintln!(
        "wrote {} (compare.json, compare.txt, {} figures)",
        out.display(),
        written.len()
    );
    if json {
        return print_json(&c.to_json());
    }
    print!("{}", c.to_text());
    Ok(())
}

/// Reads the log and prints its summary.
fn info(file: &Path, session: Option<usize>, json: bool) -> skyloop::Result<()> {
    let file = file.to_path_buf();
    let log = open(&file, session)?;
    let bytes = if log.format == LogFormat::Blackbox {
        let bytes = std::fs::read(&file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
        debug_assert_eq!(detect(&bytes), LogFormat::Blackbox);
        Some(bytes)
    } else {
        None
    };
    if json {
        return print_json(&info_json(&file.display().to_string(), &log, bytes.as_deref()));
    }
    let tuning = FirmwareTuning::from_log(&log);
    let sessions = match &bytes {
        Some(b) => blackbox::sessions(b, &file.display().to_string()),
        None => Vec::new(),
    };
    let groups = log.info();
    println!("{}: {:?} log, {:.2} s", log.source, log.format, log.duration_s());
    for n in &log.notes {
        println!("note: {n}");
    }
    if !sessions.is_empty() {
        println!("sessions:");
        for s in sessions.iter().filter(|s| s.error.is_none()) {
            println!(
                "  {:>3}  {:>8} frames  {:>8.2} s  {:>7.1} Hz  {}",
                s.index, s.main_frames, s.duration_s, s.rate_hz, s.firmware
            );
        }
        // Sessions that hold nothing (a log started and stopped on the bench) in one line per
        // reason, not one line each: a flash dump can hold dozens.
        let mut reasons: Vec<(String, Vec<usize>)> = Vec::new();
        for s in &sessions {
            if let Some(e) = &s.error {
                let why = e
                    .split(": ")
                    .last()
                    .unwrap_or(e)
                    .replace(&format!("session {} ", s.index), "");
                match reasons.iter_mut().find(|(w, _)| *w == why) {
                    Some((_, ix)) => ix.push(s.index),
                    None => reasons.push((why, vec![s.index])),
                }
            }
        }
        for (why, ix) in reasons {
            println!("  not decodable ({why}): {} session(s): {}", ix.len(), ranges(&ix));
        }
    }
    if let Some(t) = &tuning {
        for line in skyloop::firmware::header_lines(t) {
            println!("{line}");
        }
    }
    for g in &groups {
        println!(
            "{}  ({} samples, {:.1} Hz, {:.2} s)",
            g.name, g.samples, g.rate_hz, g.duration_s
        );
        for f in &g.fields {
            println!("    {f}");
        }
    }
    Ok(())
}

/// Session numbers as ranges: "2, 3, 5–11, 13" → "2–3, 5–11, 13".
fn ranges(ix: &[usize]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut k = 0;
    while k < ix.len() {
        let mut j = k;
        while j + 1 < ix.len() && ix[j + 1] == ix[j] + 1 {
            j += 1;
        }
        out.push(if j > k {
            format!("{}–{}", ix[k], ix[j])
        } else {
            ix[k].to_string()
        });
        k = j + 1;
    }
    out.join(", ")
}
