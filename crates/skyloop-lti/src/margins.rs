//! Stability margins of a SISO loop transfer L (convention u = C(r − y), L = P·C), exact with delays.
//!
//! Crossings are located on an adaptively refined logarithmic grid of the exact response L(jω)
//! (delays included) and refined to machine precision with Brent's method. The refinement is
//! worst-interval-first within a fixed budget ([`MAX_SAMPLES`] evaluations), so a loop whose
//! computed response is rounding noise somewhere (far above the dynamics of a high-order loop) costs
//! that budget at most instead of bisecting without end; the budget bounds every call
//! ([`MAX_EVALUATIONS`] in all). A band where |L| ≡ 1 (all-pass loops) is reported once as
//! [`AllMargins::unit_gain_band_rad_s`] instead of as rounding-driven gain crossovers. Delays must be
//! finite, ≥ 0 and short enough for their phase to be resolved over the searched band (at most
//! [`MAX_DELAY_TURNS`] turns). Definitions follow
//! MATLAB: `allmargin` (every crossing), `margin` (the smallest-magnitude pair), the delay margin
//! min over gain crossovers of PM/ω, and `diskmargin` with skew σ = 0 (balanced, α = 1/‖S − 1/2‖∞).
//! Closed-loop stability comes from the Nyquist criterion on the exact L (see [`nyquist_stable`]).
//!
//! Search range: from two decades below to two decades above the model's characteristic frequencies
//! (poles, 1/delay), widened until no gain crossover can lie outside; for delayed continuous loops the
//! phase crossovers (infinitely many) are listed up to one decade above the fastest dynamics or
//! gain crossover, and not beyond one decade above the last frequency where |L| ≥ 0.01
//! ([`TAIL_MAGNITUDE`]: above it no crossing can decide stability and every gain margin exceeds
//! 40 dB). Discrete loops are searched up to the Nyquist frequency π/dt.

use crate::error::{LtiError, Result};
use crate::freqresp::{dynamics_range, pole_summary, FreqEvaluator, Workspace};
use crate::ss::StateSpace;
use faer::c64;
use skyloop_linalg::scalar_search::{brent_root, golden_max};
use std::collections::BinaryHeap;
use std::f64::consts::PI;

/// Most evaluations of L spent on the adaptive grid of one [`allmargin`] / [`diskmargin`] call.
pub const MAX_SAMPLES: usize = 30_000;

/// Most evaluations of L in one margins call (grid, crossing refinement, Nyquist winding).
pub const MAX_EVALUATIONS: usize = 150_000;

/// Most turns (2π each) the loop delay's phase may make over the searched band: each turn needs
/// dozens of samples, so longer delays (relative to the dynamics) are refused with an error.
pub const MAX_DELAY_TURNS: f64 = 300.0;

/// Relative tolerance on |L| = 1 for a band to count as all-pass (|L| ≡ 1).
const UNIT_GAIN_TOL: f64 = 1e-9;

/// A gain margin read at a phase crossover (phase of L ≡ −180° mod 360°).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainMargin {
    /// Gain margin in dB: −20·log10|L(jω)| (negative when the loop gain may only decrease).
    pub gm_db: f64,
    /// Phase-crossover frequency, rad/s.
    pub w_rad_s: f64,
}

/// A phase margin read at a gain crossover (|L(jω)| = 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseMargin {
    /// Phase margin in degrees, in (−180, 180]: the angle from −1 to L(jω).
    pub pm_deg: f64,
    /// Gain-crossover frequency, rad/s.
    pub w_rad_s: f64,
    /// Extra loop delay (s) that brings this crossover onto −1: (PM mod 360°)/ω.
    pub delay_margin_s: f64,
}

/// Every crossing of the loop (MATLAB `allmargin`).
#[derive(Debug, Clone, PartialEq)]
pub struct AllMargins {
    /// Gain margins at every phase crossover, by increasing frequency.
    pub gain_margins: Vec<GainMargin>,
    /// Phase margins at every gain crossover, by increasing frequency.
    pub phase_margins: Vec<PhaseMargin>,
    /// Smallest delay margin over the gain crossovers, s (0 when the closed loop is unstable,
    /// infinite without gain crossover).
    pub delay_margin_s: f64,
    /// True when the closed loop 1/(1 + L) is stable (Nyquist criterion, valid with delays).
    pub stable: bool,
    /// The frequency band searched for crossings, rad/s (see the module documentation).
    pub w_range_rad_s: (f64, f64),
    /// Where |L(jω)| ≡ 1 to 1e-9 (an all-pass loop, e.g. (s−1)/(s+1)), the band in rad/s; no gain
    /// crossovers are listed inside it (every frequency there is one).
    pub unit_gain_band_rad_s: Option<(f64, f64)>,
}

/// The classic margin pair (MATLAB `margin`): the gain and phase margins of smallest magnitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margins {
    /// Gain margin, dB (+∞ when the phase never crosses −180°).
    pub gm_db: f64,
    /// Its phase-crossover frequency, rad/s (NaN when none).
    pub gm_w_rad_s: f64,
    /// Phase margin, degrees (+∞ when the gain never crosses 1).
    pub pm_deg: f64,
    /// Its gain-crossover frequency, rad/s (NaN when none).
    pub pm_w_rad_s: f64,
    /// Delay margin, s (see [`AllMargins::delay_margin_s`]).
    pub delay_margin_s: f64,
    /// Closed-loop stability (Nyquist).
    pub stable: bool,
}

