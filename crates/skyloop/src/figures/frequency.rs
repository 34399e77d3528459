//! Frequency-domain figures: Bode (SISO overlay, or the MIMO input–output grid), singular values,
//! Nichols and Nyquist, all on one shared grid.

use super::{channel, Labeled};
use crate::error::Result;
use skyloop_lti::freqresp;
use skyloop_plot::bode::{bode_figure, bode_mimo_figure, BodeData, BodeMarks, IoNames};
use skyloop_plot::figure::Figure;
use skyloop_plot::nichols::{nichols_figure, DEFAULT_M_DB};
use skyloop_plot::nyquist::{nyquist_figure, NyquistData};
use skyloop_plot::sigma::{sigma_figure, SigmaData};

const TWO_PI: f64 = 2.0 * std::f64::consts::PI;

/// One log-spaced grid (rad/s) of `points` frequencies covering every model's dynamics (two
/// decades either side), or the range `hz_min .. hz_max` (Hz) where given.
///
/// # Errors
/// Fewer than 2 or more than [`freqresp::MAX_GRID_POINTS`] points, or a range that is not
/// 0 < min < max < ∞.
pub fn frequency_grid(models: &[Labeled], hz_min: Option<f64>, hz_max: Option<f64>, points: usize) -> Result<Vec<f64>> {
    if points < 2 {
        return Err(format!("--points must be at least 2, got {points}").into());
    }
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for m in models {
        let g = freqresp::default_grid(&m.sys, 2).map_err(|e| format!("{}: {e}", m.label))?;
        lo = lo.min(g[0]);
        hi = hi.max(g[g.len() - 1]);
    }
    for (name, v) in [("--hz-min", hz_min), ("--hz-max", hz_max)] {
        if let Some(f) = v {
            if !(f > 0.0 && f.is_finite()) {
                return Err(format!("{name} must be a positive finite frequency in Hz, got {f}").into());
            }
        }
    }
    if let Some(f) = hz_min {
        lo = f * TWO_PI;
    }
    if let Some(f) = hz_max {
        hi = f * TWO_PI;
    }
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Err(format!(
            "frequency range must satisfy 0 < hz-min < hz-max, got {} .. {} Hz",
            lo / TWO_PI,
            hi / TWO_PI
        )
        .into());
    }
    Ok(freqresp::try_logspace(lo.log10(), hi.log10(), points)?)
}

/// Bode data of every channel of a model, indexed `[output][input]`.
fn bode_channels(m: &Labeled, w: &[f64]) -> Result<Vec<Vec<BodeData>>> {
    let b = freqresp::bode(&m.sys, Some(w)).map_err(|e| format!("{}: {e}", m.label))?;
    Ok((0..m.sys.ny())
        .map(|i| {
            (0..m.sys.nu())
                .map(|j| BodeData {
                    label: format!("{}{}", m.label, channel(&m.sys, i, j)),
                    freq_hz: b.freq_hz.clone(),
                    mag_db: b.mag_db[i][j].clone(),
                    // A zero response has no phase: leave it undrawn rather than a line at 0°.
                    phase_deg: b.phase_deg[i][j]
                        .iter()
                        .zip(&b.mag_db[i][j])
                        .map(|(p, m)| if m.is_finite() { *p } else { f64::NAN })
                        .collect(),
                })
                .collect()
        })
        .collect())
}

/// The Bode figure of the models at `w` (rad/s). SISO models are overlaid on one magnitude and one
/// phase panel (the phase axis limited to where the gain matters when a delay runs it far); as soon
/// as one model is MIMO, the figure is MATLAB's input–output grid, one panel pair per channel.
/// With `loop_margins`, the first model is the loop transfer L and its crossover, gain and phase
/// margins are marked (exact with its delay).
///
/// # Examples
/// ```
/// use skyloop::figures::{bode, frequency_grid, Labeled};
/// let l = Labeled::new("L", skyloop::prelude::parse_model("10*exp(-0.01*s)/(s*(0.1*s+1))")?);
/// let w = frequency_grid(std::slice::from_ref(&l), None, None, 400)?;
/// let fig = bode(&[l], &w, true)?;
/// assert_eq!(fig.panels.len(), 2);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn bode(models: &[Labeled], w: &[f64], loop_margins: bool) -> Result<Figure> {
    let marks = match models.first() {
        Some(l) if loop_margins => margin_marks(l)?,
        _ => BodeMarks::default(),
    };
    let channels: Vec<Vec<Vec<BodeData>>> = models.iter().map(|m| bode_channels(m, w)).collect::<Result<_>>()?;
    if models.iter().any(|m| m.sys.ny() * m.sys.nu() > 1) {
        if loop_margins {
            return Err("--margins needs a SISO loop transfer; the models here are MIMO".into());
        }
        // In the grid the system is named once (legend of the first panel), not per channel.
        let mut systems = channels;
        for (s, m) in systems.iter_mut().zip(models) {
            for d in s.iter_mut().flatten() {
                d.label = m.label.clone();
            }
        }
        return Ok(bode_mimo_figure("Bode", &systems, &IoNames::default()));
    }
    let data: Vec<BodeData> = channels.into_iter().flatten().flatten().collect();
    Ok(bode_figure("Bode", &data, &marks))
}

