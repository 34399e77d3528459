//! The candidates of a log tune: every gain set within the bounded change of the flown tune, scored
//! on a frequency grid, and the one a pilot would want.
//!
//! Why a grid and not the optimizer: a log tune is a change to a tune that flies, bounded per run
//! (±40 % per gain by default), in the firmware's own resolution (Betaflight's whole units). Within
//! that box every gain set can be scored: C_fb is linear in (Kp, Ki, Kd) for fixed filters, so its
//! response on the grid is Kp·B_P + Ki·B_I + Kd·B_D from three basis responses, and each candidate
//! costs a few hundred complex multiply-adds per plant. The ranking is screened on the grid; the
//! chosen gains are then re-verified exactly ([`skyloop_robust::structured::verify::check_loop`])
//! by the caller, and the printed claims are that exact check's.
//!
//! Screening metrics on the grid: the gain crossover (the first |L| = 1 from below the loop's band),
//! the disk margin α = min 2|1 + L|/|1 − L| (skew 0, as MATLAB's `diskmargin`), its worst over the
//! uncertainty set, and the predicted motor-command noise power ∫|C_fb(j2πf)|²·S_gyro(f) df over the
//! noise band ([`super::noise`]).

use crate::error::{Error, Result};
use crate::firmware::filter_settings::Scale;
use crate::firmware::rate_gains::RateGains;
use serde::Serialize;
use skyloop_lti::freqresp::{logspace, FreqEvaluator};
use skyloop_lti::{c64, StateSpace};
use std::f64::consts::PI;

/// Largest relative change of each gain in one run.
pub const MAX_CHANGE: f64 = 0.4;
/// Gain values tried per gain within the bounded change.
pub const LEVELS: usize = 15;
/// Least crossover gain, relative, that makes a proposal worth a flight (below it: keep the tune).
pub const MIN_GAIN: f64 = 0.03;

/// The frequency grid and basis responses a candidate is scored on.
pub struct Screen {
    w_rad_s: Vec<f64>,
    /// P(jω) (hold included) of each plant, nominal first.
    plants: Vec<Vec<c64>>,
    /// C_fb's response per unit Kp, Ki, Kd on the margin grid.
    basis: [Vec<c64>; 3],
    /// Noise grid: C_fb's basis responses and the weights S_gyro(f)·Δf.
    noise_basis: [Vec<c64>; 3],
    noise_weight: Vec<f64>,
}

/// A candidate's screened scores.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scores {
    /// Gain crossover of the nominal loop, Hz (0 when |L| never crosses 1 on the grid).
    pub crossover_hz: f64,
    /// Tracking bandwidth: the lowest frequency where |S| reaches 1/√2 (−3 dB), Hz: below it the
    /// loop rejects errors; P and I set it as much as D does (a crossover raised by D alone is not
    /// a faster quad).
    pub bandwidth_hz: f64,
    /// Disk margin α of the nominal loop.
    pub alpha: f64,
    /// Smallest α over the uncertainty set.
    pub alpha_worst: f64,
    /// Predicted motor-command noise power in the noise band, (PID-output unit)².
    pub noise: f64,
}

impl Screen {
    /// A screen for `block`'s C_fb around `plants` (hold included, nominal first), margins on a
    /// grid from 0.2 Hz to `f_max_hz`, noise from the PSD points `noise_f_hz` with weights
    /// `noise_weight` (S_gyro(f)·Δf).
    ///
    /// # Errors
    /// A plant or block whose response cannot be evaluated, or no plant.
    pub fn new(
        block: &skyloop_robust::structured::blocks::Block,
        plants: &[StateSpace],
        f_max_hz: f64,
        noise_f_hz: &[f64],
        noise_weight: &[f64],
    ) -> Result<Screen> {
        if plants.is_empty() {
            return Err(Error::Input("the candidate screen needs a plant".into()));
        }
        let w_rad_s = logspace((2.0 * PI * 0.2).log10(), (2.0 * PI * f_max_hz.max(1.0)).log10(), 700);
        let resp = |sys: &StateSpace, w: &[f64]| -> Result<Vec<c64>> {
            let ev = FreqEvaluator::new(sys)?;
            w.iter().map(|&x| Ok(ev.eval(c64::new(0.0, x))?[(0, 0)])).collect()
        };
        let unit = |k: usize| -> Result<StateSpace> {
            let mut th = [0.0; 3];
            th[k] = 1.0;
            Ok(block.realize(&th)?)
        };
        let wn: Vec<f64> = noise_f_hz.iter().map(|f| 2.0 * PI * f).collect();
        let mut basis: [Vec<c64>; 3] = Default::default();
        let mut noise_basis: [Vec<c64>; 3] = Default::default();
        for k in 0..3 {
            let c = unit(k)?;
            basis[k] = resp(&c, &w_rad_s)?;
            noise_basis[k] = resp(&c, &wn)?;
        }
        Ok(Screen {
            plants: plants.iter().map(|p| resp(p, &w_rad_s)).collect::<Result<_>>()?,
            w_rad_s,
            basis,
            noise_basis,
            noise_weight: noise_weight.to_vec(),
        })
    }

