//! Non-parametric frequency-response estimates from input/output records: ETFE, Welch (H1),
//! Blackman–Tukey SPA and SPAFDR (frequency-dependent resolution), each with squared coherence and an
//! equivalent number of averages from which confidence bands follow.
//!
//! Open loop: G = Φ_yu/Φ_uu and γ² = |Φ_yu|²/(Φ_uu·Φ_yy). Closed loop with a measured excitation r
//! (injected anywhere in the loop, uncorrelated with the noise): G = Φ_yr/Φ_ur, which stays unbiased
//! under feedback; its coherence is the signal-to-noise one (see [`Frf::coherence`]).

mod cross;
pub mod etfe;
pub mod psd;
mod segments;
pub mod spa;
pub mod spafdr;
pub mod welch;
pub mod window;

pub use segments::{default_nfft_records, estimate_records};
pub use window::Window;

use num_complex::Complex64 as C64;

use crate::error::{invalid, Result, SysidError};
use crate::logs::{detrend, Detrend};
pub(crate) use cross::Cross;

/// Input/output records sampled every `dt_s` seconds; `r` is a measured excitation for closed loop.
#[derive(Debug, Clone, Copy)]
pub struct IoData<'a> {
    /// Plant input.
    pub u: &'a [f64],
    /// Plant output.
    pub y: &'a [f64],
    /// External excitation (closed-loop experiments), or `None` for open loop.
    pub r: Option<&'a [f64]>,
    /// A measured disturbance input that also drives the output (a multirotor's throttle), or
    /// `None`: its linear effect is removed from the spectra before the response is formed
    /// (conditioned spectra; Welch and SPAFDR only), as the two-input estimate y = G·u + H·d + v
    /// would, with d its own instrument. It must not be driven by the output's noise.
    pub dist: Option<&'a [f64]>,
    /// Sample interval, s.
    pub dt_s: f64,
}

/// Which estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Empirical transfer-function estimate: ratio of full-record DFTs.
    Etfe,
    /// Welch's averaged modified periodograms (H1 estimator).
    Welch,
    /// Blackman–Tukey: Hann lag window on the correlation functions.
    Spa,
    /// Frequency-dependent resolution: Hann smoothing of the periodograms whose width grows with frequency.
    Spafdr,
}

impl std::str::FromStr for Method {
    type Err = SysidError;
    fn from_str(s: &str) -> Result<Method> {
        match s.to_ascii_lowercase().as_str() {
            "etfe" => Ok(Method::Etfe),
            "welch" | "h1" | "tfestimate" => Ok(Method::Welch),
            "spa" | "bt" => Ok(Method::Spa),
            "spafdr" => Ok(Method::Spafdr),
            _ => Err(invalid(format!("unknown method '{s}' (etfe, welch, spa, spafdr)"))),
        }
    }
}

impl Method {
    /// Whether the estimator can remove a measured disturbance ([`IoData::dist`]) from its spectra:
    /// Welch and SPAFDR average neighbouring periodograms, so a conditioned cross-spectral matrix
    /// exists; a raw ETFE has one bin per point and SPA works on correlations.
    pub fn conditions_on_disturbance(self) -> bool {
        matches!(self, Method::Welch | Method::Spafdr)
    }
}

/// Options of every estimator; fields an estimator does not use are ignored.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Estimator.
    pub method: Method,
    /// Lowest frequency reported, Hz (`None`: the lowest the record resolves).
    pub fmin_hz: Option<f64>,
    /// Highest frequency reported, Hz (`None`: Nyquist).
    pub fmax_hz: Option<f64>,
    /// Trend removed from the whole record first.
    pub detrend: Detrend,
    /// Welch: segment length (`None`: the power of two giving about 8 segments at 50 % overlap).
    pub nfft: Option<usize>,
    /// Welch: data window.
    pub window: Window,
    /// Welch: overlap fraction of consecutive segments, in [0, 1).
    pub overlap: f64,
    /// SPA: lag-window half width M in samples (`None`: min(N/10, 30) as MATLAB's spa).
    pub lag_window: Option<usize>,
    /// SPA and SPAFDR: number of output frequencies (SPA: linear spacing; SPAFDR: logarithmic).
    pub n_freq: usize,
    /// SPAFDR: relative resolution (full width of the Hann smoothing window / frequency); ETFE: unused.
    pub resolution: f64,
    /// ETFE: Hann smoothing width in bins (1 = the raw ratio Y/U).
    pub smoothing_bins: usize,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            method: Method::Spafdr,
            fmin_hz: None,
            fmax_hz: None,
            detrend: Detrend::Mean,
            nfft: None,
            window: Window::Hann,
            overlap: 0.5,
            lag_window: None,
            n_freq: 100,
            resolution: 0.15,
            smoothing_bins: 1,
        }
    }
}

