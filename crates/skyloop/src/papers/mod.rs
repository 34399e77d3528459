//! The papers that define skyloop's first users, each reproduced by one call that re-derives the
//! paper's printed numbers and sets them beside ours.
//!
//! A reproduction returns a [`Reproduction`]: its [`Claim`]s (what the paper says, its value, ours,
//! the tolerance, the verdict), the notes printed between them, and the files it wrote. A claim that
//! does not hold is reported as not reproduced; a reproduction never says "all" unless all held.
//!
//! - [`bicopter`]: Li, Qin, Xu & Zhang, "Modeling, Identification, and Control of Non-minimum Phase
//!   Dynamics of Bi-copter UAVs", Section IV (H∞ loop shaping of the roll rate), with its comparison
//!   PID in [`bicopter_pid`] and Section V's flight tests in [`bicopter_flight`].
//! - [`quadrotor_ssi`]: Tai, Phang & Hoo (2018), "Steady-State Integral PI controller for the inner
//!   loop of multirotors".
//! - [`ducted_fan`]: Pross, "H∞ and μ-synthesis of a ducted-fan VTOL micro-UAV".

pub mod bicopter;
pub mod bicopter_flight;
pub mod bicopter_pid;
pub mod ducted_fan;
pub mod quadrotor_ssi;

use serde::Serialize;
use std::path::{Path, PathBuf};

use crate::error::Result;

/// One checked statement of a paper.
#[derive(Debug, Clone, Serialize)]
pub struct Claim {
    /// What the paper states, e.g. "Step 2: γ of ncfsyn with 3rd-order Padé".
    pub what: String,
    /// The paper's number, where it prints one.
    pub paper: Option<f64>,
    /// Ours, where the claim is a number.
    pub ours: Option<f64>,
    /// Allowed |ours − paper|, where the claim is a number.
    pub tolerance: Option<f64>,
    /// Whether the claim holds.
    pub reproduced: bool,
    /// The line as printed (for claims that are not a single number, the whole statement).
    pub line: String,
}

/// One line of a reproduction's printed account, in order.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "kind", content = "index_or_text", rename_all = "lowercase")]
pub enum Entry {
    /// Free text between the claims (a heading, a measured number that is not a claim).
    Note(String),
    /// The claim at this index of [`Reproduction::claims`].
    Claim(usize),
}

/// What a reproduction found.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Reproduction {
    /// Which paper (the `skyloop reproduce NAME` name).
    pub name: String,
    /// Every checked claim.
    pub claims: Vec<Claim>,
    /// The printed account: notes and claims in the order they were made.
    pub entries: Vec<Entry>,
    /// Files written (traces, figures, summaries, report.html).
    pub artifacts: Vec<PathBuf>,
    /// Named numbers the run measured on the way (γ, μ peaks, orders), for scripts and tests.
    pub values: Vec<(String, f64)>,
}

impl Reproduction {
    /// An empty reproduction of paper `name`.
    pub fn new(name: &str) -> Self {
        Reproduction {
            name: name.to_string(),
            ..Default::default()
        }
    }

    /// Adds a line of free text.
    pub fn note(&mut self, text: impl Into<String>) {
        self.entries.push(Entry::Note(text.into()));
    }

    /// Adds a claim that is a statement, not a single number.
    pub fn check(&mut self, reproduced: bool, line: String) {
        self.push(Claim {
            what: line.clone(),
            paper: None,
            ours: None,
            tolerance: None,
            reproduced,
            line,
        });
    }

    /// Adds a numeric claim: the paper's value against ours within ±`tol`.
    pub fn number(&mut self, what: &str, paper: f64, ours: f64, tol: f64) {
        let reproduced = (ours - paper).abs() <= tol;
        let line = format!("{what:<58} paper {paper:>10.4}   ours {ours:>10.4}   (tol ±{tol:.4})");
        self.push(Claim {
            what: what.to_string(),
            paper: Some(paper),
            ours: Some(ours),
            tolerance: Some(tol),
            reproduced,
            line,
        });
    }

    /// Adds a claim built elsewhere.
    pub fn push(&mut self, claim: Claim) {
        self.entries.push(Entry::Claim(self.claims.len()));
        self.claims.push(claim);
    }

    /// Records a measured number under `name`.
    pub fn measure(&mut self, name: &str, value: f64) {
        self.values.push((name.to_string(), value));
    }

    /// The number measured under `name`.
    pub fn value(&self, name: &str) -> Option<f64> {
        self.values.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }

    /// The first claim whose statement starts with `prefix`.
    pub fn claim(&self, prefix: &str) -> Option<&Claim> {
        self.claims.iter().find(|c| c.what.starts_with(prefix))
    }

    /// Records a file the reproduction wrote.
    pub fn artifact(&mut self, path: &Path) {
        self.artifacts.push(path.to_path_buf());
    }