/// Symmetric (skew σ = 0) disk margin, MATLAB `diskmargin` for a SISO loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskMargin {
    /// Disk size α = 1 / max_ω |S − 1/2| with S = 1/(1 + L) (0 when the closed loop is unstable).
    pub alpha: f64,
    /// Tolerated gain variation [low, high] in dB: 20·log10((2 ∓ α)/(2 ± α)) (±∞ when α ≥ 2).
    pub gain_db: [f64; 2],
    /// Tolerated phase variation ± degrees: 2·atan(α/2).
    pub phase_deg: f64,
    /// Frequency where the margin is smallest, rad/s (NaN when the closed loop is unstable).
    pub w_rad_s: f64,
}

/// Evaluates a SISO loop at frequencies along the imaginary axis and nearby points.
struct Loop {
    ev: FreqEvaluator,
    ws: Workspace,
    out: [c64; 1],
    dt: f64,
    /// Evaluations so far (bounded by [`MAX_EVALUATIONS`]).
    evals: usize,
}

impl Loop {
    fn new(sys: &StateSpace) -> Result<Self> {
        if sys.ny() != 1 || sys.nu() != 1 {
            return Err(LtiError::Dimension(format!(
                "margins need a SISO loop transfer, got {} outputs and {} inputs",
                sys.ny(),
                sys.nu()
            )));
        }
        let ev = FreqEvaluator::new(sys)?;
        let ws = ev.workspace();
        Ok(Loop {
            ev,
            ws,
            out: [c64::new(0.0, 0.0)],
            dt: sys.dt,
            evals: 0,
        })
    }

    fn at_s(&mut self, s: c64) -> Result<c64> {
        self.evals += 1;
        self.ev.eval_into(s, &mut self.ws, &mut self.out)?;
        Ok(self.out[0])
    }

    fn budget_left(&self) -> bool {
        self.evals < MAX_EVALUATIONS
    }

    fn at(&mut self, w: f64) -> Result<c64> {
        self.at_s(c64::new(0.0, w))
    }

    /// L(jω), or infinity at a pole (used only where a value is needed for sign tests).
    fn at_or_inf(&mut self, w: f64) -> c64 {
        self.at(w).unwrap_or(c64::new(f64::INFINITY, 0.0))
    }
}

/// The sampled loop: frequencies (rad/s, increasing) and L at each.
struct Grid {
    w: Vec<f64>,
    l: Vec<c64>,
}

/// Search bounds (rad/s) for crossings: see the module documentation.
fn search_range(sys: &StateSpace, lp: &mut Loop) -> Result<(f64, f64)> {
    let (lo, hi) = dynamics_range(sys)?;
    // Far enough inside the floating-point range for the decade widening below (and the logarithmic
    // grid) to stay finite and normal.
    const W_MIN: f64 = 1e-250;
    const W_MAX: f64 = 1e250;
    if !(lo >= W_MIN && hi <= W_MAX) {
        return Err(LtiError::InvalidArgument(format!(
            "the loop's characteristic frequencies (poles, 1/delay) span {lo:e} to {hi:e} rad/s; margins search \
             {W_MIN:e} to {W_MAX:e} rad/s"
        )));
    }
    let nyquist = if sys.dt > 0.0 { PI / sys.dt } else { f64::INFINITY };
    let mut w_lo = (lo / 100.0).min(nyquist / 1e4);
    let delayed = sys.has_delay() && sys.dt == 0.0;
    let mut w_hi = (if delayed { hi * 10.0 } else { hi * 100.0 }).min(nyquist);
    let logmag = |lp: &mut Loop, w: f64| lp.at_or_inf(w).norm().ln();
    // Widen until the magnitude moves away from 0 dB beyond the ends (asymptotic region).
    for _ in 0..30 {
        if w_lo < 1e3 * W_MIN {
            break;
        }
        let (m1, m0) = (logmag(lp, w_lo), logmag(lp, w_lo / 10.0));
        if (m0 > 0.0) == (m1 > 0.0) && m0.abs() >= m1.abs() && m1 != 0.0 {
            break;
        }
        w_lo /= 10.0;
    }
    if w_hi < nyquist {
        for _ in 0..30 {
            if w_hi > 1e-3 * W_MAX {
                break;
            }
            let (m1, m2) = (logmag(lp, w_hi), logmag(lp, w_hi * 10.0));
            if ((m2 > 0.0) == (m1 > 0.0) && m2.abs() >= m1.abs() && m1 != 0.0) || (m1 - m2).abs() < 1e-9 {
                break;
            }
            w_hi = (w_hi * 10.0).min(nyquist);
            if w_hi >= nyquist {
                break;
            }
        }
    }
    if delayed {
        w_hi = quiet_tail(lp, w_lo.max(lo / 100.0), w_hi);
    }
    check_delay(sys, w_hi)?;
    Ok((w_lo, w_hi))
}

/// |L| below which a delayed loop's tail is not searched (−40 dB).
pub const TAIL_MAGNITUDE: f64 = 1e-2;

/// For a delayed loop: one decade above the last frequency in [a, b] where |L| ≥
/// [`TAIL_MAGNITUDE`] (or `b`). Above it no gain crossover and no encirclement of −1 can occur,
/// and its phase crossovers have gain margins above 40 dB; searching it only makes the delay's
/// phase turn (a PID's derivative filter at 1000·ω_u behind a delay of 1 s would turn 2000 times).
fn quiet_tail(lp: &mut Loop, a: f64, b: f64) -> f64 {
    if !(a > 0.0 && b > a) {
        return b;
    }
    // |L| does not depend on the delay; 100 points per decade catch resonances down to ζ ≈ 0.01.
    let n = ((100.0 * (b / a).log10()).ceil() as usize).clamp(2, 5000);
    let step = (b / a).ln() / (n - 1) as f64;
    let mut last_loud = None;
    for k in (0..n).rev() {
        let w = a * (step * k as f64).exp();
        let m = lp.at_or_inf(w).norm();
        if !(m < TAIL_MAGNITUDE) {
            last_loud = Some(w);
            break;
        }
    }
    match last_loud {
        Some(w) => (10.0 * w).min(b),
        None => b.min(10.0 * a),
    }
}

