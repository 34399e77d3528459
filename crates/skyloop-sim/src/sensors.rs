//! Gyro model: bias, white noise, a 2nd-order Butterworth pre-filter (as the bicopter's 75 Hz IMU
//! filter of eq. (7)) and a pure delay, sampled at the rate-loop frequency.

use crate::error::{check_min, Result, SimError};
use crate::geometry::V3;
use rand::rngs::SmallRng;
use rand_distr::{Distribution, Normal};
use skyloop_control::{Biquad, SosController};

/// Gyro settings as written in a scenario.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GyroSpec {
    /// White-noise standard deviation per sample (rad/s).
    pub noise_rad_s: f64,
    /// Constant bias per axis (rad/s).
    pub bias_rad_s: V3,
    /// Butterworth cutoff (Hz); 0 = no filter.
    pub lpf_hz: f64,
    /// Pure delay (s), rounded to whole samples.
    pub delay_s: f64,
}

impl Default for GyroSpec {
    fn default() -> Self {
        GyroSpec {
            noise_rad_s: 0.0,
            bias_rad_s: [0.0; 3],
            lpf_hz: 0.0,
            delay_s: 0.0,
        }
    }
}

/// Discrete 2nd-order Butterworth low-pass (bilinear transform with pre-warping) at `fc_hz`, `fs_hz`.
pub fn butterworth2(fc_hz: f64, fs_hz: f64) -> Result<Biquad<f64>> {
    if !(fc_hz > 0.0 && fc_hz < 0.5 * fs_hz) {
        return Err(SimError::Param(format!(
            "lpf_hz = {fc_hz} must be in (0, {} Hz) (Nyquist)",
            0.5 * fs_hz
        )));
    }
    let k = (std::f64::consts::PI * fc_hz / fs_hz).tan();
    let s2 = std::f64::consts::SQRT_2;
    let norm = 1.0 / (1.0 + s2 * k + k * k);
    let b0 = k * k * norm;
    Ok(Biquad {
        b0,
        b1: 2.0 * b0,
        b2: b0,
        a1: 2.0 * (k * k - 1.0) * norm,
        a2: (1.0 - s2 * k + k * k) * norm,
    })
}

/// A running gyro.
#[derive(Debug, Clone)]
pub struct Gyro {
    spec: GyroSpec,
    noise: Option<Normal<f64>>,
    filters: Option<[SosController<f64, 1>; 3]>,
    ring: Vec<V3>,
    head: usize,
}

impl Gyro {
    /// Builds a gyro sampled at `fs_hz`.
    pub fn new(spec: GyroSpec, fs_hz: f64) -> Result<Self> {
        check_min(spec.noise_rad_s, 0.0, "gyro noise_rad_s")?;
        check_min(spec.delay_s, 0.0, "gyro delay_s")?;
        check_min(spec.lpf_hz, 0.0, "gyro lpf_hz")?;
        for b in spec.bias_rad_s {
            check_min(b.abs(), 0.0, "gyro bias_rad_s")?;
        }
        let noise = if spec.noise_rad_s > 0.0 {
            Some(Normal::new(0.0, spec.noise_rad_s).map_err(|e| SimError::Param(e.to_string()))?)
        } else {
            None
        };
        let filters = if spec.lpf_hz > 0.0 {
            let q = butterworth2(spec.lpf_hz, fs_hz)?;
            let f = SosController::new(&[q], 1.0, -1e30, 1e30)?;
            Some([f, f, f])
        } else {
            None
        };
        let n = (spec.delay_s * fs_hz).round() as usize + 1;
        Ok(Gyro {
            spec,
            noise,
            filters,
            ring: vec![[0.0; 3]; n],
            head: 0,
        })
    }

    /// Primes filter and delay line with a constant reading (no start-up transient).
    pub fn prime(&mut self, w: V3) {
        for s in self.ring.iter_mut() {
            *s = w;
        }
        if let Some(f) = self.filters.as_mut() {
            for _ in 0..2000 {
                for i in 0..3 {
                    f[i].step(w[i]);
                }
            }
        }
    }

    /// One sample of true rates → measured rates.
    #[inline]
    pub fn sample(&mut self, w: V3, rng: &mut SmallRng) -> V3 {
        let mut m = [0.0; 3];
        for i in 0..3 {
            let n = self.noise.map_or(0.0, |d| d.sample(rng));
            m[i] = w[i] + self.spec.bias_rad_s[i] + n;
        }
        if let Some(f) = self.filters.as_mut() {
            for i in 0..3 {
                m[i] = f[i].step(m[i]);
            }
        }
        let len = self.ring.len();
        self.ring[self.head] = m;
        self.head = (self.head + 1) % len;
        self.ring[self.head]
    }
}
