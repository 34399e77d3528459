//! `tune --tune-filters`: the gyro and D-term lowpass cutoffs as decision variables beside P, I
//! and D, for every firmware whose log states them ([`crate::firmware::filter_settings`]).
//!
//! Each lowpass is scaled as a whole by one factor (gyro from [`GYRO_SCALES`], D term from
//! [`DTERM_SCALES`], whole Hz, notches kept); for every pair of factors the bounded P, I, D search
//! runs on the loop with those filters, judged against the flown tune with its own filters (same
//! pace, robustness and noise-budget rules), and the candidates of all pairs are ranked together
//! and verified exactly as the gains alone are.
//!
//! - The D-term lowpass is in C_fb, so its phase lag is in every loop and its effect on the
//!   motor noise |C_fb|²·S_gyro follows.
//! - The gyro lowpass is inside the identified plant (the logged gyro is after it), so a candidate
//!   one is put in by de-embedding the flown one: the plants become P·G_new/G_flown and the gyro
//!   spectrum the controller sees S_gyro·|G_new/G_flown|² ([`GyroVariant`]). The continuous
//!   prototypes of the firmware's filters are used, as for the D term.
//!
//! Safety rules on top:
//!
//! - **never less filtering where a band's noise would exceed the budget:** with a cutoff raised,
//!   each octave band of the noise range must stay within the budget times the flown tune's noise
//!   in that band, not just the total ([`bands_within_budget`]);
//! - **never a cutoff below 1.5× the crossover** (checked on the exact loop,
//!   [`MIN_CUTOFF_OVER_CROSSOVER`], for every lowpass that moved);
//! - **every change stated with its reason** ([`describe`]), and the firmware's lines printed.
//!
//! Not tuned: the dynamic notch's range and count and the RPM filter (they track peaks that move
//! with throttle; a fixed-frequency loop model cannot rank them).

use super::candidates::{rank, search_against, Candidate, Scores, Screen, SearchLimits};
use super::noise::GyroNoise;
use crate::error::Result;
use crate::firmware::filter_settings::{chain_json, gyro_ratio, FilterSettings, Knob, Scale};
use crate::firmware::rate_gains::RateGains;
use crate::firmware::Lowpass;
use serde_json::{json, Value};
use skyloop_lti::interconnect::series;
use skyloop_lti::{c64, StateSpace};
use std::f64::consts::PI;

/// The factors every D-term lowpass cutoff is scaled by (1 is the flown filters).
pub const DTERM_SCALES: [f64; 5] = [1.0, 0.8, 1.2, 1.45, 1.75];

/// The factors every gyro lowpass cutoff is scaled by (1 is the flown filters).
pub const GYRO_SCALES: [f64; 4] = [1.0, 0.8, 1.25, 1.5];

/// The lowest cutoff a changed lowpass may have, in multiples of the loop's crossover: closer, its
/// phase lag eats the phase margin.
pub const MIN_CUTOFF_OVER_CROSSOVER: f64 = 1.5;

/// The loop a gyro lowpass factor makes.
#[derive(Debug, Clone)]
pub struct GyroVariant {
    /// The factor.
    pub k: f64,
    /// G_new/G_flown (None at the flown filters).
    pub ratio: Option<StateSpace>,
    /// The plants (hold included, nominal first) with the gyro lowpass replaced.
    pub held: Vec<StateSpace>,
    /// The gyro spectrum the controller sees through it.
    pub noise: GyroNoise,
}

impl GyroVariant {
    /// The variant of factor `k` from the flown plants `held` and gyro spectrum `gn`.
    ///
    /// # Errors
    /// A gyro lowpass the loop model cannot realize.
    pub fn new(settings: &FilterSettings, k: f64, held: &[StateSpace], gn: &GyroNoise) -> Result<GyroVariant> {
        let ratio = gyro_ratio(&settings.gyro, &settings.gyro_at(k))?;
        let (held, noise) = match &ratio {
            None => (held.to_vec(), gn.clone()),
            Some(r) => (
                held.iter()
                    .map(|p| series(p, r))
                    .collect::<std::result::Result<_, _>>()?,
                gn.through(r)?,
            ),
        };
        Ok(GyroVariant { k, ratio, held, noise })
    }
}

/// The variant of `scale.gyro` among `variants` (None when it was not scored).
pub fn variant_of(variants: &[GyroVariant], scale: Scale) -> Option<&GyroVariant> {
    variants.iter().find(|v| v.k == scale.gyro)
}

