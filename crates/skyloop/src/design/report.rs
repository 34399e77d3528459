//! The files and figures of a design: controllers (LTI JSON), SOS coefficients, the summary, the
//! plots of the bicopter paper's Fig. 9–12 (C full vs reduced, L with margins, S and T, 1/|T|), a
//! closed-loop step, and report.html.

use super::loop_metrics::LoopMargins;
use super::{DesignResult, StageSummary};
use crate::error::{Error, Result};
use skyloop_lti::freqresp::{logspace, unwrap_rad, FreqEvaluator};
use skyloop_lti::interconnect::series;
use skyloop_lti::json::LtiJson;
use skyloop_lti::{c64, StateSpace};
use skyloop_plot::bode::{bode_figure, BodeData, BodeMarks};
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

/// What the loop plot marks: the crossover the phase margin is read at, the gain margin, and every
/// further gain crossover with its phase margin (a later one can set the delay margin).
fn marks(m: &LoopMargins) -> BodeMarks {
    let fin = |x: f64| x.is_finite().then_some(x);
    let main = fin(m.crossover_hz);
    let other_crossovers = m
        .gain_crossovers_hz
        .iter()
        .zip(&m.phase_margins_deg)
        .filter(|(f, _)| main.is_none_or(|c| (**f - c).abs() > 1e-9 * c.abs()))
        .map(|(f, pm)| (*pm, *f))
        .collect();
    BodeMarks {
        crossover_hz: main,
        gain_margin: fin(m.gain_margin_db).zip(fin(m.gain_margin_freq_hz)),
        phase_margin: fin(m.phase_margin_deg).zip(main),
        other_crossovers,
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
        bode_figure("Loop transfer L = P·C", &ldata, &marks(&final_stage.margins)),
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

    // Closed-loop step of T = L/(1+L) with the exact plant delay (a delay-line simulation), with
    // its stepinfo marks, on a window fitted to the dominant dynamics.
    let l = crate::figures::Labeled::new("y for r = 1 (final controller)", series(final_c, &r.plant)?);
    let (mut fig, runs) = crate::figures::step(std::slice::from_ref(&l), true, None)?;
    fig.title = "Closed-loop step response T = PC/(1+PC)".into();
    let info = &runs[0].info[0][0];
    out.push((
        "step".to_string(),
        fig,
        format!(
            "Unit reference step through the final continuous controller, exact plant delay: rise {} s, 2 % settling {} s, overshoot {} %.",
            fmt_opt(info.rise_time_s, 3),
            fmt_opt(info.settling_time_s, 3),
            fmt_opt(info.overshoot_pct, 1)
        ),
    ));
    Ok(out)
}

/// One row of the per-step table: every number in the unit its header names.
fn stage_row(st: &StageSummary) -> Vec<String> {
    let m = &st.margins;
    let crossings = if m.gain_crossovers_hz.is_empty() {
        "none".to_string()
    } else {
        m.gain_crossovers_hz
            .iter()
            .zip(&m.phase_margins_deg)
            .map(|(f, pm)| format!("{f:.3} ({pm:.1})"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let at = |v: f64, f: f64, p: usize| {
        if v.is_finite() {
            format!("{v:.p$} at {f:.3}")
        } else {
            "∞".to_string()
        }
    };
    let inf_or = |v: f64, p: usize| {
        if v.is_finite() {
            format!("{v:.p$}")
        } else {
            "∞".into()
        }
    };
    vec![
        st.stage.clone(),
        st.order.to_string(),
        fmt_opt(st.gamma, 4),
        format!("{:.4}", st.ncf_margin),
        at(m.phase_margin_deg, m.crossover_hz, 2),
        crossings,
        at(m.gain_margin_db, m.gain_margin_freq_hz, 2),
        inf_or(1e3 * m.delay_margin_s, 1),
        format!("{:.3}", m.disk_alpha),
        format!("{} / +{}", inf_or(m.disk_gain_db[0], 2), inf_or(m.disk_gain_db[1], 2)),
        format!("±{}", inf_or(m.disk_phase_deg, 1)),
        format!("{:.3}", m.ms),
        format!("{:.3}", m.mt),
        if m.stable { "yes".into() } else { "NO".into() },
    ]
}

/// What the report's quantities mean, for a reviewer who does not use them every day.
fn glossary() -> Vec<(&'static str, String)> {
    [
        ("L, S, T", "loop transfer L = P·C; sensitivity S = 1/(1+L) (disturbance → output); complementary sensitivity T = L/(1+L) (reference → output, and the noise path)"),
        ("γ", "the H∞ norm the synthesis reached: for loop shaping the 4-block norm of the shaped loop, for mixed sensitivity the weighted closed-loop norm; smaller is better, 1/γ is a robustness margin"),
        ("b(P,C)", "the normalized-coprime-factor stability margin (MATLAB ncfmargin), 0 to 1: the loop stays stable for every plant within this ν-gap distance of P. For the shaped plant W2·P·W1 that ncfsyn designs, b = 1/γ, and above about 0.25 (γ below 4) is a good design; for the unweighted loop P·C here b is usually much smaller (the weights' gain and lag are in it), so a small b(P,C) beside a good γ is not a contradiction: γ judges the shaped design, b(P,C) the tolerance of the real loop to plant error in the ν-gap sense"),
        ("PM, GM", "classic phase and gain margins (MATLAB margin), read at the gain and phase crossovers with the exact delay"),
        ("gain crossovers", "every frequency where |L| = 1; a loop that crosses 0 dB again above the first crossover has the delay margin set by the highest one"),
        ("delay margin", "the extra loop delay that makes the loop unstable: the smallest PM/ω over all gain crossovers"),
        ("disk α", "the symmetric disk margin (MATLAB diskmargin): the loop tolerates simultaneous gain and phase changes inside a disk of size α; it is shown as the equivalent gain range (dB) and phase (±deg)"),
        ("Ms, Mt", "the peaks of |S| and |T|; 1/Ms is the shortest distance of L to −1; Ms ≤ 2 (6 dB) guarantees GM ≥ 6 dB and PM ≥ 29°, Ms ≤ 1.4 is a robust tune"),
        ("reduced vs full", "the largest relative difference of the reduced controller from the full one over the band around crossover"),
        ("Tustin error", "the discrete controller C(e^{jωT}) against C(jω); the prewarped comparison isolates rounding from Tustin's frequency warping"),
    ]
    .into_iter()
    .map(|(k, v)| (k, v.to_string()))
    .collect()
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
    for n in &s.notes {
        sec.text(format!("Note: {n}"));
    }
    sec.text(
        "Margins after each design step, read on the loop L = P·C with the exact plant delay. \
         Frequencies in Hz, times in ms, gains in dB, phases in degrees; Ms and Mt absolute (see the glossary).",
    );
    sec.blocks.push(skyloop_plot::report::Block::Table {
        header: [
            "step",
            "order",
            "γ",
            "b(P,C)",
            "PM [deg] at [Hz]",
            "all gain crossovers [Hz] (PM [deg])",
            "GM [dB] at [Hz]",
            "delay margin [ms]",
            "disk α",
            "disk gain [dB]",
            "disk phase [deg]",
            "Ms",
            "Mt",
            "stable",
        ]
        .iter()
        .map(|h| h.to_string())
        .collect(),
        rows: s.stages.iter().map(stage_row).collect(),
    });
    let sec = rep.section("Controller");
    let fc = r.final_continuous();
    let zpk = crate::model::expressions(fc, crate::model::Form::Zpk)?;
    sec.text(format!(
        "Final continuous controller C(s), {} states, as zeros, poles and gain (parseable by every skyloop command):",
        fc.nx()
    ));
    sec.blocks.push(skyloop_plot::report::Block::Pre(
        zpk.iter().map(|row| row.join("    ")).collect::<Vec<_>>().join("\n"),
    ));
    let mut errs: Vec<(&str, String)> = Vec::new();
    if let Some(c) = &s.reduced_vs_full {
        errs.push((
            "reduced vs full controller",
            format!(
                "max {:.1} % ({:.3} dB, {:.2}°) over {:.3}–{:.3} Hz; balanced-truncation bound {}",
                100.0 * c.max_rel_error,
                c.max_mag_error_db,
                c.max_phase_error_deg,
                c.from_hz,
                c.to_hz,
                fmt_opt(s.reduction_error_bound, 4)
            ),
        ));
    }
    if let Some(d) = &s.discrete {
        let c = &d.vs_continuous;
        errs.push((
            "Tustin vs continuous controller",
            format!(
                "max {:.1} % ({:.3} dB, {:.2}°) up to {} Hz at {} Hz sampling; against the prewarped map {:.1e} (rounding only)",
                100.0 * c.max_rel_error,
                c.max_mag_error_db,
                c.max_phase_error_deg,
                c.to_hz,
                d.rate_hz,
                d.vs_warped.max_rel_error
            ),
        ));
    }
    if !errs.is_empty() {
        sec.key_values(&errs);
    }
    let sec = rep.section("Frequency and time responses");
    for (name, fig, caption) in figs {
        let path = dir.join(format!("{name}.svg"));
        fig.save(&path)?;
        sec.figure(fig, caption);
    }
    let sec = rep.section("Glossary");
    sec.key_values(&glossary());
    let path = dir.join("report.html");
    rep.save(&path)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_plot::layout::BoxKind;

    /// An integrator over a lightly damped resonance whose numerator is damped 25× more: |L| falls
    /// through 1 near 1.6 Hz, rises over 1 again on the resonance near 9.5 Hz and falls back, three
    /// gain crossovers. The loop plot marks every one with its phase margin, in boxes the renderer
    /// actually placed.
    #[test]
    fn the_loop_plot_marks_every_gain_crossover() {
        let p = skyloop_lti::expr::parse_model("10*(s^2+60*s+3600)/(s*(s^2+2.4*s+3600))").unwrap();
        let c = StateSpace::gain(skyloop_lti::Mat::identity(1, 1), 0.0).unwrap();
        let m = super::super::loop_metrics::loop_margins(&p, &c).unwrap();
        assert_eq!(m.gain_crossovers_hz.len(), 3, "{:?}", m.gain_crossovers_hz);
        let f_hz = logspace(-2.0, 2.3, 600);
        let data = bode_data("L", &f_hz, &response(&p, &f_hz).unwrap());
        let layout = bode_figure("L", &[data], &marks(&m)).layout().unwrap();
        let labels: Vec<&str> = layout.of(BoxKind::Label).map(|b| b.text.as_str()).collect();
        for (f, pm) in m.gain_crossovers_hz.iter().zip(&m.phase_margins_deg) {
            let at = skyloop_plot::bode::hz(*f);
            assert!(
                labels.contains(&format!("crossover {at}").as_str()),
                "{at} not in {labels:?}"
            );
            assert!(
                labels.contains(&format!("PM {pm:.1}° at {at}").as_str()),
                "PM at {at} not in {labels:?}"
            );
        }
        assert_eq!(layout.collisions(), vec![], "{}", layout.describe_collisions());
    }
}
