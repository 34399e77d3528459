//! Identification from a flight log: read the log (CSV, PX4 ULog, Betaflight blackbox), pick the
//! span, estimate the frequency response (ETFE, Welch, SPA, SPAFDR; closed loop with a measured
//! excitation), and fit a parametric model with delay and standard errors, or a rational transfer
//! function.

use std::collections::HashMap;
use std::path::PathBuf;

use crate::error::{Error, Result};
use num_complex::Complex64 as C64;
use skyloop_plot::bode::BodeData;
use skyloop_plot::frf::{plot_frf, FrfEstimate};
use skyloop_sysid::fit::{fit_expr, fit_tf, DelaySpec, FitOptions, FitResult, ParamSpec, TfFit};
use skyloop_sysid::logs::{segments_where, Condition, Log, OpenOptions};
use skyloop_sysid::spectral::{estimate, Frf, IoData, Method, Options, Window};

/// What to identify: the log, its columns, the estimator and the optional parametric fits. Field
/// for field the flags of `skyloop identify`; [`Default`] holds their defaults.
#[derive(Debug, Clone)]
pub struct IdentifyRequest {
    /// Log file: CSV with a time_s column, PX4 ULog, or Betaflight blackbox.
    pub data: PathBuf,
    /// Plant input column (e.g. `axisP[0]+axisI[0]+axisD[0]+axisF[0]`, `actuator_controls_0.control[0]`).
    pub input: String,
    /// Plant output column (e.g. `gyroADC[0]`, `vehicle_angular_velocity.xyz[0]`).
    pub output: String,
    /// Measured excitation for a closed-loop estimate G = Φ_yr/Φ_ur.
    pub excitation: Option<String>,
    /// etfe, welch, spa or spafdr.
    pub method: String,
    /// Lowest frequency, Hz.
    pub fmin_hz: Option<f64>,
    /// Highest frequency, Hz.
    pub fmax_hz: Option<f64>,
    /// Start of the segment used, s.
    pub from: Option<f64>,
    /// End of the segment used, s.
    pub to: Option<f64>,
    /// Use the longest stretch where this holds, e.g. `rcCommand[3]>1100` (throttle above idle).
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
    /// Initial values NAME=V,.. of every model parameter.
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
}

impl Default for IdentifyRequest {
    fn default() -> Self {
        IdentifyRequest {
            data: Default::default(),
            input: Default::default(),
            output: Default::default(),
            excitation: Default::default(),
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
        }
    }
}

/// What [`identify`] found.
#[derive(Debug, Clone)]
pub struct Identification {
    /// "input → output", the plot's title.
    pub title: String,
    /// The frequency-response estimate with coherence and confidence.
    pub frf: Frf,
    /// The parametric fit of `--model` with its parsed expression.
    pub fit: Option<(skyloop_lti::expr::Expr, FitResult)>,
    /// The rational fit of `--tf`.
    pub tf: Option<TfFit>,
    /// What the workflow chose on the user's behalf (the span a `--where` condition selected).
    pub notes: Vec<String>,
}

