//! Identification from a flight log: read the log (CSV, PX4 ULog, Betaflight blackbox), pick the
//! segments (all airborne ones with `--axis`, the longest stretch where a condition holds with
//! `--where`, or the given span), estimate the frequency response (ETFE, Welch, SPA, SPAFDR; closed
//! loop with the setpoint as instrument), fit a parametric model with delay, and judge it: standard
//! errors no smaller than a block jackknife's spread, a held-out validation, and warnings for
//! open-loop estimates of closed-loop data, fits that did not converge or ended on a bound, and
//! channels logged too slowly for the band.

mod band;
mod preset;
mod records;
mod report;
mod request;
mod uncertainty;

pub use band::{coherent_band, supported_band, COHERENT, MAX_REL_ERR, MIN_DOF, PILOT_LOOP_HZ};
pub use preset::{axis_preset, rate_loop_starts, AxisPreset, RATE_LOOP_MODEL};
pub use report::{plot_identification, Identification, Units};
pub use request::IdentifyRequest;
pub use uncertainty::{Uncertainty, Validation};

use std::collections::BTreeMap;
use std::ops::Range;

use crate::error::{Error, Result};
use report::fit_warnings;
use request::{apply_bounds, fit_options, param_specs};
use skyloop_sysid::fit::{evaluate, fit_expr, fit_tf, DelaySpec, FitOptions, FitResult, ParamSpec};
use skyloop_sysid::logs::flight::{airborne_segments, Axis, Span};
/// Largest `--n-freq` (frequencies of the SPA/SPAFDR estimates and of the fit grid).
pub const MAX_N_FREQ: usize = 20_000;
/// Most samples an ETFE is taken on (its raw ratio of transforms has a point per frequency bin, and
/// fitting 100 000 unsmoothed points takes minutes).
pub const MAX_ETFE_SAMPLES: usize = 65_536;

