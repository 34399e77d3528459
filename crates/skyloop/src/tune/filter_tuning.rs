//! `tune --tune-filters`: the D-term lowpass cutoffs as decision variables beside P, I and D.
//!
//! Each D-term lowpass stage is scaled together by one factor from [`SCALES`] (whole Hz, notches
//! kept); for every factor the bounded P, I, D search runs on the loop with those filters, judged
//! against the flown tune with its own filters (same pace, robustness and noise-budget rules), and
//! the candidates of all factors are ranked together and verified exactly as the gains alone are.
//! The filter's phase lag is in every loop (C_fb carries the chain), and the predicted motor noise
//! (|C_fb|²·S_gyro) moves with the candidate filters. Safety rules on top:
//!
//! - **never less filtering where a band's noise would exceed the budget:** with a cutoff raised,
//!   each octave band of the noise range must stay within the budget times the flown tune's noise
//!   in that band, not just the total ([`bands_within_budget`]);
//! - **never a cutoff below 1.5× the crossover** (checked on the exact loop, [`MIN_CUTOFF_OVER_CROSSOVER`]);
//! - **every change stated with its reason** ([`describe`]), and the firmware's `set` lines printed.
//!
//! Betaflight only so far: INAV's and PX4's D-term settings are left as flown (said in the notes).
//! The gyro lowpass and the dynamic notch sit inside the identified plant (the log's gyro is
//! filtered by them), so changing them changes the plant itself; they are not tuned here.

use super::candidates::{rank, search_against, Candidate, Scores, Screen, SearchLimits};
use crate::error::Result;
use crate::firmware::betaflight::DtermSettings;
use crate::firmware::rate_gains::RateGains;
use skyloop_lti::{c64, StateSpace};
use std::f64::consts::PI;

/// The factors every D-term lowpass cutoff is scaled by (1 is the flown filters).
pub const SCALES: [f64; 4] = [0.8, 1.2, 1.45, 1.75];

/// The lowest D-term cutoff a changed filter may have, in multiples of the loop's crossover:
/// closer, its phase lag eats the phase margin.
pub const MIN_CUTOFF_OVER_CROSSOVER: f64 = 1.5;

/// Adds the candidates of every filter factor to `ranked`/`all` (found with the flown filters) and
/// ranks them together against the flown scores `fs`. `weights` is the noise grid (Hz, S_gyro·Δf).
///
/// # Errors
/// A filter the loop model cannot realize.
#[allow(clippy::too_many_arguments)]
pub fn add_filter_candidates(
    flown: &RateGains,
    flown_screen: &Screen,
    held: &[StateSpace],
    f_max_hz: f64,
    weights: (&[f64], &[f64]),
    fs: &Scores,
    limits: &SearchLimits,
    ranked: &mut Vec<Candidate>,
    all: &mut Vec<Candidate>,
) -> Result<()> {
    let flown_terms = flown_screen.noise_terms(flown.continuous());
    for k in SCALES {
        let Some(base) = flown.with_dterm_scale(k) else {
            return Ok(());
        };
        let screen = Screen::new(&base.block()?, held, f_max_hz, weights.0, weights.1)?;
        let (ok, scored) = search_against(&screen, &base, fs, limits);
        ranked.extend(ok.into_iter().filter(|c| {
            k <= 1.0
                || bands_within_budget(
                    weights.0,
                    &flown_terms,
                    &screen.noise_terms(c.gains.continuous()),
                    limits.noise_budget,
                )
                .is_none()
        }));
        all.extend(scored);
    }
    rank(ranked, fs, limits);
    Ok(())
}

/// The first octave band (Hz) of the noise grid `freq_hz` where the candidate's noise terms exceed
/// `budget` times the flown tune's; None when every band is within it.
pub fn bands_within_budget(freq_hz: &[f64], flown: &[f64], cand: &[f64], budget: f64) -> Option<(f64, f64)> {
    let f0 = freq_hz.first().copied()?;
    let band = |i: usize| (freq_hz[i] / f0).log2().floor() as i64;
    let mut k = 0;
    while k < freq_hz.len() {
        let b = band(k);
        let (mut sf, mut sc, mut end) = (0.0, 0.0, k);
        while end < freq_hz.len() && band(end) == b {
            sf += flown[end];
            sc += cand[end];
            end += 1;
        }
        if sc > budget * sf * (1.0 + 1e-9) + f64::MIN_POSITIVE {
            return Some((freq_hz[k], freq_hz[end - 1]));
        }
        k = end;
    }
    None
}

