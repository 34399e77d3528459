//! The files of a tuning proposal: the CLI lines, the JSON, the controllers (LTI JSON), the Bode
//! and Nyquist plots of L and the closed-loop step (SVG, the Bode plot also as PNG), report.html.

use super::TuneOutcome;
use crate::design::report::{bode_data, response, write_json};
use crate::error::{Error, Result};
use skyloop_lti::freqresp::{dynamics_range, logspace};
use skyloop_lti::interconnect::{feedback, series};
use skyloop_lti::json::LtiJson;
use skyloop_lti::{c64, Mat, StateSpace};
use skyloop_plot::bode::{bode_figure, bode_figure_marked, BodeMarks};
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
    std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    let cli_path = dir.join("cli.txt");
    std::fs::write(&cli_path, out.cli.join("\n") + "\n").map_err(|e| Error::write(&cli_path, e))?;
    write_json(&dir.join("tune.json"), &out.to_json())?;
    write_json(
        &dir.join("feedback_controller.json"),
        &LtiJson::from_ss(&out.feedback_controller),
    )?;

    let (lo, hi) = dynamics_range(&series(&out.feedback_controller, &out.loop_plant)?)?;
    let f_hz = logspace((lo / 20.0).log10() - 1.0, (hi / 6.0).log10() + 0.5, 800);
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
        rows.push((
            "goal",
            format!(
                "{}: {:.5} ({})",
                g.label,
                g.value,
                if g.met { "met" } else { "NOT met" }
            ),
        ));
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

