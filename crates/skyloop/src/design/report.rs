//! The files and figures of a design: controllers (LTI JSON), SOS coefficients, the summary, the
//! plots of the bicopter paper's Fig. 9–12 (C full vs reduced, L with margins, S and T, 1/|T|), a
//! closed-loop step, and report.html.

use super::{DesignResult, StageSummary};
use crate::error::{Error, Result};
use skyloop_lti::freqresp::{logspace, unwrap_rad, FreqEvaluator};
use skyloop_lti::interconnect::{feedback, series};
use skyloop_lti::json::LtiJson;
use skyloop_lti::{c64, Mat, StateSpace};
use skyloop_plot::bode::{bode_figure, BodeData, BodeMarks};
use skyloop_plot::traces::{traces_figure, Trace, TracePanel};
use skyloop_plot::{Figure, Marker, Panel, Report, Series};
use std::f64::consts::PI;
use std::path::Path;

/// `x` with `prec` decimals, or "-" when absent.
pub fn fmt_opt(x: Option<f64>, prec: usize) -> String {
    x.map_or("-".into(), |v| format!("{v:.prec$}"))
}

pub(crate) fn write_json<T: serde::Serialize>(path: &Path, v: &T) -> Result<()> {
    let s = serde_json::to_string_pretty(v)?;
    std::fs::write(path, s).map_err(|e| Error::write(path, e))
}

/// Frequency responses of SISO models on a grid (Hz).
pub(crate) fn response(sys: &StateSpace, f_hz: &[f64]) -> Result<Vec<c64>> {
    let ev = FreqEvaluator::new(sys)?;
    f_hz.iter()
        .map(|f| Ok(ev.eval(c64::new(0.0, 2.0 * PI * f))?[(0, 0)]))
        .collect()
}

pub(crate) fn db(v: &[c64]) -> Vec<f64> {
    v.iter().map(|z| 20.0 * z.norm().log10()).collect()
}

pub(crate) fn bode_data(label: &str, f_hz: &[f64], v: &[c64]) -> BodeData {
    let ph: Vec<f64> = v.iter().map(|z| z.arg()).collect();
    BodeData {
        label: label.into(),
        freq_hz: f_hz.to_vec(),
        mag_db: db(v),
        phase_deg: unwrap_rad(&ph).into_iter().map(f64::to_degrees).collect(),
    }
}

fn marks(st: &StageSummary) -> BodeMarks {
    let m = &st.margins;
    let fin = |x: f64| x.is_finite().then_some(x);
    BodeMarks {
        crossover_hz: fin(m.crossover_hz),
        gain_margin: fin(m.gain_margin_db).zip(fin(m.gain_margin_freq_hz)),
        phase_margin: fin(m.phase_margin_deg).zip(fin(m.crossover_hz)),
    }
}

/// The plots of the paper's Fig. 9–12 and a closed-loop step, as figures.
/// The plots of the paper's Fig. 9–12 and a closed-loop step: (file stem, figure, caption).
///
/// # Errors
/// A response that cannot be evaluated.
pub fn figures(r: &DesignResult) -> Result<Vec<(String, Figure, String)>> {
    let f_hz = logspace(-2.0, 2.3, 600);
    let final_c = r.final_continuous();
    let final_stage = r.summary.stages.last().ok_or("no design step ran")?;
    let mut controllers: Vec<(&str, &StateSpace)> = vec![("full controller", &r.full)];
    if let Some(c) = &r.reduced {
        controllers.push(("reduced controller", c));
    }
    let mut out = Vec::new();

    // Fig. 9: the controllers.
    let data: Vec<BodeData> = controllers
        .iter()
        .map(|(n, c)| Ok(bode_data(n, &f_hz, &response(c, &f_hz)?)))
        .collect::<Result<_>>()?;
    out.push((
        "controller".to_string(),
        bode_figure("Controller C: full vs reduced", &data, &BodeMarks::default()),
        "Full-order (boosted) and reduced controllers (paper Fig. 9).".to_string(),
    ));

    // Fig. 10: L = P·C with the exact delay.
    let p = response(&r.plant, &f_hz)?;
    let mut ldata = Vec::new();
    let mut lfinal = Vec::new();
    for (n, c) in &controllers {
        let cv = response(c, &f_hz)?;
        let l: Vec<c64> = p.iter().zip(&cv).map(|(a, b)| a * b).collect();
        ldata.push(bode_data(&format!("L with {n}"), &f_hz, &l));
        lfinal = l;
    }
    out.push((
        "loop".to_string(),
        bode_figure("Loop transfer L = P·C", &ldata, &marks(final_stage)),
        format!(
            "Loop transfer with the exact plant delay (paper Fig. 10); margins marked for the final controller: PM {:.2}° at {:.3} Hz, GM {:.2} dB.",
            final_stage.margins.phase_margin_deg, final_stage.margins.crossover_hz, final_stage.margins.gain_margin_db
        ),
    ));

    // Fig. 11–12: S, T and the allowed multiplicative uncertainty 1/|T|.
    let s: Vec<c64> = lfinal.iter().map(|l| 1.0 / (1.0 + l)).collect();
    let t: Vec<c64> = lfinal.iter().map(|l| l / (1.0 + l)).collect();
    let mut sens = Panel::frequency("magnitude [dB]");
    sens.title = "Sensitivity S = 1/(1+L) and complementary sensitivity T = L/(1+L)".into();
    sens.series.push(Series::line("|S|", f_hz.clone(), db(&s)).colored(0));
    sens.series.push(Series::line("|T|", f_hz.clone(), db(&t)).colored(1));
    sens.markers.push(Marker::Horizontal {
        y: 0.0,
        label: String::new(),
    });
    out.push((
        "sensitivity".to_string(),
        Figure::new("Sensitivities of the final loop", vec![sens]),
        "S and T of the final loop (paper Fig. 11–12).".to_string(),
    ));
    let mut unc = Panel::frequency("1/|T| [dB]");
    unc.title = "Allowed multiplicative uncertainty |Δ| < 1/|T| (paper eq. (13))".into();
    unc.series.push(Series::line(
        "1/|T|",
        f_hz.clone(),
        t.iter().map(|z| -20.0 * z.norm().log10()).collect(),
    ));
    unc.markers.push(Marker::Horizontal {
        y: 0.0,
        label: "|Δ| = 1".into(),
    });
    out.push((
        "uncertainty".to_string(),
        Figure::new("Robust stability to multiplicative uncertainty", vec![unc]),
        "P(1+Δ)·C stays stable for any |Δ(jω)| below this curve (paper eq. (13)).".to_string(),
    ));

    // Closed-loop step of T with the Padé plant (a delay inside a loop has no state-space form).
    let l = series(final_c, &r.plant_rational)?;
    let one = StateSpace::gain(Mat::identity(1, 1), 0.0)?;
    let cl = feedback(&l, &one, -1.0)?;
    let grid = skyloop_lti::timeresp::auto_grid(&cl, None)?;
    let st = skyloop_lti::timeresp::step(&cl, Some(&grid))?;
    let panel = TracePanel {
        y_label: "output y".into(),
        traces: vec![Trace {
            label: "y for r = 1 (final controller)".into(),
            t: st.t_s.clone(),
            y: st.y[0][0].clone(),
        }],
        references: vec![(1.0, "r".into())],
    };
    out.push((
        "step".to_string(),
        traces_figure("Closed-loop step response T = PC/(1+PC)", &[panel]),
        "Unit reference step through the final continuous controller (plant delay as its Padé approximant)."
            .to_string(),
    ));
    Ok(out)
}

