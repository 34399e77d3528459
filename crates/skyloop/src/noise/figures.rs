//! The noise picture's figures and files: per axis the spectra (with the peaks marked), the
//! spectrograms against throttle and time (heatmaps with a colour bar, motor harmonics overlaid
//! where eRPM is logged), the gyro chain's Bode plot; `noise.json`, `noise.txt` and `report.html`.

use super::{AxisNoise, ChainResponse, Heat, NoiseAnalysis};
use crate::design::report::write_json;
use crate::error::{Error, Result};
use skyloop_plot::heatmap::{Heatmap, Overlay};
use skyloop_plot::report::Block;
use skyloop_plot::{Figure, Marker, Panel, Report, Series};
use std::path::Path;

/// The label of a named spectrum in a legend.
fn spectrum_label(name: &str) -> &'static str {
    match name {
        "gyro" => "gyro (logged, filtered)",
        "gyro_raw" => "gyro raw (before the filters)",
        "gyro_predicted" => "flown chain on the raw gyro",
        "gyro_what_if" => "gyro, what-if chain",
        "dterm" => "D term (logged)",
        "dterm_what_if" => "D term, what-if chain",
        "motors" => "motor commands (mean of motors)",
        _ => "other",
    }
}

/// The spectra of one axis: gyro (raw, logged, predicted, what-if) above, D term and motors below;
/// linear frequency, as pilots read noise; the peaks marked.
pub fn spectra_figure(a: &AxisNoise, units: [&str; 3]) -> Figure {
    let mut gyro = Panel {
        title: format!("{} gyro PSD", a.axis.name()),
        x_label: "frequency [Hz]".into(),
        y_label: format!("PSD [dB re 1 ({})²/Hz]", units[0]),
        ..Panel::default()
    };
    let mut other = Panel {
        title: format!("{} D term and motor commands PSD", a.axis.name()),
        x_label: "frequency [Hz]".into(),
        y_label: "PSD [dB re 1 unit²/Hz]".into(),
        ..Panel::default()
    };
    for (k, (name, v)) in a.spectra.iter().enumerate() {
        let label = spectrum_label(name);
        let s = if name.ends_with("what_if") || *name == "gyro_predicted" {
            Series::dashed(label, a.freq_hz.clone(), v.clone())
        } else {
            Series::line(label, a.freq_hz.clone(), v.clone())
        }
        .colored(k);
        if name.starts_with("gyro") {
            gyro.series.push(s);
        } else {
            other.series.push(s);
        }
    }
    for p in a.peaks.iter().take(4) {
        gyro.markers.push(Marker::Vertical {
            x: p.freq_hz,
            label: format!("{:.0} Hz {}", p.freq_hz, p.kind),
        });
    }
    let mut panels = vec![gyro];
    if !other.series.is_empty() {
        panels.push(other);
    }
    Figure::new(
        format!(
            "{} noise spectra (Welch, {} frames)",
            a.axis.name(),
            a.by_time.frames.iter().sum::<usize>()
        ),
        panels,
    )
}

/// The gyro chain's Bode plot: flown and what-if, gain and phase.
pub fn chain_figure(a: &AxisNoise) -> Figure {
    let mut gain = Panel::frequency("gain [dB]");
    let mut phase = Panel::frequency("phase [deg]");
    phase.y_degrees = true;
    let mut add = |name: &str, c: &ChainResponse, k: usize| {
        gain.series
            .push(Series::line(name, c.freq_hz.clone(), c.gain_db.clone()).colored(k));
        phase
            .series
            .push(Series::line(name, c.freq_hz.clone(), c.phase_deg.clone()).colored(k));
    };
    add("flown gyro chain", &a.gyro_chain, 0);
    if let Some(w) = &a.what_if_chain {
        add("what-if gyro chain", w, 1);
    }
    for (f, d) in &a.gyro_chain.delay_ms_at {
        phase.markers.push(Marker::Vertical {
            x: *f,
            label: format!("{d:.2} ms"),
        });
    }
    gain.title = format!("{} gyro filter chain at the flight's median throttle", a.axis.name());
    Figure::new(
        "gyro filter chain (firmware's discrete filters at the loop rate)",
        vec![gain, phase],
    )
}