/// Refuses delays whose phase over [0, w_hi] turns more than [`MAX_DELAY_TURNS`] times.
fn check_delay(sys: &StateSpace, w_hi: f64) -> Result<()> {
    let tau = sys.input_delay[0] + sys.output_delay[0];
    if !(tau.is_finite() && tau >= 0.0) {
        return Err(LtiError::InvalidArgument(format!(
            "the loop delay must be finite and >= 0, got {tau} s"
        )));
    }
    let turns = tau * w_hi / (2.0 * PI);
    if turns > MAX_DELAY_TURNS {
        return Err(LtiError::InvalidArgument(format!(
            "the loop delay of {tau} s is too long for its dynamics: its phase turns {turns:.3e} times over the \
             searched band up to {w_hi:.4e} rad/s, at most {MAX_DELAY_TURNS} are resolved (delays up to {:.4e} s for this loop)",
            MAX_DELAY_TURNS * 2.0 * PI / w_hi
        )));
    }
    Ok(())
}

/// An interval of the grid awaiting refinement, ordered by how far it is from resolved.
struct Pending {
    score: f64,
    wl: f64,
    ll: c64,
    wr: f64,
    lr: c64,
}

impl PartialEq for Pending {
    fn eq(&self, o: &Self) -> bool {
        self.score.total_cmp(&o.score).is_eq()
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Pending {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.score.total_cmp(&o.score)
    }
}

/// How unresolved an interval is: its phase change in units of 10° or its magnitude change in units
/// of 0.1 neper, whichever is larger (> 1 means it must be split); 0 when it is too narrow to split.
fn unresolved(wl: f64, ll: c64, wr: f64, lr: c64) -> f64 {
    if wr - wl <= 1e-13 * wr {
        return 0.0;
    }
    let dphi = (lr / ll).arg().abs();
    let dmag = (lr.norm().ln() - ll.norm().ln()).abs();
    let score = (dphi / 10f64.to_radians()).max(dmag / 0.1);
    if score.is_nan() {
        // A pole or an overflow at an end: split once more to locate it, but only just.
        1.0 + f64::EPSILON
    } else {
        score
    }
}

/// Samples L on [w_lo, w_hi] (100 points/decade, at most 20,000), then splits the least resolved
/// interval (phase change over 10° or magnitude change over 0.1 neper) at its geometric mean, worst
/// first, until every interval is resolved or [`MAX_SAMPLES`] evaluations are spent: so no crossing
/// hides between samples where L is resolvable, and noise-level parts cannot eat memory and time.
fn sample(lp: &mut Loop, w_lo: f64, w_hi: f64) -> Result<Grid> {
    let decades = (w_hi / w_lo).log10().max(0.1);
    let n0 = ((decades * 100.0).ceil() as usize).clamp(20, 20_000);
    let base = crate::freqresp::logspace(w_lo.log10(), w_hi.log10(), n0);
    let mut pts: Vec<(f64, c64)> = Vec::with_capacity(2 * n0);
    for &w in &base {
        pts.push((w, lp.at(w)?));
    }
    let mut heap = BinaryHeap::new();
    for p in pts.windows(2) {
        let score = unresolved(p[0].0, p[0].1, p[1].0, p[1].1);
        if score > 1.0 {
            heap.push(Pending {
                score,
                wl: p[0].0,
                ll: p[0].1,
                wr: p[1].0,
                lr: p[1].1,
            });
        }
    }
    let mut spent = 0;
    while let Some(iv) = heap.pop() {
        if spent >= MAX_SAMPLES {
            break;
        }
        let wm = (iv.wl * iv.wr).sqrt();
        let lm = lp.at(wm)?;
        spent += 1;
        pts.push((wm, lm));
        for (wl, ll, wr, lr) in [(iv.wl, iv.ll, wm, lm), (wm, lm, iv.wr, iv.lr)] {
            let score = unresolved(wl, ll, wr, lr);
            if score > 1.0 {
                heap.push(Pending { score, wl, ll, wr, lr });
            }
        }
    }
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(Grid {
        w: pts.iter().map(|p| p.0).collect(),
        l: pts.iter().map(|p| p.1).collect(),
    })
}

/// The widest run of samples with |L| = 1 to [`UNIT_GAIN_TOL`] that spans at least three samples
/// and 0.1 % in frequency, as index range: there the loop is all-pass.
fn unit_gain_band(g: &Grid) -> Option<(usize, usize)> {
    let on = |k: usize| (g.l[k].norm() - 1.0).abs() <= UNIT_GAIN_TOL;
    let mut best: Option<(usize, usize)> = None;
    let mut k = 0;
    while k < g.w.len() {
        if !on(k) {
            k += 1;
            continue;
        }
        let start = k;
        while k + 1 < g.w.len() && on(k + 1) {
            k += 1;
        }
        if k >= start + 2 && g.w[k] >= 1.001 * g.w[start] {
            let wider = best.is_none_or(|(a, b)| g.w[k] / g.w[start] > g.w[b] / g.w[a]);
            if wider {
                best = Some((start, k));
            }
        }
        k += 1;
    }
    best
}

/// Every gain margin and phase margin of the SISO loop `l` (MATLAB `allmargin`), exact with delays.
///
/// # Errors
/// A MIMO or non-finite loop, or a loop whose response cannot be evaluated on the search band.
///
/// # Examples
/// ```
/// use skyloop_lti::expr::parse_model;
/// // L = 1/(s(s+1)(s+2)): the phase crosses −180° at √2 rad/s where |L| = 1/6, so GM = 20·log10(6) dB.
/// let l = parse_model("1/(s*(s+1)*(s+2))")?;
/// let m = skyloop_lti::margins::allmargin(&l)?;
/// assert_eq!(m.gain_margins.len(), 1);
/// assert!((m.gain_margins[0].gm_db - 20.0 * 6f64.log10()).abs() < 1e-6);
/// assert!((m.gain_margins[0].w_rad_s - 2f64.sqrt()).abs() < 1e-6);
/// assert!(m.stable);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn allmargin(l: &StateSpace) -> Result<AllMargins> {
    Ok(allmargin_counted(l)?.0)
}

