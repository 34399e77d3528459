//! SPAFDR: spectral analysis with frequency-dependent resolution (Ljung, System Identification
//! Toolbox). The periodograms of the whole record are smoothed with a Hann window in frequency whose
//! width grows in proportion to the frequency, evaluated on a logarithmic grid: fine resolution where
//! the dynamics is slow, many averages where it is fast. One FFT per channel, O(N) smoothing.

use num_complex::Complex64 as C64;

use super::{limits, prepare, Cross, Frf, IoData, Options, Rfft};
use crate::error::{invalid, Result};

/// Full-record DFTs of u, y (and r), bins 0..=N/2, spaced `df` Hz.
pub(crate) struct Dft {
    pub u: Vec<C64>,
    pub y: Vec<C64>,
    pub r: Option<Vec<C64>>,
    pub df: f64,
}

impl Dft {
    pub fn new(u: &[f64], y: &[f64], r: Option<&[f64]>, dt: f64) -> Result<Dft> {
        let n = u.len();
        let fft = Rfft::new(n);
        Ok(Dft {
            u: fft.run(u, None)?,
            y: fft.run(y, None)?,
            r: r.map(|r| fft.run(r, None)).transpose()?,
            df: 1.0 / (n as f64 * dt),
        })
    }

    /// Hann-weighted sums of the periodograms over a window of full width `width_hz` centred on
    /// `f_hz` (DC excluded), with the equivalent number of averaged bins (Σw)²/Σw².
    pub fn smooth(&self, f_hz: f64, width_hz: f64) -> Option<(Cross, f64)> {
        let half = 0.5 * width_hz;
        let last = self.u.len() - 1;
        let lo = (((f_hz - half) / self.df).ceil().max(1.0)) as usize;
        let hi = (((f_hz + half) / self.df).floor().max(0.0) as usize).min(last);
        let mut c = Cross::default();
        let (mut sw, mut sw2) = (0.0, 0.0);
        for k in lo..=hi {
            let x = (k as f64 * self.df - f_hz) / width_hz;
            let w = 0.5 * (1.0 + (2.0 * std::f64::consts::PI * x).cos());
            if w <= 0.0 {
                continue;
            }
            c.add(w, self.u[k], self.y[k], self.r.as_ref().map(|r| r[k]));
            sw += w;
            sw2 += w * w;
        }
        (sw > 0.0).then(|| (c, sw * sw / sw2))
    }
}

/// Narrowest smoothing window, in bins, so that even the lowest frequency averages a few bins.
const MIN_WIDTH_BINS: f64 = 6.0;

/// SPAFDR estimate on `o.n_freq` log-spaced frequencies in [fmin, fmax]; the Hann window's full width
/// is max(`o.resolution`·f, 6 bins).
pub fn spafdr(d: &IoData, o: &Options) -> Result<Frf> {
    let p = prepare(d, o.detrend, 32)?;
    if !(o.resolution.is_finite() && o.resolution > 0.0) {
        return Err(invalid(format!(
            "relative resolution must be positive, got {}",
            o.resolution
        )));
    }
    if o.n_freq < 2 {
        return Err(invalid("SPAFDR needs at least 2 output frequencies"));
    }
    let dft = Dft::new(&p.u, &p.y, p.r.as_deref(), p.dt)?;
    let (lo, hi) = limits(o, 2.0 * MIN_WIDTH_BINS * dft.df, p.dt)?;
    let lo = lo.max(dft.df);
    if hi <= lo {
        return Err(invalid(format!(
            "frequency range ends at {hi} Hz, below the resolution {} Hz of the record",
            dft.df
        )));
    }
    let ratio = (hi / lo).powf(1.0 / (o.n_freq - 1) as f64);
    let points = (0..o.n_freq)
        .filter_map(|i| {
            let f = lo * ratio.powi(i as i32);
            let width = (o.resolution * f).max(MIN_WIDTH_BINS * dft.df);
            dft.smooth(f, width).map(|(c, nu)| (f, c, nu))
        })
        .collect();
    Frf::from_cross(points, p.r.is_some())
}
