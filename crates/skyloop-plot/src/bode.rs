//! Bode plots: magnitude (dB) and phase (deg) against frequency (Hz), several systems overlaid,
//! crossover and margins marked.

use std::path::Path;

use crate::error::Result;
use crate::figure::{Figure, Marker, Panel, Series};

/// The frequency response of one system (or one input–output channel) ready to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct BodeData {
    /// Legend text.
    pub label: String,
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// Magnitudes, dB.
    pub mag_db: Vec<f64>,
    /// Phases, degrees (unwrapped).
    pub phase_deg: Vec<f64>,
}

/// Margins to mark on a Bode plot of a loop transfer; each is optional.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BodeMarks {
    /// Gain crossover frequency, Hz.
    pub crossover_hz: Option<f64>,
    /// Gain margin (dB) and the phase-crossover frequency (Hz) where it is read.
    pub gain_margin: Option<(f64, f64)>,
    /// Phase margin (deg) and the gain-crossover frequency (Hz) where it is read.
    pub phase_margin: Option<(f64, f64)>,
}

/// Builds the two-panel Bode figure.
pub fn bode_figure(title: &str, data: &[BodeData], marks: &BodeMarks) -> Figure {
    let mut mag = Panel::frequency("magnitude [dB]");
    let mut phase = Panel::frequency("phase [deg]");
    for (k, d) in data.iter().enumerate() {
        mag.series
            .push(Series::line(d.label.clone(), d.freq_hz.clone(), d.mag_db.clone()).colored(k));
        phase
            .series
            .push(Series::line("", d.freq_hz.clone(), d.phase_deg.clone()).colored(k));
    }
    if let Some(wc) = marks.crossover_hz {
        mag.markers.push(Marker::Vertical {
            x: wc,
            label: format!("crossover {wc:.3} Hz"),
        });
        mag.markers.push(Marker::Horizontal {
            y: 0.0,
            label: String::new(),
        });
    }
    if let Some((pm, f)) = marks.phase_margin {
        phase.markers.push(Marker::Vertical {
            x: f,
            label: format!("PM {pm:.1}° at {f:.3} Hz"),
        });
    }
    if let Some((gm, f)) = marks.gain_margin {
        mag.markers.push(Marker::Vertical {
            x: f,
            label: format!("GM {gm:.2} dB at {f:.3} Hz"),
        });
        phase.markers.push(Marker::Horizontal {
            y: -180.0,
            label: "-180°".into(),
        });
    }
    Figure::new(title, vec![mag, phase])
}

/// Writes a Bode plot to `path` (`.svg` or `.png`).
pub fn plot_bode(path: &Path, title: &str, data: &[BodeData], marks: &BodeMarks) -> Result<()> {
    bode_figure(title, data, marks).save(path)
}
