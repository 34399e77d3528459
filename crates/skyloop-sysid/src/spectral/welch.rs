//! Welch's method: averaged windowed periodograms of overlapping segments (H1 estimator), as
//! MATLAB's tfestimate/mscohere and scipy.signal.csd/coherence.

use num_complex::Complex64 as C64;

use super::{limits, prepare, Cross, Frf, IoData, Options, Prepared, Rfft};
use crate::error::{invalid, Result, SysidError};
use crate::logs::{detrend, Detrend};

/// Default segment length: the power of two giving about eight 50 %-overlapping segments.
pub fn default_nfft(n: usize) -> usize {
    let target = (2 * n / 9).max(16);
    let mut p = 16usize;
    while p * 2 <= target {
        p *= 2;
    }
    p
}

/// Welch H1 estimate; frequencies are the segment's DFT bins within the requested range.
pub fn welch(d: &IoData, o: &Options) -> Result<Frf> {
    let p = prepare(d, o.detrend, 16)?;
    let n = p.u.len();
    let nfft = o.nfft.unwrap_or_else(|| default_nfft(n));
    if nfft < 8 || nfft > n {
        return Err(invalid(format!(
            "Welch segment length {nfft} must be within 8..={n} (the record length)"
        )));
    }
    let mut w = Windows::new(nfft, o)?;
    w.add(&p)?;
    w.finish(o, p.dt, p.r.is_some())
}

/// Windowed periodograms of one length accumulated over one or more records.
pub(crate) struct Windows {
    nfft: usize,
    step: usize,
    w: Vec<f64>,
    fft: Rfft,
    acc: Vec<Cross>,
    /// Equivalent independent averages so far (records are independent of each other).
    nu: f64,
}

impl Windows {
    pub fn new(nfft: usize, o: &Options) -> Result<Windows> {
        if !(0.0..1.0).contains(&o.overlap) {
            return Err(invalid(format!("overlap {} must be in [0, 1)", o.overlap)));
        }
        let w = o.window.samples(nfft);
        if w.iter().map(|v| v * v).sum::<f64>() <= 0.0 {
            return Err(SysidError::Numerical("window is all zeros".into()));
        }
        Ok(Windows {
            nfft,
            step: (((1.0 - o.overlap) * nfft as f64).round() as usize).max(1),
            w,
            fft: Rfft::new(nfft),
            acc: vec![Cross::default(); nfft / 2 + 1],
            nu: 0.0,
        })
    }

    /// Adds the windows of one record of at least `nfft` samples.
    pub fn add(&mut self, p: &Prepared) -> Result<()> {
        let (nfft, step) = (self.nfft, self.step);
        let n = p.u.len();
        if n < nfft {
            return Ok(());
        }
        let k = (n - nfft) / step + 1;
        let mut seg = vec![0.0; nfft];
        let (fft, w) = (&self.fft, &self.w);
        let spec = |x: &[f64], s: usize, seg: &mut Vec<f64>| -> Result<Vec<C64>> {
            seg.copy_from_slice(&x[s..s + nfft]);
            detrend(seg, Detrend::Mean);
            fft.run(seg, Some(w))
        };
        for i in 0..k {
            let s = i * step;
            let uf = spec(&p.u, s, &mut seg)?;
            let yf = spec(&p.y, s, &mut seg)?;
            let rf = match &p.r {
                Some(r) => Some(spec(r, s, &mut seg)?),
                None => None,
            };
            let df = match &p.dist {
                Some(x) => Some(spec(x, s, &mut seg)?),
                None => None,
            };
            for (j, a) in self.acc.iter_mut().enumerate() {
                a.add(1.0, uf[j], yf[j], rf.as_ref().map(|r| r[j]), df.as_ref().map(|x| x[j]));
            }
        }
        // Welch (1967): overlapping segments are correlated; ν = K / (1 + 2 Σ_j (1 − j/K) ρ(j·step)²).
        let w2: f64 = w.iter().map(|v| v * v).sum();
        let mut denom = 1.0;
        for j in 1..k {
            let lag = j * step;
            if lag >= nfft {
                break;
            }
            let rho: f64 = (0..nfft - lag).map(|i| w[i] * w[i + lag]).sum::<f64>() / w2;
            denom += 2.0 * (1.0 - j as f64 / k as f64) * rho * rho;
        }
        self.nu += k as f64 / denom;
        Ok(())
    }

    pub fn finish(self, o: &Options, dt: f64, closed: bool) -> Result<Frf> {
        let df = 1.0 / (self.nfft as f64 * dt);
        let (lo, hi) = limits(o, df, dt)?;
        let points = (1..=self.nfft / 2)
            .map(|j| (j as f64 * df, j))
            .filter(|(f, _)| *f >= lo - 1e-9 * df && *f <= hi + 1e-9 * df)
            .map(|(f, j)| (f, self.acc[j], self.nu))
            .collect();
        Frf::from_cross(points, closed)
    }
}
