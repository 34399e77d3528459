//! The page's requests as plain Rust: JSON options in, the CLI's `--json` objects out. No
//! wasm-bindgen here, so the host tests call these directly (`lib.rs` wraps them for JavaScript).

use serde_json::{json, Value};
use skyloop::design::loop_metrics::{four_block_norms, loop_margins};
use skyloop::figures::Labeled;
use skyloop::firmware::Axis;
use skyloop::lti::StateSpace;
use skyloop::tune::live::{loop_response, LiveLoop};
use skyloop::tune::log::{tune_from_log_bytes, LogTuneRequest};
use skyloop::tune::{Firmware, Maximize};
use skyloop::{Error, Result};

/// An optional field of an options object as a number.
fn opt_f64(o: &Value, key: &str) -> Result<Option<f64>> {
    match o.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => v
            .as_f64()
            .map(Some)
            .ok_or_else(|| Error::Input(format!("{key} must be a number, got {v}"))),
    }
}

/// An optional field of an options object as a count.
fn opt_usize(o: &Value, key: &str) -> Result<Option<usize>> {
    match o.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => v
            .as_u64()
            .map(|x| Some(x as usize))
            .ok_or_else(|| Error::Input(format!("{key} must be a whole number, got {v}"))),
    }
}

/// An optional field of an options object as text.
fn opt_str<'a>(o: &'a Value, key: &str) -> Result<Option<&'a str>> {
    match o.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => v
            .as_str()
            .map(Some)
            .ok_or_else(|| Error::Input(format!("{key} must be text, got {v}"))),
    }
}

/// A model as the CLI reads one: an LTI JSON object (text starting with `{`) or a
/// transfer-function expression with exact delays.
///
/// # Errors
/// Text that is neither (the parse error names the column).
pub fn model_of(text: &str) -> Result<StateSpace> {
    let t = text.trim();
    if t.starts_with('{') {
        return skyloop::lti::json::from_json_str(t).map_err(|e| Error::Input(format!("LTI JSON: {e}")));
    }
    Ok(skyloop::lti::expr::parse_model(t)?)
}

/// `skyloop log info FILE --json` on the file's bytes (`session`: a blackbox session, from 1).
///
/// # Errors
/// Bytes that are not a log the readers know.
pub fn log_info(bytes: &[u8], name: &str, session: Option<usize>) -> Result<Value> {
    let opts = skyloop::sysid::logs::OpenOptions {
        session,
        ..Default::default()
    };
    let log = skyloop::sysid::logs::Log::from_bytes(bytes, name, &opts)?;
    Ok(skyloop::flightlog::info_json(name, &log, Some(bytes)))
}

/// `skyloop identify FILE --axis A --json` on the file's bytes; `opts`: `axis` (roll by default),
/// `session`, `fmin_hz`, `fmax_hz`.
///
/// # Errors
/// As `skyloop identify`.
pub fn identify(bytes: &[u8], name: &str, opts: &Value) -> Result<Value> {
    let req = skyloop::identify::IdentifyRequest {
        data: name.into(),
        axis: Some(opt_str(opts, "axis")?.unwrap_or("roll").to_string()),
        session: opt_usize(opts, "session")?,
        fmin_hz: opt_f64(opts, "fmin_hz")?,
        fmax_hz: opt_f64(opts, "fmax_hz")?,
        ..Default::default()
    };
    Ok(skyloop::identify::identify_bytes(bytes, &req)?.to_json())
}

/// `skyloop tune FILE --axis A --firmware F --json` on the file's bytes, and what re-analysing
/// other gains needs. `opts`: `axis` (roll), `firmware` (read from the log when absent), `session`,
/// `fmin_hz`, `fmax_hz`, `sigma` (2), `noise_budget` (1.25), `maximize` (tracking). The JSON gains
/// `live`: `{flown, proposed}` knobs (see [`LiveLoop::knobs`]) when the log has flown gains.
///
/// # Errors
/// As `skyloop tune`.
pub fn tune_log(
    bytes: &[u8],
    name: &str,
    opts: &Value,
    progress: Option<fn(Axis, &str)>,
) -> Result<(Value, Option<LiveLoop>)> {
    let axis = Axis::parse(opt_str(opts, "axis")?.unwrap_or("roll"))?;
    let firmware = match opt_str(opts, "firmware")? {
        Some(f) => Firmware::parse(f)?,
        None => firmware_of(bytes, name, opt_usize(opts, "session")?)?,
    };
    let mut req = LogTuneRequest::new(name.into(), axis, firmware);
    req.session = opt_usize(opts, "session")?;
    req.fmin_hz = opt_f64(opts, "fmin_hz")?;
    req.fmax_hz = opt_f64(opts, "fmax_hz")?;
    req.sigma = opt_f64(opts, "sigma")?.unwrap_or(req.sigma);
    req.noise_budget = opt_f64(opts, "noise_budget")?.unwrap_or(req.noise_budget);
    if let Some(m) = opt_str(opts, "maximize")? {
        req.maximize = Maximize::parse(m)?;
    }
    req.progress = progress;
    let out = tune_from_log_bytes(&req, bytes)?;
    let mut v = out.to_json();
    v["firmware"] = json!(firmware.name());
    v["live"] = match &out.live {
        Some(l) => json!({
            "flown": LiveLoop::knobs(&l.flown),
            "proposed": LiveLoop::knobs(&l.gains(&out.proposed_analysis.gains)?),
        }),
        None => Value::Null,
    };
    Ok((v, out.live))
}

