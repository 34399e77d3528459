//! The flight cut into short frames (0.25 s, half-overlapping, inside the airborne segments), each
//! with its spectra and its operating point (throttle, motor rotation, strongest gyro peaks): the
//! unit over which a throttle-following filter is one filter, and from which the spectra, the
//! spectrograms and the what-if are accumulated.

use crate::error::{Error, Result};
use crate::firmware::channels::NoiseChannels;
use crate::firmware::filters::OperatingPoint;
use skyloop_sysid::logs::Log;
use skyloop_sysid::logs::Span;
use skyloop_sysid::spectral::psd::SegmentPsd;

/// Target frame length, s (4 Hz resolution; short enough that throttle and motor speed are nearly
/// constant within a frame).
pub const FRAME_S: f64 = 0.25;

/// The signals of one axis within the uniform columns.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AxisColumns {
    pub gyro: usize,
    pub raw: Option<usize>,
    pub dterm: Option<usize>,
}

/// The log's channels on one uniform grid at the gyro's rate.
pub(crate) struct FrameSource {
    pub dt_s: f64,
    pub t0_s: f64,
    pub nfft: usize,
    columns: Vec<Vec<f64>>,
    pub axes: Vec<AxisColumns>,
    motors: Vec<usize>,
    throttle: Option<(usize, f64, f64)>,
    rotation: Option<(Vec<usize>, f64)>,
}

/// One frame: its centre time, operating point and spectra.
pub(crate) struct Frame {
    pub t_s: f64,
    pub op: OperatingPoint,
    /// Per axis: filtered gyro, raw gyro, D term densities.
    pub gyro: Vec<Vec<f64>>,
    pub raw: Vec<Option<Vec<f64>>>,
    pub dterm: Vec<Option<Vec<f64>>>,
    /// The motor commands' density, averaged over the motors.
    pub motors: Option<Vec<f64>>,
}

impl FrameSource {
    /// Resamples the channels `ch` (and the raw gyro `raw`, roll/pitch/yaw) of `axes` (0 roll, 1
    /// pitch, 2 yaw) onto the gyro's own rate.
    ///
    /// # Errors
    /// A log without the axes' gyro, or too short a log for one frame.
    pub fn new(log: &Log, ch: &NoiseChannels, raw: Option<&[String; 3]>, axes: &[usize]) -> Result<FrameSource> {
        let mut names: Vec<String> = Vec::new();
        let mut push = |n: &str| -> usize {
            names.iter().position(|x| x == n).unwrap_or_else(|| {
                names.push(n.to_string());
                names.len() - 1
            })
        };
        let mut cols = Vec::new();
        for &a in axes {
            let g = ch.gyro[a].as_deref().map_err(|why| {
                let axis = ["roll", "pitch", "yaw"][a.min(2)];
                Error::Input(format!("{}: no gyro channel for the {axis} axis: {why}", log.source))
            })?;
            cols.push(AxisColumns {
                gyro: push(g),
                raw: raw.map(|r| push(&r[a])),
                dterm: ch.dterm[a].as_deref().map(&mut push),
            });
        }
        let motors: Vec<usize> = ch.motors.iter().map(|m| push(m)).collect();
        let throttle = ch.throttle.as_ref().map(|(n, lo, hi)| (push(n), *lo, *hi));
        let rotation = ch
            .rotation
            .as_ref()
            .map(|(ns, k)| (ns.iter().map(|n| push(n)).collect(), *k));
        let (t, _) = log.series(&names[cols[0].gyro])?;
        let rate = skyloop_sysid::logs::median_rate_hz(&t);
        if !(rate.is_finite() && rate > 0.0) {
            return Err(Error::Input(format!(
                "{}: the gyro has no steady sample rate",
                log.source
            )));
        }
        let refs: Vec<&str> = names.iter().map(String::as_str).collect();
        let d = log.uniform(&refs, Some(rate), None, None)?;
        let nfft = ((FRAME_S / d.dt_s).round() as usize)
            .next_power_of_two()
            .clamp(64, 4096);
        Ok(FrameSource {
            dt_s: d.dt_s,
            t0_s: d.t0_s,
            nfft,
            columns: d.columns,
            axes: cols,
            motors,
            throttle,
            rotation,
        })
    }

    /// The sample rate of the grid, Hz.
    pub fn rate_hz(&self) -> f64 {
        1.0 / self.dt_s
    }

