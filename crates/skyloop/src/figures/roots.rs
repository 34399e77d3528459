//! Root figures: the pole–zero map and the root locus of a loop under a swept gain.

use super::Labeled;
use crate::error::Result;
use faer::Mat;
use num_complex::Complex64 as C64;
use skyloop_lti::freqresp::{balanced_eigenvalues, dynamics_range, evalfr};
use skyloop_lti::poles_zeros::{poles, zeros};
use skyloop_plot::figure::Figure;
use skyloop_plot::pzmap::{pzmap_figure, rlocus_figure, PoleZeroData, RootLocusData};

/// Most gains a root locus evaluates (each one an n×n eigenvalue problem).
pub const MAX_LOCUS_GAINS: usize = 4000;

/// The pole–zero map (MATLAB `pzmap`) of the models: poles ×, transmission zeros ○, the imaginary
/// axis or, for discrete models, the unit circle. Models must share continuous or discrete time.
/// Delays do not move poles or zeros and are left out (a note in the CLI says so).
pub fn pzmap(models: &[Labeled]) -> Result<Figure> {
    let discrete = same_time_domain(models)?;
    let data = models
        .iter()
        .map(|m| {
            Ok(PoleZeroData {
                label: m.label.clone(),
                poles: poles(&m.sys).map_err(|e| format!("{}: {e}", m.label))?,
                zeros: zeros(&m.sys).map_err(|e| format!("{}: {e}", m.label))?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(pzmap_figure("Pole-zero map", &data, discrete))
}

/// Whether the models are all discrete (true) or all continuous (false).
fn same_time_domain(models: &[Labeled]) -> Result<bool> {
    let discrete = models.first().is_some_and(|m| !m.sys.is_continuous());
    if let Some(m) = models.iter().find(|m| m.sys.is_continuous() == discrete) {
        return Err(format!(
            "{}: continuous and discrete models cannot share one pole-zero map",
            m.label
        )
        .into());
    }
    Ok(discrete)
}

/// The closed-loop poles of `1 + k·L = 0` (negative feedback u = −k·y around the SISO loop L) for
/// a sweep of gains k ≥ 0, as MATLAB's `rlocus`: from k = 0 (the open-loop poles) over
/// `gains = (k_min, k_max)`, or by default six decades either side of the gain that makes |L| = 1
/// in the middle of the loop's dynamics, refined where the poles move fast.
///
/// # Errors
/// A MIMO loop, a delay (roots of a delayed loop are infinitely many: apply `pade` first), a gain
/// range that is not 0 < k_min < k_max < ∞.
pub fn root_locus_data(l: &Labeled, gains: Option<(f64, f64)>) -> Result<RootLocusData> {
    l.siso("a root locus")?;
    super::check_order(&l.sys, &l.label, "a root locus", super::MAX_RLOCUS_ORDER)?;
    let sys = &l.sys;
    if sys.has_delay() {
        return Err(format!(
            "{}: a root locus needs a rational loop; replace the delay by a Padé approximant first \
             (skyloop pade MODEL --order N)",
            l.label
        )
        .into());
    }
    let (k_lo, k_hi) = match gains {
        Some((a, b)) if a > 0.0 && b > a && b.is_finite() => (a, b),
        Some((a, b)) => return Err(format!("--gains must satisfy 0 < MIN < MAX < inf, got {a},{b}").into()),
        None => {
            let k_ref = reference_gain(l)?;
            (k_ref * 1e-6, k_ref * 1e6)
        }
    };
    let closed = |k: f64| -> Result<Vec<C64>> {
        let d = sys.d[(0, 0)];
        let den = 1.0 + k * d;
        if den.abs() < 1e-12 {
            return Err("gain makes 1 + k·D vanish".into());
        }
        // u = −k·(y) with y = Cx + Du  ⇒  u = −k/(1+kD)·Cx.
        let f = k / den;
        let a = Mat::from_fn(sys.nx(), sys.nx(), |i, j| {
            sys.a[(i, j)] - f * sys.b[(i, 0)] * sys.c[(0, j)]
        });
        Ok(balanced_eigenvalues(&a).map_err(|e| format!("{}: {e}", l.label))?)
    };
    let open = poles(sys).map_err(|e| format!("{}: {e}", l.label))?;
    let mut ks: Vec<f64> = vec![0.0];
    ks.extend(skyloop_lti::freqresp::try_logspace(k_lo.log10(), k_hi.log10(), 120)?);
    let mut roots: Vec<Vec<C64>> = Vec::with_capacity(ks.len());
    for &k in &ks {
        // A gain that hits 1 + kD = 0 exactly (a biproper loop) has poles at infinity: skip it.
        roots.push(closed(k).unwrap_or_default());
    }
    // Refine where a branch jumps by more than 3 % of the picture's size between neighbours.
    let scale = roots
        .iter()
        .flatten()
        .chain(&open)
        .map(|z| z.norm())
        .filter(|r| r.is_finite())
        .fold(0.0f64, f64::max)
        .max(1e-12);
    let mut pass = 0;
    while ks.len() < MAX_LOCUS_GAINS && pass < 8 {
        pass += 1;
        let mut next_k = vec![ks[0]];
        let mut next_r = vec![roots[0].clone()];
        let mut added = 0;
        for i in 1..ks.len() {
            let jump = displacement(&roots[i - 1], &roots[i]);
            if jump > 0.03 * scale && ks.len() + added < MAX_LOCUS_GAINS {
                let mid = if ks[i - 1] == 0.0 {
                    ks[i] * 1e-2
                } else {
                    (ks[i - 1] * ks[i]).sqrt()
                };
                next_k.push(mid);
                next_r.push(closed(mid).unwrap_or_default());
                added += 1;
            }
            next_k.push(ks[i]);
            next_r.push(roots[i].clone());
        }
        ks = next_k;
        roots = next_r;
        if added == 0 {
            break;
        }
    }
    let (gains, poles): (Vec<f64>, Vec<Vec<C64>>) =
        ks.into_iter().zip(roots).filter(|(_, r)| r.len() == sys.nx()).unzip();
    Ok(RootLocusData {
        gains,
        poles,
        open_loop_poles: open,
        open_loop_zeros: zeros(sys).map_err(|e| format!("{}: {e}", l.label))?,
    })
}

/// The root-locus figure of a SISO loop (see [`root_locus_data`]).
///
/// Without a gain range, the picture ends where the branches leave a disk of five times the size of
/// the open-loop poles and zeros (MATLAB frames the same region): asymptotes that run off to
/// infinity would otherwise squeeze the part where the design happens into a dot.
pub fn rlocus(l: &Labeled, gains: Option<(f64, f64)>) -> Result<Figure> {
    let mut data = root_locus_data(l, gains)?;
    if gains.is_none() && !l.sys.is_continuous() {
        // The unit circle sets the scale of a discrete locus.
        crop(&mut data, 3.0);
    } else if gains.is_none() {
        let size = data
            .open_loop_poles
            .iter()
            .chain(&data.open_loop_zeros)
            .map(|z| z.norm())
            .fold(0.0f64, f64::max);
        crop(&mut data, 5.0 * if size > 0.0 { size } else { 1.0 });
    }
    Ok(rlocus_figure(
        &format!("Root locus of {}", l.label),
        &data,
        !l.sys.is_continuous(),
    ))
}

/// Drops the gains after the first one at which a root lies beyond `radius` (that one is kept, so
/// the escaping branches reach the frame).
fn crop(data: &mut RootLocusData, radius: f64) {
    if let Some(k) = data.poles.iter().position(|r| r.iter().any(|z| z.norm() > radius)) {
        data.gains.truncate(k + 1);
        data.poles.truncate(k + 1);
    }
}

/// 1/|L(jω)| at the geometric middle of the loop's dynamics: the gain around which the locus
/// changes most.
fn reference_gain(l: &Labeled) -> Result<f64> {
    let (lo, hi) = dynamics_range(&l.sys).unwrap_or((1.0, 1.0));
    let w = (lo.max(1e-300) * hi.max(1e-300)).sqrt();
    let w = if w.is_finite() && w > 0.0 { w } else { 1.0 };
    let s = if l.sys.is_continuous() {
        C64::new(0.0, w)
    } else {
        C64::from_polar(1.0, (w * l.sys.dt).min(std::f64::consts::PI * 0.5))
    };
    let g = evalfr(&l.sys, s).map_err(|e| format!("{}: {e}", l.label))?[(0, 0)].norm();
    Ok(if g.is_finite() && g > 0.0 { 1.0 / g } else { 1.0 })
}

/// The largest distance from a root of `a` to its nearest root in `b` (a cheap branch-jump measure
/// that needs no matching); infinite when the counts differ.
fn displacement(a: &[C64], b: &[C64]) -> f64 {
    if a.len() != b.len() {
        return f64::INFINITY;
    }
    a.iter()
        .map(|p| b.iter().map(|q| (p - q).norm()).fold(f64::INFINITY, f64::min))
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prelude::parse_model;

    /// L = 1/(s(s+2)): the closed-loop poles are −1 ± √(1−k), meeting at −1 for k = 1 and going
    /// vertical after; every sampled gain must satisfy that.
    #[test]
    fn locus_matches_the_quadratic() {
        let l = Labeled::new("L", parse_model("1/(s*(s+2))").unwrap());
        let d = root_locus_data(&l, None).unwrap();
        assert!(d.gains.len() > 100);
        for (k, r) in d.gains.iter().zip(&d.poles) {
            let disc = C64::new(1.0 - k, 0.0).sqrt();
            for p in r {
                let e = (p - (C64::new(-1.0, 0.0) + disc))
                    .norm()
                    .min((p - (C64::new(-1.0, 0.0) - disc)).norm());
                assert!(e < 1e-6 * (1.0 + k.sqrt()), "k = {k}: {p}");
            }
        }
        assert!(d.open_loop_zeros.is_empty());
    }

    #[test]
    fn delays_and_bad_gains_are_refused() {
        let l = Labeled::new("L", parse_model("exp(-0.1*s)/(s+1)").unwrap());
        assert!(root_locus_data(&l, None).unwrap_err().to_string().contains("pade"));
        let l = Labeled::new("L", parse_model("1/(s+1)").unwrap());
        assert!(root_locus_data(&l, Some((2.0, 1.0))).is_err());
    }

    #[test]
    fn pzmap_refuses_mixed_domains() {
        let c = Labeled::new("c", parse_model("1/(s+1)").unwrap());
        let d = Labeled::new(
            "d",
            skyloop_lti::discretize::c2d(&c.sys, 0.1, skyloop_lti::discretize::Method::Zoh).unwrap(),
        );
        assert!(pzmap(std::slice::from_ref(&c)).is_ok());
        assert!(pzmap(&[c, d]).is_err());
    }
}
