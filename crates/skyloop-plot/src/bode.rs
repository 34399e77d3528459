//! Bode plots: magnitude (dB) and phase (deg) against frequency (Hz), several systems overlaid,
//! crossover and margins marked; and MIMO Bode plots as a grid of input–output channels.

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
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BodeMarks {
    /// Gain crossover frequency, Hz.
    pub crossover_hz: Option<f64>,
    /// Gain margin (dB) and the phase-crossover frequency (Hz) where it is read.
    pub gain_margin: Option<(f64, f64)>,
    /// Phase margin (deg) and the gain-crossover frequency (Hz) where it is read.
    pub phase_margin: Option<(f64, f64)>,
    /// The other gain crossovers (|L| = 1 again, e.g. over a resonance), each as its phase margin
    /// (deg) and frequency (Hz): marked like the main one, since the delay margin may be set at
    /// any of them.
    pub other_crossovers: Vec<(f64, f64)>,
}

/// How the phase axis is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodeOptions {
    /// Limit the phase axis to the phases seen where the magnitude is at least this many dB, when
    /// the phase runs far (a delay takes it to thousands of degrees where the gain no longer
    /// matters). `None`: the floor is −20 dB or 40 dB below the peak, whichever is lower; the limit
    /// is noted on the axis label. The curve is cut at the axis edge, not clamped.
    pub phase_floor_db: Option<f64>,
    /// Whether to limit the phase axis at all (false: fit all phases).
    pub limit_phase: bool,
}

impl Default for BodeOptions {
    fn default() -> Self {
        BodeOptions {
            phase_floor_db: None,
            limit_phase: true,
        }
    }
}

/// The widest phase window (deg) chosen automatically.
const MAX_PHASE_WINDOW: f64 = 720.0;

/// Phase spans (deg) up to which the whole phase is shown anyway.
const SHOW_ALL_PHASE_SPAN: f64 = 540.0;

/// The phase window `[lo, hi]` (deg, multiples of 45°) to show, and the magnitude floor (dB) it was
/// chosen from, or `None` when all the phase fits comfortably.
pub fn phase_window(data: &[BodeData], opts: &BodeOptions) -> Option<(f64, f64, f64)> {
    if !opts.limit_phase {
        return None;
    }
    let finite = |v: &f64| v.is_finite();
    let all: Vec<f64> = data
        .iter()
        .flat_map(|d| d.phase_deg.iter().copied())
        .filter(finite)
        .collect();
    let (lo, hi) = all
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
    if (hi - lo).is_nan() || hi - lo <= SHOW_ALL_PHASE_SPAN {
        return None;
    }
    let peak = data
        .iter()
        .flat_map(|d| d.mag_db.iter().copied())
        .filter(finite)
        .fold(f64::NEG_INFINITY, f64::max);
    let floor = opts.phase_floor_db.unwrap_or((-20.0f64).min((peak - 40.0).round()));
    let (mut wlo, mut whi) = (f64::INFINITY, f64::NEG_INFINITY);
    for d in data {
        for (m, p) in d.mag_db.iter().zip(&d.phase_deg) {
            if m.is_finite() && p.is_finite() && *m >= floor {
                wlo = wlo.min(*p);
                whi = whi.max(*p);
            }
        }
    }
    if !(wlo.is_finite() && whi.is_finite()) {
        return None;
    }
    // Keep −180° in view whenever the window comes near it: the margins are read there.
    if wlo > -180.0 && wlo < -90.0 {
        wlo = -180.0;
    }
    // Never more than two turns: below that the curve is cut at the axis edge (its frequency range
    // is then where the gain has long fallen away, or the axis label says where it was kept).
    if whi - wlo > MAX_PHASE_WINDOW {
        wlo = whi - MAX_PHASE_WINDOW;
    }
    let pad = 0.08 * (whi - wlo).max(90.0);
    let wlo = ((wlo - pad) / 45.0).floor() * 45.0;
    let whi = ((whi + pad) / 45.0).ceil() * 45.0;
    if whi - wlo >= 0.8 * (hi - lo) {
        return None;
    }
    Some((wlo, whi, floor))
}

/// Builds the two-panel Bode figure (the phase axis limited as [`BodeOptions::default`] says).
pub fn bode_figure(title: &str, data: &[BodeData], marks: &BodeMarks) -> Figure {
    bode_figure_with(title, data, marks, &BodeOptions::default())
}