/// The files of a proposal from a log: those of [`write_outputs`] (for the proposal), plus
/// current-vs-proposed Bode and Nyquist plots of L, the predicted steps of both beside the step
/// deconvolved from the log, and a report.html that puts the two tunes side by side.
///
/// # Errors
/// A file that cannot be written or a response that cannot be evaluated.
pub fn write_log_outputs(out: &super::log::LogTuneOutcome, dir: &Path) -> Result<()> {
    use super::log::TuneAnalysis;
    std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    let p = &out.proposed;
    let cli_path = dir.join("cli.txt");
    std::fs::write(&cli_path, p.cli.join("\n") + "\n").map_err(|e| Error::write(&cli_path, e))?;
    write_json(&dir.join("tune.json"), &out.to_json())?;
    write_json(
        &dir.join("feedback_controller.json"),
        &LtiJson::from_ss(&p.feedback_controller),
    )?;
    let (lo, hi) = dynamics_range(&series(&p.feedback_controller, &p.loop_plant)?)?;
    let f_hz = logspace((lo / 20.0).log10() - 1.0, (hi / 6.0).log10() + 0.5, 800);
    let plant = response(&p.loop_plant, &f_hz)?;
    let mut tunes: Vec<(&str, &TuneAnalysis)> = Vec::new();
    if let Some(c) = &out.current {
        tunes.push(("flown", c));
    }
    tunes.push(("proposed", &out.proposed_analysis));
    let mut bode_series = Vec::new();
    let mut nyq = Vec::new();
    for (name, t) in &tunes {
        let c = response(&t.feedback_controller, &f_hz)?;
        let l: Vec<c64> = plant.iter().zip(&c).map(|(a, b)| a * b).collect();
        bode_series.push(bode_data(&format!("L {name}"), &f_hz, &l));
        nyq.push(NyquistData {
            label: format!("L {name}"),
            re: l.iter().map(|z| z.re).collect(),
            im: l.iter().map(|z| z.im).collect(),
        });
    }
    let fin = |x: f64| x.is_finite().then_some(x);
    // Both tunes' crossovers and margins, each in its curve's colour.
    let marks: Vec<BodeMarks> = tunes
        .iter()
        .map(|(_, t)| {
            let m = &t.margins;
            BodeMarks {
                crossover_hz: fin(m.crossover_hz),
                gain_margin: None,
                phase_margin: fin(m.phase_margin_deg).zip(fin(m.crossover_hz)),
                ..BodeMarks::default()
            }
        })
        .collect();
    let bode = bode_figure_marked(
        "Loop transfer L = P·C_fb, flown and proposed (identified plant, exact delay)",
        &bode_series,
        &marks,
        &skyloop_plot::bode::BodeOptions::default(),
    );
    let nyquist = nyquist_figure("Nyquist plot of L, flown and proposed", &nyq, Some(3.0));
    let mut traces: Vec<Trace> = tunes
        .iter()
        .map(|(name, t)| Trace {
            label: format!("predicted, {name}"),
            t: t.step_t_s.clone(),
            y: t.step_y.clone(),
        })
        .collect();
    if let Some(ms) = &out.measured_step {
        traces.push(Trace {
            label: format!("deconvolved from the log ({} windows)", ms.windows),
            t: ms.t_s.clone(),
            y: ms.y.clone(),
        });
    }
    if let Some(cs) = &out.causal_step {
        traces.push(Trace {
            label: "causal FIR fit to the log".into(),
            t: cs.t_s.clone(),
            y: cs.y.clone(),
        });
    }
    let step = traces_figure(
        "Setpoint → gyro step",
        &[TracePanel {
            y_label: "gyro per unit setpoint".into(),
            traces,
            references: vec![(1.0, "setpoint".into())],
        }],
    );
    let flight_traces: Vec<Trace> = tunes
        .iter()
        .filter_map(|(name, t)| {
            t.flight.as_ref().map(|f| Trace {
                label: format!("6-DOF, {name}"),
                t: f.t_s.clone(),
                y: f.rate_deg_s.clone(),
            })
        })
        .collect();
    let flight = (!flight_traces.is_empty()).then(|| {
        let sp = tunes.iter().find_map(|(_, t)| t.flight.as_ref()).map(|f| Trace {
            label: "setpoint".into(),
            t: f.t_s.clone(),
            y: f.setpoint_deg_s.clone(),
        });
        traces_figure(
            "Roll-rate doublets flown in the 6-DOF quadrotor (motor lag and saturation, gyro noise and delay)",
            &[TracePanel {
                y_label: "roll rate [deg/s]".into(),
                traces: sp.into_iter().chain(flight_traces).collect(),
                references: Vec::new(),
            }],
        )
    });
    bode.save(&dir.join("loop_bode.png"))?;
    let mut rep = Report::new(format!("skyloop tune, {}: flown and proposed gains", out.axis.name()));
    verdict_section(&mut rep, out);
    if let Some(n) = &out.noise {
        rep.section("Noise").figure(
            noise_figure(n),
            format!(
                "The logged gyro's spectrum and the PID output it makes through each tune's C_fb (predicted; the logged D term beside it where logged). Motor noise is compared over {:.0}–{:.0} Hz: proposed/flown power {:.2}.",
                n.band_hz.0,
                n.band_hz.1,
                n.ratio()
            ),
        );
    }
    if let Some(fig) = filter_figure(out) {
        let text = out
            .filter_changes
            .iter()
            .map(|c| format!("{} {} → {} Hz", c.name, c.flown_hz, c.proposed_hz))
            .collect::<Vec<_>>()
            .join(", ");
        let why = out.filter_changes.first().map(|c| c.reason.clone()).unwrap_or_default();
        rep.section("Filters").figure(
            fig,
            format!("The D-term filter chain flown and proposed (--tune-filters): {text}. Why: {why}."),
        );
    }
    let sec = rep.section("Identified plant");
    let mut rows: Vec<(&str, String)> = out
        .params
        .iter()
        .map(|(k, (v, s))| ("parameter", format!("{k} = {v:.6} ± {s:.6} (1σ)")))
        .collect();
    for f in &out.filters {
        rows.push(("filter", f.clone()));
    }
    for w in &out.identification.warnings {
        rows.push(("identification warning", w.clone()));
    }
    for w in &out.warnings {
        rows.push(("WARNING", w.clone()));
    }
    sec.key_values(&rows);
    let sec = rep.section("Flown vs proposed");
    let cur = out.current.as_ref();
    let pro = &out.proposed_analysis;
    let both = |f: &dyn Fn(&TuneAnalysis) -> String| {
        format!(
            "flown {}  |  proposed {}",
            cur.map(f).unwrap_or_else(|| "-".into()),
            f(pro)
        )
    };
    let opt = |x: Option<f64>, k: f64, d: usize| x.map(|v| format!("{:.*}", d, k * v)).unwrap_or_else(|| "-".into());
    let fl = |t: &TuneAnalysis, f: &dyn Fn(&super::flight::FlightCheck) -> String| {
        t.flight.as_ref().map(f).unwrap_or_else(|| "-".into())
    };
    let doublet = |i: usize| {
        move |t: &TuneAnalysis| {
            fl(t, &|f| {
                let d = &f.doublets[i];
                format!(
                    "overshoot {:.1} %, rise {} ms, RMS error {:.1} deg/s, saturated {:.1} %{}",
                    d.overshoot_pct,
                    opt(d.rise_time_s, 1e3, 1),
                    d.rms_error_deg_s,
                    100.0 * d.saturated_fraction,
                    if f.crashed { ", CRASHED" } else { "" }
                )
            })
        }
    };
    let rows: Vec<(&str, String)> = vec![
        ("gains", both(&|t| t.gains.to_string())),
        ("disk margin α", both(&|t| format!("{:.3}", t.margins.disk_alpha))),
        (
            "disk margin α, worst over the uncertainty",
            both(&|t| format!("{:.3}", t.worst.disk_alpha)),
        ),
        (
            "gain margin [dB]",
            both(&|t| format!("{:.2}", t.margins.gain_margin_db)),
        ),
        (
            "phase margin [deg]",
            both(&|t| format!("{:.1}", t.margins.phase_margin_deg)),
        ),
        ("crossover [Hz]", both(&|t| format!("{:.2}", t.margins.crossover_hz))),
        ("Ms", both(&|t| format!("{:.3}", t.margins.ms))),
        (
            "Ms, worst over the uncertainty",
            both(&|t| format!("{:.3}", t.worst.ms)),
        ),
        (
            "noise gain max |C_fb| above the noise frequency",
            both(&|t| format!("{:.4}", t.noise_gain)),
        ),
        ("step rise time 10–90 % [ms]", both(&|t| opt(t.rise_time_s, 1e3, 1))),
        ("step overshoot [%]", both(&|t| opt(t.overshoot_pct, 1.0, 1))),
        ("6-DOF doublet 200 deg/s", both(&doublet(0))),
        ("6-DOF doublet 500 deg/s", both(&doublet(1))),
        (
            "6-DOF hover: RMS of the roll output from gyro noise (1 deg/s)",
            both(&|t| fl(t, &|f| format!("{:.4}", f.hover_output_rms))),
        ),
        (
            "model check",
            match (&out.measured_step, out.model_step_rms) {
                (Some(ms), Some(r)) => format!(
                    "RMS(predicted current step − deconvolved step) = {r:.3} over {:.2} s, {} of {} windows; {:.0} % of the deconvolved impulse response at negative lag",
                    ms.t_s.last().copied().unwrap_or(0.0),
                    ms.windows,
                    ms.windows_total,
                    100.0 * ms.acausal_fraction
                ),
                (Some(ms), None) => format!("deconvolved step from {} windows; no current tune", ms.windows),
                (None, _) => format!(
                    "no deconvolved step: {}",
                    out.measured_step_error.as_deref().unwrap_or("")
                ),
            },
        ),
        (
            "model check (causal fit)",
            match (&out.causal_step, out.causal_step_rms) {
                (Some(cs), Some(r)) => format!(
                    "RMS(predicted current step − causal FIR step) = {r:.3}; the future setpoint explains {:.0} % of the fit's residual",
                    100.0 * cs.acausal_fraction
                ),
                _ => "no causal step (too little data, or no current tune)".into(),
            },
        ),
    ];
    sec.key_values(&rows);
    let sec = rep.section("Proposal");
    let mut rows: Vec<(&str, String)> = Vec::new();
    let cli = p.cli.join("; ");
    if !cli.is_empty() {
        rows.push(("firmware lines", cli));
    }
    for g in &p.goals {
        rows.push((
            "goal",
            format!(
                "{}: {:.5} ({})",
                g.label,
                g.value,
                if g.met { "met" } else { "NOT met" }
            ),
        ));
    }
    for d in &p.defaults {
        rows.push(("default", d.clone()));
    }
    for n in p.notes.iter().chain(&out.notes) {
        rows.push(("note", n.clone()));
    }
    sec.key_values(&rows);
    let sec = rep.section("Frequency and time responses");
    for (name, fig, caption) in [
        ("loop_bode", bode, "L of both tunes with the identified plant's exact delay and the loop's hold; the proposal's PM marked."),
        ("loop_nyquist", nyquist, "Nyquist plot of L (zoomed to radius 3 around the origin)."),
        ("step", step, "Setpoint → gyro: predicted for both tunes (P and I on the error, D on the gyro, F on the setpoint; delay as Padé order 6) and the step measured in the log two ways: deconvolved as PID-Analyzer does (biased short when the pilot corrects what the craft does) and by a causal FIR fit (the setpoint's past only), the model check's reference."),
    ] {
        fig.save(&dir.join(format!("{name}.svg")))?;
        sec.figure(fig, caption);
    }
    if let Some(fig) = flight {
        fig.save(&dir.join("flight_6dof.svg"))?;
        sec.figure(
            fig,
            "The gains flown in skyloop-sim's 6-DOF quadrotor matched to the identified model (motor lag τ, gyro delay Td, output limit at full differential thrust, 1 deg/s gyro noise); setpoint moves ramp over 25 ms.",
        );
    }
    rep.save(&dir.join("report.html"))?;
    Ok(())
}

