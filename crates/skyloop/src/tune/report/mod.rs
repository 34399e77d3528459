//! The files of a tuning proposal: the CLI lines, the JSON, the controllers (LTI JSON), the Bode
//! and Nyquist plots of L and the closed-loop step (SVG, the Bode plot also as PNG), report.html.

mod from_log;
mod segments;

pub use from_log::write_log_outputs;

use super::{GoalReport, TuneOutcome};
use crate::design::report::{bode_data, response, write_json};
use crate::error::{Error, Result};
use skyloop_lti::freqresp::{dynamics_range, logspace};
use skyloop_lti::interconnect::{feedback, series};
use skyloop_lti::json::LtiJson;
use skyloop_lti::{c64, Mat, StateSpace};
use skyloop_plot::bode::{bode_figure, BodeMarks};
use skyloop_plot::nyquist::{nyquist_figure, NyquistData};
use skyloop_plot::traces::{traces_figure, Trace, TracePanel};
use skyloop_plot::Report;
use std::path::Path;

/// Writes cli.txt, tune.json, feedback_controller.json, loop_bode.svg/.png, loop_nyquist.svg,
/// step.svg and report.html to `dir`.
///
/// # Errors
/// A file that cannot be written or a response that cannot be evaluated.
pub fn write_outputs(out: &TuneOutcome, dir: &Path) -> Result<()> {
    write_data_files(dir, out, &out.to_json())?;
    let f_hz = loop_grid_hz(out)?;
    let p = response(&out.loop_plant, &f_hz)?;
    let c = response(&out.feedback_controller, &f_hz)?;
    let l: Vec<c64> = p.iter().zip(&c).map(|(a, b)| a * b).collect();
    let m = &out.margins;
    let fin = |x: f64| x.is_finite().then_some(x);
    let bode = bode_figure(
        "Loop transfer L = P·C_fb (proposed gains, exact delay)",
        &[bode_data("L", &f_hz, &l), bode_data("C_fb", &f_hz, &c)],
        &BodeMarks {
            crossover_hz: fin(m.crossover_hz),
            gain_margin: None,
            phase_margin: fin(m.phase_margin_deg).zip(fin(m.crossover_hz)),
            ..BodeMarks::default()
        },
    );
    let nyq = nyquist_figure(
        "Nyquist plot of L",
        &[NyquistData {
            label: "L".into(),
            re: l.iter().map(|z| z.re).collect(),
            im: l.iter().map(|z| z.im).collect(),
        }],
        Some(3.0),
    );
    // Step of the closed loop through C_fb with the Padé plant (a delay inside a loop has no
    // state-space form): y/r for a setpoint filtered like the measurement.
    let lr = series(&out.feedback_controller, &out.loop_plant.try_pade(6)?)?;
    let one = StateSpace::gain(Mat::identity(1, 1), 0.0)?;
    let cl = feedback(&lr, &one, -1.0)?;
    let grid = skyloop_lti::timeresp::auto_grid(&cl, None)?;
    let st = skyloop_lti::timeresp::step(&cl, Some(&grid))?;
    let step = traces_figure(
        "Closed-loop step, error feedback through C_fb",
        &[TracePanel {
            y_label: "output y".into(),
            traces: vec![Trace {
                label: "y for r = 1".into(),
                t: st.t_s.clone(),
                y: st.y[0][0].clone(),
            }],
            references: vec![(1.0, "r".into())],
        }],
    );
    bode.save(&dir.join("loop_bode.png"))?;
    let mut rep = Report::new("skyloop tune: proposed gains");
    let sec = rep.section("Proposal");
    let mut rows: Vec<(&str, String)> = vec![
        ("gains", out.gains.to_string()),
        ("disk margin α", format!("{:.4}", m.disk_alpha)),
        ("gain margin [dB]", format!("{:.3}", m.gain_margin_db)),
        ("phase margin [deg]", format!("{:.2}", m.phase_margin_deg)),
        ("crossover [Hz]", format!("{:.4}", m.crossover_hz)),
        ("Ms", format!("{:.4}", m.ms)),
    ];
    let cli = out.cli.join("\n");
    if !cli.is_empty() {
        rows.push(("firmware lines", cli));
    }
    for d in &out.defaults {
        rows.push(("default", d.clone()));
    }
    for n in &out.notes {
        rows.push(("note", n.clone()));
    }
    for g in &out.goals {
        rows.push(("goal", goal_row(g)));
    }
    sec.key_values(&rows);
    let sec = rep.section("Frequency and time responses");
    for (name, fig, caption) in [
        (
            "loop_bode",
            bode,
            "L and C_fb with the exact plant delay and the loop's hold; PM marked.",
        ),
        (
            "loop_nyquist",
            nyq,
            "Nyquist plot of L (zoomed to radius 3 around the origin).",
        ),
        (
            "step",
            step,
            "Unit setpoint step with error feedback (plant delay as Padé order 6).",
        ),
    ] {
        fig.save(&dir.join(format!("{name}.svg")))?;
        sec.figure(fig, caption);
    }
    let path = dir.join("report.html");
    rep.save(&path)?;
    Ok(())
}

/// Writes the proposal's data files to `dir` (created if missing): cli.txt (the firmware lines),
/// tune.json (`json`, the `tune --json` document) and feedback_controller.json (C_fb as LTI JSON).
///
/// # Errors
/// A directory or file that cannot be written.
fn write_data_files(dir: &Path, out: &TuneOutcome, json: &serde_json::Value) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    let cli_path = dir.join("cli.txt");
    std::fs::write(&cli_path, out.cli.join("\n") + "\n").map_err(|e| Error::write(&cli_path, e))?;
    write_json(&dir.join("tune.json"), json)?;
    write_json(
        &dir.join("feedback_controller.json"),
        &LtiJson::from_ss(&out.feedback_controller),
    )
}

/// The frequency grid of the loop plots, Hz: a decade below to half a decade above the dynamics of
/// the proposal's L = P·C_fb.
///
/// # Errors
/// A loop whose dynamics cannot be evaluated.
fn loop_grid_hz(out: &TuneOutcome) -> Result<Vec<f64>> {
    let (lo, hi) = dynamics_range(&series(&out.feedback_controller, &out.loop_plant)?)?;
    Ok(logspace((lo / 20.0).log10() - 1.0, (hi / 6.0).log10() + 0.5, 800))
}

/// A goal as the report prints it: label, value and whether it is met.
fn goal_row(g: &GoalReport) -> String {
    format!(
        "{}: {:.5} ({})",
        g.label,
        g.value,
        if g.met { "met" } else { "NOT met" }
    )
}
