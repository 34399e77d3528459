//! Complex-plane plots of dynamics: pole–zero maps (poles ×, zeros ○) and root loci (branches of
//! the closed-loop poles as a gain varies), with the stability boundary: the imaginary axis for a
//! continuous-time system, the unit circle for a discrete-time one.

use std::path::Path;

use num_complex::Complex64;

use crate::error::Result;
use crate::figure::{Figure, Marker, Panel, Series, SeriesStyle};

/// Poles and zeros of one system (rad/s for continuous time; dimensionless z for discrete time).
#[derive(Debug, Clone, PartialEq)]
pub struct PoleZeroData {
    /// Legend text (may be empty).
    pub label: String,
    /// Poles.
    pub poles: Vec<Complex64>,
    /// Zeros (finite ones).
    pub zeros: Vec<Complex64>,
}

/// The closed-loop poles of a loop `1 + k·L(s) = 0` for a sweep of gains, already computed by the
/// caller: `poles[g]` are the roots at `gains[g]` (in any order; branches are matched here).
#[derive(Debug, Clone, PartialEq)]
pub struct RootLocusData {
    /// Gains of the sweep, in increasing order.
    pub gains: Vec<f64>,
    /// Closed-loop poles at each gain.
    pub poles: Vec<Vec<Complex64>>,
    /// Open-loop poles (where the branches start, k = 0).
    pub open_loop_poles: Vec<Complex64>,
    /// Open-loop zeros (where branches end, k → ∞).
    pub open_loop_zeros: Vec<Complex64>,
}

/// Axis ranges around the given points, padded, with the stability boundary's key part in view
/// (the origin, or the unit circle when discrete).
fn view(points: impl Iterator<Item = Complex64>, discrete: bool) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1): (f64, f64, f64, f64) = if discrete {
        (-1.1, 1.1, -1.1, 1.1)
    } else {
        (-0.1, 0.1, -0.1, 0.1)
    };
    let mut any = false;
    for z in points.filter(|z| z.re.is_finite() && z.im.is_finite()) {
        any = true;
        x0 = x0.min(z.re);
        x1 = x1.max(z.re);
        // Symmetric in the imaginary part: conjugate pairs and the real axis centred.
        y0 = y0.min(-z.im.abs());
        y1 = y1.max(z.im.abs());
    }
    if !discrete && any {
        // Show some of the right half-plane even when everything is stable, so the boundary is
        // not on the frame.
        let span = (x1 - x0).max(y1 - y0);
        x1 = x1.max(0.15 * span);
        y1 = y1.max(0.15 * span);
        y0 = y0.min(-0.15 * span);
    }
    let pad = 0.08 * (x1 - x0).max(y1 - y0);
    ((x0 - pad, x1 + pad), (y0 - pad, y1 + pad))
}

/// Adds the stability boundary (imaginary axis, or unit circle when `discrete`) and its note.
fn boundary(p: &mut Panel, discrete: bool, (ylo, yhi): (f64, f64)) {
    if discrete {
        p.series.push(Series::unit_circle());
        p.markers.push(Marker::Note {
            x: 0.5f64.sqrt(),
            y: 0.5f64.sqrt(),
            label: "|z| = 1".into(),
        });
    } else {
        // Far beyond the view; the renderer cuts it at the frame.
        let r = 10.0 * (ylo.abs() + yhi.abs()).max(1.0);
        p.series
            .push(Series::line("", vec![0.0, 0.0], vec![-r, r]).styled(SeriesStyle::Reference));
        p.markers.push(Marker::Note {
            x: 0.0,
            y: ylo + 0.02 * (yhi - ylo),
            label: "stable ← | → unstable".into(),
        });
    }
}

fn complex_panel(discrete: bool) -> Panel {
    let (x_label, y_label) = if discrete {
        ("real axis", "imaginary axis")
    } else {
        ("real axis [rad/s]", "imaginary axis [rad/s]")
    };
    Panel {
        x_label: x_label.into(),
        y_label: y_label.into(),
        equal_aspect: true,
        ..Panel::default()
    }
}

fn split(z: &[Complex64]) -> (Vec<f64>, Vec<f64>) {
    (z.iter().map(|z| z.re).collect(), z.iter().map(|z| z.im).collect())
}