/// A frequency-response estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct Frf {
    /// Frequencies, Hz (increasing).
    pub freq_hz: Vec<f64>,
    /// Complex response G(j2πf).
    pub response: Vec<C64>,
    /// Squared coherence in [0, 1]. Closed loop: γ² = |G|²Φ_u⁽ʳ⁾/(|G|²Φ_u⁽ʳ⁾ + Φ_vv), with Φ_u⁽ʳ⁾ = |Φ_ur|²/Φ_rr
    /// the part of u driven by r and Φ_vv the spectrum of the residual y − Ĝu; it reduces to the
    /// ordinary coherence in open loop and makes the variance formula of the estimator
    /// (Var Ĝ = Φ_vv·Φ_rr/(ν·|Φ_ur|²)) take the same form as for H1.
    pub coherence: Vec<f64>,
    /// Equivalent number of independent averages ν behind each estimate.
    pub dof: Vec<f64>,
    /// Full width, Hz, of the Hann-shaped frequency kernel each estimate averages the raw spectra over;
    /// 0 where estimates at different frequencies share no raw DFT bin (raw ETFE, Welch). Estimates
    /// closer than their kernels' half widths are correlated; [`kernel_correlation`] gives by how much.
    pub bandwidth_hz: Vec<f64>,
}

impl Frf {
    /// |G|.
    pub fn mag(&self) -> Vec<f64> {
        self.response.iter().map(|g| g.norm()).collect()
    }

    /// 20·log10|G|, dB.
    pub fn mag_db(&self) -> Vec<f64> {
        self.response.iter().map(|g| 20.0 * g.norm().log10()).collect()
    }

    /// Phase, degrees, unwrapped along frequency.
    pub fn phase_deg(&self) -> Vec<f64> {
        unwrap_deg(self.response.iter().map(|g| g.arg().to_degrees()))
    }

    /// Normalized random error of |G| (and standard deviation of the phase in rad):
    /// ε = √((1 − γ²)/(2 ν γ²)) (Bendat & Piersol, Random Data, eq. 9.90).
    pub fn rel_std(&self) -> Vec<f64> {
        self.coherence
            .iter()
            .zip(&self.dof)
            .map(|(&c, &n)| {
                let c = c.clamp(1e-12, 1.0);
                ((1.0 - c) / (2.0 * n.max(1.0) * c)).sqrt()
            })
            .collect()
    }

    /// Magnitude band (lower, upper), dB, at ±z standard errors (z = 1.96 for ≈ 95 %).
    pub fn mag_band_db(&self, z: f64) -> (Vec<f64>, Vec<f64>) {
        let m = self.mag_db();
        let e = self.rel_std();
        let lo = m
            .iter()
            .zip(&e)
            .map(|(m, e)| m + 20.0 * (1.0 - (z * e).min(0.999)).log10())
            .collect();
        let hi = m
            .iter()
            .zip(&e)
            .map(|(m, e)| m + 20.0 * (1.0 + z * e).log10())
            .collect();
        (lo, hi)
    }

    /// Phase band (lower, upper), degrees, at ±z standard errors.
    pub fn phase_band_deg(&self, z: f64) -> (Vec<f64>, Vec<f64>) {
        let p = self.phase_deg();
        let e = self.rel_std();
        let d: Vec<f64> = e
            .iter()
            .map(|e| (z * e).min(std::f64::consts::PI).to_degrees())
            .collect();
        (
            p.iter().zip(&d).map(|(p, d)| p - d).collect(),
            p.iter().zip(&d).map(|(p, d)| p + d).collect(),
        )
    }

