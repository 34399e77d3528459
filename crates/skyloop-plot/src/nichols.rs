//! Nichols charts: open-loop gain (dB) against open-loop phase (deg), with the critical point
//! (−180°, 0 dB) and, optionally, the M-circles (contours of constant closed-loop gain
//! |L/(1+L)|).

use std::path::Path;

use crate::bode::{phase_window, BodeData, BodeOptions};
use crate::error::Result;
use crate::figure::{Figure, Marker, Panel, Series, SeriesStyle};

/// Closed-loop gains (dB) whose M-circles are drawn by [`nichols_figure`] when asked for, as in
/// MATLAB's `ngrid` subset that stays readable.
pub const DEFAULT_M_DB: [f64; 7] = [6.0, 3.0, 1.0, 0.0, -1.0, -3.0, -6.0];

/// The open-loop gain (dB) at which |L/(1+L)| = 10^(m_db/20) for an open-loop phase `phase_deg`,
/// or `None` where that contour has no point at this phase. For M > 1 a contour is closed and has
/// two gains at a phase; `upper` picks the larger.
pub fn m_circle_gain_db(m_db: f64, phase_deg: f64, upper: bool) -> Option<f64> {
    let m2 = 10f64.powf(m_db / 10.0);
    let c = phase_deg.to_radians().cos();
    // |g e^{jφ}|² = M² |1 + g e^{jφ}|²  ⇔  (1 − M²) g² − 2 M² cos φ g − M² = 0.
    let a = 1.0 - m2;
    let b = -2.0 * m2 * c;
    let cc = -m2;
    let g = if a.abs() < 1e-12 {
        // M = 1 (0 dB): a straight line g = −1/(2 cos φ).
        if c < 0.0 {
            -1.0 / (2.0 * c)
        } else {
            return None;
        }
    } else {
        let disc = b * b - 4.0 * a * cc;
        if disc < 0.0 {
            return None;
        }
        let r1 = (-b + disc.sqrt()) / (2.0 * a);
        let r2 = (-b - disc.sqrt()) / (2.0 * a);
        let (lo, hi) = (r1.min(r2), r1.max(r2));
        match (lo > 0.0, hi > 0.0) {
            (true, true) => {
                if upper {
                    hi
                } else {
                    lo
                }
            }
            (false, true) => hi,
            _ => return None,
        }
    };
    (g > 0.0 && g.is_finite()).then(|| 20.0 * g.log10())
}

/// One M-circle as a curve over the phase window `[lo, hi]` (deg), repeated every 360°.
fn m_circle(m_db: f64, lo: f64, hi: f64) -> Vec<(f64, f64)> {
    let mut pts = Vec::new();
    let n = 721;
    // Walk the lower branch one way and the upper branch back, so a closed contour closes.
    for upper in [false, true] {
        let range: Vec<usize> = if upper {
            (0..n).rev().collect()
        } else {
            (0..n).collect()
        };
        for i in range {
            let ph = lo + (hi - lo) * i as f64 / (n - 1) as f64;
            match m_circle_gain_db(m_db, ph, upper) {
                Some(g) => pts.push((ph, g)),
                None => pts.push((f64::NAN, f64::NAN)),
            }
        }
        pts.push((f64::NAN, f64::NAN));
        if m_db <= 0.0 {
            // Open contours (M ≤ 1) have one branch.
            break;
        }
    }
    pts
}