    /// The start indices of the half-overlapping frames inside `spans`.
    pub fn starts(&self, spans: &[Span]) -> Vec<usize> {
        let n = self.columns.first().map_or(0, Vec::len);
        let mut out = Vec::new();
        for s in spans {
            let lo = ((s.from_s - self.t0_s) / self.dt_s).ceil().max(0.0) as usize;
            let hi = (((s.to_s - self.t0_s) / self.dt_s).floor().max(0.0) as usize + 1).min(n);
            let mut k = lo;
            while k + self.nfft <= hi {
                out.push(k);
                k += self.nfft / 2;
            }
        }
        out
    }

    fn mean(&self, col: usize, k: usize) -> f64 {
        let x = &self.columns[col][k..k + self.nfft];
        x.iter().sum::<f64>() / x.len() as f64
    }

    /// The frame starting at sample `k` (its peaks are the strongest of the pre-notch gyro: the
    /// raw gyro where logged, else the filtered one, of the first axis).
    pub fn frame(&self, seg: &SegmentPsd, k: usize) -> Result<Frame> {
        let psd = |c: usize| seg.density(&self.columns[c][k..k + self.nfft]).map_err(Error::from);
        let mut gyro = Vec::new();
        let mut raw = Vec::new();
        let mut dterm = Vec::new();
        for a in &self.axes {
            gyro.push(psd(a.gyro)?);
            raw.push(a.raw.map(psd).transpose()?);
            dterm.push(a.dterm.map(psd).transpose()?);
        }
        let motors = if self.motors.is_empty() {
            None
        } else {
            let mut acc = vec![0.0; seg.bins()];
            for &m in &self.motors {
                for (a, d) in acc.iter_mut().zip(psd(m)?) {
                    *a += d / self.motors.len() as f64;
                }
            }
            Some(acc)
        };
        let throttle = self
            .throttle
            .map(|(c, lo, hi)| ((self.mean(c, k) - lo) / (hi - lo)).clamp(0.0, 1.0));
        let motor_hz = self
            .rotation
            .as_ref()
            .map(|(cs, f)| cs.iter().map(|&c| self.mean(c, k) * f).filter(|h| *h > 0.0).collect())
            .unwrap_or_default();
        let tracked = raw[0].as_ref().unwrap_or(&gyro[0]);
        let op = OperatingPoint {
            throttle,
            motor_hz,
            peaks_hz: strongest_peaks(tracked, self.rate_hz() / self.nfft as f64, 5),
        };
        Ok(Frame {
            t_s: self.t0_s + (k as f64 + self.nfft as f64 / 2.0) * self.dt_s,
            op,
            gyro,
            raw,
            dterm,
            motors,
        })
    }
}

/// The `n` largest local maxima of a density (above 0 Hz), as frequencies, strongest first.
pub(crate) fn strongest_peaks(d: &[f64], df_hz: f64, n: usize) -> Vec<f64> {
    let mut peaks: Vec<(usize, f64)> = (2..d.len().saturating_sub(1))
        .filter(|&k| d[k] > d[k - 1] && d[k] >= d[k + 1])
        .map(|k| (k, d[k]))
        .collect();
    peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
    peaks
        .iter()
        .take(n)
        .map(|&(k, _)| {
            // Parabolic interpolation of the peak on the dB scale (a Hann window's main lobe).
            let (a, b, c) = (
                d[k - 1].max(1e-300).ln(),
                d[k].max(1e-300).ln(),
                d[k + 1].max(1e-300).ln(),
            );
            let den = a - 2.0 * b + c;
            let off = if den.abs() > 1e-12 {
                (0.5 * (a - c) / den).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            (k as f64 + off) * df_hz
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn peaks_are_found_between_bins() {
        let dt = 1e-3;
        let nfft = 256;
        let seg = SegmentPsd::new(nfft, dt);
        let x: Vec<f64> = (0..nfft)
            .map(|k| {
                let t = k as f64 * dt;
                (2.0 * std::f64::consts::PI * 151.0 * t).sin() + 0.3 * (2.0 * std::f64::consts::PI * 302.0 * t).sin()
            })
            .collect();
        let d = seg.density(&x).unwrap();
        let p = strongest_peaks(&d, 1.0 / (nfft as f64 * dt), 2);
        assert!((p[0] - 151.0).abs() < 1.0 && (p[1] - 302.0).abs() < 1.0, "{p:?}");
    }
}
