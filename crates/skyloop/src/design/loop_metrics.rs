//! Analysis of a SISO loop L = P·C after each design step: classic and disk margins (exact delays),
//! closed-loop stability, the loop-shaping 4-block norm for a controller that is no longer
//! W1·K∞·W2 (after reduction), the RHP-zero and delay limits on the crossover, and how closely one
//! controller follows another over a band.

use serde::Serialize;
use skyloop_linalg::scalar_search::golden_max;
use skyloop_lti::error::Result;
use skyloop_lti::freqresp::{dynamics_range, logspace, FreqEvaluator, Workspace};
use skyloop_lti::interconnect::{feedback, series};
use skyloop_lti::margins::{allmargin, diskmargin, margin_from};
use skyloop_lti::{c64, LtiError, Mat, StateSpace};
use std::f64::consts::PI;

/// Hz from rad/s.
pub(crate) fn hz(w_rad_s: f64) -> f64 {
    w_rad_s / (2.0 * PI)
}

/// Classic (MATLAB `margin`) and symmetric disk margins of L = P·C, read with the exact delays,
/// every gain crossover, and the sensitivity peaks Ms and Mt.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoopMargins {
    /// Closed loop 1/(1 + L) stable (Nyquist, exact delays).
    pub stable: bool,
    /// Phase margin, degrees.
    pub phase_margin_deg: f64,
    /// Gain crossover frequency where the phase margin is read, Hz.
    pub crossover_hz: f64,
    /// Gain margin, dB.
    pub gain_margin_db: f64,
    /// Phase crossover frequency where the gain margin is read, Hz.
    pub gain_margin_freq_hz: f64,
    /// Extra loop delay that destabilizes the loop, s.
    pub delay_margin_s: f64,
    /// Disk size α (skew 0).
    pub disk_alpha: f64,
    /// Tolerated simultaneous gain variation [low, high], dB.
    pub disk_gain_db: [f64; 2],
    /// Tolerated simultaneous phase variation ±, degrees.
    pub disk_phase_deg: f64,
    /// Frequency of the smallest disk margin, Hz.
    pub disk_freq_hz: f64,
    /// Every gain crossover |L| = 1, Hz, increasing (a loop that crosses 0 dB again above the
    /// crossover has its delay margin set there).
    pub gain_crossovers_hz: Vec<f64>,
    /// The phase margin at each of `gain_crossovers_hz`, degrees.
    pub phase_margins_deg: Vec<f64>,
    /// Ms = max |S(jω)| = max 1/|1 + L|, absolute (1/Ms is the distance of L to −1).
    pub ms: f64,
    /// Frequency of Ms, Hz.
    pub ms_freq_hz: f64,
    /// Mt = max |T(jω)| = max |L/(1 + L)|, absolute.
    pub mt: f64,
    /// Frequency of Mt, Hz.
    pub mt_freq_hz: f64,
}

/// Margins of L = P·C (`p` may carry exact delays).
pub fn loop_margins(p: &StateSpace, c: &StateSpace) -> Result<LoopMargins> {
    let l = series(c, p)?;
    let all = allmargin(&l)?;
    let m = margin_from(&all);
    let dm = diskmargin(&l)?;
    let peaks = sensitivity_peaks(&l)?;
    let mut crossings: Vec<(f64, f64)> = all.phase_margins.iter().map(|p| (hz(p.w_rad_s), p.pm_deg)).collect();
    crossings.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(LoopMargins {
        stable: all.stable,
        phase_margin_deg: m.pm_deg,
        crossover_hz: hz(m.pm_w_rad_s),
        gain_margin_db: m.gm_db,
        gain_margin_freq_hz: hz(m.gm_w_rad_s),
        delay_margin_s: m.delay_margin_s,
        disk_alpha: dm.alpha,
        disk_gain_db: dm.gain_db,
        disk_phase_deg: dm.phase_deg,
        disk_freq_hz: hz(dm.w_rad_s),
        gain_crossovers_hz: crossings.iter().map(|c| c.0).collect(),
        phase_margins_deg: crossings.iter().map(|c| c.1).collect(),
        ms: peaks[0].0,
        ms_freq_hz: hz(peaks[0].1),
        mt: peaks[1].0,
        mt_freq_hz: hz(peaks[1].1),
    })
}