/// Adds the candidates of every pair of filter factors to `ranked`/`all` (found with the flown
/// filters) and ranks them together against the flown scores `fs`. A cutoff is never raised above
/// the highest frequency the log's gyro spectrum shows (its Nyquist frequency): the noise there is
/// not seen, so less filtering cannot be judged. Returns the gyro variants the candidates were
/// scored on (the flown one first) and notes on factors left out.
///
/// # Errors
/// A filter the loop model cannot realize.
#[allow(clippy::too_many_arguments)]
pub fn add_filter_candidates(
    flown: &RateGains,
    settings: &FilterSettings,
    flown_screen: &Screen,
    held: &[StateSpace],
    f_max_hz: f64,
    gn: &GyroNoise,
    fs: &Scores,
    limits: &SearchLimits,
    ranked: &mut Vec<Candidate>,
    all: &mut Vec<Candidate>,
) -> Result<(Vec<GyroVariant>, Vec<String>)> {
    let (freq_hz, _) = gn.weights();
    let seen_hz = gn.band_hz.1;
    let mut unseen: Vec<(&str, f64)> = Vec::new();
    let flown_terms = flown_screen.noise_terms(flown.continuous());
    let gyro_scales: &[f64] = if settings.has(Knob::Gyro) && !settings.gyro.is_empty() {
        &GYRO_SCALES
    } else {
        &[1.0]
    };
    let dterm_scales: &[f64] = if settings.has(Knob::Dterm) && flown.lowest_dterm_cutoff_hz().is_some() {
        &DTERM_SCALES
    } else {
        &[1.0]
    };
    let mut variants = Vec::new();
    for &kg in gyro_scales {
        if let Some(hz) = settings
            .lowest_gyro_cutoff_hz(kg)
            .filter(|hz| kg > 1.0 && *hz > seen_hz)
        {
            unseen.push(("gyro", hz));
            continue;
        }
        let v = GyroVariant::new(settings, kg, held, gn)?;
        let (_, weights) = v.noise.weights();
        for &kd in dterm_scales {
            let scale = Scale { gyro: kg, dterm: kd };
            let base = if kd == 1.0 {
                Some(flown.clone())
            } else {
                flown.with_dterm_scale(kd)
            };
            let Some(base) = base.filter(|_| !scale.is_flown()) else {
                continue;
            };
            if let Some(hz) = base.lowest_dterm_cutoff_hz().filter(|hz| kd > 1.0 && *hz > seen_hz) {
                unseen.push(("D-term", hz));
                continue;
            }
            let screen = Screen::new(&base.block()?, &v.held, f_max_hz, &freq_hz, &weights)?;
            let (ok, scored) = search_against(&screen, &base, fs, limits);
            let less = kg > 1.0 || kd > 1.0;
            ranked.extend(ok.into_iter().map(|c| Candidate { scale, ..c }).filter(|c| {
                !less
                    || bands_within_budget(
                        &freq_hz,
                        &flown_terms,
                        &screen.noise_terms(c.gains.continuous()),
                        limits.noise_budget,
                    )
                    .is_none()
            }));
            all.extend(scored.into_iter().map(|c| Candidate { scale, ..c }));
        }
        variants.push(v);
    }
    rank(ranked, fs, limits);
    let notes = ["gyro", "D-term"]
        .into_iter()
        .filter_map(|what| {
            let hz = unseen.iter().filter(|u| u.0 == what).map(|u| u.1).min_by(f64::total_cmp)?;
            Some(format!(
                "--tune-filters: the {what} lowpass is not raised (to {hz:.0} Hz or more): the log's gyro shows the noise only up to {seen_hz:.0} Hz (its Nyquist frequency); log at a higher rate to judge less filtering"
            ))
        })
        .collect();
    Ok((variants, notes))
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

/// The response of a lowpass chain at `f_hz`: (gain dB, phase degrees, summed stage by stage so
/// the phase is not wrapped); (0, 0) for an empty chain.
pub fn chain_response(stages: &[Lowpass], f_hz: f64) -> (f64, f64) {
    let s = c64::new(0.0, 2.0 * PI * f_hz);
    stages
        .iter()
        .filter_map(|l| {
            let m = l.model().ok()?;
            let ev = skyloop_lti::freqresp::FreqEvaluator::new(&m).ok()?;
            let v = ev.eval(s).ok()?[(0, 0)];
            Some((20.0 * v.norm().log10(), v.arg().to_degrees()))
        })
        .fold((0.0, 0.0), |(a, b), (m, p)| (a + m, b + p))
}

/// The filters of a proposal against the flown ones: what a report draws and what the JSON's
/// `filters_proposed` states (so the margins can be recomputed: the proposal's plant is
/// P·G_new/G_flown with the gyro chains below).
#[derive(Debug, Clone, PartialEq)]
pub struct ProposedFilters {
    /// The factors.
    pub scale: Scale,
    /// Gyro lowpass chain flown, and proposed.
    pub gyro: (Vec<Lowpass>, Vec<Lowpass>),
    /// D-term chain flown, and proposed.
    pub dterm: (Vec<Lowpass>, Vec<Lowpass>),
}

impl ProposedFilters {
    /// The filters of a proposal with factors `scale`.
    pub fn new(settings: &FilterSettings, scale: Scale, flown: &RateGains, proposed: &RateGains) -> ProposedFilters {
        ProposedFilters {
            scale,
            gyro: (settings.gyro.clone(), settings.gyro_at(scale.gyro)),
            dterm: (flown.dterm_lowpasses(), proposed.dterm_lowpasses()),
        }
    }

    /// `{gyro_scale, dterm_scale, gyro_lowpass: {flown, proposed}, dterm_lowpass: {flown,
    /// proposed}, plant}` (chains as `[{type, hz}]`).
    pub fn to_json(&self) -> Value {
        json!({
            "gyro_scale": self.scale.gyro,
            "dterm_scale": self.scale.dterm,
            "gyro_lowpass": {"flown": chain_json(&self.gyro.0), "proposed": chain_json(&self.gyro.1)},
            "dterm_lowpass": {"flown": chain_json(&self.dterm.0), "proposed": chain_json(&self.dterm.1)},
            "plant": "the proposal's loop uses the identified plant times G_new/G_flown of the gyro lowpass chains (the logged gyro is after the flown one); the D-term chain is in the printed controller",
        })
    }
}

/// One filter change with its reason, for the report and the JSON.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterChange {
    /// The firmware setting, e.g. `dterm_lpf1_dyn_min_hz`, `IMU_GYRO_CUTOFF`.
    pub name: String,
    /// "gyro" or "dterm".
    pub filter: &'static str,
    /// True for a setting every axis shares (see [`crate::firmware::filter_settings::FilterSetting::shared`]).
    pub shared: bool,
    /// Flown value, Hz.
    pub flown_hz: f64,
    /// Proposed value, Hz.
    pub proposed_hz: f64,
    /// Why, in a pilot's words.
    pub reason: String,
}