fn parse_pairs(text: &str, what: &str) -> Result<Vec<(String, String)>> {
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

fn num(v: &str, what: &str) -> Result<f64> {
    let x: f64 = v
        .parse()
        .map_err(|_| Error::Input(format!("{what}: '{v}' is not a number")))?;
    if x.is_nan() {
        return Err(Error::Input(format!("{what}: NaN")));
    }
    Ok(x)
}

fn param_specs(a: &IdentifyRequest) -> Result<Vec<ParamSpec>> {
    let init = a
        .init
        .as_deref()
        .ok_or_else(|| Error::Input("--model needs --init NAME=V,.. for its parameters".into()))?;
    let mut specs = Vec::new();
    for (k, v) in parse_pairs(init, "--init")? {
        specs.push(ParamSpec::new(&k, num(&v, &format!("--init {k}"))?));
    }
    if let Some(b) = &a.bounds {
        for (k, v) in parse_pairs(b, "--bounds")? {
            let (lo, hi) = v
                .split_once(':')
                .ok_or_else(|| Error::Input(format!("--bounds {k}: '{v}' is not LO:HI")))?;
            let p = specs
                .iter_mut()
                .find(|p| p.name == k)
                .ok_or_else(|| Error::Input(format!("--bounds names '{k}', which has no --init value")))?;
            if !lo.trim().is_empty() {
                p.lower = num(lo.trim(), &format!("--bounds {k}"))?;
            }
            if !hi.trim().is_empty() {
                p.upper = num(hi.trim(), &format!("--bounds {k}"))?;
            }
        }
    }
    Ok(specs)
}

/// Reads the log, selects the span, estimates the FRF and runs the requested fits.
///
/// # Errors
/// An unreadable log, a column it does not hold, a condition that never holds for 2 s, options out
/// of range ([`Error::Input`] names the flag), or a fit that fails.
pub fn identify(a: &IdentifyRequest) -> Result<Identification> {
    let mut notes = Vec::new();
    let method: Method = a.method.parse()?;
    let window: Window = a.window.parse()?;
    let log = Log::open(
        &a.data,
        &OpenOptions {
            session: a.session,
            ..Default::default()
        },
    )?;
    let mut cols: Vec<&str> = vec![a.input.as_str(), a.output.as_str()];
    if let Some(r) = &a.excitation {
        cols.push(r);
    }
    let cond = a.condition.as_deref().map(Condition::parse).transpose()?;
    if let Some(c) = &cond {
        cols.push(&c.column);
    }
    let mut data = log.uniform(&cols, a.rate, a.from, a.to)?;
    if let Some(c) = &cond {
        let mask: Vec<bool> = data.columns[cols.len() - 1].iter().map(|&x| c.holds(x)).collect();
        let min_len = (2.0 / data.dt_s).ceil() as usize;
        let seg = segments_where(&mask, min_len)
            .into_iter()
            .max_by_key(|r| r.len())
            .ok_or_else(|| {
                Error::Input(format!(
                    "'{}' never holds for 2 s or more in the selected span",
                    a.condition.as_deref().unwrap_or("")
                ))
            })?;
        notes.push(format!(
            "using {:.2} s .. {:.2} s where {}",
            data.t0_s + seg.start as f64 * data.dt_s,
            data.t0_s + seg.end as f64 * data.dt_s,
            a.condition.as_deref().unwrap_or("")
        ));
        data = data.slice(seg)?;
    }
    let io = IoData {
        u: &data.columns[0],
        y: &data.columns[1],
        r: a.excitation.as_ref().map(|_| data.columns[2].as_slice()),
        dt_s: data.dt_s,
    };
    let opts = Options {
        method,
        fmin_hz: a.fmin_hz,
        fmax_hz: a.fmax_hz,
        nfft: a.nfft,
        window,
        overlap: a.overlap,
        lag_window: a.lag_window,
        n_freq: a.n_freq,
        resolution: a.resolution,
        ..Options::default()
    };
    let frf = estimate(&io, &opts)?;
    let fit_opts = FitOptions {
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
    };
    let fit = match &a.model {
        Some(text) => {
            let expr = skyloop_lti::expr::parse(text).map_err(|e| Error::Input(format!("--model: {e}")))?;
            let specs = param_specs(a)?;
            let r = fit_expr(&frf, &expr, &specs, &fit_opts)?;
            Some((expr, r))
        }
        None => {
            if a.init.is_some() || a.bounds.is_some() {
                return Err(Error::Input("--init and --bounds need --model".into()));
            }
            None
        }
    };
    let tf = match &a.tf {
        Some(orders) => {
            let (nz, np) = orders
                .split_once('/')
                .ok_or_else(|| Error::Input(format!("--tf '{orders}' is not NZ/NP")))?;
            let nz: usize = nz
                .trim()
                .parse()
                .map_err(|_| Error::Input(format!("--tf: '{nz}' is not a count")))?;
            let np: usize = np
                .trim()
                .parse()
                .map_err(|_| Error::Input(format!("--tf: '{np}' is not a count")))?;
            let delay = match a.delay_s {
                Some(d) => DelaySpec::Fixed(d),
                None => DelaySpec::Estimate { max_s: a.max_delay_s },
            };
            Some(fit_tf(&frf, nz, np, delay, &fit_opts)?)
        }
        None => None,
    };
    Ok(Identification {
        title: format!("{} → {}", a.input, a.output),
        frf,
        fit,
        tf,
        notes,
    })
}

impl Identification {
    /// `{"frf": {freq_hz, mag, phase_deg, coherence}, "fit": {params, stderr, fit_percent}, "tf":
    /// {num, den, delay_s, fit_percent}}`, as `skyloop identify --json` prints it (a non-finite
    /// standard error is null).
    pub fn to_json(&self) -> serde_json::Value {
        let frf = &self.frf;
        let mut v = serde_json::json!({
            "frf": {
                "freq_hz": frf.freq_hz,
                "mag": frf.mag(),
                "phase_deg": frf.phase_deg(),
                "coherence": frf.coherence,
            }
        });
        if let Some((_, r)) = &self.fit {
            v["fit"] = serde_json::json!({
                "params": r.params,
                "stderr": r.stderr.iter().map(|(k, s)| (k.clone(), if s.is_finite() { serde_json::json!(s) } else { serde_json::Value::Null })).collect::<serde_json::Map<_, _>>(),
                "fit_percent": r.fit_percent,
            });
        }
        if let Some(t) = &self.tf {
            v["tf"] =
                serde_json::json!({"num": t.num, "den": t.den, "delay_s": t.delay_s, "fit_percent": t.fit_percent});
        }
        v
    }
}

/// Plots the measured FRF with its 95 % band and the fitted models (SVG or PNG by extension).
///
/// # Errors
/// A model that cannot be evaluated on the grid, or a file that cannot be written.
pub fn plot_identification(path: &std::path::Path, id: &Identification) -> Result<()> {
    let (frf, fit, tf) = (&id.frf, id.fit.as_ref(), id.tf.as_ref());
    let est = FrfEstimate {
        freq_hz: frf.freq_hz.clone(),
        mag_db: frf.mag_db(),
        phase_deg: frf.phase_deg(),
        mag_band_db: frf.mag_band_db(1.96),
        phase_band_deg: frf.phase_band_deg(1.96),
        coherence: frf.coherence.clone(),
    };
    let mut fits = Vec::new();
    let s_of = |f: f64| C64::new(0.0, 2.0 * std::f64::consts::PI * f);
    let bode = |label: String, g: Vec<C64>| BodeData {
        label,
        freq_hz: frf.freq_hz.clone(),
        mag_db: g.iter().map(|g| 20.0 * g.norm().log10()).collect(),
        phase_deg: skyloop_sysid::spectral::unwrap_deg(g.iter().map(|g| g.arg().to_degrees())),
    };
    if let Some((expr, r)) = fit {
        let params: HashMap<String, f64> = r.params.iter().map(|(k, v)| (k.clone(), *v)).collect();
        let g = frf
            .freq_hz
            .iter()
            .map(|f| expr.eval(s_of(*f), &params))
            .collect::<std::result::Result<Vec<_>, _>>()?;
        fits.push(bode(format!("fit ({:.1} %)", r.fit_percent), g));
    }
    if let Some(t) = tf {
        fits.push(bode(
            format!("tf fit ({:.1} %)", t.fit_percent),
            frf.freq_hz.iter().map(|f| t.eval(s_of(*f))).collect(),
        ));
    }
    plot_frf(path, &id.title, &est, &fits)?;
    Ok(())
}
