//! Blackman–Tukey spectral analysis (MATLAB's spa): sample correlation functions up to lag M,
//! weighted by a Hann lag window, Fourier transformed at the requested frequencies
//! (Ljung, System Identification, 2nd ed., §6.4).

use std::f64::consts::PI;

use num_complex::Complex64 as C64;

use super::{limits, prepare, Cross, Frf, IoData, Options, Prepared, Rfft};
use crate::error::{invalid, Result, SysidError};

/// R_ab(τ) = (1/N) Σ_t a(t+τ)·b(t) for τ = −m..=m (index τ + m), from the DFTs of the zero-padded records.
fn correlation(a: &[C64], b: &[C64], nfft: usize, n: usize, m: usize) -> Result<Vec<f64>> {
    let mut spec: Vec<C64> = a.iter().zip(b).map(|(x, y)| x * y.conj()).collect();
    spec[0].im = 0.0;
    if let Some(l) = spec.last_mut() {
        l.im = 0.0;
    }
    let plan = realfft::RealFftPlanner::<f64>::new().plan_fft_inverse(nfft);
    let mut out = plan.make_output_vec();
    plan.process(&mut spec, &mut out)
        .map_err(|e| SysidError::Numerical(format!("inverse FFT failed: {e}")))?;
    // realfft's inverse is unnormalized: divide by nfft, and by N for the biased estimate.
    let s = 1.0 / (nfft as f64 * n as f64);
    Ok((0..=2 * m)
        .map(|i| {
            let tau = i as isize - m as isize;
            let idx = if tau >= 0 {
                tau as usize
            } else {
                (nfft as isize + tau) as usize
            };
            out[idx] * s
        })
        .collect())
}

/// The six correlation functions R_uu, R_yy, R_yu (and R_rr, R_ur, R_yr) of one record up to lag `m`,
/// each (1/N)·Σ.
pub(crate) fn correlations(p: &Prepared, m: usize) -> Result<Correlations> {
    let n = p.u.len();
    let nfft = (n + m + 1).next_power_of_two();
    let fft = Rfft::new(nfft);
    let uf = fft.run(&p.u, None)?;
    let yf = fft.run(&p.y, None)?;
    let rf = p.r.as_ref().map(|r| fft.run(r, None)).transpose()?;
    let ruu = correlation(&uf, &uf, nfft, n, m)?;
    let ryy = correlation(&yf, &yf, nfft, n, m)?;
    let ryu = correlation(&yf, &uf, nfft, n, m)?;
    let closed = match &rf {
        Some(rf) => Some((
            correlation(rf, rf, nfft, n, m)?,
            correlation(&uf, rf, nfft, n, m)?,
            correlation(&yf, rf, nfft, n, m)?,
        )),
        None => None,
    };
    Ok((ruu, ryy, ryu, closed))
}

/// R_rr, R_ur, R_yr.
pub(crate) type Closed = (Vec<f64>, Vec<f64>, Vec<f64>);

/// R_uu, R_yy, R_yu and, with an excitation, [`Closed`].
pub(crate) type Correlations = (Vec<f64>, Vec<f64>, Vec<f64>, Option<Closed>);

/// Blackman–Tukey estimate on `o.n_freq` linearly spaced frequencies in [fmin, fmax].
pub fn spa(d: &IoData, o: &Options) -> Result<Frf> {
    let p = prepare(d, o.detrend, 16)?;
    let n = p.u.len();
    let m = o.lag_window.unwrap_or((n / 10).min(30));
    if m < 2 || m >= n {
        return Err(invalid(format!(
            "lag window {m} must be within 2..{n} (the record length)"
        )));
    }
    let (ruu, ryy, ryu, closed) = correlations(&p, m)?;
    from_correlations(o, p.dt, n, m, (ruu, ryy, ryu, closed))
}

/// The SPA estimate from correlation functions (of `n` samples in all) up to lag `m`.
pub(crate) fn from_correlations(
    o: &Options,
    dt: f64,
    n: usize,
    m: usize,
    (ruu, ryy, ryu, closed): Correlations,
) -> Result<Frf> {
    if o.n_freq < 2 {
        return Err(invalid("SPA needs at least 2 output frequencies"));
    }
    let lag_w: Vec<f64> = (0..=2 * m)
        .map(|i| {
            let tau = i as f64 - m as f64;
            0.5 * (1.0 + (PI * tau / m as f64).cos())
        })
        .collect();
    // Asymptotic variance (Ljung eq. 6.72): Var Ĝ ∝ (1/N) Σ W(τ)², i.e. ν = N / Σ W(τ)².
    let nu = n as f64 / lag_w.iter().map(|w| w * w).sum::<f64>();
    let (fmax_default, _) = (0.5 / dt, ());
    let (lo, hi) = limits(o, fmax_default / o.n_freq as f64, dt)?;
    let step = (hi - lo) / (o.n_freq - 1) as f64;
    let points = (0..o.n_freq)
        .map(|i| {
            let f = lo + i as f64 * step;
            let w = 2.0 * PI * f * dt;
            let ft = |r: &[f64]| -> C64 {
                r.iter()
                    .zip(&lag_w)
                    .enumerate()
                    .map(|(i, (r, lw))| {
                        let tau = i as f64 - m as f64;
                        C64::from_polar(r * lw, -w * tau)
                    })
                    .sum()
            };
            let mut c = Cross {
                uu: ft(&ruu).re,
                yy: ft(&ryy).re,
                yu: ft(&ryu),
                ..Cross::default()
            };
            if let Some((rr, ur, yr)) = &closed {
                c.rr = ft(rr).re;
                c.ur = ft(ur);
                c.yr = ft(yr);
            }
            (f, c, nu)
        })
        .filter(|(f, _, _)| *f > 0.0)
        .collect();
    let mut frf = Frf::from_cross(points, closed.is_some())?;
    // The Hann lag window of half-length M smooths the periodograms with a kernel whose equivalent
    // bandwidth, 4/(3·M·dt), equals that of a Hann frequency kernel of full width 2/(M·dt).
    let width = 2.0 / (m as f64 * dt);
    frf.bandwidth_hz = vec![width; frf.freq_hz.len()];
    Ok(frf)
}
