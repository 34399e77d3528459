//! Identification from a flight log: read the log (CSV, PX4 ULog, Betaflight blackbox), pick the
//! segments (all airborne ones with `--axis`, the longest stretch where a condition holds with
//! `--where`, or the given span), estimate the frequency response (ETFE, Welch, SPA, SPAFDR; closed
//! loop with the setpoint as instrument), fit a parametric model with delay, and judge it: standard
//! errors no smaller than a block jackknife's spread, a held-out validation, and warnings for
//! open-loop estimates of closed-loop data, fits that did not converge or ended on a bound, and
//! channels logged too slowly for the band.

mod airborne;
mod band;
mod channels;
mod conditioning;
mod estimate;
mod modelfit;
mod preset;
mod records;
mod remarks;
mod report;
mod request;
mod segments;
mod uncertainty;

pub(crate) use airborne::hold_last;
pub use airborne::{airborne_segments, Airborne, SegmentVerdict};
pub use band::{coherent_band, supported_band, COHERENT, MAX_REL_ERR, MIN_DOF, PILOT_LOOP_HZ};
pub use preset::{axis_preset, preset_starts, rate_loop_starts, AxisPreset, RATE_LOOP_MODEL, YAW_RATE_LOOP_MODEL};
pub use report::{plot_identification, Identification, Units};
pub use request::IdentifyRequest;
pub use uncertainty::{Uncertainty, Validation};

use std::collections::BTreeMap;

use crate::error::{Error, Result};
use channels::Channels;
use estimate::Estimator;
use remarks::Remarks;
use request::fit_options;
/// Largest `--n-freq` (frequencies of the SPA/SPAFDR estimates and of the fit grid).
pub const MAX_N_FREQ: usize = 20_000;
/// Most samples an ETFE is taken on (its raw ratio of transforms has a point per frequency bin, and
/// fitting 100 000 unsmoothed points takes minutes).
pub const MAX_ETFE_SAMPLES: usize = 65_536;

use skyloop_sysid::logs::Log;
use skyloop_sysid::spectral::{Method, Window};

/// Relative resolutions (SPAFDR smoothing width / frequency) the `--axis` preset falls back to, in
/// turn, when the default's estimate does not support its model: a wider window averages more of
/// the flight into each point (less random error, less detail), which a flight with little stick
/// input on an axis needs before the lag's corner is determined. 0.6 is ±30 % of each frequency;
/// the rate-loop model changes little within it.
pub const COARSER_RESOLUTIONS: [f64; 2] = [0.3, 0.6];

/// The words of the warning that a channel is logged too slowly for the rate loop (see
/// `channels::band_limit`).
const SLOW_CHANNEL: &str = "too slow to show the rate loop's dynamics";

/// The estimate and the parametric fit on it.
struct Fitted {
    frf: skyloop_sysid::spectral::Frf,
    fit_opts: skyloop_sysid::fit::FitOptions,
    fit_band_hz: Option<(f64, f64)>,
    fit: Option<modelfit::ModelFit>,
}

/// The estimate of the request on the selection, and the fit of `model_text` (if any) on it.
fn estimate_and_fit(
    a: &IdentifyRequest,
    model_text: Option<&str>,
    ch: &Channels,
    sel: &segments::Selection,
    fmax_hz: Option<f64>,
    rm: &mut Remarks,
) -> Result<Fitted> {
    let est = Estimator::new(
        a,
        &sel.data,
        &sel.ranges,
        ch.excitation.is_some(),
        ch.disturbance.is_some(),
        ch.preset.is_none(),
        fmax_hz,
        rm,
    )?;
    let frf = est.frf_of(&sel.ranges)?;
    let mut fit_opts = fit_options(a)?;
    let (fit_band_hz, fit) = match model_text {
        Some(text) => {
            let band = modelfit::fit_band(a, &frf, ch.preset.is_some(), fmax_hz, &mut fit_opts, rm)?;
            let d = modelfit::FitData {
                est: &est,
                records: &sel.ranges,
                opts: &fit_opts,
            };
            let preset_model = ch.preset.is_some() && a.model.is_none();
            (band, Some(modelfit::fit_model(a, text, &frf, &d, preset_model, rm)?))
        }
        None if a.init.is_some() || a.bounds.is_some() => {
            return Err(Error::Input("--init and --bounds need --model".into()));
        }
        None => (None, None),
    };
    Ok(Fitted {
        frf,
        fit_opts,
        fit_band_hz,
        fit,
    })
}