    /// The points with fmin_hz ≤ f ≤ fmax_hz.
    pub fn restrict(&self, fmin_hz: f64, fmax_hz: f64) -> Frf {
        let keep: Vec<usize> = (0..self.freq_hz.len())
            .filter(|&i| self.freq_hz[i] >= fmin_hz && self.freq_hz[i] <= fmax_hz)
            .collect();
        Frf {
            freq_hz: keep.iter().map(|&i| self.freq_hz[i]).collect(),
            response: keep.iter().map(|&i| self.response[i]).collect(),
            coherence: keep.iter().map(|&i| self.coherence[i]).collect(),
            dof: keep.iter().map(|&i| self.dof[i]).collect(),
            bandwidth_hz: keep.iter().map(|&i| self.bandwidth_hz[i]).collect(),
        }
    }

    pub(crate) fn from_cross(points: Vec<(f64, Cross, f64)>, closed: bool) -> Result<Frf> {
        let mut f = Frf {
            freq_hz: vec![],
            response: vec![],
            coherence: vec![],
            dof: vec![],
            bandwidth_hz: vec![],
        };
        for (hz, c, nu) in points {
            let (g, coh) = c.response(closed);
            // Conditioning on a disturbance spends one average of each estimate (Bendat & Piersol:
            // ν − q for q conditioning inputs).
            let nu = if c.dd > 0.0 { (nu - 1.0).max(1.0) } else { nu };
            if g.re.is_finite() && g.im.is_finite() && coh.is_finite() {
                f.freq_hz.push(hz);
                f.response.push(g);
                f.coherence.push(coh.clamp(0.0, 1.0));
                f.dof.push(nu);
                f.bandwidth_hz.push(0.0);
            }
        }
        if f.freq_hz.is_empty() {
            return Err(SysidError::NotEnoughData(
                "no frequency in range where the input has power (is the input constant?)".into(),
            ));
        }
        Ok(f)
    }
}

/// Correlation between the errors of two estimates whose frequencies differ by `df_hz` and that
/// average a smooth (white-noise-like) raw spectrum with Hann kernels of full widths `b1_hz`, `b2_hz`:
/// ∫h₁(x)h₂(x − Δ)dx / √(∫h₁²·∫h₂²). 1 for the same kernel, 0 once the kernels no longer overlap
/// or when either width is 0 (independent bins).
pub fn kernel_correlation(df_hz: f64, b1_hz: f64, b2_hz: f64) -> f64 {
    let d = df_hz.abs();
    if !(b1_hz > 0.0 && b2_hz > 0.0) || d >= 0.5 * (b1_hz + b2_hz) {
        return 0.0;
    }
    let hann = |x: f64, b: f64| {
        if x.abs() >= 0.5 * b {
            0.0
        } else {
            0.5 * (1.0 + (2.0 * std::f64::consts::PI * x / b).cos())
        }
    };
    let (a, z) = ((-0.5 * b1_hz).max(d - 0.5 * b2_hz), (0.5 * b1_hz).min(d + 0.5 * b2_hz));
    // Simpson's rule: the integrand is smooth (both kernels end with zero slope) on [a, z].
    const N: usize = 64;
    let h = (z - a) / N as f64;
    let mut sum = 0.0;
    for i in 0..=N {
        let x = a + i as f64 * h;
        let c = if i == 0 || i == N {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        sum += c * hann(x, b1_hz) * hann(x - d, b2_hz);
    }
    // ∫ of a squared Hann kernel of full width b is 3b/8.
    (sum * h / 3.0 / (0.375 * (b1_hz * b2_hz).sqrt())).clamp(0.0, 1.0)
}

/// Unwraps a phase sequence in degrees (jumps over 180° are removed).
pub fn unwrap_deg(p: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::new();
    let mut offset = 0.0;
    let mut prev: Option<f64> = None;
    for x in p {
        if let Some(q) = prev {
            let d = x + offset - q;
            offset -= 360.0 * (d / 360.0).round();
        }
        let v = x + offset;
        out.push(v);
        prev = Some(v);
    }
    out
}

/// Checked, detrended copies of the records.
pub(crate) struct Prepared {
    pub u: Vec<f64>,
    pub y: Vec<f64>,
    pub r: Option<Vec<f64>>,
    pub dist: Option<Vec<f64>>,
    pub dt: f64,
}

pub(crate) fn prepare(d: &IoData, how: Detrend, min_len: usize) -> Result<Prepared> {
    if !(d.dt_s.is_finite() && d.dt_s > 0.0) {
        return Err(invalid(format!("sample interval must be positive, got {} s", d.dt_s)));
    }
    let n = d.u.len();
    if d.y.len() != n || d.r.is_some_and(|r| r.len() != n) || d.dist.is_some_and(|x| x.len() != n) {
        return Err(invalid(format!(
            "input, output (and excitation, disturbance) differ in length: {}, {}{}{}",
            n,
            d.y.len(),
            d.r.map(|r| format!(", {}", r.len())).unwrap_or_default(),
            d.dist.map(|x| format!(", {}", x.len())).unwrap_or_default()
        )));
    }
    if n < min_len {
        return Err(SysidError::NotEnoughData(format!(
            "{n} samples; this estimate needs at least {min_len}"
        )));
    }
    let check = |x: &[f64], what: &str| -> Result<Vec<f64>> {
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!("{what} sample {i} is not finite")));
        }
        let mut v = x.to_vec();
        detrend(&mut v, how);
        Ok(v)
    };
    Ok(Prepared {
        u: check(d.u, "input")?,
        y: check(d.y, "output")?,
        r: d.r.map(|r| check(r, "excitation")).transpose()?,
        dist: d.dist.map(|x| check(x, "disturbance")).transpose()?,
        dt: d.dt_s,
    })
}