/// [`allmargin`] and the number of evaluations of L it took.
fn allmargin_counted(l: &StateSpace) -> Result<(AllMargins, usize)> {
    let mut lp = Loop::new(l)?;
    let (w_lo, w_hi) = search_range(l, &mut lp)?;
    let g = sample(&mut lp, w_lo, w_hi)?;
    let (stable, nyquist_evals) = nyquist_counted(l)?;
    let mut gain_margins = Vec::new();
    let mut phase_margins = Vec::new();

    // DC: a finite, real, negative L(0) is a phase crossover at ω = 0 (as MATLAB and python-control).
    let integrators = pole_summary(l)?.origin > 0;
    if let (false, Ok(l0)) = (integrators, lp.at(0.0)) {
        if l0.re < 0.0 && l0.im.abs() <= 1e-12 * l0.norm() {
            gain_margins.push(GainMargin {
                gm_db: -20.0 * l0.norm().log10(),
                w_rad_s: 0.0,
            });
        }
    }
    let tol = |a: f64, b: f64| 1e-15 * a.abs().max(b.abs());
    let band = unit_gain_band(&g);
    let in_band = |k: usize| band.is_some_and(|(a, b)| k + 1 >= a && k <= b);
    for k in 0..g.w.len() - 1 {
        if !lp.budget_left() {
            return Err(LtiError::Numerical(format!(
                "margins: the crossings were not resolved within {MAX_EVALUATIONS} evaluations of L"
            )));
        }
        let (wa, wb) = (g.w[k], g.w[k + 1]);
        let (la, lb) = (g.l[k], g.l[k + 1]);
        // Where the computed response over- or underflowed (NaN: inf − inf in a long chain of
        // integrators, say) no side of |L| = 1 or of the real axis is known: a NaN compared as
        // "below 1" would report a crossover at the overflow's edge.
        if la.re.is_nan() || la.im.is_nan() || lb.re.is_nan() || lb.im.is_nan() {
            continue;
        }
        // Phase crossover: Im L changes sign where Re L < 0 (sin(arg L) is bounded and smooth there).
        if (la.im > 0.0) != (lb.im > 0.0) && (la.re < 0.0 || lb.re < 0.0) {
            let wc = brent_root(
                |w| {
                    let v = lp.at_or_inf(w);
                    v.im / v.norm()
                },
                wa,
                wb,
                tol(wa, wb),
            );
            let v = lp.at(wc)?;
            if v.re < 0.0 {
                gain_margins.push(GainMargin {
                    gm_db: -20.0 * v.norm().log10(),
                    w_rad_s: wc,
                });
            }
        }
        // Gain crossover: ln|L| changes sign (not inside an all-pass band, where it is rounding).
        if (la.norm() > 1.0) != (lb.norm() > 1.0) && !in_band(k) {
            let wc = brent_root(|w| lp.at_or_inf(w).norm().ln(), wa, wb, tol(wa, wb));
            let v = lp.at(wc)?;
            let pm = (-v).arg();
            // (−180, 180]: −L = −1 − 0i (a signed zero) would read −180°.
            let pm = if pm <= -PI { PI } else { pm };
            let pm_pos = if pm < 0.0 { pm + 2.0 * PI } else { pm };
            phase_margins.push(PhaseMargin {
                pm_deg: pm.to_degrees(),
                w_rad_s: wc,
                delay_margin_s: pm_pos / wc,
            });
        }
    }
    let delay_margin_s = if !stable {
        0.0
    } else {
        phase_margins
            .iter()
            .map(|p| p.delay_margin_s)
            .fold(f64::INFINITY, f64::min)
    };
    let all = AllMargins {
        gain_margins,
        phase_margins,
        delay_margin_s,
        stable,
        w_range_rad_s: (w_lo, w_hi),
        unit_gain_band_rad_s: band.map(|(a, b)| (g.w[a], g.w[b])),
    };
    Ok((all, lp.evals + nyquist_evals))
}

/// The gain and phase margins of smallest magnitude (MATLAB `margin` semantics: min |GM in dB|, min |PM|).
///
/// # Errors
/// As [`allmargin`].
///
/// # Examples
/// ```
/// let l = skyloop_lti::expr::parse_model("1/(s*(s+1)*(s+2))")?;
/// let m = skyloop_lti::margins::margin(&l)?;
/// assert!((m.gm_db - 15.563).abs() < 1e-3);
/// assert!(m.pm_deg > 50.0 && m.pm_deg < 54.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn margin(l: &StateSpace) -> Result<Margins> {
    let all = allmargin(l)?;
    Ok(margin_from(&all))
}

/// Picks the MATLAB `margin` pair out of `allmargin` results.
pub fn margin_from(all: &AllMargins) -> Margins {
    let gm = all
        .gain_margins
        .iter()
        .min_by(|a, b| a.gm_db.abs().total_cmp(&b.gm_db.abs()));
    let pm = all
        .phase_margins
        .iter()
        .min_by(|a, b| a.pm_deg.abs().total_cmp(&b.pm_deg.abs()));
    Margins {
        gm_db: gm.map_or(f64::INFINITY, |g| g.gm_db),
        gm_w_rad_s: gm.map_or(f64::NAN, |g| g.w_rad_s),
        pm_deg: pm.map_or(f64::INFINITY, |p| p.pm_deg),
        pm_w_rad_s: pm.map_or(f64::NAN, |p| p.w_rad_s),
        delay_margin_s: all.delay_margin_s,
        stable: all.stable,
    }
}

