//! The step response setpoint → gyro measured from a flight log, as PID-Analyzer shows it
//! (Florian Melsheimer's method, described in its README): cut the flight into overlapping
//! windows, estimate each window's impulse response by Wiener-regularised deconvolution of the
//! gyro by the setpoint, integrate it to a step response, and average the windows that carry
//! enough stick input.
//!
//! Per window (Tukey-tapered, zero-padded to twice its length so the circular
//! deconvolution does not wrap): H(f) = Y(f)·X̄(f) / (|X(f)|² + λ(f)), with λ(f) = ⟨|X|²⟩/SNR
//! inside the band f ≤ `cutoff_hz` and 10⁹ times that above it,
//! with a raised-cosine transition over one half octave; the regularisation is relative to the
//! window's own input power so the result does not depend on the setpoint's units or amplitude.

use crate::error::{Error, Result};
use num_complex::Complex64 as C64;
use realfft::RealFftPlanner;
use std::f64::consts::PI;

/// In-band signal-to-noise ratio of the regularisation, relative to the window's mean in-band
/// input power. PID-Analyzer's 10 (in its absolute units) shrinks the response by ~10 % where
/// a pilot's stick spectrum has fallen off; 1000, with the averaging over windows, recovers a
/// known response within 4 % (the unit test).
const SNR: f64 = 1000.0;

/// Options of [`step_from_log`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeconvOptions {
    /// Window length, s.
    pub window_s: f64,
    /// Window advance, s.
    pub step_s: f64,
    /// Length of the step response returned, s.
    pub response_s: f64,
    /// Band edge of the deconvolution, Hz.
    pub cutoff_hz: f64,
    /// Windows whose setpoint RMS (mean removed) is below this are skipped, setpoint units.
    pub min_input_rms: f64,
}

impl Default for DeconvOptions {
    /// PID-Analyzer's defaults: 1 s windows, a 0.5 s response, 25 Hz band; windows advanced by
    /// 0.25 s; at least 5 deg/s of stick activity.
    fn default() -> Self {
        DeconvOptions {
            window_s: 1.0,
            step_s: 0.25,
            response_s: 0.5,
            cutoff_hz: 25.0,
            min_input_rms: 5.0,
        }
    }
}

/// The measured step response.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredStep {
    /// Time, s (from 0, the sample period of the log).
    pub t_s: Vec<f64>,
    /// Mean step response of the windows used (output per unit setpoint step).
    pub y: Vec<f64>,
    /// Its standard deviation over the windows.
    pub y_std: Vec<f64>,
    /// Windows averaged.
    pub windows: usize,
    /// Windows available (before the input-activity test).
    pub windows_total: usize,
    /// Share of the deconvolved impulse response's mass that lies at negative lag (gyro moving
    /// before the setpoint), over the response's length before 0: |Σ h(t < 0)| / (|Σ h(t < 0)| +
    /// |Σ h(0 ≤ t < response_s)|), averaged over windows. A causal loop gives ≈ 0; a pilot whose
    /// stick corrects what the craft just did closes a loop around the rate loop, the setpoint then
    /// depends on past gyro, and the step (which starts at t = 0) comes out short by this share.
    pub acausal_fraction: f64,
}

/// The averaged step response of `output` to `input` (uniformly sampled at `dt_s`) over the
/// windows that lie inside one of `ranges` (sample-index ranges, e.g. the airborne segments).
///
/// # Errors
/// Mismatched lengths, options out of range (named), or no window with enough input.
pub fn step_from_log(
    input: &[f64],
    output: &[f64],
    dt_s: f64,
    ranges: &[std::ops::Range<usize>],
    o: &DeconvOptions,
) -> Result<MeasuredStep> {
    let (n, m) = window_sizes(input, output, dt_s, o)?;
    let adv = ((o.step_s / dt_s).round() as usize).max(1);
    let d = Deconvolver::new(n, dt_s, o.cutoff_hz);
    let mut sum = vec![0.0; m];
    let mut sum2 = vec![0.0; m];
    let mut neg_sum = 0.0;
    let (mut used, mut total) = (0usize, 0usize);
    for r in ranges {
        let mut start = r.start;
        while start + n <= r.end.min(input.len()) {
            total += 1;
            let x = &input[start..start + n];
            let y = &output[start..start + n];
            start += adv;
            let mx = x.iter().sum::<f64>() / n as f64;
            let rms = (x.iter().map(|v| (v - mx).powi(2)).sum::<f64>() / n as f64).sqrt();
            if !(rms >= o.min_input_rms) {
                continue;
            }
            let Some(imp) = d.impulse(x, y)? else { continue };
            let mut acc = 0.0;
            for k in 0..m {
                acc += imp[k];
                sum[k] += acc;
                sum2[k] += acc * acc;
            }
            // The circular buffer's last m samples are lags −m·dt … −dt.
            neg_sum += imp[d.nfft - m..].iter().sum::<f64>();
            used += 1;
        }
    }
    if used == 0 {
        return Err(Error::Input(format!(
            "deconvolution: none of the {total} windows of {} s has a setpoint RMS of at least {} (the log holds no stick input to measure a step response from)",
            o.window_s, o.min_input_rms
        )));
    }
    let k = used as f64;
    let y: Vec<f64> = sum.iter().map(|s| s / k).collect();
    let y_std = sum2
        .iter()
        .zip(&y)
        .map(|(s2, mu)| (s2 / k - mu * mu).max(0.0).sqrt())
        .collect();
    let (neg, pos) = ((neg_sum / k).abs(), y.last().copied().unwrap_or(0.0).abs());
    let acausal_fraction = if neg + pos > 0.0 { neg / (neg + pos) } else { 0.0 };
    Ok(MeasuredStep {
        t_s: (0..m).map(|i| i as f64 * dt_s).collect(),
        y,
        y_std,
        windows: used,
        windows_total: total,
        acausal_fraction,
    })
}

