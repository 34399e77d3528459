//! The comparison's figures and files: per axis `<axis>_compare.{png,svg}` (tracking magnitude and
//! phase with their ±2σ bands, the causal steps with their ±2σ bands, the gyro PSDs) and
//! `<axis>_plant.{png,svg}` (the identified plants' FRFs), A in blue and B in orange; `compare.json`
//! and `compare.txt`.

use super::{AxisComparison, AxisSide, Comparison, Measured};
use crate::design::report::write_json;
use crate::error::{Error, Result};
use skyloop_plot::figure::Band;
use skyloop_plot::{Figure, Marker, Panel, Series};
use std::path::{Path, PathBuf};

/// Largest ±2σ half width drawn, dB or degrees (incoherent points would fill the panel).
const BAND_CLIP: f64 = 12.0;

/// The legend of log `which` ("A" or "B"); a missing part says so briefly (its reason is in
/// `compare.txt`: a long legend would narrow every panel).
fn label<T>(which: &str, m: &Measured<T>) -> String {
    match m {
        Ok(_) => which.to_string(),
        Err(_) => format!("{which}: not identified (see compare.txt)"),
    }
}

fn band(label: &str, x: &[f64], y: &[f64], s: &[f64], color: usize) -> Band {
    Band {
        label: label.into(),
        x: x.to_vec(),
        lower: y.iter().zip(s).map(|(v, e)| v - (2.0 * e).min(BAND_CLIP)).collect(),
        upper: y.iter().zip(s).map(|(v, e)| v + (2.0 * e).min(BAND_CLIP)).collect(),
        color,
    }
}

/// Tracking magnitude and phase panels; only the coherent points are drawn.
fn tracking_panels(a: &AxisComparison) -> (Panel, Panel) {
    let mut mag = Panel::frequency("|setpoint → gyro| [dB]");
    mag.title = format!(
        "{} tracking (closed loop), ±2σ shaded; coherent points only",
        a.axis.name()
    );
    let mut ph = Panel::frequency("phase [deg]");
    ph.y_degrees = true;
    for (k, (which, side)) in [("A", &a.a), ("B", &a.b)].into_iter().enumerate() {
        let name = label(which, &side.tracking);
        let Ok(t) = &side.tracking else {
            mag.series.push(Series::line(name, vec![], vec![]).colored(k));
            continue;
        };
        let keep: Vec<usize> = (0..t.freq_hz.len())
            .filter(|&i| super::side::coherent(t.coherence[i]))
            .collect();
        let pick = |v: &[f64]| keep.iter().map(|&i| v[i]).collect::<Vec<f64>>();
        let (f, m, p) = (pick(&t.freq_hz), pick(&t.mag_db), pick(&t.phase_deg));
        mag.bands.push(band("", &f, &m, &pick(&t.std_db), k));
        ph.bands.push(band("", &f, &p, &pick(&t.std_deg), k));
        mag.series.push(Series::line(name.clone(), f.clone(), m).colored(k));
        ph.series.push(Series::line(name, f, p).colored(k));
        if let Some(bw) = t.bandwidth_hz {
            mag.markers.push(Marker::Vertical {
                x: bw,
                label: format!("{which} −3 dB {bw:.0} Hz"),
            });
        }
    }
    mag.markers.push(Marker::Horizontal {
        y: -3.0,
        label: String::new(),
    });
    (mag, ph)
}

fn step_panel(a: &AxisComparison) -> Panel {
    let mut p = Panel {
        title: format!("{} step setpoint → gyro (causal FIR fit), ±2σ shaded", a.axis.name()),
        x_label: "time [ms]".into(),
        y_label: "gyro per unit setpoint step".into(),
        ..Panel::default()
    };
    for (k, (which, side)) in [("A", &a.a), ("B", &a.b)].into_iter().enumerate() {
        let mut name = label(which, &side.step);
        let Ok(s) = &side.step else {
            p.series.push(Series::line(name, vec![], vec![]).colored(k));
            continue;
        };
        if let (Some(o), Some(r)) = (s.overshoot_pct, s.rise_time_ms) {
            name = format!("{which}: rise {r:.1} ms, overshoot {o:.0} %");
        }
        let t: Vec<f64> = s.t_s.iter().map(|x| 1e3 * x).collect();
        p.bands.push(band("", &t, &s.y, &s.y_std, k));
        p.series.push(Series::line(name, t, s.y.clone()).colored(k));
    }
    p.markers.push(Marker::Horizontal {
        y: 1.0,
        label: String::new(),
    });
    p
}