/// The response of a gain set's D-term chain (lowpasses and notch) at `f_hz`: (gain dB, phase
/// degrees, summed stage by stage so the phase is not wrapped); (0, 0) without one.
pub fn dterm_response(g: &RateGains, f_hz: f64) -> (f64, f64) {
    let s = c64::new(0.0, 2.0 * PI * f_hz);
    g.dterm_chain()
        .iter()
        .filter_map(|l| {
            let m = l.model().ok()?;
            let ev = skyloop_lti::freqresp::FreqEvaluator::new(&m).ok()?;
            let v = ev.eval(s).ok()?[(0, 0)];
            Some((20.0 * v.norm().log10(), v.arg().to_degrees()))
        })
        .fold((0.0, 0.0), |(a, b), (m, p)| (a + m, b + p))
}

/// The phase of a gain set's D-term chain at `f_hz`, degrees.
fn dterm_phase_deg(g: &RateGains, f_hz: f64) -> f64 {
    dterm_response(g, f_hz).1
}

/// The proposal's gain set rebuilt from the flown one and the reported changes (the factor the
/// first change scales its setting by); None without changes.
pub fn proposed_filters(flown: &RateGains, changes: &[FilterChange]) -> Option<RateGains> {
    let c = changes.first()?;
    let k = c.proposed_hz / c.flown_hz;
    let k = SCALES
        .iter()
        .copied()
        .min_by(|a, b| (a - k).abs().total_cmp(&(b - k).abs()))?;
    flown.with_dterm_scale(k)
}

/// The factor a proposal's D-term chain is scaled by relative to the flown one (1 when unchanged).
pub fn scale_of(flown: &RateGains, proposed: &RateGains) -> f64 {
    match (flown.lowest_dterm_cutoff_hz(), proposed.lowest_dterm_cutoff_hz()) {
        (Some(a), Some(b)) if a > 0.0 && (b - a).abs() > 0.5 => SCALES
            .iter()
            .copied()
            .min_by(|x, y| (a * x - b).abs().total_cmp(&(a * y - b).abs()))
            .unwrap_or(1.0),
        _ => 1.0,
    }
}

/// One filter change with its reason, for the report and the JSON.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterChange {
    /// The firmware setting, e.g. `dterm_lpf1_dyn_min_hz`.
    pub name: String,
    /// Flown value, Hz.
    pub flown_hz: f64,
    /// Proposed value, Hz.
    pub proposed_hz: f64,
    /// Why, in a pilot's words.
    pub reason: String,
}

/// The changes of a proposal whose D-term chain is scaled by `k`, each with its reason: the noise
/// against the budget and the D-term chain's phase at the proposal's crossover `fc_hz`.
pub fn describe(
    settings: &DtermSettings,
    k: f64,
    flown: &RateGains,
    proposed: &RateGains,
    fc_hz: f64,
    noise_ratio: f64,
    budget: f64,
) -> Vec<FilterChange> {
    let (p0, p1) = (dterm_phase_deg(flown, fc_hz), dterm_phase_deg(proposed, fc_hz));
    let why = if k > 1.0 {
        format!(
            "less D-term filtering: predicted motor noise ×{noise_ratio:.2} of the flown tune (budget ×{budget:.2}) with every octave band of the noise range within the budget; the D-term chain's phase at the {fc_hz:.1} Hz crossover {p0:.1}° → {p1:.1}°"
        )
    } else {
        format!(
            "more D-term filtering: predicted motor noise ×{noise_ratio:.2} of the flown tune; the D-term chain's phase at the {fc_hz:.1} Hz crossover {p0:.1}° → {p1:.1}° (the cutoff stays above {MIN_CUTOFF_OVER_CROSSOVER}× the crossover)"
        )
    };
    settings
        .scaled(k)
        .into_iter()
        .filter(|(_, a, b)| a != b)
        .map(|(name, flown_hz, proposed_hz)| FilterChange {
            name,
            flown_hz,
            proposed_hz,
            reason: why.clone(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_band_over_budget_is_found() {
        let f: Vec<f64> = (0..64).map(|i| 100.0 + 10.0 * i as f64).collect();
        let flown = vec![1.0; f.len()];
        let mut cand = vec![1.1; f.len()];
        assert_eq!(bands_within_budget(&f, &flown, &cand, 1.25), None);
        // One peak raised in the third octave (400..800 Hz): the total stays within budget.
        cand[40] = 20.0;
        let total: f64 = cand.iter().sum::<f64>() / flown.iter().sum::<f64>();
        assert!(total < 1.5);
        let b = bands_within_budget(&f, &flown, &cand, 1.25).unwrap();
        assert!(b.0 <= f[40] && f[40] <= b.1 && b.0 >= 400.0, "{b:?}");
    }
}
