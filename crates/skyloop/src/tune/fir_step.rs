//! The step response setpoint → gyro measured from a flight log by a least-squares FIR fit that
//! separates causal from anticipating lags.
//!
//! Why next to PID-Analyzer's deconvolution ([`super::deconv`]): a pilot in the loop makes the
//! setpoint depend on past gyro. The deconvolution divides cross- by auto-spectra, which
//! attributes that dependence to the response (mass at negative lag, a step that comes out
//! short). Here the gyro is regressed on the setpoint's present and past samples only,
//! y(t) = Σ_{k=0..M−1} h_k·r(t − k) + e(t), so the stick's reply to what the craft did (which
//! comes a human reaction time later) cannot enter the response; the bias left is the
//! disturbance's correlation over that reaction time. The step is the running sum of the taps.
//!
//! How much the pilot is in the loop is measured as the classic FIR test for feedback does
//! (Ljung §13.4, a Granger test): on the same samples, M/2 future setpoint taps are added, and the
//! share of the causal fit's residual they explain is reported.
//!
//! Data are block-averaged to about 2 ms (the rate loop's response is resolved, the gyro noise
//! averaged). The normal equations of each contiguous stretch are accumulated in O(taps·samples)
//! with the lagged-product recursion; the spread of the step is a delete-one-block jackknife over
//! eight blocks of the flight.

use super::deconv::MeasuredStep;
use crate::error::{Error, Result};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

/// Sample period the data are averaged to, s.
const TARGET_DT_S: f64 = 0.002;
/// Jackknife blocks.
const BLOCKS: usize = 8;
/// Ridge, relative to the mean diagonal of the normal matrix (keeps a nearly constant setpoint
/// from making the fit singular; small enough not to shrink a fit with stick input).
const RIDGE: f64 = 1e-6;