fn named(label: &str, what: &str) -> String {
    if label.is_empty() {
        what.to_string()
    } else {
        format!("{label}: {what}")
    }
}

/// Builds a pole–zero map as MATLAB's `pzmap`: poles ×, zeros ○, system `k` in palette colour `k`,
/// the imaginary axis (or the unit circle when `discrete`) as the stability boundary, equal scales.
pub fn pzmap_figure(title: &str, systems: &[PoleZeroData], discrete: bool) -> Figure {
    let mut p = complex_panel(discrete);
    let (xr, yr) = view(
        systems.iter().flat_map(|s| s.poles.iter().chain(&s.zeros).copied()),
        discrete,
    );
    p.x_range = Some(xr);
    p.y_range = Some(yr);
    boundary(&mut p, discrete, yr);
    for (k, s) in systems.iter().enumerate() {
        let (x, y) = split(&s.poles);
        p.series
            .push(Series::points(named(&s.label, "poles"), x, y, SeriesStyle::Crosses).colored(k));
        if !s.zeros.is_empty() {
            let (x, y) = split(&s.zeros);
            p.series
                .push(Series::points(named(&s.label, "zeros"), x, y, SeriesStyle::Circles).colored(k));
        }
    }
    let mut f = Figure::new(title, vec![p]);
    f.width = 820;
    f.panel_height = 680;
    f
}