/// Builds the two-panel Bode figure with explicit phase-axis options. System `k` of `data` has
/// palette colour `k` in both panels.
pub fn bode_figure_with(title: &str, data: &[BodeData], marks: &BodeMarks, opts: &BodeOptions) -> Figure {
    bode_figure_marked(title, data, std::slice::from_ref(marks), opts)
}

/// Builds the two-panel Bode figure with the margins of several systems: `marks[k]` belongs to
/// system `k` of `data` and is drawn in its colour (its labels name the system when there are
/// several), so two tunes' crossovers and margins can be compared on one plot.
pub fn bode_figure_marked(title: &str, data: &[BodeData], marks: &[BodeMarks], opts: &BodeOptions) -> Figure {
    let (mut mag, mut phase) = bode_panels(data, opts);
    // The frequency axis is described once, under the phase (the panels share it).
    mag.x_label.clear();
    let named = |k: usize, text: String| -> String {
        match data.get(k) {
            Some(d) if marks.len() > 1 && !d.label.is_empty() => format!("{}: {text}", d.label),
            _ => text,
        }
    };
    for (k, m) in marks.iter().enumerate() {
        let others = || m.other_crossovers.iter().copied();
        for wc in m.crossover_hz.into_iter().chain(others().map(|(_, f)| f)) {
            mag.markers.push(Marker::Vertical {
                x: wc,
                label: named(k, format!("crossover {}", hz(wc))),
            });
        }
        // As MATLAB's `margin` draws them: the margins as solid segments from the curve to the
        // critical level (0 dB, −180°), in the colour of the system whose margins they are.
        if let Some((gm, f)) = m.gain_margin.filter(|(g, f)| g.is_finite() && f.is_finite()) {
            mag.series.push(Series::line("", vec![f, f], vec![-gm, 0.0]).colored(k));
        }
        let margins = || m.phase_margin.into_iter().chain(others());
        for (pm, f) in margins().filter(|(p, f)| p.is_finite() && f.is_finite()) {
            // The −180° nearest the curve there (the phase may sit a turn lower).
            let at = data.get(k).and_then(|d| {
                d.freq_hz
                    .iter()
                    .zip(&d.phase_deg)
                    .min_by(|a, b| (a.0 - f).abs().total_cmp(&(b.0 - f).abs()))
                    .map(|(_, p)| *p)
            });
            let base = at.map_or(-180.0, |p| -180.0 + 360.0 * ((p - pm + 180.0) / 360.0).round());
            phase
                .series
                .push(Series::line("", vec![f, f], vec![base, base + pm]).colored(k));
        }
        for (pm, f) in margins() {
            phase.markers.push(Marker::Vertical {
                x: f,
                label: named(k, format!("PM {pm:.1}° at {}", hz(f))),
            });
        }
        if let Some((gm, f)) = m.gain_margin {
            mag.markers.push(Marker::Vertical {
                x: f,
                label: named(k, format!("GM {gm:.2} dB at {}", hz(f))),
            });
        }
    }
    if marks
        .iter()
        .any(|m| m.crossover_hz.is_some() || m.gain_margin.is_some())
    {
        mag.markers.push(Marker::Horizontal {
            y: 0.0,
            label: "0 dB".into(),
        });
    }
    if marks
        .iter()
        .any(|m| m.gain_margin.is_some() || m.phase_margin.is_some())
    {
        phase.markers.push(Marker::Horizontal {
            y: -180.0,
            label: "-180°".into(),
        });
    }
    Figure::new(title, vec![mag, phase])
}

/// A frequency with 3 significant digits and its unit ("1.47 Hz", "12.3 kHz").
pub fn hz(f: f64) -> String {
    if f.abs() >= 1e3 {
        format!("{} kHz", sig3(f / 1e3))
    } else {
        format!("{} Hz", sig3(f))
    }
}