/// The changes of a proposal with filters `pf`, each with its reason: the noise against the budget
/// and the moved chain's phase at the proposal's crossover `fc_hz`.
pub fn describe(
    settings: &FilterSettings,
    pf: &ProposedFilters,
    fc_hz: f64,
    noise_ratio: f64,
    budget: f64,
) -> Vec<FilterChange> {
    let why = |knob: Knob| {
        let (what, (a, b)) = match knob {
            Knob::Gyro => ("gyro", &pf.gyro),
            Knob::Dterm => ("D-term", &pf.dterm),
        };
        let (p0, p1) = (chain_response(a, fc_hz).1, chain_response(b, fc_hz).1);
        if pf.scale.of(knob) > 1.0 {
            format!(
                "less {what} filtering: predicted motor noise ×{noise_ratio:.2} of the flown tune (budget ×{budget:.2}) with every octave band of the noise range within the budget; the {what} chain's phase at the {fc_hz:.1} Hz crossover {p0:.1}° → {p1:.1}°"
            )
        } else {
            format!(
                "more {what} filtering: predicted motor noise ×{noise_ratio:.2} of the flown tune; the {what} chain's phase at the {fc_hz:.1} Hz crossover {p0:.1}° → {p1:.1}° (the cutoff stays above {MIN_CUTOFF_OVER_CROSSOVER}× the crossover)"
            )
        }
    };
    settings
        .settings
        .iter()
        .filter(|s| s.at(pf.scale) != s.flown_hz)
        .map(|s| FilterChange {
            name: s.name.clone(),
            filter: s.knob.name(),
            shared: s.shared,
            flown_hz: s.flown_hz,
            proposed_hz: s.at(pf.scale),
            reason: if s.shared {
                format!(
                    "{}; {} acts on every axis: tune the other axes with it before flying",
                    why(s.knob),
                    s.name
                )
            } else {
                why(s.knob)
            },
        })
        .collect()
}

/// Why the changed filters of a proposal at crossover `fc_hz` break the cutoff rule, None when
/// they do not: every lowpass that moved keeps its cutoff at least
/// [`MIN_CUTOFF_OVER_CROSSOVER`] × the crossover.
pub fn cutoff_rule(settings: Option<&FilterSettings>, scale: Scale, gains: &RateGains, fc_hz: f64) -> Option<String> {
    let limit = MIN_CUTOFF_OVER_CROSSOVER * fc_hz;
    let gyro = settings
        .filter(|_| scale.gyro != 1.0)
        .and_then(|s| s.lowest_gyro_cutoff_hz(scale.gyro))
        .map(|f| ("gyro", f));
    let dterm = gains
        .lowest_dterm_cutoff_hz()
        .filter(|_| scale.dterm != 1.0)
        .map(|f| ("D-term", f));
    gyro.into_iter()
        .chain(dterm)
        .find(|(_, f)| *f < limit)
        .map(|(what, f)| {
            format!("{what} cutoff {f:.0} Hz below {MIN_CUTOFF_OVER_CROSSOVER}× the {fc_hz:.1} Hz crossover")
        })
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