/// Delay margin of the loop in seconds: the smallest extra loop delay that destabilizes it
/// (min over gain crossovers of (PM mod 360°)/ω; the loop's own delays are already in its phase).
pub fn delay_margin(l: &StateSpace) -> Result<f64> {
    Ok(allmargin(l)?.delay_margin_s)
}

/// Symmetric disk margin of the SISO loop `l` (skew σ = 0), exact with delays.
///
/// # Errors
/// As [`allmargin`].
///
/// # Examples
/// ```
/// // L = 2/s: |S − 1/2| = |(s − 2)/(2(s + 2))| = 1/2 at every ω, so α = 2 (MATLAB diskmargin),
/// // and the disk holds every gain from 0 to ∞.
/// let l = skyloop_lti::expr::parse_model("2/s")?;
/// let d = skyloop_lti::margins::diskmargin(&l)?;
/// assert!((d.alpha - 2.0).abs() < 1e-9);
/// assert_eq!(d.gain_db, [f64::NEG_INFINITY, f64::INFINITY]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn diskmargin(l: &StateSpace) -> Result<DiskMargin> {
    let mut lp = Loop::new(l)?;
    if !nyquist_stable(l)? {
        return Ok(DiskMargin {
            alpha: 0.0,
            gain_db: [0.0, 0.0],
            phase_deg: 0.0,
            w_rad_s: f64::NAN,
        });
    }
    let (w_lo, w_hi) = search_range(l, &mut lp)?;
    let g = sample(&mut lp, w_lo, w_hi)?;
    let f = |v: c64| ((1.0 - v) / (2.0 * (1.0 + v))).norm();
    let mut best = (f64::NAN, 0.0);
    if pole_summary(l)?.origin == 0 {
        if let Ok(l0) = lp.at(0.0) {
            best = (0.0, f(l0));
        }
    }
    let mut kbest = None;
    for (k, &v) in g.l.iter().enumerate() {
        let fv = f(v);
        if fv > best.1 {
            best = (g.w[k], fv);
            kbest = Some(k);
        }
    }
    if let Some(k) = kbest {
        let a = g.w[k.saturating_sub(1)];
        let b = g.w[(k + 1).min(g.w.len() - 1)];
        let (x, fx) = golden_max(|w| f(lp.at_or_inf(w)), a, b, 1e-13);
        if fx > best.1 {
            best = (x, fx);
        }
    }
    // With no peak (f ≤ 1/2 asymptotes), the supremum is read at the grid end.
    let alpha = if best.1 > 0.0 { 1.0 / best.1 } else { f64::INFINITY };
    Ok(DiskMargin::from_alpha(alpha, best.0))
}

impl DiskMargin {
    /// The balanced (skew 0) disk of size `alpha` as gain range (dB) and phase (± degrees), at the
    /// frequency `w` (rad/s) where it was found: the gain may change by a factor in
    /// [(2 − α)/(2 + α), (2 + α)/(2 − α)] and the phase by ±2·atan(α/2), both at once.
    ///
    /// ```
    /// let d = skyloop_lti::margins::DiskMargin::from_alpha(0.5, 1.0);
    /// assert!((d.gain_db[1] - 4.437).abs() < 1e-3 && (d.phase_deg - 28.07).abs() < 1e-2);
    /// ```
    pub fn from_alpha(alpha: f64, w: f64) -> DiskMargin {
        // From α = 2 on, the disk holds every gain from 0 to ∞ (MATLAB: GM = [0 Inf]). An α a few ulps
        // below 2 (the loop 1/s) must not turn into a finite ±319 dB.
        let unbounded = alpha >= 2.0 * (1.0 - 1e-9);
        let low = (2.0 - alpha) / (2.0 + alpha);
        let high = (2.0 + alpha) / (2.0 - alpha);
        DiskMargin {
            alpha,
            gain_db: if unbounded {
                [f64::NEG_INFINITY, f64::INFINITY]
            } else {
                [20.0 * low.log10(), 20.0 * high.log10()]
            },
            phase_deg: (2.0 * (alpha / 2.0).atan()).to_degrees(),
            w_rad_s: w,
        }
    }
}

/// Closed-loop stability of the unity negative feedback around `l` by the Nyquist criterion on the
/// exact L (delays included): the winding of 1 + L(s) along the imaginary axis (unit circle for
/// discrete loops), indented to the right of open-loop poles on the axis, must equal the number of
/// open-loop poles in the right half-plane (outside the unit circle).
pub fn nyquist_stable(l: &StateSpace) -> Result<bool> {
    Ok(nyquist_counted(l)?.0)
}