/// The causal step of `output` to `input` (uniform at `dt_s`) over `ranges` (sample-index
/// ranges, e.g. the airborne segments): `response_s` of causal lags, half that of
/// anticipating ones.
///
/// `acausal_fraction` of the result is the share of the causal fit's residual that the future
/// setpoint explains (0: no sign of a pilot reacting to the craft).
///
/// # Errors
/// Mismatched lengths, a bad period or span (named), or too little data with stick input.
pub fn causal_step(
    input: &[f64],
    output: &[f64],
    dt_s: f64,
    ranges: &[std::ops::Range<usize>],
    response_s: f64,
) -> Result<MeasuredStep> {
    if input.len() != output.len() {
        return Err(Error::Input(format!(
            "causal step: input has {} samples, output {}",
            input.len(),
            output.len()
        )));
    }
    if !(dt_s.is_finite() && dt_s > 0.0 && dt_s <= 0.1) {
        return Err(Error::Input(format!(
            "causal step: sample period must be in (0, 0.1] s, got {dt_s}"
        )));
    }
    if !(response_s.is_finite() && response_s > 0.0 && response_s <= 5.0) {
        return Err(Error::Input(format!(
            "causal step: response length must be in (0, 5] s, got {response_s}"
        )));
    }
    let q = ((TARGET_DT_S / dt_s).round() as usize).max(1);
    let dt = dt_s * q as f64;
    let m = ((response_s / dt).round() as usize).max(2);
    let lead = (m / 2).max(1);
    let p = m + lead;
    // Block averages of each range, then the ranges split into BLOCKS stretches of about equal
    // length (a stretch shorter than the regressor is dropped).
    let mut pieces: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    for r in ranges {
        let (a, b) = (r.start.min(input.len()), r.end.min(input.len()));
        let avg = |v: &[f64]| -> Vec<f64> {
            v[a..b]
                .chunks_exact(q)
                .map(|c| c.iter().sum::<f64>() / q as f64)
                .collect()
        };
        let (x, y) = (avg(input), avg(output));
        if x.iter().chain(&y).any(|v| !v.is_finite()) {
            return Err(Error::Input(
                "causal step: the setpoint or gyro holds non-finite samples".into(),
            ));
        }
        pieces.push((x, y));
    }
    let total: usize = pieces.iter().map(|p| p.0.len()).sum();
    if total < 4 * p {
        return Err(Error::Input(format!(
            "causal step: {:.2} s of data at {:.1} ms, at least {:.2} s needed for {p} taps",
            total as f64 * dt,
            dt * 1e3,
            4.0 * p as f64 * dt
        )));
    }
    let per_block = total.div_ceil(BLOCKS);
    let mut blocks: Vec<(Mat<f64>, Vec<f64>, f64)> = Vec::new();
    for (x, y) in &pieces {
        for s in (0..x.len()).step_by(per_block) {
            let e = (s + per_block).min(x.len());
            if e - s > p + 1 {
                blocks.push(normal_equations(&x[s..e], &y[s..e], m, lead));
            }
        }
    }
    if blocks.len() < 2 {
        return Err(Error::Input("causal step: too little contiguous data for a fit".into()));
    }
    let mut a = Mat::<f64>::zeros(p, p);
    let mut g = vec![0.0; p];
    let mut yy = 0.0;
    for (ab, gb, yb) in &blocks {
        a += ab;
        g.iter_mut().zip(gb).for_each(|(s, v)| *s += v);
        yy += yb;
    }
    // Tap order: lags −lead … −1, then 0 … m−1; the causal fit is the trailing block.
    let causal = |a: &Mat<f64>, g: &[f64]| (a.get(lead.., lead..).to_owned(), g[lead..].to_vec());
    let fit = |a: &Mat<f64>, g: &[f64]| -> Result<Vec<f64>> {
        let p = g.len();
        let ridge = RIDGE * (0..p).map(|i| a[(i, i)]).sum::<f64>() / p as f64;
        if !(ridge > 0.0) {
            return Err(Error::Input(
                "causal step: the setpoint does not move in the data".into(),
            ));
        }
        let mut reg = a.clone();
        for i in 0..p {
            reg[(i, i)] += ridge;
        }
        let llt = reg
            .llt(Side::Lower)
            .map_err(|_| Error::Failed("causal step: the normal equations are not positive definite".into()))?;
        let rhs = Mat::from_fn(p, 1, |i, _| g[i]);
        let h = llt.solve(&rhs);
        Ok((0..p).map(|i| h[(i, 0)]).collect())
    };
    let step_of = |h: &[f64]| -> Vec<f64> {
        h.iter()
            .scan(0.0, |acc, v| {
                *acc += v;
                Some(*acc)
            })
            .collect()
    };
    let (ac, gc) = causal(&a, &g);
    let h = fit(&ac, &gc)?;
    let y = step_of(&h);
    // Residual sums of squares at the least-squares solutions: yᵀy − gᵀh.
    let rss = |g: &[f64], h: &[f64]| yy - g.iter().zip(h).map(|(a, b)| a * b).sum::<f64>();
    let (rss_causal, rss_full) = (rss(&gc, &h), rss(&g, &fit(&a, &g)?));
    // Jackknife variance of the delete-one-block estimates: (B − 1)/B·Σ(θ_i − θ̄)².
    let nb = blocks.len() as f64;
    let mut reps = Vec::new();
    for (ab, gb, _) in &blocks {
        let a_i = &a - ab;
        let g_i: Vec<f64> = g.iter().zip(gb).map(|(s, v)| s - v).collect();
        let (ac, gc) = causal(&a_i, &g_i);
        reps.push(step_of(&fit(&ac, &gc)?));
    }
    let y_std = (0..m)
        .map(|k| {
            let mean = reps.iter().map(|r| r[k]).sum::<f64>() / nb;
            ((nb - 1.0) / nb * reps.iter().map(|r| (r[k] - mean).powi(2)).sum::<f64>()).sqrt()
        })
        .collect();
    Ok(MeasuredStep {
        t_s: (0..m).map(|k| k as f64 * dt).collect(),
        y,
        y_std,
        windows: blocks.len(),
        windows_total: blocks.len(),
        acausal_fraction: if rss_causal > 0.0 {
            ((rss_causal - rss_full) / rss_causal).clamp(0.0, 1.0)
        } else {
            0.0
        },
    })
}