    /// The scores of continuous gains `k` = (Kp, Ki, Kd).
    pub fn score(&self, k: [f64; 3]) -> Scores {
        let c: Vec<c64> = (0..self.w_rad_s.len())
            .map(|i| self.basis[0][i] * k[0] + self.basis[1][i] * k[1] + self.basis[2][i] * k[2])
            .collect();
        let mut alpha_worst = f64::INFINITY;
        let mut alpha = f64::INFINITY;
        let mut crossover_hz = 0.0;
        let mut bandwidth_hz = 0.0;
        for (j, p) in self.plants.iter().enumerate() {
            let mut a = f64::INFINITY;
            let mut prev_above = None;
            for (i, (&pi, &ci)) in p.iter().zip(&c).enumerate() {
                let l = pi * ci;
                let d = (c64::new(1.0, 0.0) - l).norm();
                if d > 0.0 {
                    a = a.min(2.0 * (c64::new(1.0, 0.0) + l).norm() / d);
                }
                if j == 0 && bandwidth_hz == 0.0 && (c64::new(1.0, 0.0) + l).norm() <= std::f64::consts::SQRT_2 {
                    bandwidth_hz = self.w_rad_s[i] / (2.0 * PI);
                }
                let above = l.norm() >= 1.0;
                if j == 0 && crossover_hz == 0.0 && prev_above == Some(true) && !above {
                    // Log-linear interpolation of |L| between the two grid points.
                    let (w0, w1) = (self.w_rad_s[i - 1], self.w_rad_s[i]);
                    let (m0, m1) = ((p[i - 1] * c[i - 1]).norm().ln(), l.norm().ln());
                    let t = if m0 != m1 { m0 / (m0 - m1) } else { 0.5 };
                    crossover_hz = (w0.ln() + t * (w1.ln() - w0.ln())).exp() / (2.0 * PI);
                }
                prev_above = Some(above);
            }
            if j == 0 {
                alpha = a;
            }
            alpha_worst = alpha_worst.min(a);
        }
        Scores {
            crossover_hz,
            bandwidth_hz,
            alpha,
            alpha_worst,
            noise: self.noise(k),
        }
    }

    /// Predicted motor-command noise power of gains `k`: Σ |C_fb(j2πf)|²·S_gyro(f)·Δf.
    pub fn noise(&self, k: [f64; 3]) -> f64 {
        self.noise_terms(k).into_iter().sum()
    }

    /// The terms of [`noise`](Self::noise), one per noise-grid point: |C_fb(j2πf)|²·S_gyro(f)·Δf.
    pub fn noise_terms(&self, k: [f64; 3]) -> Vec<f64> {
        (0..self.noise_weight.len())
            .map(|i| {
                let c = self.noise_basis[0][i] * k[0] + self.noise_basis[1][i] * k[1] + self.noise_basis[2][i] * k[2];
                c.norm_sqr() * self.noise_weight[i]
            })
            .collect()
    }
}

/// A scored gain set.
#[derive(Debug, Clone)]
pub struct Candidate {
    /// The gains.
    pub gains: RateGains,
    /// Its screened scores.
    pub scores: Scores,
    /// The factors its gyro and D-term lowpass cutoffs are scaled by (`--tune-filters`; the
    /// D-term chain is also in `gains`).
    pub scale: Scale,
}

