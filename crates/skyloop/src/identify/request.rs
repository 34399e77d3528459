//! What to identify: [`IdentifyRequest`], field for field the flags of `skyloop identify`, and the
//! parsing of its model parameters, bounds and fit options.

use crate::error::{Error, Result};
use skyloop_sysid::fit::{FitOptions, ParamSpec};
use std::path::PathBuf;

/// What to identify: the log, its columns, the estimator and the optional parametric fits. Field
/// for field the flags of `skyloop identify`; [`Default`] holds their defaults.
#[derive(Debug, Clone)]
pub struct IdentifyRequest {
    /// Log file: CSV with a time_s column, PX4 ULog, or Betaflight blackbox.
    pub data: PathBuf,
    /// roll, pitch or yaw: the firmware's rate-loop channels, all airborne segments, the setpoint as
    /// instrument and the model [`RATE_LOOP_MODEL`](super::RATE_LOOP_MODEL) (see [`axis_preset`](super::axis_preset)); every other field given
    /// overrides its part of the preset.
    pub axis: Option<String>,
    /// Plant input column (e.g. `axisP[0]+axisI[0]+axisD[0]+axisF[0]`, `actuator_controls_0.control[0]`);
    /// required without `axis`.
    pub input: Option<String>,
    /// Plant output column (e.g. `gyroADC[0]`, `vehicle_angular_velocity.xyz[0]`); required without `axis`.
    pub output: Option<String>,
    /// Measured excitation (instrument) for a closed-loop estimate G = Φ_yr/Φ_ur; `"none"` forces an
    /// open-loop estimate when `axis` would choose the setpoint.
    pub excitation: Option<String>,
    /// Measured disturbance input whose linear effect on the output is removed from the spectra
    /// before the response is formed (conditioned spectra; welch and spafdr): the `axis` preset uses
    /// the collective throttle; `"none"` turns it off.
    pub disturbance: Option<String>,
    /// etfe, welch, spa or spafdr.
    pub method: String,
    /// Lowest frequency, Hz.
    pub fmin_hz: Option<f64>,
    /// Highest frequency, Hz (at most half the rate of the slowest channel used).
    pub fmax_hz: Option<f64>,
    /// Start of the span searched, s.
    pub from: Option<f64>,
    /// End of the span searched, s.
    pub to: Option<f64>,
    /// Use the longest stretch where this holds, e.g. `rcCommand[3]>1100` (throttle above idle),
    /// instead of the airborne segments.
    pub condition: Option<String>,
    /// Resampling rate, Hz (default: the fastest of the columns).
    pub rate: Option<f64>,
    /// Blackbox session (counted from 1); default: the longest.
    pub session: Option<usize>,
    /// Number of output frequencies (spa, spafdr).
    pub n_freq: usize,
    /// Welch segment length (samples).
    pub nfft: Option<usize>,
    /// Welch window: hann, hamming, blackman, rectangular.
    pub window: String,
    /// Welch overlap fraction.
    pub overlap: f64,
    /// SPA lag-window half width M (samples).
    pub lag_window: Option<usize>,
    /// SPAFDR relative resolution (smoothing width / frequency).
    pub resolution: f64,
    /// Model expression with named parameters, e.g. `K*exp(-Td*s)/(tau*s+1)`.
    pub model: Option<String>,
    /// Initial values NAME=V,.. of every model parameter (found automatically for the preset's model).
    pub init: Option<String>,
    /// Bounds NAME=LO:HI,.. (either side may be empty).
    pub bounds: Option<String>,
    /// Residual: log (default) or complex.
    pub error: String,
    /// Frequency weights: inverse-variance (default), coherence (CIFER) or none.
    pub weighting: String,
    /// Also fit a rational TF with NZ zeros and NP poles, given as NZ/NP (e.g. 2/4).
    pub tf: Option<String>,
    /// Delay of the rational fit, s; estimated within [0, --max-delay-s] when absent.
    pub delay_s: Option<f64>,
    /// Largest delay the rational fit considers, s.
    pub max_delay_s: f64,
    /// Blocks of the jackknife and the validation split (2..=64; 0 turns both off).
    pub blocks: usize,
    /// Accept a fit whose fit percentage is below 0 (worse than the FRF's mean) instead of failing.
    pub allow_poor_fit: bool,
}