/// [(Ms, ω), (Mt, ω)] of a SISO loop `l` (exact delays), ω in rad/s: the peaks of |1/(1 + L)| and
/// |L/(1 + L)| on a grid of 80 points per decade over the loop's dynamics ±3 decades, each refined
/// by golden-section search between its grid neighbours. Meaningful for a stable closed loop.
pub fn sensitivity_peaks(l: &StateSpace) -> Result<[(f64, f64); 2]> {
    let mut ls = Siso::new(l)?;
    let (lo, hi) = dynamics_range(l)?;
    let f = |w: f64| -> [f64; 2] {
        match ls.at(w) {
            Ok(v) => {
                let s = 1.0 / (1.0 + v);
                [s.norm(), (v * s).norm()]
            }
            // A grid point on an integrator's pole: |S| = 0 and |T| = 1 there.
            Err(_) => [0.0, 1.0],
        }
    };
    grid_peaks(f, lo, hi)
}

/// True when the negative-feedback loop of the rational `p` and `c` is internally stable (every
/// state of both realizations is in the closed-loop A, so hidden unstable modes count too).
pub fn closed_loop_stable(p: &StateSpace, c: &StateSpace) -> Result<bool> {
    let l = series(c, p)?;
    let one = StateSpace::gain(Mat::identity(l.ny(), l.ny()), l.dt)?;
    let cl = feedback(&l, &one, -1.0)?;
    Ok(skyloop_lti::poles_zeros::poles(&cl)?.iter().all(|p| p.re < 0.0))
}

/// SISO frequency responses evaluated one point at a time.
struct Siso {
    ev: FreqEvaluator,
    ws: Workspace,
    out: [c64; 1],
}

impl Siso {
    fn new(sys: &StateSpace) -> Result<Self> {
        if sys.ny() != 1 || sys.nu() != 1 {
            return Err(LtiError::Dimension(format!(
                "expected a SISO model, got {}x{}",
                sys.ny(),
                sys.nu()
            )));
        }
        let ev = FreqEvaluator::new(sys)?;
        let ws = ev.workspace();
        Ok(Siso {
            ev,
            ws,
            out: [c64::new(0.0, 0.0)],
        })
    }

    /// G(jω), ω in rad/s (discrete models at z = e^{jω·dt}).
    fn at(&mut self, w: f64) -> Result<c64> {
        self.ev.eval_into(c64::new(0.0, w), &mut self.ws, &mut self.out)?;
        Ok(self.out[0])
    }
}

/// The loop-shaping γ of a controller C that need not factor as W1·K∞·W2: the 4-block norm
/// ‖[I; K](I − Ps·K)⁻¹[I Ps]‖∞ of the shaped plant Ps = W2·P·W1 with K = −W1⁻¹·C·W2⁻¹, which equals
/// ‖[W2; −W1⁻¹C](1 + PC)⁻¹[W2⁻¹, P·W1]‖∞ and, being rank one for SISO, |S|·‖u‖·‖v‖ at each ω.
/// Evaluated on a logarithmic grid over the dynamics of all four models (±3 decades) with golden-
/// section refinement of the peak; +∞ when the rational loop is not internally stable.
pub fn shaped_gamma(
    p_rational: &StateSpace,
    w1: Option<&StateSpace>,
    w2: Option<&StateSpace>,
    c: &StateSpace,
) -> Result<f64> {
    Ok(four_block_norms(p_rational, w1, w2, c)?.0)
}

/// (γ of the shaped loop as in [`shaped_gamma`], 1/b(P, C) of the unweighted loop) from one set of
/// frequency-response evaluations; both +∞ when the rational loop is not internally stable.
/// 1/b(P, C) = ‖[I; C](1 + PC)⁻¹[I P]‖∞ is the same expression with W1 = W2 = 1 (MATLAB ncfmargin).
pub fn four_block_norms(
    p_rational: &StateSpace,
    w1: Option<&StateSpace>,
    w2: Option<&StateSpace>,
    c: &StateSpace,
) -> Result<(f64, f64)> {
    if !closed_loop_stable(p_rational, c)? {
        return Ok((f64::INFINITY, f64::INFINITY));
    }
    let mut ps = Siso::new(p_rational)?;
    let mut cs = Siso::new(c)?;
    let mut w1s = w1.map(Siso::new).transpose()?;
    let mut w2s = w2.map(Siso::new).transpose()?;
    let (mut lo, mut hi) = dynamics_range(p_rational)?;
    for s in [Some(c), w1, w2].into_iter().flatten() {
        let (l, h) = dynamics_range(s)?;
        lo = lo.min(l);
        hi = hi.max(h);
    }
    let f = |w: f64| -> [f64; 2] {
        let one = c64::new(1.0, 0.0);
        let v = (|| -> Result<[f64; 2]> {
            let pv = ps.at(w)?;
            let cv = cs.at(w)?;
            let w1v = match w1s.as_mut() {
                Some(s) => s.at(w)?,
                None => one,
            };
            let w2v = match w2s.as_mut() {
                Some(s) => s.at(w)?,
                None => one,
            };
            let sens = (1.0 / (1.0 + pv * cv)).norm();
            let u = (w2v.norm_sqr() + (cv / w1v).norm_sqr()).sqrt();
            let v = ((1.0 / w2v).norm_sqr() + (pv * w1v).norm_sqr()).sqrt();
            let plain = ((1.0 + cv.norm_sqr()) * (1.0 + pv.norm_sqr())).sqrt();
            Ok([sens * u * v, sens * plain])
        })();
        // A grid point on a pole or zero of a weight: the neighbours carry the peak.
        v.ok()
            .map(|x| x.map(|y| if y.is_finite() { y } else { 0.0 }))
            .unwrap_or([0.0, 0.0])
    };
    let [(g, _), (b, _)] = grid_peaks(f, lo, hi)?;
    Ok((g, b))
}