/// The report's first section: the verdict, the gains flown / proposed / change in rows, the
/// predicted motor noise and the trade-off front.
fn verdict_section(rep: &mut Report, out: &super::log::LogTuneOutcome) {
    let sec = rep.section("Verdict");
    sec.text(out.verdict.text.clone());
    let rows_of = |g: &serde_json::Value| -> Vec<(String, f64)> {
        g.as_object()
            .map(|m| m.iter().filter_map(|(k, v)| Some((k.clone(), v.as_f64()?))).collect())
            .unwrap_or_default()
    };
    let flown = out.current.as_ref().map(|c| rows_of(&c.gains)).unwrap_or_default();
    let mut rows: Vec<Vec<String>> = rows_of(&out.proposed_analysis.gains)
        .into_iter()
        .map(|(k, v)| {
            let f = flown.iter().find(|(n, _)| *n == k).map(|x| x.1);
            vec![
                k.to_uppercase(),
                f.map(|x| x.to_string()).unwrap_or_else(|| "-".into()),
                v.to_string(),
                f.map(|x| super::verdict::pct(v, x)).unwrap_or_default(),
            ]
        })
        .collect();
    if let Some(c) = &out.current {
        let p = &out.proposed_analysis;
        for (name, a, b) in [
            ("crossover [Hz]", c.margins.crossover_hz, p.margins.crossover_hz),
            ("disk margin α", c.margins.disk_alpha, p.margins.disk_alpha),
            ("disk α, worst case", c.worst.disk_alpha, p.worst.disk_alpha),
            (
                "phase margin [deg]",
                c.margins.phase_margin_deg,
                p.margins.phase_margin_deg,
            ),
        ] {
            rows.push(vec![
                name.into(),
                format!("{a:.3}"),
                format!("{b:.3}"),
                super::verdict::pct(b, a),
            ]);
        }
    }
    if let Some(n) = &out.noise {
        rows.push(vec![
            format!("motor noise {:.0}–{:.0} Hz (relative)", n.band_hz.0, n.band_hz.1),
            "1".into(),
            format!("{:.2}", n.ratio()),
            super::verdict::pct(n.ratio(), 1.0),
        ]);
    }
    sec.table(&["", "flown", "proposed", "change"], rows);
    if let Some(n) = out.notes.iter().find(|n| n.starts_with("d_min ")) {
        sec.text(format!("D: {n}; the change of D is against the header's d."));
    }
    if !out.front.is_empty() {
        sec.text("Trade-off front within the bounded change (screened on the frequency grid):");
        sec.table(
            &["gains", "crossover [Hz]", "disk α", "worst α", "noise ×"],
            out.front
                .iter()
                .map(|(g, sc, r)| {
                    vec![
                        g.to_string(),
                        format!("{:.1}", sc.crossover_hz),
                        format!("{:.2}", sc.alpha),
                        format!("{:.2}", sc.alpha_worst),
                        format!("{r:.2}"),
                    ]
                })
                .collect(),
        );
    }
}