/// The window and response lengths in samples, (n, m), after checking the inputs.
///
/// # Errors
/// Mismatched lengths, a sample period or option that is not a positive number, or a window
/// outside 16..=2^20 samples.
fn window_sizes(input: &[f64], output: &[f64], dt_s: f64, o: &DeconvOptions) -> Result<(usize, usize)> {
    if input.len() != output.len() {
        return Err(Error::Input(format!(
            "deconvolution: input has {} samples, output {}",
            input.len(),
            output.len()
        )));
    }
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(Error::Input(format!(
            "deconvolution: sample period must be > 0 s, got {dt_s}"
        )));
    }
    for (name, v) in [
        ("window_s", o.window_s),
        ("step_s", o.step_s),
        ("response_s", o.response_s),
        ("cutoff_hz", o.cutoff_hz),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Input(format!("deconvolution: {name} must be > 0, got {v}")));
        }
    }
    let n = (o.window_s / dt_s).round() as usize;
    let m = ((o.response_s / dt_s).round() as usize).min(n);
    if !(16..=1 << 20).contains(&n) {
        return Err(Error::Input(format!(
            "deconvolution: a {} s window holds {n} samples at {dt_s} s; allowed 16..=2^20",
            o.window_s
        )));
    }
    Ok((n, m))
}

/// The regularized deconvolution of one window: tapered, zero-padded to twice its length,
/// H = Y·X̄/(|X|² + λ) with λ growing beyond the cutoff.
struct Deconvolver {
    fwd: std::sync::Arc<dyn realfft::RealToComplex<f64>>,
    inv: std::sync::Arc<dyn realfft::ComplexToReal<f64>>,
    taper: Vec<f64>,
    /// Window length, samples.
    n: usize,
    /// FFT length (2n), samples.
    nfft: usize,
    /// Bin spacing, Hz.
    df: f64,
    /// Band edge, Hz.
    fc: f64,
}

impl Deconvolver {
    /// Plans the transforms of an `n`-sample window at `dt_s` with band edge `fc` Hz.
    fn new(n: usize, dt_s: f64, fc: f64) -> Self {
        let nfft = 2 * n;
        let mut planner = RealFftPlanner::<f64>::new();
        // Tukey (α = 0.25): flat over most of the window, so the output's taper matches the
        // input's wherever the response has settled (a Hann taper biases the final value low by ~5 %).
        let alpha = 0.25;
        let taper = (0..n)
            .map(|k| {
                let x = k as f64 / (n - 1) as f64;
                if x < alpha / 2.0 {
                    0.5 * (1.0 + (2.0 * PI / alpha * (x - alpha / 2.0)).cos())
                } else if x > 1.0 - alpha / 2.0 {
                    0.5 * (1.0 + (2.0 * PI / alpha * (x - 1.0 + alpha / 2.0)).cos())
                } else {
                    1.0
                }
            })
            .collect();
        Self {
            fwd: planner.plan_fft_forward(nfft),
            inv: planner.plan_fft_inverse(nfft),
            taper,
            n,
            nfft,
            df: 1.0 / (nfft as f64 * dt_s),
            fc,
        }
    }

    /// Weight of the band: 1 up to fc, 0 beyond √2·fc, a raised cosine in log frequency between.
    fn band(&self, f: f64) -> f64 {
        let fc = self.fc;
        if f <= fc {
            1.0
        } else if f >= fc * 2f64.sqrt() {
            0.0
        } else {
            0.5 + 0.5 * (PI * (f / fc).log2() / 0.5).cos()
        }
    }

    /// The tapered, zero-padded spectrum of a window. The means stay in: the windows' mean rates
    /// are what tells the step's final value.
    fn spectrum(&self, v: &[f64]) -> Result<Vec<C64>> {
        let mut buf = vec![0.0; self.nfft];
        for k in 0..self.n {
            buf[k] = v[k] * self.taper[k];
        }
        let mut out = self.fwd.make_output_vec();
        self.fwd
            .process(&mut buf, &mut out)
            .map_err(|e| Error::Failed(format!("FFT failed: {e}")))?;
        Ok(out)
    }