/// Builds the Nichols chart of open-loop responses: x is the phase in degrees (limited, as on a
/// Bode plot, to where the gain matters when it runs far), y the gain in dB, the critical point
/// (−180°, 0 dB) marked, and the M-circles for `m_circles_db` (closed-loop gains in dB; pass
/// [`DEFAULT_M_DB`] or an empty slice for none) drawn thin and grey with their values. System `k`
/// has palette colour `k`.
pub fn nichols_figure(title: &str, data: &[BodeData], m_circles_db: &[f64]) -> Figure {
    let mut p = Panel {
        x_label: "open-loop phase [deg]".into(),
        y_label: "open-loop gain [dB]".into(),
        x_degrees: true,
        ..Panel::default()
    };
    for (k, d) in data.iter().enumerate() {
        p.series
            .push(Series::line(d.label.clone(), d.phase_deg.clone(), d.mag_db.clone()).colored(k));
    }
    let window = phase_window(data, &BodeOptions::default());
    if let Some((lo, hi, floor)) = window {
        p.x_range = Some((lo, hi));
        p.x_label = format!("open-loop phase [deg] (where gain ≥ {floor:.0} dB)");
    }
    let (plo, phi) = window.map(|(a, b, _)| (a, b)).unwrap_or_else(|| {
        let all = data
            .iter()
            .flat_map(|d| d.phase_deg.iter().copied())
            .filter(|v| v.is_finite());
        let (a, b) = all.fold((-180.0f64, -180.0f64), |(a, b), v| (a.min(v), b.max(v)));
        (a - 10.0, b + 10.0)
    });
    if !m_circles_db.is_empty() {
        // Fix the gain axis to the data, so the M-circles (which run to ±∞) do not set it.
        let gains = data
            .iter()
            .flat_map(|d| d.mag_db.iter().copied())
            .filter(|v| v.is_finite());
        let (glo, ghi) = gains.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        if glo.is_finite() {
            let pad = 0.05 * (ghi - glo).max(10.0);
            p.y_range = Some((glo.min(-10.0) - pad, ghi.max(10.0) + pad));
        }
        if p.x_range.is_none() {
            p.x_range = Some((plo, phi));
        }
        // Labels go by the critical point the first curve passes at its 0 dB crossing: that is the one
        // the margins are read at.
        let label_centre = data.first().and_then(|d| {
            (1..d.mag_db.len().min(d.phase_deg.len()))
                .find(|&i| (d.mag_db[i - 1] >= 0.0) != (d.mag_db[i] >= 0.0))
                .map(|i| -180.0 + 360.0 * ((d.phase_deg[i] + 180.0) / 360.0).round())
        });
        // Critical points every 360° in view; the contours circle each of them.
        let k0 = ((plo + 180.0) / 360.0).floor() as i64;
        let k1 = ((phi + 180.0) / 360.0).ceil() as i64;
        for &m in m_circles_db {
            let mut x = Vec::new();
            let mut y = Vec::new();
            for k in k0..=k1 {
                let c = -180.0 + 360.0 * k as f64;
                for (a, b) in m_circle(m, c - 180.0, c + 180.0) {
                    x.push(a);
                    y.push(b);
                }
            }
            p.series.push(Series::line("", x, y).styled(SeriesStyle::Reference));
            // The label at the top of a closed contour (above the critical point), or at −100°
            // (+360°·k) on an open one, near the middle of the view.
            let centre = label_centre.unwrap_or(-180.0 + 360.0 * (((plo + phi) / 2.0 + 180.0) / 360.0).round());
            let at = if m > 0.0 { centre } else { centre + 80.0 };
            if let Some(g) = m_circle_gain_db(m, at, true) {
                p.markers.push(Marker::Note {
                    x: at,
                    y: g,
                    label: format!("{} dB", crate::ticks::format_tick(m, 1.0)),
                });
            }
        }
    }
    p.markers.push(Marker::Point {
        x: -180.0,
        y: 0.0,
        label: "(−180°, 0 dB)".into(),
    });
    let mut f = Figure::new(title, vec![p]);
    f.panel_height = 640;
    f
}

/// Writes a Nichols chart to `path` (`.svg` or `.png`).
pub fn plot_nichols(path: &Path, title: &str, data: &[BodeData], m_circles_db: &[f64]) -> Result<()> {
    nichols_figure(title, data, m_circles_db).save(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn m_circles_satisfy_their_equation() {
        for m in DEFAULT_M_DB {
            for ph in [-250.0, -200.0, -180.0, -150.0, -100.0] {
                for upper in [false, true] {
                    if let Some(g) = m_circle_gain_db(m, ph, upper) {
                        let l = num_complex::Complex64::from_polar(10f64.powf(g / 20.0), f64::to_radians(ph));
                        let t = (l / (1.0 + l)).norm();
                        assert!((20.0 * t.log10() - m).abs() < 1e-9, "M {m} dB at {ph}°: {g} dB");
                    }
                }
            }
        }
        // 0 dB: g = 1/(−2 cos φ); at −180° that is −6.02 dB.
        let g = m_circle_gain_db(0.0, -180.0, true).expect("on the line");
        assert!((g + 6.0206).abs() < 1e-3);
    }

    #[test]
    fn nichols_marks_the_critical_point() {
        let d = BodeData {
            label: "L".into(),
            freq_hz: vec![0.1, 1.0, 10.0],
            mag_db: vec![20.0, 0.0, -20.0],
            phase_deg: vec![-100.0, -140.0, -200.0],
        };
        let f = nichols_figure("N", &[d], &DEFAULT_M_DB);
        let p = &f.panels[0];
        assert!(p.x_degrees);
        assert!(p
            .markers
            .iter()
            .any(|m| matches!(m, Marker::Point { x, y, .. } if *x == -180.0 && *y == 0.0)));
        assert_eq!(p.series.len(), 1 + DEFAULT_M_DB.len());
        let (lo, hi) = p.y_range.expect("gain axis fixed to the data");
        assert!(lo < -20.0 && hi > 20.0 && hi < 30.0);
    }
}