fn noise_panel(a: &AxisComparison) -> Panel {
    let mut p = Panel {
        title: format!("{} gyro PSD (logged, filtered)", a.axis.name()),
        x_label: "frequency [Hz]".into(),
        ..Panel::default()
    };
    let mut unit = "deg/s";
    for (k, (which, side)) in [("A", &a.a), ("B", &a.b)].into_iter().enumerate() {
        let mut name = label(which, &side.noise);
        let Ok(n) = &side.noise else {
            p.series.push(Series::line(name, vec![], vec![]).colored(k));
            continue;
        };
        unit = n.unit;
        if let Some(h) = n.high_db {
            name = format!(
                "{which}: {h:.1} dB re 1 ({})² over {:.0}–{:.0} Hz",
                n.unit,
                super::side::NOISE_SPLIT_HZ,
                n.high_top_hz
            );
        }
        p.series
            .push(Series::line(name, n.freq_hz.clone(), n.psd_db.clone()).colored(k));
    }
    p.y_label = format!("PSD [dB re 1 ({unit})²/Hz]");
    p.markers.push(Marker::Vertical {
        x: super::side::NOISE_SPLIT_HZ,
        label: String::new(),
    });
    p
}

/// The axis' comparison figure: tracking magnitude, phase, step and gyro PSD.
pub fn axis_figure(a: &AxisComparison) -> Figure {
    let (mag, ph) = tracking_panels(a);
    let panels: Vec<Panel> = [mag, ph, step_panel(a), noise_panel(a)]
        .into_iter()
        .filter(has_data)
        .collect();
    let mut f = Figure::new(format!("{}: A (blue) against B (orange)", a.axis.name()), panels);
    f.panel_height = 330;
    f
}

/// The identified plants PID sum → gyro, magnitude and phase with ±2σ on the magnitude.
pub fn plant_figure(a: &AxisComparison) -> Figure {
    let mut mag = Panel::frequency("|PID sum → gyro| [dB]");
    mag.title = format!(
        "{} plant (identified, setpoint as instrument), ±2σ shaded",
        a.axis.name()
    );
    let mut ph = Panel::frequency("phase [deg]");
    ph.y_degrees = true;
    let sides: [(&str, &AxisSide); 2] = [("A", &a.a), ("B", &a.b)];
    for (k, (which, side)) in sides.into_iter().enumerate() {
        let mut name = label(which, &side.plant);
        let Ok(p) = &side.plant else {
            mag.series.push(Series::line(name, vec![], vec![]).colored(k));
            continue;
        };
        name = format!(
            "{which}: K {}, tau {:.1} ms, Td {:.1} ms",
            super::report::sig(p.k.0),
            1e3 * p.tau_s.0,
            1e3 * p.td_s.0
        );
        mag.bands.push(band("", &p.freq_hz, &p.mag_db, &p.std_db, k));
        mag.series
            .push(Series::line(name.clone(), p.freq_hz.clone(), p.mag_db.clone()).colored(k));
        ph.series
            .push(Series::line(name, p.freq_hz.clone(), p.phase_deg.clone()).colored(k));
    }
    let panels: Vec<Panel> = [mag, ph].into_iter().filter(has_data).collect();
    Figure::new(format!("{} plant: A (blue) against B (orange)", a.axis.name()), panels)
}

fn has_data(p: &Panel) -> bool {
    p.series.iter().any(|s| !s.x.is_empty())
}

/// True when a figure has at least one curve with data.
fn drawable(f: &Figure) -> bool {
    f.panels.iter().any(has_data)
}

/// Writes `compare.json`, `compare.txt` and, per axis where either log has data,
/// `<axis>_compare.png|svg` and `<axis>_plant.png|svg` into `dir`; returns the figures written.
///
/// # Errors
/// A folder or file that cannot be written.
pub fn write_outputs(c: &Comparison, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    write_json(&dir.join("compare.json"), &c.to_json())?;
    let txt = dir.join("compare.txt");
    std::fs::write(&txt, c.to_text()).map_err(|e| Error::write(&txt, e))?;
    let mut written = Vec::new();
    for a in &c.axes {
        for (fig, stem) in [(axis_figure(a), "compare"), (plant_figure(a), "plant")] {
            if !drawable(&fig) {
                continue;
            }
            for ext in ["png", "svg"] {
                let p = dir.join(format!("{}_{stem}.{ext}", a.axis.name()));
                fig.save(&p)?;
                written.push(p);
            }
        }
    }
    Ok(written)
}