/// Frequency limits (Hz) after defaults: [fmin or `lowest`, fmax or Nyquist].
pub(crate) fn limits(o: &Options, lowest: f64, dt: f64) -> Result<(f64, f64)> {
    let nyq = 0.5 / dt;
    let lo = o.fmin_hz.unwrap_or(lowest);
    let hi = o.fmax_hz.unwrap_or(nyq).min(nyq);
    if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo) {
        return Err(invalid(format!(
            "frequency range [{lo}, {hi}] Hz is empty or outside [0, Nyquist {nyq} Hz]"
        )));
    }
    Ok((lo, hi))
}

/// Estimates the frequency response with the chosen method (frequencies in Hz, complex response
/// with coherence and confidence per point).
///
/// # Errors
/// Signals of different lengths or too short for the method, a non-positive sample interval, or a
/// frequency range outside [0, Nyquist].
///
/// # Examples
/// A first-order lag y\[k\] = 0.9·y[k−1] + 0.1·u[k−1] (unit DC gain) driven by white noise:
/// ```
/// use skyloop_sysid::spectral::{estimate, IoData, Method, Options};
///
/// let mut seed = 12345u64;
/// let u: Vec<f64> = (0..20_000)
///     .map(|_| {
///         seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
///         (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
///     })
///     .collect();
/// let mut y = vec![0.0; u.len()];
/// for k in 1..u.len() {
///     y[k] = 0.9 * y[k - 1] + 0.1 * u[k - 1];
/// }
/// let io = IoData { u: &u, y: &y, r: None, dist: None, dt_s: 0.001 };
/// let opts = Options { method: Method::Welch, fmax_hz: Some(5.0), ..Options::default() };
/// let frf = estimate(&io, &opts)?;
/// // Near DC the lag passes the input unchanged.
/// let i = frf.freq_hz.iter().position(|&f| f > 0.0).expect("a positive frequency");
/// assert!(frf.freq_hz[i] < 1.0);
/// assert!((frf.mag()[i] - 1.0).abs() < 0.05, "{}", frf.mag()[i]);
/// assert!(frf.coherence[i] > 0.99);
/// # Ok::<(), skyloop_sysid::SysidError>(())
/// ```
pub fn estimate(d: &IoData, o: &Options) -> Result<Frf> {
    if d.dist.is_some() && !o.method.conditions_on_disturbance() {
        return Err(no_conditioning(o.method));
    }
    match o.method {
        Method::Etfe => etfe::etfe(d, o),
        Method::Welch => welch::welch(d, o),
        Method::Spa => spa::spa(d, o),
        Method::Spafdr => spafdr::spafdr(d, o),
    }
}