/// What the search is asked to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchLimits {
    /// Largest noise power relative to the flown tune's.
    pub noise_budget: f64,
    /// The robust floor on the worst-case α (α ≥ min(0.5, flown)).
    pub alpha_floor: f64,
    /// Keep the nominal α at least the flown tune's (the pilot's default: faster at no loss of
    /// robustness); false lets it fall to the floor (`--maximize crossover`).
    pub keep_robustness: bool,
    /// Rank by Ki instead of crossover (`--maximize integral_gain`).
    pub rank_by_integral: bool,
}

/// Every candidate within the bounded change of `flown`, scored, those within the limits ranked
/// best first. Never dominated: a candidate both slower and less robust (nominal α) than the flown
/// tune is dropped. When the flown tune is below the robust floor, candidates that reach it rank
/// first by crossover, then the rest by α (the most robust step towards the floor).
///
/// Returns (ranked admissible candidates, every scored candidate, the flown tune's scores).
pub fn search(screen: &Screen, flown: &RateGains, limits: &SearchLimits) -> (Vec<Candidate>, Vec<Candidate>, Scores) {
    let f = screen.score(flown.continuous());
    let (mut ok, all) = search_against(screen, flown, &f, limits);
    rank(&mut ok, &f, limits);
    (ok, all, f)
}

/// The candidates within the bounded change of `base` (its gains, with the filters of `screen`),
/// judged against the flown tune's scores `f` (which may come from another screen: the flown
/// filters, when `base` carries candidate filters). Returns (admissible, unranked; every scored).
pub fn search_against(
    screen: &Screen,
    base: &RateGains,
    f: &Scores,
    limits: &SearchLimits,
) -> (Vec<Candidate>, Vec<Candidate>) {
    let f = *f;
    let all: Vec<Candidate> = base
        .neighbours(MAX_CHANGE, LEVELS)
        .into_iter()
        .map(|g| Candidate {
            scores: screen.score(g.continuous()),
            gains: g,
            scale: Scale::FLOWN,
        })
        .collect();
    let eps = 1e-3;
    let below_floor = f.alpha_worst < limits.alpha_floor;
    let ok: Vec<Candidate> = all
        .iter()
        .filter(|c| {
            let s = &c.scores;
            let slower = s.crossover_hz < f.crossover_hz * (1.0 - eps)
                || limits.keep_robustness && s.bandwidth_hz < f.bandwidth_hz * (1.0 - eps);
            let dominated = slower && s.alpha < f.alpha - eps;
            let noise_ok = s.noise <= limits.noise_budget * f.noise.max(f64::MIN_POSITIVE);
            let robust_ok = if below_floor {
                s.alpha_worst > f.alpha_worst
            } else {
                s.alpha_worst >= limits.alpha_floor - eps
                    && (!limits.keep_robustness || s.alpha >= f.alpha - eps && s.alpha_worst >= f.alpha_worst - eps)
            };
            // The pilot's default is never slower: not in crossover, not in tracking bandwidth.
            let pace_ok = !limits.keep_robustness || below_floor || !slower;
            s.crossover_hz > 0.0 && !dominated && noise_ok && robust_ok && pace_ok
        })
        .cloned()
        .collect();
    (ok, all)
}

/// Sorts admissible candidates best first against the flown tune's scores `f` (see [`search`]).
pub fn rank(ok: &mut [Candidate], f: &Scores, limits: &SearchLimits) {
    let eps = 1e-3;
    let below_floor = f.alpha_worst < limits.alpha_floor;
    let key = |c: &Candidate| -> (bool, f64) {
        let s = &c.scores;
        let reaches = s.alpha_worst >= limits.alpha_floor - eps;
        let v = if below_floor && !reaches {
            s.alpha_worst
        } else if limits.rank_by_integral {
            c.gains.continuous()[1]
        } else if limits.keep_robustness {
            // Tracking: the error-rejection bandwidth, the crossover breaking ties.
            s.bandwidth_hz + 1e-3 * s.crossover_hz
        } else {
            s.crossover_hz
        };
        (reaches, v)
    };
    ok.sort_by(|a, b| {
        let (ra, va) = key(a);
        let (rb, vb) = key(b);
        rb.cmp(&ra)
            .then(vb.total_cmp(&va))
            .then(a.scores.noise.total_cmp(&b.scores.noise))
    });
}