/// The `--axis` preset's fit, as an engineer would retry it: when the request leaves the model,
/// band and estimator to the preset and the default estimate does not support the preset's model
/// (no band, a fit below the mean, an undetermined parameter), the estimate is smoothed more
/// ([`COARSER_RESOLUTIONS`]), then the preset's fallback model is tried the same way; the first
/// that holds is kept, with a note of what was tried. Every other request is fitted as given.
fn preset_fit(
    a: &IdentifyRequest,
    ch: &Channels,
    sel: &segments::Selection,
    fmax_hz: Option<f64>,
    rm: &mut Remarks,
) -> Result<Fitted> {
    let model_text = a
        .model
        .clone()
        .or_else(|| ch.preset.as_ref().map(|p| p.model.to_string()));
    let default_resolution = IdentifyRequest::default().resolution;
    let automatic = a.model.is_none()
        && a.init.is_none()
        && a.bounds.is_none()
        && a.fmin_hz.is_none()
        && a.fmax_hz.is_none()
        && a.method == "spafdr"
        && a.resolution == default_resolution;
    let Some(preset) = ch.preset.as_ref().filter(|_| automatic) else {
        return estimate_and_fit(a, model_text.as_deref(), ch, sel, fmax_hz, rm);
    };
    let strict = IdentifyRequest {
        allow_poor_fit: false,
        ..a.clone()
    };
    let mut refused: Vec<String> = Vec::new();
    for model in [Some(preset.model), preset.fallback_model].into_iter().flatten() {
        for resolution in std::iter::once(default_resolution).chain(COARSER_RESOLUTIONS) {
            let req = IdentifyRequest {
                resolution,
                ..strict.clone()
            };
            let mut trial = rm.clone();
            match estimate_and_fit(&req, Some(model), ch, sel, fmax_hz, &mut trial) {
                Ok(f) => {
                    if !refused.is_empty() {
                        trial.note(format!(
                            "the estimate was retried, smoothed more: {}; {model} holds at relative resolution {resolution} (each point averages ±{:.0} % of its frequency)",
                            refused.join("; "),
                            50.0 * resolution
                        ));
                    }
                    *rm = trial;
                    return Ok(f);
                }
                Err(Error::Input(m)) => refused.push(format!(
                    "{}at resolution {resolution} {}",
                    if model == preset.model {
                        String::new()
                    } else {
                        format!("{model} ")
                    },
                    first_clause(&m)
                )),
                Err(e) => return Err(e),
            }
        }
    }
    // None holds: the default attempt as asked (with --allow-poor-fit: its fit and warnings).
    estimate_and_fit(a, model_text.as_deref(), ch, sel, fmax_hz, rm)
}

/// The cause of a refusal, without the advice after it.
fn first_clause(msg: &str) -> &str {
    msg.split(" (the error exceeds")
        .next()
        .and_then(|m| m.split("; fly ").next())
        .and_then(|m| m.split(": the model or the band").next())
        .unwrap_or(msg)
}

/// Reads the log, selects the segments, estimates the FRF and runs the requested fits.
///
/// # Errors
/// An unreadable log, a column it does not hold, no airborne segment or a condition that never holds
/// for 2 s, a band above a channel's Nyquist frequency, options out of range ([`Error::Input`] names
/// the flag), a fit that fails or whose fit percentage is below 0 (unless `allow_poor_fit`).
pub fn identify(a: &IdentifyRequest) -> Result<Identification> {
    check_request(a)?;
    let (log, derived) = crate::firmware::open_log(&a.data, a.session)?;
    let mut id = identify_log(&log, a)?;
    id.notes.extend(derived);
    Ok(id)
}