/// The peaks of `N` smooth frequency functions `f(ω)` (rad/s): a grid of 80 points per decade over
/// `lo`/1000 .. `hi`·1000, then golden-section refinement of each peak between its grid neighbours.
/// Returns (peak value, ω) per function.
fn grid_peaks<const N: usize>(mut f: impl FnMut(f64) -> [f64; N], lo: f64, hi: f64) -> Result<[(f64, f64); N]> {
    let (a, b) = ((lo * 1e-3).log10(), (hi * 1e3).log10());
    let grid = logspace(a, b, ((b - a) * 80.0).ceil().max(50.0) as usize);
    let vals: Vec<[f64; N]> = grid.iter().map(|&w| f(w)).collect();
    let mut out = [(0.0, 0.0); N];
    for (j, o) in out.iter_mut().enumerate() {
        let (k, best) = vals
            .iter()
            .enumerate()
            .map(|(k, v)| (k, v[j]))
            .max_by(|x, y| x.1.total_cmp(&y.1))
            .ok_or_else(|| LtiError::Numerical("empty frequency grid".into()))?;
        let a = grid[k.saturating_sub(1)].ln();
        let b = grid[(k + 1).min(grid.len() - 1)].ln();
        let (x, refined) = golden_max(|x| f(x.exp())[j], a, b, 1e-10);
        *o = if refined > best {
            (refined, x.exp())
        } else {
            (best, grid[k])
        };
    }
    Ok(out)
}

/// Closeness of a controller `c` to a reference `r` over [f_lo, f_hi] Hz (400 log-spaced points).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Closeness {
    /// Lower end of the band, Hz.
    pub from_hz: f64,
    /// Upper end of the band, Hz.
    pub to_hz: f64,
    /// max |c − r|/|r| over the band.
    pub max_rel_error: f64,
    /// max |c − r| over the band.
    pub max_abs_error: f64,
    /// max |20·log10|c/r|| over the band, dB.
    pub max_mag_error_db: f64,
    /// max |∠(c/r)| over the band, degrees.
    pub max_phase_error_deg: f64,
}

/// How closely `c` follows `r` over [from_hz, to_hz]; either may be discrete (evaluated at e^{jω·dt}).
pub fn closeness(c: &StateSpace, r: &StateSpace, from_hz: f64, to_hz: f64) -> Result<Closeness> {
    closeness_warped(c, r, from_hz, to_hz, |w| w)
}

/// Like [`closeness`] but compares c(jω) with r(j·warp(ω)).
pub fn closeness_warped(
    c: &StateSpace,
    r: &StateSpace,
    from_hz: f64,
    to_hz: f64,
    warp: impl Fn(f64) -> f64,
) -> Result<Closeness> {
    if !(from_hz > 0.0 && to_hz > from_hz) {
        return Err(LtiError::InvalidArgument(format!(
            "comparison band must satisfy 0 < from < to, got [{from_hz}, {to_hz}] Hz"
        )));
    }
    let mut cs = Siso::new(c)?;
    let mut rs = Siso::new(r)?;
    let mut out = Closeness {
        from_hz,
        to_hz,
        max_rel_error: 0.0,
        max_abs_error: 0.0,
        max_mag_error_db: 0.0,
        max_phase_error_deg: 0.0,
    };
    for f in logspace(from_hz.log10(), to_hz.log10(), 400) {
        let w = 2.0 * PI * f;
        let cv = cs.at(w)?;
        let rv = rs.at(warp(w))?;
        let ratio = cv / rv;
        out.max_rel_error = out.max_rel_error.max((cv - rv).norm() / rv.norm());
        out.max_abs_error = out.max_abs_error.max((cv - rv).norm());
        out.max_mag_error_db = out.max_mag_error_db.max((20.0 * ratio.norm().log10()).abs());
        out.max_phase_error_deg = out.max_phase_error_deg.max(ratio.arg().abs().to_degrees());
    }
    Ok(out)
}