use skyloop_sysid::logs::{median_rate_hz, segments_where, Condition, Log, LogFormat};
use skyloop_sysid::spectral::{default_nfft_records, estimate, estimate_records, Frf, IoData, Method, Options, Window};

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
    let mut notes = Vec::new();
    let mut warnings = Vec::new();
    let method: Method = a.method.parse()?;
    let window: Window = a.window.parse()?;
    let preset = a
        .axis
        .as_deref()
        .map(|ax| -> Result<AxisPreset> { axis_preset(log, ax.parse::<Axis>()?) })
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
    let (slow_name, slow_rate) = slowest_channel(log, &specs)?;
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
    // A rate loop logged below what shows its dynamics: the firmware's setting that logs it faster.
    if let Some(fw) = preset.as_ref().map(|p| p.channels.firmware) {
        if let (Some(min), Some(advice)) = (fw.min_rate_hz(), fw.slow_log_advice()) {
            if slow_rate < min {
                warnings.push(format!(
                    "'{slow_name}' is logged at {slow_rate:.1} Hz, too slow to show the rate loop's dynamics (at least {min:.0} Hz): the fit below is not to be trusted; {advice}"
                ));
            }
        }
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
        let air = airborne_segments(log, &output, &p.criteria, Some(data.t0_s), Some(t_end))?;
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
            .map(|s| data.range_of(s))
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
    let dt = data.dt_s;
    let has_r = excitation.is_some();
    // Sizes a user sets are checked before anything is allocated or fitted on them.
    if !(2..=MAX_N_FREQ).contains(&a.n_freq) {
        return Err(Error::Input(format!(
            "--n-freq {} is outside 2..={MAX_N_FREQ}",
            a.n_freq
        )));
    }
    if method == Method::Etfe && data.len() > MAX_ETFE_SAMPLES {
        return Err(Error::Input(format!(
            "--method etfe on {} samples: the raw ratio of transforms has one point per sample pair, at most {MAX_ETFE_SAMPLES} samples are taken (use welch or spa, which average)",
            data.len()
        )));
    }
    let mut opts = Options {
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
    // Every refit (jackknife, validation) uses the full data's Welch length, so that leaving out a
    // block changes the data, not the resolution.
    if method == Method::Welch && opts.nfft.is_none() && ranges.len() > 1 {
        opts.nfft = Some(default_nfft_records(
            &ranges.iter().map(|r| r.len()).collect::<Vec<_>>(),
        ));
    }
    if ranges.len() > 1 {
        notes.push(format!(
            "spectra estimated within each of the {} segments and averaged, weighted by length{}",
            ranges.len(),
            if method == Method::Etfe {
                " (etfe: the segments joined, as a raw ETFE needs one DFT grid)"
            } else {
                ""
            }
        ));
    }
    let frf_of = |recs: &[Range<usize>]| -> Result<Frf> {
        let io: Vec<IoData> = recs
            .iter()
            .map(|r| IoData {
                u: &data.columns[0][r.clone()],
                y: &data.columns[1][r.clone()],
                r: if has_r { Some(&data.columns[2][r.clone()]) } else { None },
                dt_s: dt,
            })
            .collect();
        // One span of a log the user chose keeps the single-record estimate (SPAFDR untapered, as
        // a bench record that starts and ends at rest wants); flight segments are always tapered.
        if io.len() == 1 && preset.is_none() {
            return Ok(estimate(&io[0], &opts)?);
        }
        Ok(estimate_records(&io, &opts)?)
    };
    let frf = frf_of(&ranges)?;
    let coherent_band_hz = coherent_band(&frf);

    let mut fit_opts = fit_options(a)?;
    let model_text = a.model.clone().or_else(|| preset.as_ref().map(|p| p.model.to_string()));
    let mut fit_band_hz = None;
    // The pilot's preset fits where the estimate's random error is small, above the pilot's own loop.
    if preset.is_some() && a.fmin_hz.is_none() && a.fmax_hz.is_none() && model_text.is_some() {
        match supported_band(&frf, PILOT_LOOP_HZ) {
            Some((lo, hi)) => {
                fit_opts.fmin_hz = Some(lo);
                fit_opts.fmax_hz = Some(hi);
                fit_band_hz = Some((lo, hi));
                notes.push(format!(
                    "fitting {lo:.2} .. {hi:.2} Hz: above {PILOT_LOOP_HZ} Hz (below, the pilot's own corrections make the setpoint a biased instrument), where the estimate's random error is at most {:.0} %",
                    100.0 * MAX_REL_ERR
                ));
            }
            None => {
                let msg = format!(
                    "the setpoint does not excite the rate loop enough to identify it: no band of an octave above {PILOT_LOOP_HZ} Hz where the estimate's random error is below {:.0} % (fly longer, with sharper stick inputs, or a chirp; give --fmin-hz/--fmax-hz or --allow-poor-fit to fit anyway)",
                    100.0 * MAX_REL_ERR
                );
                if !a.allow_poor_fit {
                    return Err(Error::Input(msg));
                }
                warnings.push(msg);
            }
        }
    } else if let (Some(_), Some(lo), Some(hi)) = (&model_text, a.fmin_hz, fmax_hz) {
        fit_band_hz = Some((lo, hi));
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
                let blocks = records::blocks(&ranges, a.blocks);
                let mut loo = Vec::new();
                for b in 0..blocks.len() {
                    let keep: Vec<usize> = (0..blocks.len()).filter(|k| *k != b).collect();
                    if let Ok(f) = frf_of(&records::pieces(&blocks, &keep)) {
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
                let part = |ix: &[usize]| records::pieces(&blocks, ix);
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
                    Ok(v) => {
                        // docs/flight-logs.md: a held-out FRF residual below about 0.3 means the
                        // model predicts the other half of the flight; below 0 % it predicts
                        // worse than the mean, which is no model at all.
                        if !(v.fit_percent >= 0.0) {
                            // A model that predicts the other half of the flight worse than its
                            // mean is no model: refused, as a fit below 0 % is (reference tests
                            // that compare the fitting arithmetic on such data pass the flag).
                            let msg = format!(
                                "the fit does not validate: on the held-out half of the flight it explains less than the mean (fit {:.1} %, FRF residual {:.2}); fly a log with stick inputs on this axis, or pass --allow-poor-fit to see the fit anyway",
                                v.fit_percent, v.frf_residual
                            );
                            if !a.allow_poor_fit {
                                return Err(Error::Input(msg));
                            }
                            warnings.push(msg);
                        } else if v.frf_residual > 0.35 || v.fit_percent < 50.0 {
                            warnings.push(format!(
                                "held-out validation is poor (fit {:.1} %, FRF residual {:.2}; about 0.3 or less is a model that predicts the flight): treat the parameters with caution, or fly a log with more stick input on this axis",
                                v.fit_percent, v.frf_residual
                            ));
                        }
                        validation = Some(v);
                    }
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
            // The preset's model stands for a rate loop only if the data pin each of its parameters:
            // an error larger than the value says the band does not reach the dynamics it describes.
            if preset.is_some() && a.model.is_none() {
                let loose: Vec<String> = r
                    .params
                    .iter()
                    .filter(|(k, v)| r.stderr.get(*k).is_none_or(|se| !(se.abs() <= v.abs())))
                    .map(|(k, v)| format!("{k} = {v:.4} ± {:.2}", r.stderr.get(k).copied().unwrap_or(f64::NAN)))
                    .collect();
                if !loose.is_empty() {
                    // The band the fit saw: the options' limits, else the estimate's own ends.
                    let first = frf.freq_hz.first().copied().unwrap_or(0.0);
                    let last = frf.freq_hz.last().copied().unwrap_or(0.0);
                    let lo = fit_opts.fmin_hz.map_or(first, |f| f.max(first));
                    let hi = fit_opts.fmax_hz.map_or(last, |f| f.min(last));
                    let msg = format!(
                        "the data do not determine the rate-loop model between {lo:.2} and {hi:.2} Hz: {} (the error exceeds the value); fly sharper, faster stick inputs or a chirp, or pass --allow-poor-fit to see the fit anyway",
                        loose.join(", ")
                    );
                    if !a.allow_poor_fit {
                        return Err(Error::Input(msg));
                    }
                    warnings.push(msg);
                }
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
            let fit = fit_tf(&frf, nz, np, delay, &fit_opts)?;
            // An unstable fit of data from a stable system is a fit of noise or of too many
            // poles: say so (the model stays, a pilot with an unstable airframe may want it).
            let rhp = skyloop_lti::poly::Poly::new(fit.den.clone())
                .roots()
                .map(|r| r.iter().filter(|z| z.re > 0.0).count())
                .unwrap_or(0);
            if rhp > 0 {
                warnings.push(format!(
                    "the --tf {nz}/{np} fit has {rhp} pole(s) in the right half plane (an unstable model): check the data, or fit fewer poles"
                ));
            }
            Some(fit)
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
        fit_band_hz,
        clock_origin_s: log.clock_origin_s,
        fit,
        uncertainty,
        validation,
        tf,
        notes,
        warnings,
    })
}