/// The firmware that wrote a log (the `--firmware` a pilot would give).
fn firmware_of(bytes: &[u8], name: &str, session: Option<usize>) -> Result<Firmware> {
    let opts = skyloop::sysid::logs::OpenOptions {
        session,
        ..Default::default()
    };
    let log = skyloop::sysid::logs::Log::from_bytes(bytes, name, &opts)?;
    Firmware::of_log(&log).ok_or_else(|| {
        Error::Input(format!(
            "{name}: no firmware this tuner knows wrote this log (Betaflight, INAV, PX4 or ArduPilot); a CSV log names no firmware and is not tuned from here"
        ))
    })
}

/// `skyloop margins MODEL --json`.
///
/// # Errors
/// A model that is not SISO or whose margins cannot be computed.
pub fn margins(model: &str) -> Result<Value> {
    skyloop::json_out::margins_json(&model_of(model)?)
}

/// `skyloop freqresp MODEL [--hz F,..] --json` (the CLI's default grid without frequencies).
///
/// # Errors
/// A bad model or frequency list.
pub fn freqresp(model: &str, freq_hz: Option<Vec<f64>>) -> Result<Value> {
    use skyloop::response;
    let sys = model_of(model)?;
    let f = match freq_hz {
        Some(f) => {
            response::check_frequencies_hz(&f, "--hz")?;
            f
        }
        None => response::default_grid_hz(&sys, 50)?,
    };
    let w: Vec<f64> = f.iter().map(|x| 2.0 * std::f64::consts::PI * x).collect();
    let g = skyloop::lti::freqresp::freqresp_flat(&sys, &w)?;
    Ok(serde_json::to_value(response::ResponseJson::new(
        &f,
        &g,
        sys.ny(),
        sys.nu(),
    ))?)
}

/// `skyloop step MODEL [--closed-loop] --json`.
///
/// # Errors
/// A bad model, or a closed loop too large to simulate.
pub fn step(model: &str, closed_loop: bool) -> Result<Value> {
    let models = [Labeled {
        label: model.to_string(),
        sys: model_of(model)?,
    }];
    let (_, runs) = skyloop::figures::step(&models, closed_loop, None)?;
    Ok(json!({ "models": runs }))
}

/// `skyloop ncfsyn P --w1 W1 --w2 W2 --pade N --factor F --json`, with the loop it makes analysed
/// as `skyloop design` reports a step: `analysis` holds `b_pc` (b(P, C), the unweighted loop's
/// normalized-coprime-factor margin, on the rational plant), `order` (the controller's states),
/// `margins` (of L = P·C with P's exact delay), `loop` (L's frequency response) and `step` (the
/// closed loop's). `opts`: `plant`, `w1`, `w2` (expressions or LTI JSON), `pade` (3), `factor`
/// (1.1).
///
/// # Errors
/// As `skyloop ncfsyn`.
pub fn ncfsyn(opts: &Value) -> Result<Value> {
    use skyloop::robust::ncfsyn::{ncfsyn as run, NcfOptions};
    let p = model_of(opt_str(opts, "plant")?.ok_or_else(|| Error::Input("give the plant P".into()))?)?;
    let weight = |k: &str| -> Result<Option<StateSpace>> {
        match opt_str(opts, k)?.map(str::trim) {
            None | Some("") => Ok(None),
            Some(t) => Ok(Some(model_of(t)?)),
        }
    };
    let (w1, w2) = (weight("w1")?, weight("w2")?);
    let o = NcfOptions {
        factor: opt_f64(opts, "factor")?.unwrap_or(1.1),
        pade_order: opt_usize(opts, "pade")?.unwrap_or(3),
    };
    let sol = run(&p, w1.as_ref(), w2.as_ref(), &o).map_err(|e| Error::Failed(format!("ncfsyn: {e}")))?;
    let mut v = skyloop::json_out::ncfsyn_json(&sol);
    let c = &sol.controller;
    let p_rational = p.try_pade(o.pade_order)?;
    let (_, inv_b) = four_block_norms(&p_rational, None, None, c)?;
    let l = skyloop::lti::interconnect::series(c, &p_rational)?;
    let freq_hz = skyloop::response::default_grid_hz(&l, 300)?;
    let (_, runs) = skyloop::figures::step(
        &[Labeled {
            label: "closed loop".into(),
            sys: l,
        }],
        true,
        None,
    )?;
    v["analysis"] = json!({
        "b_pc": 1.0 / inv_b,
        "order": c.nx(),
        "margins": loop_margins(&p, c)?,
        "loop": loop_response(&p, c, &freq_hz)?,
        "step": runs,
    });
    Ok(v)
}

/// `skyloop export CONTROLLER --dt T --c F.h` as text (the header the CLI writes), `float`, no
/// output limits.
///
/// # Errors
/// A bad controller, sample time or C name.
pub fn c_header(controller: &str, dt_s: f64, name: &str) -> Result<String> {
    let sys = model_of(controller)?;
    let (text, _) =
        skyloop::export::c_header::controller_header(&sys, dt_s, name, "float", -1e30, 1e30, "skyloop web")?;
    Ok(text)
}