    /// The impulse response of one window (circular, `nfft` samples, negative lags at the end);
    /// None when the input has no power in the band.
    ///
    /// # Errors
    /// An FFT that fails.
    fn impulse(&self, x: &[f64], y: &[f64]) -> Result<Option<Vec<f64>>> {
        let xs = self.spectrum(x)?;
        let ys = self.spectrum(y)?;
        let inband: Vec<f64> = xs
            .iter()
            .enumerate()
            .filter(|(k, _)| *k as f64 * self.df <= self.fc)
            .map(|(_, z)| z.norm_sqr())
            .collect();
        let lam0 = inband.iter().sum::<f64>() / inband.len().max(1) as f64 / SNR;
        if !(lam0 > 0.0) {
            return Ok(None);
        }
        let mut h: Vec<C64> = xs
            .iter()
            .zip(&ys)
            .enumerate()
            .map(|(k, (xk, yk))| {
                let w = self.band(k as f64 * self.df);
                let lam = lam0 * (w + (1.0 - w) * 1e9);
                yk * xk.conj() / (xk.norm_sqr() + lam)
            })
            .collect();
        // A real signal's DC and Nyquist bins are real; rounding leaves tiny imaginary parts.
        h[0].im = 0.0;
        if let Some(last) = h.last_mut() {
            last.im = 0.0;
        }
        let mut imp = self.inv.make_output_vec();
        self.inv
            .process(&mut h, &mut imp)
            .map_err(|e| Error::Failed(format!("inverse FFT failed: {e}")))?;
        // realfft's inverse is unnormalized.
        let nfft = self.nfft as f64;
        Ok(Some(imp.into_iter().map(|v| v / nfft).collect()))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// The same first-order loop, but with a "pilot" whose stick corrects the output of 50 ms
    /// ago: the setpoint now depends on past output, the deconvolution puts mass at negative lag,
    /// the step comes out short, and `acausal_fraction` says so.
    #[test]
    fn a_pilot_in_the_loop_shows_as_acausal_mass() {
        let dt: f64 = 0.002;
        let a = (-dt / 0.01f64).exp();
        let n = 60_000;
        let mut uniform = skyloop_fixtures::lcg(99u64);
        let mut rnd = || uniform() - 0.5;
        let (mut w, mut u, mut y) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for k in 1..n {
            w[k] = 0.995 * w[k - 1] + 20.0 * rnd();
            u[k] = w[k] - if k >= 25 { 0.9 * y[k - 25] } else { 0.0 };
            y[k] = a * y[k - 1] + (1.0 - a) * u[k - 1];
        }
        let st = step_from_log(&u, &y, dt, std::slice::from_ref(&(0..n)), &DeconvOptions::default()).unwrap();
        let last = *st.y.last().unwrap();
        assert!(
            st.acausal_fraction > 0.1,
            "{} (step ends at {last})",
            st.acausal_fraction
        );
        assert!(last < 0.95, "{last}");
    }

    /// A known discrete system y[k] = a·y[k−1] + (1 − a)·u[k−1] (unit DC gain, time constant
    /// −dt/ln a) driven by a random-walk setpoint: the deconvolved step equals its exact step
    /// response 1 − a^k (delayed one sample) to within the band limit's smoothing.
    #[test]
    fn recovers_a_first_order_step() {
        let dt: f64 = 0.001;
        let a = (-dt / 0.02f64).exp();
        let n = 20_000;
        let mut uniform = skyloop_fixtures::lcg(12345u64);
        let mut rnd = || uniform() - 0.5;
        let mut u = vec![0.0; n];
        for k in 1..n {
            // Low-passed noise, like a pilot's sticks.
            u[k] = 0.98 * u[k - 1] + 40.0 * rnd();
        }
        let mut y = vec![0.0; n];
        for k in 1..n {
            y[k] = a * y[k - 1] + (1.0 - a) * u[k - 1];
        }
        let o = DeconvOptions {
            cutoff_hz: 100.0,
            ..Default::default()
        };
        let st = step_from_log(&u, &y, dt, std::slice::from_ref(&(0..n)), &o).unwrap();
        assert!(st.windows > 50, "{}", st.windows);
        for (i, &t) in st.t_s.iter().enumerate() {
            let exact = if i == 0 { 0.0 } else { 1.0 - a.powi(i as i32) };
            if t > 0.01 {
                assert!((st.y[i] - exact).abs() < 0.04, "t {t}: {} vs {exact}", st.y[i]);
            }
        }
        assert!(st.acausal_fraction < 0.05, "{}", st.acausal_fraction);
        let quiet = vec![0.0; n];
        let e = step_from_log(&quiet, &y, dt, std::slice::from_ref(&(0..n)), &o).unwrap_err();
        assert!(e.to_string().contains("setpoint RMS"), "{e}");
    }
}