/// The trade-off front: of the candidates within the noise budget and the robust floor, those no
/// other beats in crossover, nominal α and noise at once; up to `n` of them spread over the
/// crossover range, fastest first.
pub fn front(all: &[Candidate], flown: &Scores, limits: &SearchLimits, n: usize) -> Vec<Candidate> {
    let pool: Vec<&Candidate> = all
        .iter()
        .filter(|c| {
            c.scores.crossover_hz > 0.0
                && c.scores.alpha_worst >= limits.alpha_floor.min(flown.alpha_worst) - 1e-3
                && c.scores.noise <= limits.noise_budget * flown.noise.max(f64::MIN_POSITIVE) * 2.0
        })
        .collect();
    let beats = |a: &Scores, b: &Scores| {
        a.crossover_hz >= b.crossover_hz
            && a.alpha >= b.alpha
            && a.noise <= b.noise
            && (a.crossover_hz > b.crossover_hz || a.alpha > b.alpha || a.noise < b.noise)
    };
    let mut pareto: Vec<&Candidate> = pool
        .iter()
        .filter(|c| !pool.iter().any(|o| beats(&o.scores, &c.scores)))
        .copied()
        .collect();
    pareto.sort_by(|a, b| b.scores.crossover_hz.total_cmp(&a.scores.crossover_hz));
    if pareto.len() <= n {
        return pareto.into_iter().cloned().collect();
    }
    // n points evenly spread by rank over the front.
    (0..n)
        .map(|k| pareto[k * (pareto.len() - 1) / (n - 1).max(1)].clone())
        .collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::firmware::betaflight::{self, Gains};
    use crate::firmware::Axis;
    use skyloop_robust::structured::verify::check_loop;

    fn setup() -> (RateGains, Vec<StateSpace>) {
        let plant = skyloop_lti::expr::parse_model("150*exp(-0.003*s)/(s*(0.02*s+1))").unwrap();
        let flown = RateGains::Betaflight {
            gains: Gains {
                p: 30,
                i: 40,
                d: 20,
                f: 0,
            },
            axis: Axis::Roll,
            filters: betaflight::Filters::default(),
        };
        (flown, vec![plant])
    }

    /// The grid's crossover and α agree with the exact check of the same loop (an independent code
    /// path: allmargin and diskmargin on the state-space loop) to within the grid's resolution.
    #[test]
    fn screened_scores_agree_with_the_exact_check() {
        let (flown, plants) = setup();
        let screen = Screen::new(&flown.block().unwrap(), &plants, 1000.0, &[100.0], &[1.0]).unwrap();
        let s = screen.score(flown.continuous());
        let exact = check_loop(&plants[0], &flown.feedback_controller().unwrap()).unwrap();
        assert!(
            (s.crossover_hz / exact.crossover_hz - 1.0).abs() < 0.01,
            "{s:?} vs {exact:?}"
        );
        assert!((s.alpha / exact.disk_alpha - 1.0).abs() < 0.02, "{s:?} vs {exact:?}");
    }

    /// With robustness kept, nothing ranked is slower and less robust, or noisier than allowed.
    #[test]
    fn ranked_candidates_respect_the_limits() {
        let (flown, plants) = setup();
        let f: Vec<f64> = (0..100).map(|k| 50.0 + 5.0 * k as f64).collect();
        let screen = Screen::new(&flown.block().unwrap(), &plants, 1000.0, &f, &vec![1.0; f.len()]).unwrap();
        let limits = SearchLimits {
            noise_budget: 1.25,
            alpha_floor: 0.5,
            keep_robustness: true,
            rank_by_integral: false,
        };
        let (ok, all, fl) = search(&screen, &flown, &limits);
        assert!(all.len() > 100);
        for c in &ok {
            assert!(c.scores.noise <= 1.25 * fl.noise * (1.0 + 1e-12));
            assert!(c.scores.alpha >= fl.alpha - 1e-3);
            assert!(c.scores.crossover_hz >= fl.crossover_hz * 0.999 || c.scores.alpha >= fl.alpha);
        }
        // The best is at least as fast as the flown tune (the flown gains are a candidate).
        assert!(ok[0].scores.crossover_hz >= fl.crossover_hz * 0.999);
        let fr = front(&all, &fl, &limits, 5);
        assert!(!fr.is_empty() && fr.len() <= 5);
    }
}