/// Writes the controllers, SOS coefficients, summary.json, one SVG per figure and report.html to `dir`.
///
/// # Errors
/// A directory or file that cannot be written, or a response that cannot be evaluated.
pub fn write_outputs(r: &DesignResult, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    write_json(&dir.join("controller_full.json"), &LtiJson::from_ss(&r.full))?;
    if let Some(c) = &r.reduced {
        write_json(&dir.join("controller_reduced.json"), &LtiJson::from_ss(c))?;
    }
    if let Some(c) = &r.discrete {
        write_json(&dir.join("controller_discrete.json"), &LtiJson::from_ss(c))?;
    }
    if let Some(s) = &r.sos {
        write_json(&dir.join("controller_sos.json"), s)?;
    }
    write_json(&dir.join("summary.json"), &r.summary)?;
    let figs = figures(r)?;
    let s = &r.summary;
    let title = if s.name.is_empty() {
        "skyloop design"
    } else {
        s.name.as_str()
    };
    let mut rep = Report::new(title);
    let sec = rep.section("Summary");
    let mut rows: Vec<(&str, String)> = vec![
        ("method", s.method.clone()),
        ("γ_min", fmt_opt(s.gamma_min, 6)),
        ("boost gain", format!("{:.6}", s.boost_gain)),
        ("crossover [Hz]", format!("{:.4}", s.limits.crossover_hz)),
        ("RHP-zero limit |z|/2 [Hz]", fmt_opt(s.limits.rhp_zero_limit_hz, 4)),
        ("delay limit 1/θ [Hz]", fmt_opt(s.limits.delay_limit_hz, 4)),
    ];
    if let Some(d) = &s.discrete {
        rows.push(("Tustin rate [Hz]", format!("{}", d.rate_hz)));
        rows.push((
            "Tustin vs continuous, max error",
            format!(
                "{:.3} dB, {:.2}° up to {} Hz",
                d.vs_continuous.max_mag_error_db, d.vs_continuous.max_phase_error_deg, d.vs_continuous.to_hz
            ),
        ));
    }
    sec.key_values(&rows);
    sec.blocks.push(skyloop_plot::report::Block::Table {
        header: [
            "step",
            "order",
            "γ",
            "b(P,C)",
            "PM [deg]",
            "crossover [Hz]",
            "GM [dB]",
            "disk α",
        ]
        .iter()
        .map(|h| h.to_string())
        .collect(),
        rows: s
            .stages
            .iter()
            .map(|st| {
                vec![
                    st.stage.clone(),
                    st.order.to_string(),
                    fmt_opt(st.gamma, 4),
                    format!("{:.4}", st.ncf_margin),
                    format!("{:.2}", st.margins.phase_margin_deg),
                    format!("{:.4}", st.margins.crossover_hz),
                    format!("{:.3}", st.margins.gain_margin_db),
                    format!("{:.4}", st.margins.disk_alpha),
                ]
            })
            .collect(),
    });
    let sec = rep.section("Frequency and time responses");
    for (name, fig, caption) in figs {
        let path = dir.join(format!("{name}.svg"));
        fig.save(&path)?;
        sec.figure(fig, caption);
    }
    let path = dir.join("report.html");
    rep.save(&path)?;
    Ok(())
}