/// [`nyquist_stable`] and the number of evaluations of L it took.
fn nyquist_counted(l: &StateSpace) -> Result<(bool, usize)> {
    let mut lp = Loop::new(l)?;
    // Loop::new has checked that L is SISO.
    if (1.0 + l.d[(0, 0)]).abs() <= 1e-12 * l.d[(0, 0)].abs().max(1.0) {
        // 1 + L(∞) = 0: the closed loop L/(1 + L) is improper (e.g. (1−s)/(1+s) gives (1−s)/2), so
        // "stable" has no meaning for it; saying UNSTABLE would be as wrong as saying stable.
        return Err(LtiError::Unsupported(format!(
            "the feedback loop is ill-posed: L(∞) = {} so 1 + L(∞) = 0 and the closed loop L/(1 + L) is improper",
            l.d[(0, 0)]
        )));
    }
    let dt = lp.dt;
    let poles = pole_summary(l)?;
    let unstable = poles.unstable;
    let (lo, hi) = dynamics_range(l)?;
    let mut w_end = if dt > 0.0 { PI / dt } else { hi * 1e4 };
    if dt == 0.0 {
        // Past w_end the rational part must have died out, so the tail adds no winding.
        let (d, tau) = (l.d[(0, 0)], l.input_delay[0] + l.output_delay[0]);
        for _ in 0..40 {
            let v = lp.at(w_end).unwrap_or(c64::new(f64::INFINITY, 0.0));
            if (v - d * c64::new(0.0, -w_end * tau).exp()).norm() <= 1e-3 {
                break;
            }
            w_end *= 10.0;
        }
    }
    if dt == 0.0 && l.has_delay() && l.d[(0, 0)].abs() >= 1.0 {
        return Err(LtiError::Unsupported(
            "a delayed loop with |D| >= 1 is a neutral system; its Nyquist test is not decided".into(),
        ));
    }
    let mut axis = poles.axis_w.clone();
    axis.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs().max(1.0));
    let mut total = 0.0;
    let mut prev: Option<c64> = None;
    let add = |v: c64, prev: &mut Option<c64>, total: &mut f64| -> bool {
        let f = 1.0 + v;
        if !(f.re.is_finite() && f.im.is_finite()) || f.norm() == 0.0 {
            return false;
        }
        if let Some(p) = *prev {
            *total += (f / p).arg();
        }
        *prev = Some(f);
        true
    };
    // Path: segments on the axis between indentations; each piece refined so that the phase of
    // 1 + L moves less than 30° per step.
    let mut pieces: Vec<Piece> = Vec::new();
    let mut w0 = 0.0;
    if poles.origin > 0 {
        // Radius far outside the integrators' numerical scatter, far inside the other dynamics.
        let eps0 = (poles.origin_radius.max(1e-12 * lo) * lo).sqrt();
        pieces.push(Piece::Arc {
            center: 0.0,
            radius: eps0,
            from: 0.0,
            to: PI / 2.0,
        });
        w0 = eps0;
    }
    for (k, &wp) in axis.iter().enumerate() {
        if wp > w_end * (1.0 + 1e-12) || wp <= w0 {
            continue;
        }
        let gap = [k.checked_sub(1).map(|i| axis[i]), axis.get(k + 1).copied()]
            .into_iter()
            .flatten()
            .map(|o| (o - wp).abs())
            .fold(wp, f64::min);
        let eps = (1e-4 * wp).min(1e-2 * gap).max(1e-10 * wp);
        pieces.push(Piece::Axis { from: w0, to: wp - eps });
        let to = if wp >= w_end * (1.0 - 1e-12) { 0.0 } else { PI / 2.0 };
        pieces.push(Piece::Arc {
            center: wp,
            radius: eps,
            from: -PI / 2.0,
            to,
        });
        w0 = wp + eps;
    }
    if w0 < w_end {
        pieces.push(Piece::Axis { from: w0, to: w_end });
    }
    for piece in pieces {
        let pt = |t: f64| piece.point(t);
        let n0 = 400usize;
        let mut tprev = 0.0;
        let Ok(v0) = lp.at_s(pt(0.0)) else {
            return Ok((false, lp.evals));
        };
        if !add(v0, &mut prev, &mut total) {
            return Ok((false, lp.evals));
        }
        let mut fprev = 1.0 + v0;
        for k in 1..=n0 {
            let t = k as f64 / n0 as f64;
            let mut stack = vec![(t, 0u32)];
            while let Some(&(tr, depth)) = stack.last() {
                if !lp.budget_left() {
                    return Err(LtiError::Numerical(format!(
                        "Nyquist test: the winding of 1 + L was not resolved within {MAX_EVALUATIONS} evaluations"
                    )));
                }
                let v = match lp.at_s(pt(tr)) {
                    Ok(v) => v,
                    Err(_) => return Ok((false, lp.evals)),
                };
                let f = 1.0 + v;
                if (f / fprev).arg().abs() > PI / 6.0 && depth < 50 {
                    stack.push((0.5 * (tprev + tr), depth + 1));
                    continue;
                }
                if !add(v, &mut prev, &mut total) {
                    return Ok((false, lp.evals));
                }
                tprev = tr;
                fprev = f;
                stack.pop();
            }
        }
    }
    let winding = total / PI;
    let w_int = winding.round();
    if (winding - w_int).abs() > 0.25 {
        // 1 + L passes (numerically) through 0 or the tail did not settle: marginal at best.
        return Ok((false, lp.evals));
    }
    Ok((w_int as i64 == unstable as i64, lp.evals))
}

/// One piece of the upper half of the Nyquist contour, parametrized by t ∈ [0, 1].
#[derive(Clone, Copy)]
enum Piece {
    /// s = jω with ω from `from` to `to` (log-spaced when both are positive).
    Axis { from: f64, to: f64 },
    /// s = j·center + radius·e^{jθ}, θ from `from` to `to` (to the right of the axis).
    Arc {
        center: f64,
        radius: f64,
        from: f64,
        to: f64,
    },
}

