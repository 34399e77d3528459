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
pub use preset::{axis_preset, rate_loop_starts, AxisPreset, RATE_LOOP_MODEL};
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
    let ch = channels::resolve(log, a, &mut rm)?;
    let fmax_hz = channels::band_limit(log, a, &ch, &mut rm)?;
    let sel = segments::select(log, a, &ch, &mut rm)?;
    let est = Estimator::new(
        a,
        &sel.data,
        &sel.ranges,
        ch.excitation.is_some(),
        ch.preset.is_none(),
        fmax_hz,
        &mut rm,
    )?;
    let frf = est.frf_of(&sel.ranges)?;
    let coherent_band_hz = coherent_band(&frf);

    let mut fit_opts = fit_options(a)?;
    let model_text = a
        .model
        .clone()
        .or_else(|| ch.preset.as_ref().map(|p| p.model.to_string()));
    let (fit_band_hz, fit) = match &model_text {
        Some(text) => {
            let band = modelfit::fit_band(a, &frf, ch.preset.is_some(), fmax_hz, &mut fit_opts, &mut rm)?;
            let d = modelfit::FitData {
                est: &est,
                records: &sel.ranges,
                opts: &fit_opts,
            };
            let preset_model = ch.preset.is_some() && a.model.is_none();
            (
                band,
                Some(modelfit::fit_model(a, text, &frf, &d, preset_model, &mut rm)?),
            )
        }
        None if a.init.is_some() || a.bounds.is_some() => {
            return Err(Error::Input("--init and --bounds need --model".into()));
        }
        None => (None, None),
    };
    let tf =
        a.tf.as_deref()
            .map(|orders| modelfit::fit_orders(a, orders, &frf, &fit_opts, &mut rm))
            .transpose()?;
    let units = ch.preset.as_ref().map(|p| Units {
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
    let (fit, uncertainty, validation) = match fit {
        Some(m) => (Some(m.fit), m.uncertainty, m.validation),
        None => (None, None, None),
    };
    let Channels {
        preset,
        input,
        output,
        excitation,
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