/// AᵀA, Aᵀy and yᵀy of one contiguous stretch, the regressor of sample t being
/// [r(t + lead), …, r(t + 1), r(t), …, r(t − m + 1)] for every t with all of them inside.
///
/// The normal matrix is Toeplitz up to end effects: entry (i + 1, j + 1) is entry (i, j) with one
/// product entering at the start and one leaving at the end, so it costs O(taps²) after the
/// first row's O(taps·samples).
fn normal_equations(x: &[f64], y: &[f64], m: usize, lead: usize) -> (Mat<f64>, Vec<f64>, f64) {
    let p = m + lead;
    // Regressor i of sample t is x[t + lead − i]; t runs over [m − 1, n − lead).
    let (t0, t1) = (m - 1, x.len() - lead);
    let reg = |t: usize, i: usize| x[t + lead - i];
    let mut a = Mat::<f64>::zeros(p, p);
    for j in 0..p {
        a[(0, j)] = (t0..t1).map(|t| reg(t, 0) * reg(t, j)).sum();
    }
    for i in 1..p {
        for j in i..p {
            // Shifting both regressors by one sample moves the window of t back by one.
            a[(i, j)] =
                a[(i - 1, j - 1)] + reg(t0 - 1, i - 1) * reg(t0 - 1, j - 1) - reg(t1 - 1, i - 1) * reg(t1 - 1, j - 1);
        }
    }
    for i in 0..p {
        for j in 0..i {
            a[(i, j)] = a[(j, i)];
        }
    }
    let g = (0..p).map(|i| (t0..t1).map(|t| reg(t, i) * y[t]).sum()).collect();
    (a, g, y[t0..t1].iter().map(|v| v * v).sum())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::single_range_in_vec_init)]
    use super::*;

    /// A rate loop y = T·r (first order, 20 ms) with output noise, driven by stick moves; then
    /// the same with a pilot who corrects the gyro of 60 ms ago. The causal fit recovers the
    /// step in both; the future setpoint explains part of the residual only with the pilot.
    #[test]
    fn recovers_a_step_with_and_without_a_pilot_in_the_loop() {
        let dt: f64 = 0.0005;
        let n = 200_000;
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let tau: f64 = 0.02;
        let a = (-dt / tau).exp();
        for pilot in [0.0, 0.6] {
            let delay = (0.06 / dt) as usize;
            let (mut r, mut y) = (vec![0.0; n], vec![0.0; n]);
            let (mut intent, mut state, mut dist) = (0.0, 0.0, 0.0);
            for t in 0..n {
                if t % 400 == 0 {
                    intent = 300.0 * rnd();
                }
                // Disturbance: first-order noise at ~30 ms correlation.
                dist = 0.985 * dist + 20.0 * rnd();
                let back = if t > delay { y[t - delay] } else { 0.0 };
                r[t] = intent - pilot * back;
                state = a * state + (1.0 - a) * r[t];
                y[t] = state + dist;
            }
            let s = causal_step(&r, &y, dt, &[0..n], 0.2).unwrap();
            // At 0.15 s the true step is 0.9994. PID-Analyzer's deconvolution gives 0.84–0.85 on
            // these data (with and without the pilot); the causal fit is within 1 %.
            let at = |t: &[f64], v: &[f64], x: f64| v[t.iter().position(|&u| u >= x).unwrap()];
            let w = super::super::deconv::step_from_log(&r, &y, dt, &[0..n], &Default::default()).unwrap();
            let (yc, yw) = (at(&s.t_s, &s.y, 0.15), at(&w.t_s, &w.y, 0.15));
            assert!(
                (yc - 0.9994).abs() < 0.01 && (yc - 0.9994).abs() < (yw - 0.9994).abs(),
                "{yc} vs {yw}"
            );
            for (k, &tk) in s.t_s.iter().enumerate() {
                // Block averaging to 2 ms shifts the sampled step by half a block at most.
                let want = 1.0 - (-(tk + 0.002) / tau).exp();
                let want_lo = 1.0 - (-(tk - 0.001).max(0.0) / tau).exp();
                assert!(
                    s.y[k] > want_lo - 0.06 && s.y[k] < want + 0.06,
                    "pilot {pilot}: t {tk}: {} vs {want_lo}..{want}",
                    s.y[k]
                );
                assert!(s.y_std[k] < 0.05, "{}", s.y_std[k]);
            }
            if pilot > 0.0 {
                assert!(s.acausal_fraction > 0.05, "{}", s.acausal_fraction);
            } else {
                assert!(s.acausal_fraction < 0.01, "{}", s.acausal_fraction);
            }
        }
    }

    #[test]
    fn the_recursion_equals_the_direct_sums() {
        let x: Vec<f64> = (0..50).map(|k| ((k * 37 % 11) as f64 - 5.0) * 0.3).collect();
        let y: Vec<f64> = (0..50).map(|k| (k as f64 * 0.7).sin()).collect();
        let (m, lead) = (6, 2);
        let (a, g, _) = normal_equations(&x, &y, m, lead);
        for i in 0..m + lead {
            for j in 0..m + lead {
                let direct: f64 = (m - 1..50 - lead).map(|t| x[t + lead - i] * x[t + lead - j]).sum();
                assert!((a[(i, j)] - direct).abs() < 1e-12, "{i},{j}");
            }
            let direct: f64 = (m - 1..50 - lead).map(|t| x[t + lead - i] * y[t]).sum();
            assert!((g[i] - direct).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_input_is_named() {
        let e = causal_step(&[1.0; 10], &[1.0; 9], 0.001, &[0..9], 0.5).unwrap_err();
        assert!(e.to_string().contains("input has 10"), "{e}");
        let e = causal_step(&[1.0; 10], &[1.0; 10], 0.0, &[0..10], 0.5).unwrap_err();
        assert!(e.to_string().contains("(0, 0.1]"), "{e}");
        let e = causal_step(&[1.0; 100], &[1.0; 100], 0.001, &[0..100], 0.5).unwrap_err();
        assert!(e.to_string().contains("needed"), "{e}");
    }
}