impl Piece {
    fn point(&self, t: f64) -> c64 {
        match *self {
            Piece::Axis { from, to } => {
                let w = if from > 0.0 {
                    from * (to / from).powf(t)
                } else {
                    // from 0: linear to a small value, then logarithmic
                    let knee = to * 1e-6;
                    if t < 0.1 {
                        knee * t / 0.1
                    } else {
                        knee * (to / knee).powf((t - 0.1) / 0.9)
                    }
                };
                c64::new(0.0, w)
            }
            Piece::Arc {
                center,
                radius,
                from,
                to,
            } => {
                let th = from + (to - from) * t;
                c64::new(radius * th.cos(), center + radius * th.sin())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// The gain and phase a disk α tolerates, checked on the perturbation set itself rather than the
    /// closed forms: the balanced disk multiplies L by f = (2 + αδ)/(2 − αδ), |δ| ≤ 1, so the gain
    /// range is f at δ = ±1 and the phase is the largest arg f along |δ| = 1.
    #[test]
    fn disk_from_alpha_matches_the_perturbation_set() {
        for alpha in [0.1, 0.5, 0.625, 1.0, 1.5] {
            let d = DiskMargin::from_alpha(alpha, 1.0);
            let f = |z: c64| (c64::new(2.0, 0.0) + z * alpha) / (c64::new(2.0, 0.0) - z * alpha);
            let hi = 20.0 * f(c64::new(1.0, 0.0)).re.log10();
            let lo = 20.0 * f(c64::new(-1.0, 0.0)).re.log10();
            let phase = (0..=200_000)
                .map(|k| f(c64::from_polar(1.0, k as f64 * std::f64::consts::PI / 200_000.0)).arg())
                .fold(0.0f64, f64::max)
                .to_degrees();
            assert!(
                (d.gain_db[1] - hi).abs() < 1e-9 && (d.gain_db[0] - lo).abs() < 1e-9,
                "{alpha}"
            );
            assert!(
                (d.phase_deg - phase).abs() < 1e-6,
                "{alpha}: {} vs {phase}",
                d.phase_deg
            );
        }
        // The floor tune states: α = 0.5 is ±4.44 dB (gain 0.6 … 1.667) and ±28.07°.
        let d = DiskMargin::from_alpha(0.5, 1.0);
        assert!((d.gain_db[1] - 20.0 * (5.0f64 / 3.0).log10()).abs() < 1e-12);
        assert!((d.phase_deg - 28.0725).abs() < 1e-4);
    }

    fn tf1(num: &[f64], den: &[f64], delay: f64) -> StateSpace {
        // Test-only controllable canonical realization of num/den (den monic after scaling).
        let n = den.len() - 1;
        let lead = den[0];
        let a = Mat::from_fn(n, n, |i, j| {
            if i == 0 {
                -den[j + 1] / lead
            } else if i == j + 1 {
                1.0
            } else {
                0.0
            }
        });
        let b = Mat::from_fn(n, 1, |i, _| if i == 0 { 1.0 } else { 0.0 });
        let mut nm = vec![0.0; n + 1];
        nm[n + 1 - num.len()..].copy_from_slice(num);
        let d0 = nm[0] / lead;
        let c = Mat::from_fn(1, n, |_, j| nm[j + 1] / lead - d0 * den[j + 1] / lead);
        let d = Mat::from_fn(1, 1, |_, _| d0);
        StateSpace::new(a, b, c, d, 0.0)
            .unwrap()
            .with_delays(vec![delay], vec![0.0])
            .unwrap()
    }

    #[test]
    fn third_order_type_one_loop_closed_form() {
        // L = 3/(s(s+1)(s+2)): phase crossover at ω = √2 with |L| = 1/2 (GM = 20·log10 2 dB).
        let l = tf1(&[3.0], &[1.0, 3.0, 2.0, 0.0], 0.0);
        let m = margin(&l).unwrap();
        assert!((m.gm_w_rad_s - 2f64.sqrt()).abs() < 1e-12);
        assert!((m.gm_db - 20.0 * 2f64.log10()).abs() < 1e-10);
        assert!(m.stable);
    }

    #[test]
    fn pure_delay_integrator_closed_form() {
        // L = k e^{−sτ}/s: |L| = 1 at ω = k; PM = 90° − kτ rad; closed loop stable iff kτ < π/2.
        let (k, tau) = (2.0, 0.1);
        let l = tf1(&[k], &[1.0, 0.0], tau);
        let all = allmargin(&l).unwrap();
        assert_eq!(all.phase_margins.len(), 1);
        let pm = all.phase_margins[0];
        assert!((pm.w_rad_s - k).abs() < 1e-12);
        assert!((pm.pm_deg - (90.0 - (k * tau).to_degrees())).abs() < 1e-9);
        // delay margin: (π/2 − kτ)/k
        assert!((all.delay_margin_s - (PI / 2.0 - k * tau) / k).abs() < 1e-12);
        assert!(all.stable);
        let unstable = tf1(&[20.0], &[1.0, 0.0], tau);
        assert!(!nyquist_stable(&unstable).unwrap());
    }

    #[test]
    fn nyquist_counts_open_loop_rhp_poles() {
        // L = 10(s+3)/((s−1)(s+8)): closed-loop char. poly s² + 17s + 22, stable (Routh).
        assert!(nyquist_stable(&tf1(&[10.0, 30.0], &[1.0, 7.0, -8.0], 0.0)).unwrap());
        // L = 2/(s−1)·1/(s+8): char. poly s² + 7s − 6, unstable.
        assert!(!nyquist_stable(&tf1(&[2.0], &[1.0, 7.0, -8.0], 0.0)).unwrap());
    }

    /// A random n-state loop (seeded): Gaussian A, B, C like a careless design iteration, gain
    /// spread over decades; about half are closed-loop unstable, some open-loop unstable.
    fn random_loop(n: usize, seed: u64) -> StateSpace {
        use rand::{Rng, SeedableRng};
        let mut r = rand::rngs::StdRng::seed_from_u64(seed);
        let mut g = || {
            // Box–Muller normal deviates.
            let (u, v): (f64, f64) = (r.gen_range(1e-12..1.0), r.gen_range(0.0..1.0));
            (-2.0 * u.ln()).sqrt() * (2.0 * PI * v).cos()
        };
        let a = Mat::from_fn(n, n, |_, _| g());
        let b = Mat::from_fn(n, 1, |_, _| g());
        let k = 10f64.powf(2.0 * g());
        let c = Mat::from_fn(1, n, |_, _| k * g());
        if seed % 2 == 0 {
            return StateSpace::new(a, b, c, Mat::zeros(1, 1), 0.0).unwrap();
        }
        // Odd seeds: an all-pole loop k/Π(s − p) of relative degree n (poles at random
        // frequencies, some lightly damped, some unstable) in companion form, hidden by a dense
        // orthogonal change of coordinates: far above the poles its computed response is rounding
        // noise, where unbounded bisection used to run away.
        let mut den = crate::poly::Poly::one();
        let mut m = 0;
        while m < n {
            let w = 10f64.powf(1.5 * g());
            if m + 1 < n && g() > 0.0 {
                let z = 10f64.powf(-2.0 + 1.5 * g().abs().min(1.5));
                let zeta = if g() > 1.5 { -z } else { z };
                den = &den * &crate::poly::Poly::new(vec![1.0, 2.0 * zeta * w, w * w]);
                m += 2;
            } else {
                den = &den * &crate::poly::Poly::new(vec![1.0, w * g().signum()]);
                m += 1;
            }
        }
        let lead = k * den.coeff_of_power(0).abs().max(1e-300);
        let base = tf1(&[lead], &den.coeffs, 0.0);
        let h = Mat::from_fn(n, n, |_, _| g());
        let q = h.qr().compute_Q();
        let a = q.transpose() * &base.a * &q;
        let b = q.transpose() * &base.b;
        let c = &base.c * &q;
        StateSpace::new(a, b, c, Mat::zeros(1, 1), 0.0).unwrap()
    }

    #[test]
    fn random_loops_finish_within_the_budget() {
        let mut worst = (0usize, 0.0f64);
        let mut errors = Vec::new();
        for seed in 0..200u64 {
            let n = if seed % 20 == 19 { 50 } else { 6 };
            let l = random_loop(n, seed);
            let t0 = std::time::Instant::now();
            let r = allmargin_counted(&l);
            let dt = t0.elapsed().as_secs_f64();
            // Either margins or a clear error; never a hang.
            if let Err(e) = &r {
                errors.push((seed, e.to_string()));
            }
            if let Ok((all, evals)) = &r {
                assert!(*evals <= 2 * MAX_EVALUATIONS, "seed {seed}: {evals} evaluations");
                worst.0 = worst.0.max(*evals);
                for pm in &all.phase_margins {
                    let v = FreqEvaluator::new(&l).unwrap().eval(c64::new(0.0, pm.w_rad_s)).unwrap()[(0, 0)];
                    assert!(
                        (v.norm() - 1.0).abs() < 1e-8,
                        "seed {seed}: |L| = {} at a crossover",
                        v.norm()
                    );
                }
            }
            worst.1 = worst.1.max(dt);
            assert!(dt < 1.0, "seed {seed} (n = {n}) took {dt} s");
        }
        eprintln!(
            "random loops: worst {} evaluations, worst {:.3} s, errors {errors:?}",
            worst.0, worst.1
        );
        assert!(errors.len() <= 10, "{errors:?}");
    }

    #[test]
    fn all_pass_loop_is_one_band_not_crossovers() {
        let l = tf1(&[1.0, -1.0], &[1.0, 1.0], 0.0);
        let all = allmargin(&l).unwrap();
        eprintln!("all-pass: {all:?}");
        assert!(all.phase_margins.is_empty(), "{:?}", all.phase_margins);
        let (a, b) = all.unit_gain_band_rad_s.expect("all-pass band");
        assert!(
            a <= all.w_range_rad_s.0 * 1.01 && b >= all.w_range_rad_s.1 * 0.99,
            "{a} {b}"
        );
        // (1−s)/(1+s) has L(∞) = −1: the feedback is ill-posed, which is said rather than a verdict.
        let err = nyquist_stable(&tf1(&[-1.0, 1.0], &[1.0, 1.0], 0.0))
            .unwrap_err()
            .to_string();
        assert!(err.contains("ill-posed"), "{err}");
        // An ordinary loop has none.
        assert!(allmargin(&tf1(&[3.0], &[1.0, 3.0, 2.0, 0.0], 0.0))
            .unwrap()
            .unit_gain_band_rad_s
            .is_none());
    }

    #[test]
    fn delays_are_validated() {
        // 1e4 s of delay on a 1 rad/s loop: thousands of phase turns over the band -> error.
        let l = tf1(&[2.0], &[1.0, 1.0], 1e4);
        let e = allmargin(&l).unwrap_err().to_string();
        assert!(e.contains("too long") && e.contains("at most"), "{e}");
        // A tiny delay (1e-300 s) is outside the searchable range: an error naming it, no overflow.
        let l = tf1(&[2.0], &[1.0, 1.0], 1e-300);
        assert!(allmargin(&l).is_err());
        // A long but resolvable delay works and is quick.
        let t0 = std::time::Instant::now();
        let l = tf1(&[0.5], &[1.0, 1.0], 50.0);
        assert!(allmargin(&l).is_ok());
        assert!(t0.elapsed().as_secs_f64() < 1.0);
    }

    #[test]
    fn mimo_is_rejected() {
        let g = StateSpace::gain(Mat::identity(2, 2), 0.0).unwrap();
        assert!(allmargin(&g).is_err());
        assert!(diskmargin(&g).is_err());
    }
}