/// [`identify`] on a log's bytes already in memory (a browser's dropped file); `a.data` only names
/// it in messages.
///
/// # Errors
/// As [`identify`].
pub fn identify_bytes(bytes: &[u8], a: &IdentifyRequest) -> Result<Identification> {
    check_request(a)?;
    let (log, derived) = crate::firmware::open_log_bytes(bytes, &a.data.display().to_string(), a.session)?;
    let mut id = identify_log(&log, a)?;
    id.notes.extend(derived);
    Ok(id)
}

/// The options of a request checked before the log is read.
fn check_request(a: &IdentifyRequest) -> Result<()> {
    a.method.parse::<Method>()?;
    a.window.parse::<Window>()?;
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
    for (lo_name, lo, hi_name, hi) in [
        ("--from", a.from, "--to", a.to),
        ("--fmin-hz", a.fmin_hz, "--fmax-hz", a.fmax_hz),
    ] {
        if let (Some(lo), Some(hi)) = (lo, hi) {
            if lo >= hi {
                return Err(Error::Input(format!("{lo_name} {lo} must be below {hi_name} {hi}")));
            }
        }
    }
    if a.blocks == 1 || a.blocks > 64 {
        return Err(Error::Input(format!(
            "--blocks {} is outside 2..=64 (0 turns the jackknife off)",
            a.blocks
        )));
    }
    Ok(())
}

/// [`identify`] on a log already read (and prepared by [`crate::firmware::prepare_log`]); `a.data`
/// only names it.
///
/// # Errors
/// As [`identify`].
pub fn identify_log(log: &Log, a: &IdentifyRequest) -> Result<Identification> {
    let mut rm = Remarks::default();
    let mut ch = channels::resolve(log, a, &mut rm)?;
    let fmax_hz = channels::band_limit(log, a, &ch, &mut rm)?;
    let sel = segments::select(log, a, &ch, &mut rm)?;
    conditioning::choose(a, &mut ch, &sel, fmax_hz, &mut rm)?;
    let Fitted {
        frf,
        fit_opts,
        fit_band_hz,
        fit,
    } = preset_fit(a, &ch, &sel, fmax_hz, &mut rm).map_err(|e| match e {
        // A channel logged too slowly is the first cause of a fit that fails: say it first.
        Error::Input(m) => match rm.warnings.iter().find(|w| w.contains(SLOW_CHANNEL)) {
            Some(slow) => Error::Input(format!(
                "{}; and {m}",
                slow.replace(": the fit below is not to be trusted", "")
            )),
            None => Error::Input(m),
        },
        other => other,
    })?;
    let coherent_band_hz = coherent_band(&frf);
    let tf =
        a.tf.as_deref()
            .map(|orders| modelfit::fit_orders(a, orders, &frf, &fit_opts, &mut rm))
            .transpose()?;
    let units = ch.preset.as_ref().map(|p| Units {
        input: p.channels.input_unit.to_string(),
        output: p.channels.output_unit.to_string(),
        params: if a.model.is_none() {
            let mut units = BTreeMap::from([
                ("K".to_string(), p.channels.gain_unit()),
                ("tau".to_string(), "s".to_string()),
                ("Td".to_string(), "s".to_string()),
            ]);
            if fit.as_ref().is_some_and(|m| m.fit.1.params.contains_key("Tz")) {
                units.insert("Tz".to_string(), "s".to_string());
            }
            units
        } else {
            BTreeMap::new()
        },
    });
    let (fit, uncertainty, validation) = match fit {
        Some(m) => (Some(m.fit), m.uncertainty, m.validation),
        None => (None, None, None),
    };
    let Channels {
        preset,
        input,
        output,
        excitation,
        disturbance,
    } = ch;
    Ok(Identification {
        title: format!("{input} → {output}"),
        preset: preset.as_ref().map(|p| {
            (
                p.firmware.display_name().to_string(),
                p.channels.axis.name().to_string(),
            )
        }),
        input,
        output,
        instrument: excitation,
        disturbance,
        units,
        segments: sel.segments,
        timeline: sel.timeline,
        frf,
        coherent_band_hz,
        fit_band_hz,
        clock_origin_s: log.clock_origin_s,
        fit,
        uncertainty,
        validation,
        tf,
        notes: rm.notes,
        warnings: rm.warnings,
    })
}