/// Crossover, gain margin and phase margin of a SISO loop, in the plot's units (Hz, dB, deg), and
/// every other gain crossover with its phase margin.
fn margin_marks(l: &Labeled) -> Result<BodeMarks> {
    l.siso("--margins")?;
    let all = skyloop_lti::margins::allmargin(&l.sys).map_err(|e| format!("{}: {e}", l.label))?;
    let m = skyloop_lti::margins::margin_from(&all);
    let hz = |w: f64| w / TWO_PI;
    let finite = |v: f64, w: f64| (v.is_finite() && w.is_finite()).then_some((v, hz(w)));
    let mut other_crossovers: Vec<(f64, f64)> = all
        .phase_margins
        .iter()
        .filter(|p| p.w_rad_s != m.pm_w_rad_s)
        .filter_map(|p| finite(p.pm_deg, p.w_rad_s))
        .collect();
    other_crossovers.sort_by(|a, b| a.1.total_cmp(&b.1));
    Ok(BodeMarks {
        crossover_hz: m.pm_w_rad_s.is_finite().then(|| hz(m.pm_w_rad_s)),
        gain_margin: finite(m.gm_db, m.gm_w_rad_s),
        phase_margin: finite(m.pm_deg, m.pm_w_rad_s),
        other_crossovers,
    })
}

/// The singular-value figure (MATLAB `sigma`) of the models at `w` (rad/s), in dB against Hz.
pub fn sigma(models: &[Labeled], w: &[f64]) -> Result<Figure> {
    let freq_hz: Vec<f64> = w.iter().map(|w| w / TWO_PI).collect();
    let data = models
        .iter()
        .map(|m| {
            let sv = skyloop_lti::norms::sigma(&m.sys, w).map_err(|e| format!("{}: {e}", m.label))?;
            Ok(SigmaData {
                label: m.label.clone(),
                freq_hz: freq_hz.clone(),
                sv_db: sv
                    .iter()
                    .map(|v| v.iter().map(|s| 20.0 * s.log10()).collect())
                    .collect(),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(sigma_figure("Singular values", &data))
}

/// The Nichols chart of SISO loop transfers at `w` (rad/s), with the standard M-circles.
pub fn nichols(models: &[Labeled], w: &[f64]) -> Result<Figure> {
    let mut data = Vec::new();
    for m in models {
        m.siso("a Nichols chart")?;
        data.extend(bode_channels(m, w)?.into_iter().flatten());
    }
    Ok(nichols_figure("Nichols", &data, &DEFAULT_M_DB))
}

/// The Nyquist figure of SISO loop transfers at `w` (rad/s); the view is |z| ≤ `radius` around the
/// origin when given (loops with integrators run off to infinity), the curve clipped at the frame.
pub fn nyquist(models: &[Labeled], w: &[f64], radius: Option<f64>) -> Result<Figure> {
    if let Some(r) = radius {
        if !(r > 0.0 && r.is_finite()) {
            return Err(format!("--radius must be a positive finite number, got {r}").into());
        }
    }
    let mut data = Vec::new();
    for m in models {
        m.siso("a Nyquist plot")?;
        let g = freqresp::freqresp(&m.sys, w).map_err(|e| format!("{}: {e}", m.label))?;
        data.push(NyquistData {
            label: m.label.clone(),
            re: g.iter().map(|g| g[(0, 0)].re).collect(),
            im: g.iter().map(|g| g[(0, 0)].im).collect(),
        });
    }
    Ok(nyquist_figure("Nyquist", &data, radius))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prelude::parse_model;

    fn diag(a: &str, b: &str) -> skyloop_lti::StateSpace {
        skyloop_lti::interconnect::append(&parse_model(a).unwrap(), &parse_model(b).unwrap()).unwrap()
    }

    fn lab(e: &str) -> Labeled {
        Labeled::new(e, parse_model(e).unwrap())
    }

    #[test]
    fn mimo_bode_is_a_grid_and_siso_an_overlay() {
        let g = Labeled::new("G", diag("1/(s+1)", "2/(s+3)"));
        let w = frequency_grid(std::slice::from_ref(&g), None, None, 50).unwrap();
        // 2×2: a magnitude and a phase panel per channel.
        assert_eq!(bode(&[g], &w, false).unwrap().panels.len(), 8);
        let s = [lab("1/(s+1)"), lab("1/(s+2)")];
        let f = bode(&s, &w, false).unwrap();
        assert_eq!(f.panels.len(), 2);
        assert_eq!(f.panels[0].series.len(), 2);
    }

    #[test]
    fn sigma_of_diagonal_is_its_gains() {
        let g = Labeled::new("G", diag("10/(s+1)", "0.1/(s+1)"));
        let f = sigma(&[g], &[1e-3]).unwrap();
        let ys: Vec<f64> = f.panels[0].series.iter().map(|s| s.y[0]).collect();
        assert!((ys[0] - 20.0).abs() < 1e-3 && (ys[1] + 20.0).abs() < 1e-3, "{ys:?}");
    }

    #[test]
    fn bad_ranges_are_named() {
        let g = [lab("1/(s+1)")];
        let e = frequency_grid(&g, Some(f64::NAN), None, 10).unwrap_err().to_string();
        assert!(e.contains("--hz-min"), "{e}");
        let e = frequency_grid(&g, Some(10.0), Some(1.0), 10).unwrap_err().to_string();
        assert!(e.contains("hz-min < hz-max"), "{e}");
        assert!(nichols(&[Labeled::new("M", diag("1/(s+1)", "1/(s+1)"))], &[1.0]).is_err());
    }
}