/// |P(jω)·C(jω)| (exact delays do not change the magnitude).
pub fn loop_gain_at(p: &StateSpace, c: &StateSpace, w_rad_s: f64) -> Result<f64> {
    let pv = Siso::new(p)?.at(w_rad_s)?;
    let cv = Siso::new(c)?.at(w_rad_s)?;
    Ok((pv * cv).norm())
}

/// Fundamental limits on the crossover (Skogestad & Postlethwaite §5.6–5.7): a real RHP zero z
/// bounds the bandwidth by about z/2, a delay θ by about 1/θ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CrossoverLimits {
    /// Smallest-magnitude RHP zero of the delay-free plant, Hz (null when none).
    pub rhp_zero_hz: Option<f64>,
    /// |z|/2 in Hz (null when no RHP zero).
    pub rhp_zero_limit_hz: Option<f64>,
    /// Total plant delay, s.
    pub delay_s: f64,
    /// 1/θ in Hz (null without delay).
    pub delay_limit_hz: Option<f64>,
    /// The final loop's gain crossover, Hz.
    pub crossover_hz: f64,
    /// crossover below both limits.
    pub within_limits: bool,
}

/// The crossover limits of a SISO plant (exact delays) for a loop crossing over at `crossover_hz`.
pub fn crossover_limits(p: &StateSpace, crossover_hz: f64) -> Result<CrossoverLimits> {
    let mut free = p.clone();
    free.input_delay.iter_mut().for_each(|t| *t = 0.0);
    free.output_delay.iter_mut().for_each(|t| *t = 0.0);
    let zeros = skyloop_lti::poles_zeros::zeros(&free)?;
    let z = zeros
        .iter()
        .filter(|z| z.re > 0.0)
        .map(|z| z.norm())
        .fold(f64::INFINITY, f64::min);
    let delay_s = p.input_delay.iter().sum::<f64>() + p.output_delay.iter().sum::<f64>();
    let rhp_zero_hz = z.is_finite().then(|| hz(z));
    let rhp_zero_limit_hz = rhp_zero_hz.map(|f| f / 2.0);
    let delay_limit_hz = (delay_s > 0.0).then(|| hz(1.0 / delay_s));
    let within_limits = crossover_hz.is_finite()
        && rhp_zero_limit_hz.is_none_or(|f| crossover_hz < f)
        && delay_limit_hz.is_none_or(|f| crossover_hz < f);
    Ok(CrossoverLimits {
        rhp_zero_hz,
        rhp_zero_limit_hz,
        delay_s,
        delay_limit_hz,
        crossover_hz,
        within_limits,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// L = 1/(s(s+1)): T = 1/(s²+s+1) peaks at 1/(2ζ√(1−ζ²)) = 2/√3 at ω = 1/√2 (ζ = 1/2), and
    /// |S|² = x(x+1)/(x²−x+1) with x = ω² peaks at x = (1+√3)/2.
    #[test]
    fn peaks_match_closed_forms() {
        let l = skyloop_lti::expr::parse_model("1/(s*(s+1))").unwrap();
        let [(ms, wms), (mt, wmt)] = sensitivity_peaks(&l).unwrap();
        assert!((mt - 2.0 / 3f64.sqrt()).abs() < 1e-9, "Mt {mt}");
        assert!((wmt - 0.5f64.sqrt()).abs() < 1e-4, "ω {wmt}");
        let x: f64 = (1.0 + 3f64.sqrt()) / 2.0;
        let ms_exact = (x * (x + 1.0) / (x * x - x + 1.0)).sqrt();
        assert!((ms - ms_exact).abs() < 1e-9, "Ms {ms} vs {ms_exact}");
        assert!((wms - x.sqrt()).abs() < 1e-4);
    }

    /// A delay leaves |L| alone but moves the phase: the peaks follow the exact delayed loop.
    #[test]
    fn delay_raises_ms() {
        let a = skyloop_lti::expr::parse_model("1/(s*(s+1))").unwrap();
        let b = skyloop_lti::expr::parse_model("exp(-0.3*s)/(s*(s+1))").unwrap();
        let (ma, mb) = (sensitivity_peaks(&a).unwrap()[0].0, sensitivity_peaks(&b).unwrap()[0].0);
        assert!(mb > ma + 0.3, "{ma} {mb}");
    }
}
