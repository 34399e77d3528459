//! The files of a proposal from a log: the proposal's own, plus the flown and proposed tunes side
//! by side (Bode and Nyquist plots of L, predicted steps beside the steps measured in the log, the
//! 6-DOF doublets, noise and filter figures) in a report.html that opens with the verdict.

use super::{goal_row, loop_grid_hz, write_data_files};
use crate::design::report::{bode_data, response};
use crate::error::Result;
use crate::tune::flight::FlightCheck;
use crate::tune::log::{LogTuneOutcome, TuneAnalysis};
use crate::tune::noise::NoiseReport;
use crate::tune::verdict::pct;
use skyloop_lti::c64;
use skyloop_plot::bode::{bode_figure_marked, BodeMarks, BodeOptions};
use skyloop_plot::figure::Figure;
use skyloop_plot::nyquist::{nyquist_figure, NyquistData};
use skyloop_plot::traces::{traces_figure, Trace, TracePanel};
use skyloop_plot::Report;
use std::path::Path;

/// A tune's name in the figures ("flown", "proposed") and its analysis.
type Tunes<'a> = Vec<(&'a str, &'a TuneAnalysis)>;

/// Writes the files of [`super::write_outputs`] (for the proposal), plus current-vs-proposed Bode
/// and Nyquist plots of L, the predicted steps of both beside the step deconvolved from the log,
/// the 6-DOF doublets, and a report.html that puts the two tunes side by side.
///
/// # Errors
/// A file that cannot be written or a response that cannot be evaluated.
pub fn write_log_outputs(out: &LogTuneOutcome, dir: &Path) -> Result<()> {
    write_data_files(dir, &out.proposed, &out.to_json())?;
    let mut tunes: Tunes = Vec::new();
    if let Some(c) = &out.current {
        tunes.push(("flown", c));
    }
    tunes.push(("proposed", &out.proposed_analysis));
    let (bode, nyquist) = loop_figures(out, &tunes)?;
    let step = step_figure(out, &tunes);
    let flight = flight_figure(&tunes);
    bode.save(&dir.join("loop_bode.png"))?;
    let mut rep = Report::new(format!("skyloop tune, {}: flown and proposed gains", out.axis.name()));
    verdict_section(&mut rep, out);
    noise_and_filter_sections(&mut rep, out);
    plant_section(&mut rep, out);
    if let Some(fig) = super::segments::segments_section(&mut rep, out) {
        fig.save(&dir.join("flight_segments.svg"))?;
    }
    if let Some(fig) = crossover_section(&mut rep, out) {
        fig.save(&dir.join("crossover_check.svg"))?;
    }
    comparison_section(&mut rep, out);
    proposal_section(&mut rep, out);
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

/// The flown loop where its margins are decided: |S| and |T| around the flown crossover on the
/// plant the flight measured (with its ±2σ band) beside the model's, so a claim that the flown tune
/// is near instability shows its measured evidence (or the lack of it) next to the prediction.
fn crossover_section(rep: &mut Report, out: &LogTuneOutcome) -> Option<Figure> {
    use skyloop_plot::figure::{Band, Marker, Panel, Series};
    let c = out.crossover_check.as_ref()?;
    let (m, mf, me) = c.measured_peak();
    let (p, pf) = c.predicted_peak();
    let mut s_panel = Panel::frequency("|S| [dB]");
    s_panel.title = "sensitivity S = 1/(1 + L): disturbance amplification; its peak is 1/(distance of L to −1)".into();
    let two = |sign: f64| -> Vec<f64> {
        c.measured_s_db
            .iter()
            .zip(&c.measured_s_err_db)
            .map(|(v, e)| v + sign * 2.0 * e)
            .collect()
    };
    s_panel.bands.push(Band {
        label: "measured ±2σ".into(),
        x: c.freq_hz.clone(),
        lower: two(-1.0),
        upper: two(1.0),
        color: 0,
    });
    // Measured (solid) and model (dashed) curves in the same two colours on both panels.
    let pair = |panel: &mut Panel, measured: &[f64], predicted: &[f64]| {
        let f = c.freq_hz.clone();
        panel
            .series
            .push(Series::line("measured plant, flown controller", f.clone(), measured.to_vec()).colored(0));
        panel
            .series
            .push(Series::dashed("identified model, flown controller", f, predicted.to_vec()).colored(1));
    };
    pair(&mut s_panel, &c.measured_s_db, &c.predicted_s_db);
    s_panel.markers.push(Marker::Vertical {
        x: c.crossover_hz,
        label: format!("flown crossover {:.1} Hz", c.crossover_hz),
    });
    let mut t_panel = Panel::frequency("|T| [dB]");
    pair(&mut t_panel, &c.measured_t_db, &c.predicted_t_db);
    let fig = Figure::new(
        "The flown loop at its crossover: measured plant against the model",
        vec![s_panel, t_panel],
    );
    let sec = rep.section("The flown loop at its crossover");
    sec.text(format!(
        "Half to twice the flown crossover ({:.1} Hz), the flown feedback controller (the firmware's arithmetic, known exactly) closed around the plant this flight measured, point by point (the setpoint-instrument estimate, {} points with a random error of at most {:.0} %), and around the identified model. |S| peaks at {m:.1} ± {me:.1} dB ({mf:.1} Hz) on the measured plant and at {p:.1} dB ({pf:.1} Hz) on the model: {}.",
        c.crossover_hz,
        c.freq_hz.len(),
        100.0 * crate::tune::model_check::CROSSOVER_POINT_ERR_MAX,
        if c.disagrees() {
            "they disagree, so the model is wrong where the margins are decided and no proposal is made from it"
        } else {
            "they agree within the measurement's error, so the flight itself shows the margins the model claims"
        }
    ));
    sec.figure(
        fig.clone(),
        "|S| and |T| of the flown tune: solid on the measured plant (shaded ±2σ), dashed on the identified model.",
    );
    Some(fig)
}

/// Bode and Nyquist plots of L for each tune, both tunes' crossovers and phase margins marked in
/// their curve's colour.
///
/// # Errors
/// A loop whose response cannot be evaluated.
fn loop_figures(out: &LogTuneOutcome, tunes: &Tunes) -> Result<(Figure, Figure)> {
    let f_hz = loop_grid_hz(&out.proposed)?;
    let plant = response(&out.proposed.loop_plant, &f_hz)?;
    let mut bode_series = Vec::new();
    let mut nyq = Vec::new();
    for (name, t) in tunes {
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
        &BodeOptions::default(),
    );
    let nyquist = nyquist_figure("Nyquist plot of L, flown and proposed", &nyq, Some(3.0));
    Ok((bode, nyquist))
}

/// Setpoint → gyro steps: each tune's prediction, the step deconvolved from the log and the causal
/// FIR fit's.
fn step_figure(out: &LogTuneOutcome, tunes: &Tunes) -> Figure {
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
    traces_figure(
        "Setpoint → gyro step",
        &[TracePanel {
            y_label: "gyro per unit setpoint".into(),
            traces,
            references: vec![(1.0, "setpoint".into())],
        }],
    )
}

/// The 6-DOF roll-rate doublets of each tune with their setpoint (None when none was flown).
fn flight_figure(tunes: &Tunes) -> Option<Figure> {
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
    if flight_traces.is_empty() {
        return None;
    }
    let sp = tunes.iter().find_map(|(_, t)| t.flight.as_ref()).map(|f| Trace {
        label: "setpoint".into(),
        t: f.t_s.clone(),
        y: f.setpoint_deg_s.clone(),
    });
    Some(traces_figure(
        "Roll-rate doublets flown in the 6-DOF quadrotor (motor lag and saturation, gyro noise and delay)",
        &[TracePanel {
            y_label: "roll rate [deg/s]".into(),
            traces: sp.into_iter().chain(flight_traces).collect(),
            references: Vec::new(),
        }],
    ))
}

/// The noise figure (when the log's gyro was analysed) and the D-term filter chain (when
/// `--tune-filters` changed it).
fn noise_and_filter_sections(rep: &mut Report, out: &LogTuneOutcome) {
    if let Some(n) = &out.noise {
        rep.section("Noise").figure(
            noise_figure(n),
            format!(
                "The logged gyro's spectrum and the PID output it makes through each tune's C_fb (predicted; the logged D term beside it where logged). Motor noise is compared over {:.0}–{:.0} Hz: proposed/flown power {:.2}{}.",
                n.band_hz.0,
                n.band_hz.1,
                n.ratio(),
                n.budget
                    .map(|b| format!(" (budget {b:.2}: the dashed line is the flown output times it; the proposal's total must stay under it, and with a raised filter cutoff each octave too)"))
                    .unwrap_or_default()
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
        let mut reasons: Vec<&str> = out.filter_changes.iter().map(|c| c.reason.as_str()).collect();
        reasons.dedup();
        let why = reasons.join(" / ");
        rep.section("Filters").figure(
            fig,
            format!("The gyro lowpass and D-term chains flown (dashed) and proposed (--tune-filters; a changed gyro lowpass is de-embedded from the identified plant: P·G_new/G_flown): {text}. Why: {why}."),
        );
    }
}

/// The identified plant's parameters with 1σ errors, the firmware's filters and every warning.
fn plant_section(rep: &mut Report, out: &LogTuneOutcome) {
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
}

/// `x × k` with `d` decimals, "-" when absent.
fn opt(x: Option<f64>, k: f64, d: usize) -> String {
    x.map(|v| format!("{:.*}", d, k * v)).unwrap_or_else(|| "-".into())
}

/// Doublet `i` of a tune's 6-DOF flight as one line, "-" when not flown.
fn doublet_line(t: &TuneAnalysis, i: usize) -> String {
    t.flight.as_ref().map_or_else(
        || "-".into(),
        |f: &FlightCheck| {
            let d = &f.doublets[i];
            format!(
                "overshoot {:.1} %, rise {} ms, RMS error {:.1} deg/s, saturated {:.1} %{}",
                d.overshoot_pct,
                opt(d.rise_time_s, 1e3, 1),
                d.rms_error_deg_s,
                100.0 * d.saturated_fraction,
                if f.crashed { ", CRASHED" } else { "" }
            )
        },
    )
}

/// The model checks as lines: the predicted flown step against the deconvolved and the causal
/// steps of the log.
fn model_check_rows(out: &LogTuneOutcome) -> [(&'static str, String); 2] {
    let deconvolved = match (&out.measured_step, out.model_step_rms) {
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
    };
    let causal = match (&out.causal_step, out.causal_step_rms) {
        (Some(cs), Some(r)) => format!(
            "RMS(predicted current step − causal FIR step) = {r:.3}; the future setpoint explains {:.0} % of the fit's residual",
            100.0 * cs.acausal_fraction
        ),
        _ => "no causal step (too little data, or no current tune)".into(),
    };
    [("model check", deconvolved), ("model check (causal fit)", causal)]
}

/// Flown against proposed, row by row: gains, margins nominal and worst case, noise gain, the
/// predicted step, the 6-DOF doublets and hover, and the model checks.
fn comparison_section(rep: &mut Report, out: &LogTuneOutcome) {
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
    let mut rows: Vec<(&str, String)> = vec![
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
        ("6-DOF doublet 200 deg/s", both(&|t| doublet_line(t, 0))),
        ("6-DOF doublet 500 deg/s", both(&|t| doublet_line(t, 1))),
        (
            "6-DOF hover: RMS of the roll output from gyro noise (1 deg/s)",
            both(&|t| {
                t.flight
                    .as_ref()
                    .map_or_else(|| "-".into(), |f| format!("{:.4}", f.hover_output_rms))
            }),
        ),
    ];
    rows.extend(model_check_rows(out));
    sec.key_values(&rows);
}

/// The proposal: the firmware lines, every goal re-verified, the defaults assumed and the notes.
fn proposal_section(rep: &mut Report, out: &LogTuneOutcome) {
    let p = &out.proposed;
    let sec = rep.section("Proposal");
    let mut rows: Vec<(&str, String)> = Vec::new();
    let cli = p.cli.join("; ");
    if !cli.is_empty() {
        rows.push(("firmware lines", cli));
    }
    for g in &p.goals {
        rows.push(("goal", goal_row(g)));
    }
    for d in &p.defaults {
        rows.push(("default", d.clone()));
    }
    for n in p.notes.iter().chain(&out.notes) {
        rows.push(("note", n.clone()));
    }
    sec.key_values(&rows);
}

/// The report's first section: the verdict, the gains flown / proposed / change in rows, the
/// predicted motor noise and the trade-off front.
fn verdict_section(rep: &mut Report, out: &LogTuneOutcome) {
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
                f.map(|x| pct(v, x)).unwrap_or_default(),
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
            rows.push(vec![name.into(), format!("{a:.3}"), format!("{b:.3}"), pct(b, a)]);
        }
    }
    if let Some(n) = &out.noise {
        rows.push(vec![
            format!("motor noise {:.0}–{:.0} Hz (relative)", n.band_hz.0, n.band_hz.1),
            "1".into(),
            format!("{:.2}", n.ratio()),
            pct(n.ratio(), 1.0),
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

/// The gyro and D-term lowpass chains' gain and phase, flown against proposed (None without
/// filter changes).
fn filter_figure(out: &LogTuneOutcome) -> Option<skyloop_plot::figure::Figure> {
    use crate::tune::filter_tuning::chain_response;
    use skyloop_plot::figure::{Figure, Panel, Series};
    let pf = out.proposed_filters.as_ref()?;
    let f: Vec<f64> = (0..300).map(|k| 10f64.powf(0.5 + 2.3 * f64::from(k) / 299.0)).collect();
    let mut gain = Panel::frequency("gain [dB]");
    let mut phase = Panel::frequency("phase [deg]");
    let chains = [("gyro lowpass", &pf.gyro, 2), ("D-term chain", &pf.dterm, 0)];
    for (what, (a, b), c) in chains
        .into_iter()
        .filter(|(_, (a, b), _)| !(a.is_empty() && b.is_empty()))
    {
        for (when, chain, dashed) in [("flown", a, true), ("proposed", b, false)] {
            let r: Vec<(f64, f64)> = f.iter().map(|&x| chain_response(chain, x)).collect();
            let label = format!("{what}, {when}");
            let mk = |y: Vec<f64>| {
                if dashed {
                    Series::dashed(label.clone(), f.clone(), y).colored(c)
                } else {
                    Series::line(label.clone(), f.clone(), y).colored(c)
                }
            };
            gain.series.push(mk(r.iter().map(|x| x.0).collect()));
            phase.series.push(mk(r.iter().map(|x| x.1).collect()));
        }
    }
    Some(Figure::new("Filter chains, flown and proposed", vec![gain, phase]))
}

/// The noise spectra in dB: gyro, predicted PID output of both tunes, the logged D term.
fn noise_figure(n: &NoiseReport) -> skyloop_plot::figure::Figure {
    use skyloop_plot::figure::{Figure, Panel, Series};
    let db = |v: &[f64]| v.iter().map(|x| 10.0 * x.max(1e-30).log10()).collect::<Vec<_>>();
    let sp = &n.spectra;
    let mut panel = Panel::frequency("PSD [dB re unit²/Hz]");
    panel
        .series
        .push(Series::line("gyro (logged)", sp.freq_hz.clone(), db(&sp.gyro)).colored(2));
    if !sp.gyro_proposed.is_empty() {
        panel.series.push(
            Series::dashed(
                "gyro behind the proposed gyro lowpass (predicted)",
                sp.freq_hz.clone(),
                db(&sp.gyro_proposed),
            )
            .colored(2),
        );
    }
    panel
        .series
        .push(Series::line("PID output, flown (predicted)", sp.freq_hz.clone(), db(&sp.flown)).colored(0));
    panel
        .series
        .push(Series::line("PID output, proposed (predicted)", sp.freq_hz.clone(), db(&sp.proposed)).colored(1));
    // The budget over the noise band: the flown tune's PID output times the accepted ratio.
    if let Some(b) = n.budget {
        let (f, y): (Vec<f64>, Vec<f64>) = sp
            .freq_hz
            .iter()
            .zip(&sp.flown)
            .filter(|(f, _)| (n.band_hz.0..=n.band_hz.1).contains(*f))
            .map(|(f, p)| (*f, 10.0 * (b * p).max(1e-30).log10()))
            .unzip();
        panel.series.push(
            Series::dashed(
                format!("noise budget: flown × {b:.2}, {:.0}–{:.0} Hz", n.band_hz.0, n.band_hz.1),
                f,
                y,
            )
            .colored(0),
        );
    }
    if sp.dterm.len() == sp.freq_hz.len() {
        panel
            .series
            .push(Series::line("D term, flown (logged)", sp.freq_hz.clone(), db(&sp.dterm)).colored(4));
    }
    Figure::new("Noise: the logged gyro and the PID output it makes", vec![panel])
}
