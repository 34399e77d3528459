//! Identification from a flight log: read the log (CSV, PX4 ULog, Betaflight blackbox), pick the
//! segments (all airborne ones with `--axis`, the longest stretch where a condition holds with
//! `--where`, or the given span), estimate the frequency response (ETFE, Welch, SPA, SPAFDR; closed
//! loop with the setpoint as instrument), fit a parametric model with delay, and judge it: standard
//! errors no smaller than a block jackknife's spread, a held-out validation, and warnings for
//! open-loop estimates of closed-loop data, fits that did not converge or ended on a bound, and
//! channels logged too slowly for the band.

mod preset;
mod uncertainty;

pub use preset::{axis_preset, rate_loop_starts, AxisPreset, RATE_LOOP_MODEL};
pub use uncertainty::{Uncertainty, Validation};

use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use std::path::PathBuf;

use crate::error::{Error, Result};
use num_complex::Complex64 as C64;
use skyloop_plot::bode::BodeData;
use skyloop_plot::frf::{plot_frf, FrfEstimate};
use skyloop_sysid::fit::{evaluate, fit_expr, fit_tf, DelaySpec, FitOptions, FitResult, ParamSpec, TfFit};
use skyloop_sysid::logs::flight::{airborne_segments, Axis, Span};
use skyloop_sysid::logs::{median_rate_hz, segments_where, Condition, Log, LogFormat, OpenOptions};
use skyloop_sysid::spectral::{estimate, Frf, IoData, Method, Options, Window};

/// What to identify: the log, its columns, the estimator and the optional parametric fits. Field
/// for field the flags of `skyloop identify`; [`Default`] holds their defaults.
#[derive(Debug, Clone)]
pub struct IdentifyRequest {
    /// Log file: CSV with a time_s column, PX4 ULog, or Betaflight blackbox.
    pub data: PathBuf,
    /// roll, pitch or yaw: the firmware's rate-loop channels, all airborne segments, the setpoint as
    /// instrument and the model [`RATE_LOOP_MODEL`] (see [`axis_preset`]); every other field given
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

/// Units of the identified quantities (with `--axis`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Units {
    /// Plant input, e.g. "PID unit".
    pub input: String,
    /// Plant output, e.g. "deg/s".
    pub output: String,
    /// Each parameter of the default model: K "deg/s² per PID unit", tau and Td "s".
    pub params: BTreeMap<String, String>,
}

/// What [`identify`] found.
#[derive(Debug, Clone)]
pub struct Identification {
    /// "input → output", the plot's title.
    pub title: String,
    /// Plant input column used.
    pub input: String,
    /// Plant output column used.
    pub output: String,
    /// Instrument (excitation) column, `None` for an open-loop estimate.
    pub instrument: Option<String>,
    /// Firmware and axis when `--axis` chose the channels, e.g. ("Betaflight", "roll").
    pub preset: Option<(String, String)>,
    /// Units, with `--axis`.
    pub units: Option<Units>,
    /// The spans of the log the estimate used, s.
    pub segments: Vec<Span>,
    /// The frequency-response estimate with coherence and confidence.
    pub frf: Frf,
    /// The coherence-supported band (see [`coherent_band`]), Hz.
    pub coherent_band_hz: Option<(f64, f64)>,
    /// The parametric fit of `--model` with its parsed expression; its `stderr` is the larger of the
    /// model-based and the jackknife error.
    pub fit: Option<(skyloop_lti::expr::Expr, FitResult)>,
    /// The two error estimates behind the fit's reported `stderr`.
    pub uncertainty: Option<Uncertainty>,
    /// The held-out validation of the fit.
    pub validation: Option<Validation>,
    /// The rational fit of `--tf`.
    pub tf: Option<TfFit>,
    /// What the workflow chose on the user's behalf (segments, the band).
    pub notes: Vec<String>,
    /// What the user should act on: an open-loop estimate of closed-loop data, a fit that did not
    /// converge or ended on a bound, a channel logged too slowly for the band.
    pub warnings: Vec<String>,
}

/// Squared coherence (averaged over a third of a decade) from which the instrument supports the
/// estimate: the random error of |G| is then at most √((1 − 0.2)/(2ν·0.2)), 20 % for ν = 50
/// averages. A pilot's setpoint in a real acro flight gives 0.2 to 0.5 up to about 7 Hz.
pub const COHERENT: f64 = 0.2;