/// The error for a measured disturbance given to an estimator that cannot condition on it.
pub(crate) fn no_conditioning(m: Method) -> SysidError {
    invalid(format!(
        "{m:?} cannot remove a measured disturbance (a raw ETFE has one bin per point, SPA works on correlations): use welch or spafdr"
    ))
}

/// A planned real-input FFT of one length.
pub(crate) struct Rfft {
    plan: std::sync::Arc<dyn realfft::RealToComplex<f64>>,
    n: usize,
}

impl Rfft {
    pub fn new(n: usize) -> Rfft {
        // One planner for the process: it caches plans by length, and computing the twiddles of a
        // long mixed-radix FFT costs as much as running it. Estimates of several axes of one log all
        // share the record length.
        static PLANNER: std::sync::OnceLock<std::sync::Mutex<realfft::RealFftPlanner<f64>>> =
            std::sync::OnceLock::new();
        let planner = PLANNER.get_or_init(|| std::sync::Mutex::new(realfft::RealFftPlanner::new()));
        let plan = match planner.lock() {
            Ok(mut p) => p.plan_fft_forward(n),
            // A panic elsewhere while planning poisons the lock; a fresh planner is always correct.
            Err(_) => realfft::RealFftPlanner::<f64>::new().plan_fft_forward(n),
        };
        Rfft { plan, n }
    }

    /// X_k, k = 0..=n/2, of `x` (zero-padded or cut to n) multiplied by `window` when given.
    pub fn run(&self, x: &[f64], window: Option<&[f64]>) -> Result<Vec<C64>> {
        let mut buf = vec![0.0; self.n];
        let m = x.len().min(self.n);
        match window {
            Some(w) => buf[..m].iter_mut().zip(x).zip(w).for_each(|((b, x), w)| *b = x * w),
            None => buf[..m].copy_from_slice(&x[..m]),
        }
        let mut out = self.plan.make_output_vec();
        self.plan
            .process(&mut buf, &mut out)
            .map_err(|e| SysidError::Numerical(format!("FFT failed: {e}")))?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::kernel_correlation;

    /// Against a fine midpoint sum of the same overlap integral (a different quadrature), and the
    /// limits: identical kernels correlate fully, disjoint or zero-width ones not at all.
    #[test]
    fn kernel_correlation_matches_direct_sum() {
        let hann = |x: f64, b: f64| {
            if x.abs() >= 0.5 * b {
                0.0
            } else {
                0.5 * (1.0 + (2.0 * std::f64::consts::PI * x / b).cos())
            }
        };
        for (d, b1, b2) in [
            (0.0, 1.0, 1.0),
            (0.3, 1.0, 1.0),
            (0.2, 0.8, 1.3),
            (0.9, 1.0, 1.2),
            (1.05, 1.0, 1.2),
        ] {
            let n = 200_000;
            let (a, z) = (-2.0, 3.0);
            let h = (z - a) / n as f64;
            let (mut s12, mut s11, mut s22) = (0.0, 0.0, 0.0);
            for i in 0..n {
                let x = a + (i as f64 + 0.5) * h;
                let (p, q) = (hann(x, b1), hann(x - d, b2));
                s12 += p * q * h;
                s11 += p * p * h;
                s22 += q * q * h;
            }
            let want = s12 / (s11 * s22).sqrt();
            let got = kernel_correlation(d, b1, b2);
            assert!((got - want).abs() < 1e-6, "({d}, {b1}, {b2}): {got} vs {want}");
            assert!((kernel_correlation(-d, b2, b1) - got).abs() < 1e-12);
        }
        assert!((kernel_correlation(0.0, 2.0, 2.0) - 1.0).abs() < 1e-9);
        assert_eq!(kernel_correlation(1.5, 1.0, 2.0), 0.0);
        assert_eq!(kernel_correlation(0.0, 0.0, 2.0), 0.0);
    }
}