/// Three significant digits without trailing zeros.
pub(crate) fn sig3(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let d = (2 - v.abs().log10().floor() as i32).clamp(0, 9) as usize;
    let mut s = format!("{v:.d$}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    s
}

/// Magnitude and phase panels of `data`, system `k` in colour `k`.
fn bode_panels(data: &[BodeData], opts: &BodeOptions) -> (Panel, Panel) {
    let mut mag = Panel::frequency("magnitude [dB]");
    let mut phase = Panel::frequency("phase [deg]");
    phase.y_degrees = true;
    for (k, d) in data.iter().enumerate() {
        mag.series
            .push(Series::line(d.label.clone(), d.freq_hz.clone(), d.mag_db.clone()).colored(k));
        phase
            .series
            .push(Series::line("", d.freq_hz.clone(), d.phase_deg.clone()).colored(k));
    }
    if let Some((lo, hi, floor)) = phase_window(data, opts) {
        phase.y_range = Some((lo, hi));
        // The phase is only meaningful where the gain is not negligible; say so in words.
        phase.y_label = format!("phase [deg], shown where gain ≥ {floor:.0} dB");
    }
    (mag, phase)
}

/// Names of the inputs and outputs of a MIMO system, for panel titles; missing names are `u1`,
/// `u2`, … and `y1`, `y2`, ….
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IoNames {
    /// Input names, by input index.
    pub inputs: Vec<String>,
    /// Output names, by output index.
    pub outputs: Vec<String>,
}

impl IoNames {
    fn input(&self, j: usize) -> String {
        self.inputs.get(j).cloned().unwrap_or_else(|| format!("u{}", j + 1))
    }
    fn output(&self, i: usize) -> String {
        self.outputs.get(i).cloned().unwrap_or_else(|| format!("y{}", i + 1))
    }
}

/// Builds the Bode plot of MIMO systems as an input–output grid, as MATLAB's `bode` of a MIMO
/// system: one column per input, and for each output a magnitude row above a phase row; the panel
/// pair of channel (i, j) is titled "from u_j to y_i".
///
/// `systems[s][i][j]` is the response of system `s` from input `j` to output `i` (indexed
/// `[output][input]`); the label of `systems[s][0][0]` names system `s` in the legend, and system `s`
/// has palette colour `s` in every panel. Systems with fewer channels leave those panels to the
/// others.
pub fn bode_mimo_figure(title: &str, systems: &[Vec<Vec<BodeData>>], names: &IoNames) -> Figure {
    let ny = systems.iter().map(Vec::len).max().unwrap_or(0);
    let nu = systems.iter().flat_map(|s| s.iter().map(Vec::len)).max().unwrap_or(0);
    let mut panels: Vec<Panel> = Vec::with_capacity(2 * ny * nu);
    for i in 0..ny {
        let mut mag_row = Vec::with_capacity(nu);
        let mut phase_row = Vec::with_capacity(nu);
        for j in 0..nu {
            let ch: Vec<(usize, &BodeData)> = systems
                .iter()
                .enumerate()
                .filter_map(|(s, sys)| sys.get(i).and_then(|row| row.get(j)).map(|d| (s, d)))
                .collect();
            let data: Vec<BodeData> = ch.iter().map(|(_, d)| (*d).clone()).collect();
            let (mut mag, mut phase) = bode_panels(&data, &BodeOptions::default());
            // Colour by system index (not by position among the systems that have this channel).
            for (series, (s, _)) in mag.series.iter_mut().zip(&ch) {
                series.color = Some(*s);
                if i != 0 || j != 0 {
                    series.label.clear();
                }
            }
            for (series, (s, _)) in phase.series.iter_mut().zip(&ch) {
                series.color = Some(*s);
            }
            mag.title = format!("from {} to {}", names.input(j), names.output(i));
            let zero = data.iter().all(|d| d.mag_db.iter().all(|m| !m.is_finite()));
            if zero {
                // An identically zero channel (e.g. off the diagonal): empty axes over the others'
                // frequencies, as MATLAB draws it, instead of a curve at −∞.
                let f = systems
                    .iter()
                    .flatten()
                    .flatten()
                    .flat_map(|d| d.freq_hz.iter().copied());
                let (lo, hi) = f
                    .filter(|v| *v > 0.0 && v.is_finite())
                    .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
                mag.title.push_str(" (zero)");
                mag.x_range = Some((lo, hi));
                mag.y_range = Some((-40.0, 0.0));
                phase.x_range = Some((lo, hi));
                phase.y_range = Some((-180.0, 180.0));
            }
            // Axis descriptions once per row and column keep small panels readable.
            mag.x_label.clear();
            if i + 1 != ny {
                phase.x_label.clear();
            }
            if j != 0 {
                mag.y_label.clear();
                if phase.y_range.is_none() {
                    phase.y_label.clear();
                }
            } else {
                mag.y_label = "mag. [dB]".into();
                if phase.y_range.is_none() {
                    phase.y_label = "phase [deg]".into();
                }
            }
            mag_row.push(mag);
            phase_row.push(phase);
        }
        panels.extend(mag_row);
        panels.extend(phase_row);
    }
    let mut f = Figure::new(title, panels);
    f.columns = nu.max(1);
    f.width = (420 * nu as u32).max(960);
    f.panel_height = 230;
    f
}

/// Writes a Bode plot to `path` (`.svg` or `.png`).
pub fn plot_bode(path: &Path, title: &str, data: &[BodeData], marks: &BodeMarks) -> Result<()> {
    bode_figure(title, data, marks).save(path)
}

/// Writes a MIMO Bode grid (see [`bode_mimo_figure`]) to `path` (`.svg` or `.png`).
pub fn plot_bode_mimo(path: &Path, title: &str, systems: &[Vec<Vec<BodeData>>], names: &IoNames) -> Result<()> {
    bode_mimo_figure(title, systems, names).save(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A delayed second-order lag: the phase runs to −2700° and beyond.
    fn delayed() -> BodeData {
        let f: Vec<f64> = (0..300).map(|i| 10f64.powf(-1.0 + 4.0 * i as f64 / 299.0)).collect();
        let mag_db = f
            .iter()
            .map(|f| 20.0 - 20.0 * (1.0 + (f / 2.0).powi(2)).log10())
            .collect();
        let phase_deg = f
            .iter()
            .map(|f| -2.0 * (f / 2.0).atan().to_degrees() - 360.0 * f * 0.032)
            .collect();
        BodeData {
            label: "delayed".into(),
            freq_hz: f,
            mag_db,
            phase_deg,
        }
    }

    #[test]
    fn a_far_running_phase_is_windowed_where_the_gain_matters() {
        let d = delayed();
        let full = d.phase_deg.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(full < -2700.0);
        let (lo, hi, floor) = phase_window(std::slice::from_ref(&d), &BodeOptions::default()).expect("windowed");
        assert_eq!(floor, -20.0);
        assert!(lo <= -180.0 && lo > -1000.0 && hi >= 0.0, "{lo} {hi}");
        assert_eq!(lo % 45.0, 0.0);
        let fig = bode_figure("d", std::slice::from_ref(&d), &BodeMarks::default());
        assert_eq!(fig.panels[1].y_range, Some((lo, hi)));
        assert!(fig.panels[1].y_label.contains("-20 dB"));
        let off = BodeOptions {
            limit_phase: false,
            ..BodeOptions::default()
        };
        assert_eq!(
            bode_figure_with("d", &[d], &BodeMarks::default(), &off).panels[1].y_range,
            None
        );
    }

    #[test]
    fn mimo_grid_has_a_panel_pair_per_channel() {
        let d = delayed();
        let sys = vec![vec![d.clone(), d.clone(), d.clone()], vec![d.clone(), d.clone(), d]];
        let fig = bode_mimo_figure("G", &[sys.clone(), sys], &IoNames::default());
        assert_eq!(fig.columns, 3);
        assert_eq!(fig.panels.len(), 2 * 2 * 3);
        assert_eq!(fig.grid(), (4, 3));
        assert_eq!(fig.panels[0].title, "from u1 to y1");
        assert_eq!(fig.panels[2].title, "from u3 to y1");
        assert_eq!(fig.panels[6].title, "from u1 to y2");
        assert!(fig.panels[3].title.is_empty(), "phase row under the magnitude row");
        // The second system keeps colour 1 everywhere, labelled once.
        assert!(fig.panels.iter().all(|p| p.series[1].color == Some(1)));
        let labelled = fig
            .panels
            .iter()
            .flat_map(|p| &p.series)
            .filter(|s| !s.label.is_empty())
            .count();
        assert_eq!(labelled, 2);
    }

    #[test]
    fn frequencies_print_with_three_digits() {
        assert_eq!(hz(1.4712), "1.47 Hz");
        assert_eq!(hz(12345.0), "12.3 kHz");
        assert_eq!(hz(0.05), "0.05 Hz");
    }
}