impl Default for IdentifyRequest {
    fn default() -> Self {
        IdentifyRequest {
            data: Default::default(),
            axis: None,
            input: None,
            output: None,
            excitation: None,
            disturbance: None,
            method: "spafdr".into(),
            fmin_hz: Default::default(),
            fmax_hz: Default::default(),
            from: Default::default(),
            to: Default::default(),
            condition: Default::default(),
            rate: Default::default(),
            session: Default::default(),
            n_freq: 100,
            nfft: Default::default(),
            window: "hann".into(),
            overlap: 0.5,
            lag_window: Default::default(),
            resolution: 0.15,
            model: Default::default(),
            init: Default::default(),
            bounds: Default::default(),
            error: "log".into(),
            weighting: "inverse-variance".into(),
            tf: Default::default(),
            delay_s: Default::default(),
            max_delay_s: 0.1,
            blocks: 8,
            allow_poor_fit: false,
        }
    }
}

pub(crate) fn parse_pairs(text: &str, what: &str) -> Result<Vec<(String, String)>> {
    text.split(',')
        .filter(|t| !t.trim().is_empty())
        .map(|t| {
            let (k, v) = t
                .split_once('=')
                .ok_or_else(|| Error::Input(format!("{what}: '{t}' is not NAME=VALUE")))?;
            Ok((k.trim().to_string(), v.trim().to_string()))
        })
        .collect()
}

pub(crate) fn num(v: &str, what: &str) -> Result<f64> {
    let x: f64 = v
        .parse()
        .map_err(|_| Error::Input(format!("{what}: '{v}' is not a number")))?;
    if x.is_nan() {
        return Err(Error::Input(format!("{what}: NaN")));
    }
    Ok(x)
}

pub(crate) fn param_specs(a: &IdentifyRequest) -> Result<Vec<ParamSpec>> {
    let init = a
        .init
        .as_deref()
        .ok_or_else(|| Error::Input("--model needs --init NAME=V,.. for its parameters".into()))?;
    let mut specs = Vec::new();
    for (k, v) in parse_pairs(init, "--init")? {
        specs.push(ParamSpec::new(&k, num(&v, &format!("--init {k}"))?));
    }
    if let Some(b) = &a.bounds {
        apply_bounds(&mut specs, b)?;
    }
    Ok(specs)
}

/// Sets the bounds `NAME=LO:HI,..` of `--bounds` on `specs`.
pub(crate) fn apply_bounds(specs: &mut [ParamSpec], b: &str) -> Result<()> {
    for (k, v) in parse_pairs(b, "--bounds")? {
        let (lo, hi) = v
            .split_once(':')
            .ok_or_else(|| Error::Input(format!("--bounds {k}: '{v}' is not LO:HI")))?;
        let p = specs
            .iter_mut()
            .find(|p| p.name == k)
            .ok_or_else(|| Error::Input(format!("--bounds names '{k}', which is not a model parameter")))?;
        if !lo.trim().is_empty() {
            p.lower = num(lo.trim(), &format!("--bounds {k}"))?;
        }
        if !hi.trim().is_empty() {
            p.upper = num(hi.trim(), &format!("--bounds {k}"))?;
        }
    }
    Ok(())
}

/// Options of the fits from the request's `--error` and `--weighting`.
pub(crate) fn fit_options(a: &IdentifyRequest) -> Result<FitOptions> {
    Ok(FitOptions {
        error: match a.error.as_str() {
            "log" => skyloop_sysid::fit::ErrorKind::Log,
            "complex" => skyloop_sysid::fit::ErrorKind::Complex,
            o => return Err(Error::Input(format!("unknown --error '{o}' (log or complex)"))),
        },
        weighting: match a.weighting.as_str() {
            "inverse-variance" => skyloop_sysid::fit::Weighting::InverseVariance,
            "coherence" => skyloop_sysid::fit::Weighting::Coherence,
            "none" => skyloop_sysid::fit::Weighting::None,
            o => {
                return Err(Error::Input(format!(
                    "unknown --weighting '{o}' (inverse-variance, coherence, none)"
                )))
            }
        },
        ..FitOptions::default()
    })
}