/// Fewest averages behind a point of the coherent band (see [`coherent_band`]).
pub const MIN_DOF: f64 = 10.0;

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
        apply_bounds(&mut specs, b)?;
    }
    Ok(specs)
}

/// Sets the bounds `NAME=LO:HI,..` of `--bounds` on `specs`.
fn apply_bounds(specs: &mut [ParamSpec], b: &str) -> Result<()> {
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
fn fit_options(a: &IdentifyRequest) -> Result<FitOptions> {
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

/// The channels a column spec (a channel, or channels joined by + and −) reads.
fn spec_channels(spec: &str) -> Vec<String> {
    spec.split(['+', '-'])
        .map(|t| t.trim().to_string())
        .filter(|t| !t.is_empty())
        .collect()
}

/// The slowest channel behind the specs and its own median rate, Hz.
fn slowest_channel(log: &Log, specs: &[&str]) -> Result<(String, f64)> {
    let mut slowest = (String::new(), f64::INFINITY);
    for spec in specs {
        let names = if log.channel(spec).is_ok() {
            vec![spec.to_string()]
        } else {
            spec_channels(spec)
        };
        for n in names {
            let (t, _) = log.channel(&n)?;
            let r = median_rate_hz(t);
            if r < slowest.1 {
                slowest = (n, r);
            }
        }
    }
    Ok(slowest)
}

/// The coherence-supported band: the widest run (in octaves) of frequencies where the coherence,
/// averaged over the points within a sixth of a decade either side, is at least [`COHERENT`] and
/// that average at least [`MIN_DOF`] times, as
/// (lowest, highest) frequency, Hz. The average keeps one noisy point from splitting the band; the
/// fit's inverse-variance weights then discount the weak points inside it.
pub fn coherent_band(frf: &Frf) -> Option<(f64, f64)> {
    let f = &frf.freq_hz;
    let smooth: Vec<f64> = (0..f.len())
        .map(|i| {
            let (lo, hi) = (f[i] * 10f64.powf(-1.0 / 6.0), f[i] * 10f64.powf(1.0 / 6.0));
            let near: Vec<f64> = (0..f.len())
                .filter(|&k| f[k] >= lo && f[k] <= hi)
                .map(|k| frf.coherence[k])
                .collect();
            near.iter().sum::<f64>() / near.len().max(1) as f64
        })
        .collect();
    // A coherence estimate from ν averages is biased up by about 1/ν (it is 1 for a single
    // periodogram), so points with fewer than MIN_DOF averages cannot vouch for themselves.
    let mask: Vec<bool> = (0..f.len())
        .map(|i| smooth[i] >= COHERENT && f[i] > 0.0 && frf.dof.get(i).copied().unwrap_or(0.0) >= MIN_DOF)
        .collect();
    let r = segments_where(&mask, 2).into_iter().max_by(|a, b| {
        let w = |r: &Range<usize>| f[r.end - 1] / f[r.start];
        w(a).total_cmp(&w(b))
    })?;
    Some((f[r.start], f[r.end - 1]))
}

/// Fits `expr` from each start, keeping the lowest cost.
fn best_fit(frf: &Frf, expr: &skyloop_lti::expr::Expr, starts: &[Vec<ParamSpec>], o: &FitOptions) -> Result<FitResult> {
    let mut best: Option<FitResult> = None;
    let mut first_err = None;
    for s in starts {
        match fit_expr(frf, expr, s, o) {
            Ok(r) if r.cost.is_finite() && best.as_ref().is_none_or(|b| r.cost < b.cost) => best = Some(r),
            Ok(_) => {}
            Err(e) => first_err = first_err.or(Some(e)),
        }
    }
    match (best, first_err) {
        (Some(b), _) => Ok(b),
        (None, Some(e)) => Err(e.into()),
        (None, None) => Err(Error::Input("--model: no starting point to fit from".into())),
    }
}

/// The parameter specs restarted at `at` (for refits of parts of the data).
fn restart(specs: &[ParamSpec], at: &BTreeMap<String, f64>) -> Vec<ParamSpec> {
    specs
        .iter()
        .map(|p| ParamSpec {
            init: at.get(&p.name).copied().unwrap_or(p.init).clamp(p.lower, p.upper),
            ..p.clone()
        })
        .collect()
}

/// Reads the log, selects the segments, estimates the FRF and runs the requested fits.
///
/// # Errors
/// An unreadable log, a column it does not hold, no airborne segment or a condition that never holds
/// for 2 s, a band above a channel's Nyquist frequency, options out of range ([`Error::Input`] names
/// the flag), a fit that fails or whose fit percentage is below 0 (unless `allow_poor_fit`).
pub fn identify(a: &IdentifyRequest) -> Result<Identification> {
    let mut notes = Vec::new();
    let mut warnings = Vec::new();
    let method: Method = a.method.parse()?;
    let window: Window = a.window.parse()?;
    for (name, v) in [
        ("--fmin-hz", a.fmin_hz),
        ("--fmax-hz", a.fmax_hz),
        ("--from", a.from),
        ("--to", a.to),
    ] {
        if v.is_some_and(|x| !x.is_finite()) {
            return Err(Error::Input(format!("{name} must be a finite number")));
        }
    }
    if a.blocks == 1 || a.blocks > 64 {
        return Err(Error::Input(format!(
            "--blocks {} is outside 2..=64 (0 turns the jackknife off)",
            a.blocks
        )));
    }
    let log = Log::open(
        &a.data,
        &OpenOptions {
            session: a.session,
            ..Default::default()
        },
    )?;
    let preset = a
        .axis
        .as_deref()
        .map(|ax| -> Result<AxisPreset> { axis_preset(&log, ax.parse::<Axis>()?) })
        .transpose()?;
    let input = a
        .input
        .clone()
        .or_else(|| preset.as_ref().map(|p| p.channels.input.clone()))
        .ok_or_else(|| Error::Input("--input is required without --axis".into()))?;
    let output = a
        .output
        .clone()
        .or_else(|| preset.as_ref().map(|p| p.channels.output.clone()))
        .ok_or_else(|| Error::Input("--output is required without --axis".into()))?;
    let excitation = match a.excitation.as_deref() {
        Some(x) if x.eq_ignore_ascii_case("none") => None,
        Some(x) => Some(x.to_string()),
        None => preset.as_ref().map(|p| p.channels.instrument.clone()),
    };
    if let Some(p) = &preset {
        notes.push(format!(
            "{} log, {} axis: input {input}, output {output}, instrument {}",
            p.channels.firmware.name(),
            p.channels.axis.name(),
            excitation.as_deref().unwrap_or("none (open loop)")
        ));
    }

    // Closed-loop data estimated open loop: Φ_yu/Φ_uu is pulled towards −1/C by the feedback noise.
    if excitation.is_none() {
        let fields = log.field_names();
        let setpoint = fields
            .iter()
            .find(|f| f.to_lowercase().contains("setpoint"))
            .or_else(|| fields.iter().find(|f| f.starts_with("rcCommand[")))
            .cloned();
        if log.format != LogFormat::Csv || setpoint.is_some() {
            let better = match (&a.axis, &setpoint) {
                (Some(_), _) => "drop --excitation none".to_string(),
                (None, Some(s)) => format!("--excitation {s} (or --axis roll|pitch|yaw)"),
                (None, None) => "--excitation SETPOINT (or --axis roll|pitch|yaw)".to_string(),
            };
            warnings.push(format!(
                "open-loop estimate of closed loop data: feedback makes Φ_yu/Φ_uu biased (low gain, wrong phase where the controller acts); give the setpoint as instrument: {better}"
            ));
        }
    }

    // A channel's own rate bounds the band: nothing above its Nyquist frequency exists in the data.
    let mut specs: Vec<&str> = vec![input.as_str(), output.as_str()];
    if let Some(r) = &excitation {
        specs.push(r);
    }
    let (slow_name, slow_rate) = slowest_channel(&log, &specs)?;
    let fastest = specs
        .iter()
        .map(|s| log.series(s).map(|(t, _)| median_rate_hz(&t)))
        .collect::<std::result::Result<Vec<_>, _>>()?
        .into_iter()
        .fold(0.0f64, f64::max);
    let grid_rate = a.rate.unwrap_or(fastest);
    let mut fmax_hz = a.fmax_hz;
    if let Some(f) = a.fmax_hz {
        if f > 0.5 * slow_rate {
            return Err(Error::Input(format!(
                "channel '{slow_name}' is logged at {slow_rate:.1} Hz: nothing above its Nyquist frequency {:.1} Hz is in the data, but --fmax-hz asks for {f} Hz; ask for at most {:.1} Hz (2.5 samples per period) or log the channel faster",
                0.5 * slow_rate,
                slow_rate / 2.5
            )));
        }
        if f > slow_rate / 2.5 {
            warnings.push(format!(
                "channel '{slow_name}' is logged at {slow_rate:.1} Hz, less than 2.5 × the requested band {f} Hz: the estimate near {f} Hz is attenuated and aliased"
            ));
        }
    } else if slow_rate < 0.99 * grid_rate {
        fmax_hz = Some(slow_rate / 2.5);
        warnings.push(format!(
            "channel '{slow_name}' is logged at only {slow_rate:.1} Hz (resampled to {grid_rate:.1} Hz): the estimate stops at {:.2} Hz, 1/2.5 of its rate",
            slow_rate / 2.5
        ));
    }

    // The segments.
    let mut cols: Vec<&str> = specs.clone();
    let cond = a.condition.as_deref().map(Condition::parse).transpose()?;
    if let Some(c) = &cond {
        cols.push(&c.column);
    }
    let data = log.uniform(&cols, a.rate, a.from, a.to)?;
    let t_of = |i: usize| data.t0_s + i as f64 * data.dt_s;
    let ranges: Vec<Range<usize>> = if let Some(c) = &cond {
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
            t_of(seg.start),
            t_of(seg.end),
            a.condition.as_deref().unwrap_or("")
        ));
        vec![seg]
    } else if let Some(p) = &preset {
        let t_end = t_of(data.len() - 1);
        let air = airborne_segments(&log, &output, &p.criteria, Some(data.t0_s), Some(t_end))?;
        let total: f64 = air.segments.iter().map(Span::len_s).sum();
        let excluded: Vec<String> = air
            .excluded_s
            .iter()
            .filter(|(_, s)| *s > 0.0)
            .map(|(r, s)| format!("{r} {s:.1} s"))
            .collect();
        notes.push(format!(
            "{} airborne segments, {total:.1} s of {:.1} s searched (excluded: {})",
            air.segments.len(),
            air.searched.len_s(),
            if excluded.is_empty() {
                "nothing".to_string()
            } else {
                excluded.join(", ")
            }
        ));
        air.segments
            .iter()
            .map(|s| {
                let lo = ((s.from_s - data.t0_s) / data.dt_s).ceil().max(0.0) as usize;
                let hi = (((s.to_s - data.t0_s) / data.dt_s).floor() as usize + 1).min(data.len());
                lo..hi
            })
            .filter(|r| r.end > r.start + 1)
            .collect()
    } else {
        std::iter::once(0..data.len()).collect()
    };
    let segments: Vec<Span> = ranges
        .iter()
        .map(|r| Span {
            from_s: t_of(r.start),
            to_s: t_of(r.end - 1),
        })
        .collect();
    // Half-second ramps: long against the loop's dynamics (tens of ms), short against the segments.
    let taper = if ranges.len() > 1 {
        (0.5 / data.dt_s).round() as usize
    } else {
        0
    };
    let joined = data.segments_joined(&ranges, taper);
    let dt = data.dt_s;
    let has_r = excitation.is_some();
    let opts = Options {
        method,
        fmin_hz: a.fmin_hz,
        fmax_hz,
        nfft: a.nfft,
        window,
        overlap: a.overlap,
        lag_window: a.lag_window,
        n_freq: a.n_freq,
        resolution: a.resolution,
        ..Options::default()
    };
    let frf_of = |c: &[Vec<f64>]| -> Result<Frf> {
        let io = IoData {
            u: &c[0],
            y: &c[1],
            r: if has_r { Some(c[2].as_slice()) } else { None },
            dt_s: dt,
        };
        Ok(estimate(&io, &opts)?)
    };
    let frf = frf_of(&joined)?;
    let coherent_band_hz = coherent_band(&frf);

    let mut fit_opts = fit_options(a)?;
    let model_text = a.model.clone().or_else(|| preset.as_ref().map(|p| p.model.to_string()));
    // The pilot's preset fits where the instrument's coherence supports the estimate.
    if preset.is_some() && a.fmin_hz.is_none() && a.fmax_hz.is_none() {
        if let Some((lo, hi)) = coherent_band_hz {
            fit_opts.fmin_hz = Some(lo);
            fit_opts.fmax_hz = Some(hi);
            notes.push(format!(
                "fitting {lo:.2} .. {hi:.2} Hz, where the coherence is at least {COHERENT}"
            ));
        }
    }
    let mut uncertainty = None;
    let mut validation = None;
    let fit = match &model_text {
        Some(text) => {
            let expr = skyloop_lti::expr::parse(text).map_err(|e| Error::Input(format!("--model: {e}")))?;
            let starts = if a.init.is_none() && a.model.is_none() {
                let (lo, hi) = (
                    fit_opts.fmin_hz.unwrap_or(0.0),
                    fit_opts.fmax_hz.unwrap_or(f64::INFINITY),
                );
                let mut s = rate_loop_starts(&frf, lo, hi);
                if let Some(b) = &a.bounds {
                    for start in &mut s {
                        apply_bounds(start, b)?;
                        // An automatic start moves inside the user's bounds (inverted ones fail in the fit).
                        for p in start.iter_mut() {
                            p.init = p.init.clamp(p.lower.min(p.upper), p.upper.max(p.lower));
                        }
                    }
                }
                s
            } else {
                vec![param_specs(a)?]
            };
            let mut r = best_fit(&frf, &expr, &starts, &fit_opts)?;
            let specs = restart(&starts[0], &r.params);
            if a.blocks >= 2 {
                let n = joined[0].len();
                let blocks = uncertainty::blocks(n, a.blocks);
                let mut loo = Vec::new();
                for b in 0..blocks.len() {
                    let keep: Vec<Range<usize>> = blocks
                        .iter()
                        .enumerate()
                        .filter(|(k, _)| *k != b)
                        .map(|(_, r)| r.clone())
                        .collect();
                    let part = uncertainty::pick(&joined, &keep);
                    if let Ok(f) = frf_of(&part) {
                        if let Ok(fr) = fit_expr(&f, &expr, &specs, &fit_opts) {
                            if fr.params.values().all(|v| v.is_finite()) {
                                loo.push(fr.params);
                            }
                        }
                    }
                }
                if loo.len() >= 2 {
                    let jk = uncertainty::jackknife(&loo);
                    let model_stderr = r.stderr.clone();
                    for (k, se) in r.stderr.iter_mut() {
                        if let Some(j) = jk.get(k) {
                            // NaN (undetermined) stays NaN: the jackknife cannot vouch for it.
                            if se.is_finite() {
                                *se = se.max(*j);
                            }
                        }
                    }
                    uncertainty = Some(Uncertainty {
                        model_stderr,
                        jackknife_stderr: jk,
                        blocks: blocks.len(),
                        blocks_used: loo.len(),
                    });
                } else {
                    warnings.push(format!(
                        "the jackknife refit succeeded on {} of {} blocks: the reported errors are model-based only",
                        loo.len(),
                        blocks.len()
                    ));
                }
                // Held out: fit the even blocks, predict the odd ones (both spread over the flight).
                let train: Vec<usize> = (0..blocks.len()).step_by(2).collect();
                let test: Vec<usize> = (1..blocks.len()).step_by(2).collect();
                let part = |ix: &[usize]| {
                    uncertainty::pick(&joined, &ix.iter().map(|&i| blocks[i].clone()).collect::<Vec<_>>())
                };
                let held = (|| -> Result<Validation> {
                    let f_train = frf_of(&part(&train))?;
                    let f_test = frf_of(&part(&test))?;
                    let fr = fit_expr(&f_train, &expr, &specs, &fit_opts)?;
                    let e = evaluate(&f_test, &expr, &fr.params, &fit_opts)?;
                    Ok(Validation {
                        train_blocks: train.clone(),
                        test_blocks: test.clone(),
                        train_fit_percent: fr.fit_percent,
                        fit_percent: e.fit_percent,
                        frf_residual: e.log_residual_rms,
                    })
                })();
                match held {
                    Ok(v) => validation = Some(v),
                    Err(e) => warnings.push(format!("no held-out validation: {e}")),
                }
            }
            fit_warnings(&r, &mut warnings);
            if !(r.fit_percent >= 0.0) {
                let msg = format!(
                    "the fit of '{text}' explains less than the FRF's mean (fit {:.1} %): the model or the band does not suit the data; change --model, --fmin-hz/--fmax-hz, or pass --allow-poor-fit to see it anyway",
                    r.fit_percent
                );
                if !a.allow_poor_fit {
                    return Err(Error::Input(msg));
                }
                warnings.push(msg);
            }
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
    let units = preset.as_ref().map(|p| Units {
        input: p.channels.input_unit.to_string(),
        output: p.channels.output_unit.to_string(),
        params: if a.model.is_none() {
            BTreeMap::from([
                ("K".to_string(), p.channels.gain_unit()),
                ("tau".to_string(), "s".to_string()),
                ("Td".to_string(), "s".to_string()),
            ])
        } else {
            BTreeMap::new()
        },
    });
    Ok(Identification {
        title: format!("{input} → {output}"),
        preset: preset.as_ref().map(|p| {
            (
                p.channels.firmware.name().to_string(),
                p.channels.axis.name().to_string(),
            )
        }),
        input,
        output,
        instrument: excitation,
        units,
        segments,
        frf,
        coherent_band_hz,
        fit,
        uncertainty,
        validation,
        tf,
        notes,
        warnings,
    })
}

/// Warnings for a fit that stopped at the iteration limit, ended on a bound or has undetermined errors.
fn fit_warnings(r: &FitResult, warnings: &mut Vec<String>) {
    if !r.converged {
        warnings.push(format!(
            "the fit did not converge ({} iterations, limit reached): its parameters are not a minimum",
            r.iterations
        ));
    }
    if !r.at_bounds.is_empty() {
        warnings.push(format!(
            "the fit ended on a bound for {}: the data do not determine it within the bounds",
            r.at_bounds.join(", ")
        ));
    }
    let nan: Vec<&str> = r
        .stderr
        .iter()
        .filter(|(_, s)| !s.is_finite())
        .map(|(k, _)| k.as_str())
        .collect();
    if !nan.is_empty() || r.params.values().any(|v| !v.is_finite()) {
        warnings.push(format!(
            "the fit's standard errors are undetermined for {}: the data do not constrain them",
            if nan.is_empty() {
                "some parameters".to_string()
            } else {
                nan.join(", ")
            }
        ));
    }
}

impl Identification {
    /// `{"frf": {freq_hz, mag, phase_deg, coherence}, "fit": {params, stderr, fit_percent, converged,
    /// at_bounds, units}, "tf": {num, den, delay_s, fit_percent}, "segments": [{from_s, to_s}],
    /// "instrument", "input", "output", "coherent_band_hz": [lo, hi], "uncertainty", "validation":
    /// {fit_percent, frf_residual, ..}, "converged", "at_bounds", "warnings"}`, as `skyloop identify
    /// --json` prints it (a non-finite number is null).
    pub fn to_json(&self) -> serde_json::Value {
        let num = |x: f64| {
            if x.is_finite() {
                serde_json::json!(x)
            } else {
                serde_json::Value::Null
            }
        };
        let map = |m: &BTreeMap<String, f64>| {
            m.iter()
                .map(|(k, s)| (k.clone(), num(*s)))
                .collect::<serde_json::Map<_, _>>()
        };
        let frf = &self.frf;
        let mut v = serde_json::json!({
            "frf": {
                "freq_hz": frf.freq_hz,
                "mag": frf.mag(),
                "phase_deg": frf.phase_deg(),
                "coherence": frf.coherence,
            },
            "input": self.input,
            "output": self.output,
            "instrument": self.instrument,
            "segments": self.segments,
            "coherent_band_hz": self.coherent_band_hz.map(|(a, b)| [a, b]),
            "coherence_threshold": COHERENT,
            "warnings": self.warnings,
        });
        if let Some((firmware, axis)) = &self.preset {
            v["firmware"] = serde_json::json!(firmware);
            v["axis"] = serde_json::json!(axis);
        }
        if let Some(u) = &self.units {
            v["units"] = serde_json::json!(u);
        }
        if let Some((_, r)) = &self.fit {
            v["fit"] = serde_json::json!({
                "params": map(&r.params),
                "stderr": map(&r.stderr),
                "fit_percent": num(r.fit_percent),
                "converged": r.converged,
                "at_bounds": r.at_bounds,
            });
            v["converged"] = serde_json::json!(r.converged && r.stderr.values().all(|s| s.is_finite()));
            v["at_bounds"] = serde_json::json!(r.at_bounds);
        }
        if let Some(u) = &self.uncertainty {
            v["uncertainty"] = serde_json::json!({
                "model_stderr": map(&u.model_stderr),
                "jackknife_stderr": map(&u.jackknife_stderr),
                "blocks": u.blocks,
                "blocks_used": u.blocks_used,
            });
        }
        if let Some(val) = &self.validation {
            v["validation"] = serde_json::json!({
                "train_blocks": val.train_blocks,
                "test_blocks": val.test_blocks,
                "train_fit_percent": num(val.train_fit_percent),
                "fit_percent": num(val.fit_percent),
                "frf_residual": num(val.frf_residual),
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