/// Matches the unordered pole lists of successive gains into continuous branches (each pole goes to
/// the nearest unclaimed pole of the next gain); a branch whose pole is missing at a gain gets NaN
/// there, which breaks its line.
pub fn root_locus_branches(poles: &[Vec<Complex64>]) -> Vec<Vec<Complex64>> {
    let nan = Complex64::new(f64::NAN, f64::NAN);
    let n = poles.iter().map(Vec::len).max().unwrap_or(0);
    let mut branches: Vec<Vec<Complex64>> = vec![Vec::with_capacity(poles.len()); n];
    let mut last: Vec<Option<Complex64>> = vec![None; n];
    for list in poles {
        let mut taken = vec![false; list.len()];
        let mut assigned: Vec<Option<Complex64>> = vec![None; n];
        // Closest pairs first, so a branch does not jump to a neighbour's pole.
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (b, l) in last.iter().enumerate() {
            if let Some(l) = l {
                for (i, z) in list.iter().enumerate() {
                    pairs.push(((z - l).norm(), b, i));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (_, b, i) in pairs {
            if assigned[b].is_none() && !taken[i] {
                assigned[b] = Some(list[i]);
                taken[i] = true;
            }
        }
        // Poles left over (first gain, or a branch that had none) start the free branches.
        let free_list: Vec<usize> = (0..n)
            .filter(|b| assigned[*b].is_none() && last[*b].is_none())
            .collect();
        let mut free = free_list.into_iter();
        for (i, z) in list.iter().enumerate() {
            if !taken[i] {
                if let Some(b) = free.next() {
                    assigned[b] = Some(*z);
                }
            }
        }
        for b in 0..n {
            branches[b].push(assigned[b].unwrap_or(nan));
            if assigned[b].is_some() {
                last[b] = assigned[b];
            }
        }
    }
    branches
}

/// Builds a root-locus figure as MATLAB's `rlocus`: one line per branch of closed-loop poles (each
/// in its own palette colour), open-loop poles × and zeros ○ in black, the stability boundary
/// (imaginary axis, or unit circle when `discrete`), equal scales. The gains of the sweep's first and
/// last points are noted in the title.
pub fn rlocus_figure(title: &str, data: &RootLocusData, discrete: bool) -> Figure {
    let mut p = complex_panel(discrete);
    let branches = root_locus_branches(&data.poles);
    let (xr, yr) = view(
        branches
            .iter()
            .flatten()
            .chain(&data.open_loop_poles)
            .chain(&data.open_loop_zeros)
            .copied(),
        discrete,
    );
    p.x_range = Some(xr);
    p.y_range = Some(yr);
    boundary(&mut p, discrete, yr);
    for (b, br) in branches.iter().enumerate() {
        let (x, y) = split(br);
        p.series.push(Series::line("", x, y).colored(b));
    }
    // Black (palette 7): the open-loop singularities are not any one branch's.
    let (x, y) = split(&data.open_loop_poles);
    p.series
        .push(Series::points("open-loop poles", x, y, SeriesStyle::Crosses).colored(7));
    if !data.open_loop_zeros.is_empty() {
        let (x, y) = split(&data.open_loop_zeros);
        p.series
            .push(Series::points("open-loop zeros", x, y, SeriesStyle::Circles).colored(7));
    }
    if let (Some(g0), Some(g1)) = (data.gains.first(), data.gains.last()) {
        p.title = format!("gain k from {} to {}", crate::bode::sig3(*g0), crate::bode::sig3(*g1));
    }
    let mut f = Figure::new(title, vec![p]);
    f.width = 820;
    f.panel_height = 680;
    f
}

/// Writes a pole–zero map to `path` (`.svg` or `.png`).
pub fn plot_pzmap(path: &Path, title: &str, systems: &[PoleZeroData], discrete: bool) -> Result<()> {
    pzmap_figure(title, systems, discrete).save(path)
}

/// Writes a root locus to `path` (`.svg` or `.png`).
pub fn plot_rlocus(path: &Path, title: &str, data: &RootLocusData, discrete: bool) -> Result<()> {
    rlocus_figure(title, data, discrete).save(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(re: f64, im: f64) -> Complex64 {
        Complex64::new(re, im)
    }

    #[test]
    fn branches_follow_the_nearest_pole_whatever_the_order() {
        // k/(s(s+2)): poles −1 ± sqrt(1−k); given in shuffled order at each gain.
        let gains: Vec<f64> = (0..=40).map(|i| i as f64 * 0.1).collect();
        let poles: Vec<Vec<Complex64>> = gains
            .iter()
            .enumerate()
            .map(|(i, k)| {
                let d = Complex64::new(1.0 - k, 0.0).sqrt();
                let (a, b) = (c(-1.0, 0.0) + d, c(-1.0, 0.0) - d);
                if i % 2 == 0 {
                    vec![a, b]
                } else {
                    vec![b, a]
                }
            })
            .collect();
        let br = root_locus_branches(&poles);
        assert_eq!(br.len(), 2);
        for b in &br {
            for w in b.windows(2) {
                assert!((w[1] - w[0]).norm() < 0.5, "a branch jumped: {w:?}");
            }
        }
        let f = rlocus_figure(
            "R",
            &RootLocusData {
                gains,
                poles,
                open_loop_poles: vec![c(0.0, 0.0), c(-2.0, 0.0)],
                open_loop_zeros: vec![],
            },
            false,
        );
        let p = &f.panels[0];
        assert!(p.equal_aspect);
        assert_eq!(p.series.iter().filter(|s| s.style == SeriesStyle::Line).count(), 2);
        assert!(p.series.iter().any(|s| s.style == SeriesStyle::Crosses));
        let (x0, x1) = p.x_range.expect("range");
        assert!(x0 < -2.0 && x1 > 0.0);
    }

    #[test]
    fn pzmap_has_poles_zeros_and_the_boundary() {
        let s = PoleZeroData {
            label: "G".into(),
            poles: vec![c(-1.0, 2.0), c(-1.0, -2.0), c(-5.0, 0.0)],
            zeros: vec![c(3.0, 0.0)],
        };
        let f = pzmap_figure("P", std::slice::from_ref(&s), false);
        let p = &f.panels[0];
        assert!(p
            .series
            .iter()
            .any(|s| s.style == SeriesStyle::Crosses && s.label == "G: poles"));
        assert!(p
            .series
            .iter()
            .any(|s| s.style == SeriesStyle::Circles && s.label == "G: zeros"));
        // The imaginary axis, long enough to cross the whole view.
        let axis = p
            .series
            .iter()
            .find(|s| s.style == SeriesStyle::Reference)
            .expect("boundary");
        assert_eq!(axis.x, vec![0.0, 0.0]);
        let (y0, y1) = p.y_range.expect("range");
        assert!(axis.y[0] < y0 && axis.y[1] > y1);
        let fd = pzmap_figure("P", &[s], true);
        let circle = fd.panels[0]
            .series
            .iter()
            .find(|s| s.style == SeriesStyle::Reference)
            .expect("unit circle");
        assert!(circle
            .x
            .iter()
            .zip(&circle.y)
            .all(|(x, y)| ((x * x + y * y) - 1.0).abs() < 1e-12));
    }
}
