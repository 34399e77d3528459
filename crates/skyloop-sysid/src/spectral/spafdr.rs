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
    pub dist: Option<Vec<C64>>,
    pub df: f64,
}

impl Dft {
    pub fn new(u: &[f64], y: &[f64], r: Option<&[f64]>, dist: Option<&[f64]>, dt: f64) -> Result<Dft> {
        let n = u.len();
        let fft = Rfft::new(n);
        Ok(Dft {
            u: fft.run(u, None)?,
            y: fft.run(y, None)?,
            r: r.map(|r| fft.run(r, None)).transpose()?,
            dist: dist.map(|x| fft.run(x, None)).transpose()?,
            df: 1.0 / (n as f64 * dt),
        })
    }

    /// Hann-weighted sums of the periodograms over a window of full width `width_hz` centred on
    /// `f_hz` (DC excluded), with the equivalent number of averaged bins (Σw)²/Σw².
    pub fn smooth(&self, f_hz: f64, width_hz: f64) -> Option<(Cross, f64)> {
        self.smooth_sums(f_hz, width_hz).map(|(c, sw, sw2)| (c, sw * sw / sw2))
    }

    /// As [`Dft::smooth`], with the sums Σw and Σw² of the window's taps in place of the average count.
    pub fn smooth_sums(&self, f_hz: f64, width_hz: f64) -> Option<(Cross, f64, f64)> {
        let half = 0.5 * width_hz;
        let last = self.u.len() - 1;
        let lo = (((f_hz - half) / self.df).ceil().max(1.0)) as usize;
        let hi = (((f_hz + half) / self.df).floor().max(0.0) as usize).min(last);
        let mut c = Cross::default();
        let (mut sw, mut sw2) = (0.0, 0.0);
        // cos of the window phase by rotation from bin to bin: one complex multiply instead of a cos
        // per bin (windows span up to ~10⁵ bins; the recurrence drifts by ~k·ε, far below the estimate's
        // own variance). Restarted exactly every 1024 bins to bound the drift.
        let phase = |k: usize| 2.0 * std::f64::consts::PI * (k as f64 * self.df - f_hz) / width_hz;
        let step = C64::from_polar(1.0, 2.0 * std::f64::consts::PI * self.df / width_hz);
        let mut rot = C64::from_polar(1.0, phase(lo));
        for k in lo..=hi {
            if (k - lo) % 1024 == 0 {
                rot = C64::from_polar(1.0, phase(k));
            }
            let w = 0.5 * (1.0 + rot.re);
            rot *= step;
            if w <= 0.0 {
                continue;
            }
            c.add(
                w,
                self.u[k],
                self.y[k],
                self.r.as_ref().map(|r| r[k]),
                self.dist.as_ref().map(|x| x[k]),
            );
            sw += w;
            sw2 += w * w;
        }
        (sw > 0.0).then_some((c, sw, sw2))
    }
}

/// Narrowest smoothing window, in bins, so that even the lowest frequency averages a few bins.
pub(crate) const MIN_WIDTH_BINS: f64 = 6.0;

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
    let dft = Dft::new(&p.u, &p.y, p.r.as_deref(), p.dist.as_deref(), p.dt)?;
    let (lo, hi) = limits(o, 2.0 * MIN_WIDTH_BINS * dft.df, p.dt)?;
    let lo = lo.max(dft.df);
    if hi <= lo {
        return Err(invalid(format!(
            "frequency range ends at {hi} Hz, below the resolution {} Hz of the record",
            dft.df
        )));
    }
    let ratio = (hi / lo).powf(1.0 / (o.n_freq - 1) as f64);
    let width = |f: f64| (o.resolution * f).max(MIN_WIDTH_BINS * dft.df);
    let points = (0..o.n_freq)
        .filter_map(|i| {
            let f = lo * ratio.powi(i as i32);
            dft.smooth(f, width(f)).map(|(c, nu)| (f, c, nu))
        })
        .collect();
    let mut frf = Frf::from_cross(points, p.r.is_some())?;
    frf.bandwidth_hz = frf.freq_hz.iter().map(|&f| width(f)).collect();
    Ok(frf)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rotated window equals the Hann window evaluated bin by bin with `cos`, over windows far
    /// wider than the 1024-bin restart interval.
    #[test]
    fn recurrence_window_matches_direct_cosine() {
        let n: usize = 200_000;
        let u: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1000) as f64 / 500.0 - 1.0).collect();
        let y: Vec<f64> = (0..n).map(|i| ((i * 104_729) % 997) as f64 / 498.5 - 1.0).collect();
        let dft = Dft::new(&u, &y, None, None, 0.001).unwrap();
        for (f, width) in [(3.0, 0.2), (120.0, 18.0), (400.0, 60.0)] {
            let (c, nu) = dft.smooth(f, width).unwrap();
            let mut want = Cross::default();
            let (mut sw, mut sw2) = (0.0, 0.0);
            for k in 1..dft.u.len() {
                let x = (k as f64 * dft.df - f) / width;
                if x.abs() > 0.5 {
                    continue;
                }
                let w = 0.5 * (1.0 + (2.0 * std::f64::consts::PI * x).cos());
                want.add(w, dft.u[k], dft.y[k], None, None);
                sw += w;
                sw2 += w * w;
            }
            let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
            assert!(
                rel(c.uu, want.uu) < 1e-9 && rel(c.yy, want.yy) < 1e-9,
                "f {f}: {c:?} vs {want:?}"
            );
            assert!((c.yu - want.yu).norm() < 1e-9 * want.yu.norm().max(want.uu), "f {f}");
            assert!(rel(nu, sw * sw / sw2) < 1e-9, "f {f}: ν {nu}");
        }
    }
}