    /// How many claims held.
    pub fn reproduced_count(&self) -> usize {
        self.claims.iter().filter(|c| c.reproduced).count()
    }

    /// The claims that did not hold.
    pub fn not_reproduced(&self) -> impl Iterator<Item = &Claim> {
        self.claims.iter().filter(|c| !c.reproduced)
    }

    /// The final line: "N of M claims reproduced, K not reproduced (see above)", or "all M claims
    /// reproduced" only when every claim held.
    pub fn summary_line(&self) -> String {
        let (n, m) = (self.reproduced_count(), self.claims.len());
        if n == m {
            format!("all {m} claims reproduced")
        } else {
            format!("{n} of {m} claims reproduced, {} not reproduced (see above)", m - n)
        }
    }

    /// The printed account, one line per entry, claims marked `[ok]` or `[not reproduced]`, ending
    /// with [`Self::summary_line`].
    pub fn lines(&self) -> Vec<String> {
        let mut out: Vec<String> = self
            .entries
            .iter()
            .map(|e| match e {
                Entry::Note(t) => t.clone(),
                Entry::Claim(i) => {
                    let c = &self.claims[*i];
                    format!("  [{}] {}", if c.reproduced { "ok" } else { "not reproduced" }, c.line)
                }
            })
            .collect();
        out.push(self.summary_line());
        out
    }
}

/// Writes `report.html` into `out`: the claims table (paper, ours, tolerance, verdict), every SVG
/// figure the run wrote, and the printed account; adds it to the artifacts.
///
/// # Errors
/// A figure that cannot be read back or a report that cannot be written.
pub fn write_report(rep: &mut Reproduction, title: &str, out: &Path) -> Result<()> {
    let mut doc = skyloop_plot::Report::new(title);
    let num = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v:.6}"));
    let sec = doc.section("Claims");
    sec.text(rep.summary_line());
    sec.table(
        &["claim", "paper", "ours", "tolerance", "verdict"],
        rep.claims
            .iter()
            .map(|c| {
                vec![
                    c.what.clone(),
                    num(c.paper),
                    num(c.ours),
                    // 6 significant digits: a tolerance derived as 0.5 % of 139.3 prints 0.6965, not 0.6965000000000001.
                    c.tolerance.map_or(String::new(), |t| format!("±{}", significant(t, 6))),
                    if c.reproduced { "reproduced" } else { "NOT reproduced" }.to_string(),
                ]
            })
            .collect(),
    );
    let figures: Vec<PathBuf> = rep
        .artifacts
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "svg"))
        .cloned()
        .collect();
    if !figures.is_empty() {
        let sec = doc.section("Figures");
        for p in &figures {
            let svg = std::fs::read_to_string(p).map_err(|e| crate::Error::read(p, e))?;
            let caption = p
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned());
            sec.blocks.push(skyloop_plot::report::Block::Svg { svg, caption });
        }
    }
    doc.section("Account")
        .blocks
        .push(skyloop_plot::report::Block::Pre(rep.lines().join("\n")));
    let path = out.join("report.html");
    doc.save(&path)?;
    rep.artifact(&path);
    Ok(())
}

/// The reproductions `reproduce` knows, by name.
pub const NAMES: [&str; 3] = ["bicopter", "quadrotor-ssi", "ducted-fan"];

/// Runs reproduction `name`, writing its traces, figures and report under `out`; `quick` uses
/// coarser grids and fewer iterations where the paper allows (the ducted fan).
pub fn reproduce(name: &str, out: &Path, quick: bool) -> Result<Reproduction> {
    match name {
        "quadrotor-ssi" => quadrotor_ssi::run(out),
        "ducted-fan" => ducted_fan::run(out, quick),
        "bicopter" => bicopter::run(out),
        other => Err(crate::Error::Input(format!(
            "unknown reproduction '{other}' (known: {})",
            NAMES.join(", ")
        ))),
    }
}

/// `x` rounded to `digits` significant digits, without trailing zeros (`0.6965000000000001` → `0.6965`).
fn significant(x: f64, digits: i32) -> String {
    if x == 0.0 || !x.is_finite() {
        return x.to_string();
    }
    let scale = 10f64.powi(digits - 1 - x.abs().log10().floor() as i32);
    ((x * scale).round() / scale).to_string()
}

#[cfg(test)]
mod tests {
    #[test]
    fn tolerances_print_with_six_significant_digits() {
        assert_eq!(super::significant(0.005 * 139.3, 6), "0.6965");
        assert_eq!(super::significant(0.005 * 232.4, 6), "1.162");
        assert_eq!(super::significant(352.05, 6), "352.05");
        assert_eq!(super::significant(0.0005, 6), "0.0005");
    }
}
