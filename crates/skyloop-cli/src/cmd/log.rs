//! `skyloop log info FILE`: topics/fields, rates and duration of a ULog, blackbox or CSV log.

use std::path::PathBuf;

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
        /// The log file (.ulg, blackbox .bbl/.bfl, or CSV).
        file: PathBuf,
        /// Blackbox session (counted from 1); default: the longest.
        #[arg(long)]
        session: Option<usize>,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// Reads the log and prints its summary.
pub fn run(a: Args) -> skyloop::Result<()> {
    let Action::Info { file, session, json } = a.action;
    let log = Log::open(
        &file,
        &OpenOptions {
            session,
            ..Default::default()
        },
    )?;
    let sessions = if log.format == LogFormat::Blackbox {
        let bytes = std::fs::read(&file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
        debug_assert_eq!(detect(&bytes), LogFormat::Blackbox);
        blackbox::sessions(&bytes, &file.display().to_string())
    } else {
        Vec::new()
    };
    let groups = log.info();
    if json {
        let v = serde_json::json!({
            "file": file.display().to_string(),
            "format": format!("{:?}", log.format).to_lowercase(),
            "duration_s": log.duration_s(),
            "notes": log.notes,
            "groups": groups,
            "sessions": sessions,
        });
        return print_json(&v);
    }
    println!("{}: {:?} log, {:.2} s", log.source, log.format, log.duration_s());
    for n in &log.notes {
        println!("note: {n}");
    }
    if !sessions.is_empty() {
        println!("sessions:");
        for s in &sessions {
            match &s.error {
                None => println!(
                    "  {:>3}  {:>8} frames  {:>8.2} s  {:>7.1} Hz  {}",
                    s.index, s.main_frames, s.duration_s, s.rate_hz, s.firmware
                ),
                Some(e) => println!("  {:>3}  not decodable: {e}", s.index),
            }
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