/// A spectrogram as a heatmap, with the motor harmonics where eRPM is logged.
pub fn heatmap(a: &AxisNoise, h: &Heat, x_label: &str, what: &str, unit: &str) -> Heatmap {
    let rows: Vec<usize> = (0..h.x.len()).filter(|&i| h.frames[i] > 0).collect();
    let overlays = (1..=3)
        .filter_map(|k| {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .filter_map(|&i| h.motor_hz[i].map(|m| (h.x[i], m * k as f64)))
                .collect();
            (pts.len() >= 2).then(|| Overlay {
                label: format!("motor ×{k}"),
                points: pts,
            })
        })
        .collect();
    Heatmap {
        title: format!(
            "{} {what} against {}",
            a.axis.name(),
            x_label.split(' ').next().unwrap_or("x")
        ),
        x_label: x_label.into(),
        y_label: "frequency [Hz]".into(),
        colorbar_label: format!("PSD [dB re 1 ({unit})²/Hz]"),
        x: rows.iter().map(|&i| h.x[i]).collect(),
        y: h.freq_hz.clone(),
        z: rows.iter().map(|&i| h.psd_db[i].clone()).collect(),
        overlays,
        y_max: None,
        z_range: None,
    }
}

/// Writes `noise.json`, `noise.txt`, per axis `<axis>_spectra.png`, `<axis>_throttle.png`,
/// `<axis>_time.png`, `<axis>_chain.png`, and `report.html` into `dir`.
///
/// # Errors
/// A folder or file that cannot be written, or a figure without data.
pub fn write_outputs(out: &NoiseAnalysis, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    write_json(&dir.join("noise.json"), &out.to_json())?;
    let txt = dir.join("noise.txt");
    std::fs::write(&txt, out.to_text()).map_err(|e| Error::write(&txt, e))?;
    let mut rep = Report::new(format!("Noise: {}", out.source));
    rep.section("Flight and filters").text(format!(
        "{} — {:.1} s airborne in {} frames of {:.3} s at {:.0} Hz; the firmware's filters run at {:.0} Hz.",
        out.firmware, out.airborne_s, out.frames, out.frame_s, out.log_rate_hz, out.loop_hz
    ));
    let mut rows: Vec<Vec<String>> = out
        .flown
        .stages
        .iter()
        .map(|s| vec!["flown".into(), s.describe()])
        .collect();
    if let Some((_, changes)) = &out.what_if {
        rows.extend(changes.iter().map(|c| vec!["what-if change".into(), c.clone()]));
    }
    rep.section("Filter chain").table(&["", "stage"], rows);
    let what = if out.raw_gyro.is_some() {
        "raw gyro"
    } else {
        "gyro (logged, after the filters)"
    };
    for a in &out.axes {
        let name = a.axis.name();
        let spectra = spectra_figure(a, out.units);
        spectra.save(&dir.join(format!("{name}_spectra.png")))?;
        let chain = chain_figure(a);
        chain.save(&dir.join(format!("{name}_chain.png")))?;
        let by_thr = heatmap(a, &a.by_throttle, "throttle [%]", what, out.units[0]);
        let by_time = heatmap(a, &a.by_time, "time [s]", what, out.units[0]);
        let mut svgs = Vec::new();
        for ((h, heat), file) in [(&by_thr, &a.by_throttle), (&by_time, &a.by_time)]
            .into_iter()
            .zip(["throttle", "time"])
        {
            if heat.x.is_empty() {
                rep.section(format!("{name}: spectrogram against {file}")).text(format!(
                    "not drawn: no frame has a {file} to place it by (the log has no {file} channel the firmware model reads, or no airborne frame)"
                ));
                continue;
            }
            match h.save(&dir.join(format!("{name}_{file}.png"))) {
                Ok(()) => svgs.push((h.to_svg_string()?, h.title.clone())),
                // Any other figure that cannot be drawn: say so, keep going.
                Err(e) => {
                    rep.section(format!("{name}: spectrogram against {file}"))
                        .text(format!("not drawn: {e}"));
                }
            }
        }
        let text = super::report::axis_summary(a, out.units[0]);
        let sec = rep.section(format!("{name} axis"));
        sec.blocks.push(Block::Pre(text));
        sec.interactive_figure(
            spectra,
            "PSD in dB (Welch over the airborne frames); dashed: predicted by a filter chain",
        );
        for (svg, caption) in svgs {
            sec.blocks.push(Block::Svg { svg, caption });
        }
        sec.figure(
            chain,
            "the gyro chain's gain and phase; the markers give its phase delay at 10, 20, 50 and 100 Hz",
        );
    }
    if !out.notes.is_empty() {
        rep.section("Notes").text(out.notes.join("\n"));
    }
    rep.save(&dir.join("report.html"))?;
    Ok(())
}
