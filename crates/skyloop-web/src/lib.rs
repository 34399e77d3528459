//! skyloop in the browser: the `skyloop` library compiled to `wasm32-unknown-unknown` with
//! wasm-bindgen, for the static page in `web/`. Every function takes and returns the JSON objects
//! the CLI prints with `--json` (as text), computed by the same library functions, so the page's
//! numbers are the CLI's. The page runs them in a Web Worker; a long log tune reports its stages
//! through the function given to [`set_progress`].
//!
//! The Rust side of each request is in [`api`] (plain Rust, tested on the host); this file only
//! converts errors to JavaScript exceptions and keeps the last log tune for [`retune`].

pub mod api;

use serde_json::Value;
use skyloop::firmware::Axis;
use skyloop::tune::live::LiveLoop;
use std::cell::RefCell;
use wasm_bindgen::prelude::*;

thread_local! {
    /// The JavaScript function that receives progress messages (`axis`, `stage`).
    static PROGRESS: RefCell<Option<js_sys::Function>> = const { RefCell::new(None) };
    /// The JavaScript function that receives a panic's message before the module traps.
    static PANIC_SINK: RefCell<Option<js_sys::Function>> = const { RefCell::new(None) };
    /// The last log tune's model, for [`retune`].
    static LIVE: RefCell<Option<LiveLoop>> = const { RefCell::new(None) };
}

/// A library error as a JavaScript exception carrying the message the CLI would print.
fn js_err(e: skyloop::Error) -> JsError {
    JsError::new(&e.to_string())
}

fn to_text(v: skyloop::Result<Value>) -> Result<String, JsError> {
    v.map(|v| v.to_string()).map_err(js_err)
}

fn parse_opts(opts: &str) -> Result<Value, JsError> {
    if opts.trim().is_empty() {
        return Ok(Value::Object(Default::default()));
    }
    serde_json::from_str(opts).map_err(|e| JsError::new(&format!("options are not JSON: {e}")))
}

/// Sets the functions that receive progress messages (`f(axis, stage)`) and a panic's message
/// (`g(message)`; a panic is a bug of ours: the page shows it, then restarts the worker). Also
/// installs the panic hook.
#[wasm_bindgen]
pub fn set_progress(f: js_sys::Function, g: js_sys::Function) {
    PROGRESS.with(|p| *p.borrow_mut() = Some(f));
    PANIC_SINK.with(|p| *p.borrow_mut() = Some(g));
    std::panic::set_hook(Box::new(|info| {
        let msg = format!("internal error (please report it): {info}");
        PANIC_SINK.with(|p| {
            if let Some(g) = p.borrow().as_ref() {
                let _ = g.call1(&JsValue::NULL, &JsValue::from_str(&msg));
            }
        });
    }));
}

/// The log tune's progress callback: forwards to the page's function.
fn post_progress(axis: Axis, stage: &str) {
    PROGRESS.with(|p| {
        if let Some(f) = p.borrow().as_ref() {
            let _ = f.call2(
                &JsValue::NULL,
                &JsValue::from_str(axis.name()),
                &JsValue::from_str(stage),
            );
        }
    });
}

/// `skyloop log info --json` of a log's bytes (`session` from 1; 0: the longest).
#[wasm_bindgen]
pub fn log_info(bytes: &[u8], name: &str, session: u32) -> Result<String, JsError> {
    to_text(api::log_info(bytes, name, (session > 0).then_some(session as usize)))
}

/// `skyloop identify --axis A --json` of a log's bytes; `opts` as [`api::identify`].
#[wasm_bindgen]
pub fn identify(bytes: &[u8], name: &str, opts: &str) -> Result<String, JsError> {
    to_text(api::identify(bytes, name, &parse_opts(opts)?))
}

/// `skyloop tune LOG --axis A --json` of a log's bytes; `opts` as [`api::tune_log`]. Keeps the
/// identified model for [`retune`].
#[wasm_bindgen]
pub fn tune_log(bytes: &[u8], name: &str, opts: &str) -> Result<String, JsError> {
    let (v, live) = api::tune_log(bytes, name, &parse_opts(opts)?, Some(post_progress)).map_err(js_err)?;
    LIVE.with(|l| *l.borrow_mut() = live);
    Ok(v.to_string())
}

/// Another gain set (the firmware's keys, `dterm_hz`, and `robust`: false for the nominal plant
/// alone, while a slider is dragged) analysed on the last log tune's model: [`LiveLoop::evaluate`]'s
/// JSON.
#[wasm_bindgen]
pub fn retune(gains: &str) -> Result<String, JsError> {
    let v = parse_opts(gains)?;
    LIVE.with(|l| match l.borrow().as_ref() {
        Some(live) => {
            let robust = v.get("robust").and_then(Value::as_bool).unwrap_or(true);
            to_text(live.gains(&v).and_then(|g| live.evaluate(&g, robust)))
        }
        None => Err(JsError::new(
            "no log tune with flown gains to re-analyse: tune a Betaflight, INAV or PX4 log first",
        )),
    })
}

/// `skyloop margins MODEL --json`.
#[wasm_bindgen]
pub fn margins(model: &str) -> Result<String, JsError> {
    to_text(api::margins(model))
}

/// `skyloop freqresp MODEL --hz .. --json`; `hz`: a JSON list of frequencies, or empty for the
/// CLI's default grid.
#[wasm_bindgen]
pub fn freqresp(model: &str, hz: &str) -> Result<String, JsError> {
    let f = if hz.trim().is_empty() {
        None
    } else {
        Some(serde_json::from_str(hz).map_err(|e| JsError::new(&format!("hz: a JSON list of numbers: {e}")))?)
    };
    to_text(api::freqresp(model, f))
}

/// `skyloop step MODEL [--closed-loop] --json`.
#[wasm_bindgen]
pub fn step(model: &str, closed_loop: bool) -> Result<String, JsError> {
    to_text(api::step(model, closed_loop))
}

/// `skyloop ncfsyn --json` with the loop analysed; `opts` as [`api::ncfsyn`].
#[wasm_bindgen]
pub fn ncfsyn(opts: &str) -> Result<String, JsError> {
    to_text(api::ncfsyn(&parse_opts(opts)?))
}

/// The C header `skyloop export CONTROLLER --dt T --c F.h --name N` writes.
#[wasm_bindgen]
pub fn c_header(controller: &str, dt_s: f64, name: &str) -> Result<String, JsError> {
    api::c_header(controller, dt_s, name).map_err(js_err)
}