/// The D-term chain's gain and phase, flown against proposed (None without filter changes).
fn filter_figure(out: &super::log::LogTuneOutcome) -> Option<skyloop_plot::figure::Figure> {
    use super::filter_tuning::{dterm_response, proposed_filters};
    use skyloop_plot::figure::{Figure, Panel, Series};
    let flown = &out.live.as_ref()?.flown;
    let proposed = proposed_filters(flown, &out.filter_changes)?;
    let f: Vec<f64> = (0..300).map(|k| 10f64.powf(0.5 + 2.3 * f64::from(k) / 299.0)).collect();
    let resp = |g| f.iter().map(|&x| dterm_response(g, x)).collect::<Vec<_>>();
    let (a, b) = (resp(flown), resp(&proposed));
    let mut gain = Panel::frequency("gain [dB]");
    let mut phase = Panel::frequency("phase [deg]");
    for (label, r, c) in [("flown", &a, 0), ("proposed", &b, 1)] {
        gain.series
            .push(Series::line(label, f.clone(), r.iter().map(|x| x.0).collect()).colored(c));
        phase
            .series
            .push(Series::line(label, f.clone(), r.iter().map(|x| x.1).collect()).colored(c));
    }
    Some(Figure::new("D-term filter chain", vec![gain, phase]))
}

/// The noise spectra in dB: gyro, predicted PID output of both tunes, the logged D term.
fn noise_figure(n: &super::noise::NoiseReport) -> skyloop_plot::figure::Figure {
    use skyloop_plot::figure::{Figure, Panel, Series};
    let db = |v: &[f64]| v.iter().map(|x| 10.0 * x.max(1e-30).log10()).collect::<Vec<_>>();
    let sp = &n.spectra;
    let mut panel = Panel::frequency("PSD [dB re unit²/Hz]");
    panel
        .series
        .push(Series::line("gyro (logged)", sp.freq_hz.clone(), db(&sp.gyro)).colored(2));
    panel
        .series
        .push(Series::line("PID output, flown (predicted)", sp.freq_hz.clone(), db(&sp.flown)).colored(0));
    panel
        .series
        .push(Series::line("PID output, proposed (predicted)", sp.freq_hz.clone(), db(&sp.proposed)).colored(1));
    if sp.dterm.len() == sp.freq_hz.len() {
        panel
            .series
            .push(Series::line("D term, flown (logged)", sp.freq_hz.clone(), db(&sp.dterm)).colored(3));
    }
    Figure::new("Noise: the logged gyro and the PID output it makes", vec![panel])
}
