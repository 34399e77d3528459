// The page: a log → tune workflow and a loop-shaping workflow, every number computed by skyloop
// (WebAssembly) in a Web Worker. window.skyloop exposes the state and timings to the browser test.
"use strict";

const $ = (id) => document.getElementById(id);
const fmt = (x, d = 2) => (x === null || x === undefined || !isFinite(x) ? "—" : Number(x).toFixed(d));
const timings = {};
const state = { bytes: null, name: null, tune: null, flownEval: null, knobs: null, live: null, pending: null, busy: false };

// ---- the worker -------------------------------------------------------------------------------

let worker = null, nextId = 1;
const waiting = new Map();
function startWorker() {
  worker = new Worker("worker.js", { type: "module" });
  worker.onmessage = (ev) => {
    const m = ev.data;
    if (m.progress) { $("progress").textContent = `${m.progress.axis}: ${m.progress.stage} …`; return; }
    const w = waiting.get(m.id);
    if (!w) return;
    waiting.delete(m.id);
    if (m.ms !== undefined) timings.last_compute_ms = m.ms;
    if (m.ok) w.resolve(m.result); else w.reject(new Error(m.error));
    if (m.dead) {
      // A panic left the module unusable: a fresh worker (the log must be tuned again).
      for (const other of waiting.values()) other.reject(new Error(m.error));
      waiting.clear();
      worker.terminate();
      startWorker();
    }
  };
  worker.onerror = (e) => {
    for (const w of waiting.values()) w.reject(new Error(`the worker failed: ${e.message || e}`));
    waiting.clear();
  };
}
/** One request to skyloop in the worker: a promise of its JSON. */
function rpc(fn, args) {
  return new Promise((resolve, reject) => {
    const id = nextId++;
    waiting.set(id, { resolve, reject });
    worker.postMessage({ id, fn, args });
  });
}
startWorker();

function showError(box, e) {
  box.hidden = !e;
  box.textContent = e ? (e.message || String(e)) : "";
}

// ---- log → tune ----------------------------------------------------------------------------------

async function loadLog(name, bytes) {
  state.bytes = bytes; state.name = name;
  $("file-name").textContent = `${name} (${(bytes.length / 1e6).toFixed(2)} MB)`;
  showError($("error"), null);
  $("results").hidden = true;
  $("run-tune").disabled = true;
  const sel = $("session");
  sel.innerHTML = "";
  const t0 = performance.now();
  try {
    const info = await rpc("log_info", { bytes, name });
    timings.log_info_ms = performance.now() - t0;
    sel.add(new Option("longest", "0"));
    for (const s of info.sessions || []) {
      const text = s.error ? `${s.index}: not decodable` : `${s.index}: ${fmt(s.duration_s, 1)} s, ${s.firmware}`;
      const o = new Option(text, String(s.index));
      o.disabled = !!s.error;
      sel.add(o);
    }
    $("progress").textContent = `${info.format} log, ${fmt(info.duration_s, 1)} s` + (info.sessions && info.sessions.length ? `, ${info.sessions.length} sessions` : "");
    $("run-tune").disabled = false;
  } catch (e) {
    $("progress").textContent = "";
    showError($("error"), e);
  }
}

async function runTune() {
  showError($("error"), null);
  $("run-tune").disabled = true;
  const opts = { axis: $("axis").value, session: Number($("session").value) || null };
  const t0 = performance.now();
  try {
    const v = await rpc("tune_log", { bytes: state.bytes, name: state.name, opts });
    timings.tune_ms = performance.now() - t0;
    state.tune = v;
    $("progress").textContent = `tuned in ${(timings.tune_ms / 1000).toFixed(1)} s`;
    renderTune(v);
    if (v.live) {
      state.flownEval = await rpc("retune", { gains: knobValues(v.live.flown) });
      buildSliders(v.live);
      await setKnobs(v.live.proposed);
    } else {
      $("sliders").textContent = "This log's header carries no flown gains for the axis: nothing to move from.";
    }
  } catch (e) {
    $("progress").textContent = "";
    showError($("error"), e);
  } finally {
    $("run-tune").disabled = false;
  }
}

function renderTune(v) {
  $("results").hidden = false;
  const kind = v.verdict.kind;
  $("verdict").className = `verdict ${kind}`;
  $("verdict").textContent = v.verdict.text;
  renderModel(v);
  renderCompare(v, null);
  const notes = [...(v.warnings || []).map((w) => `warning: ${w}`), ...(v.notes || [])];
  $("notes").innerHTML = "";
  for (const n of notes) { const li = document.createElement("li"); li.textContent = n; $("notes").appendChild(li); }
}

function renderModel(v) {
  const id = v.identification;
  const p = id.params, s = id.stderr;
  const row = (k, unit, scale, d) => `<tr><td>${k}</td><td>${fmt(p[k] * scale, d)} ± ${fmt(s[k] * scale, d)} ${unit}</td></tr>`;
  // The plant's units are the firmware's: PID sum → deg/s (Betaflight, INAV), torque → rad/s (PX4),
  // the rate controller's normalized output RATE.ROut → RATE.R in deg/s (ArduPilot).
  const kUnit = { px4: "(rad/s² per unit normalized torque)", ardupilot: "(deg/s² per unit RATE.ROut)" }[v.firmware]
    || "(deg/s² per PID-sum unit)";
  // Yaw's model has the rotors' reaction-torque zero Tz.
  const zero = p.Tz !== undefined;
  $("model").innerHTML = `<p class="formula">P(s) = K·${zero ? "(Tz·s + 1)·" : ""}e<sup>−Td·s</sup> / (s·(τ·s + 1))</p>
    <table class="kv">${row("K", kUnit, 1, 2)}${row("tau", "ms", 1e3, 2)}${row("Td", "ms", 1e3, 2)}${zero ? row("Tz", "ms", 1e3, 1) : ""}
    <tr><td>fit</td><td>${fmt(id.fit_percent, 1)} % over ${id.segments.length} airborne segments; uncertainty set: ${id.plants} plants</td></tr></table>`;
  const cur = v.current;
  const series = [];
  let x = null;
  if (v.causal_step) {
    x = v.causal_step.t_s;
    const lo = v.causal_step.y.map((y, k) => y - 2 * v.causal_step.y_std[k]);
    const hi = v.causal_step.y.map((y, k) => y + 2 * v.causal_step.y_std[k]);
    series.push({ label: "measured (causal FIR)", y: v.causal_step.y, color: COLORS.measured });
    series.push({ label: "−2σ", y: lo, color: "rgba(44,160,44,0.35)", width: 1 });
    series.push({ label: "+2σ", y: hi, color: "rgba(44,160,44,0.35)", width: 1 });
    if (cur) series.push({ label: "predicted, flown tune", y: x.map((t) => interp(cur.step.t_s, cur.step.y, t)), color: COLORS.flown });
  } else if (cur) {
    x = cur.step.t_s;
    series.push({ label: "predicted, flown tune", y: cur.step.y, color: COLORS.flown });
  }
  if (x) linePlot($("plot-check"), { x: x.map((t) => 1e3 * t), series, xLabel: "time [ms]", yLabel: "gyro / setpoint step", height: 200 });
  const rms = v.causal_step_rms;
  const cl = v.closed_loop_check;
  $("check-text").textContent = (rms !== null && rms !== undefined
    ? `RMS difference ${fmt(rms, 3)} per unit step (refused above 0.25): ${rms <= 0.25 ? "the model reproduces the flight" : "the model misses the flight"}.`
    : `no measured step: ${v.measured_step_error || "too little stick input"}.`) +
    (cl ? ` Closed loop setpoint → gyro: measured peak ${fmt(cl.measured_peak_db, 1)} dB, RMS difference ${fmt(cl.rms_db, 1)} dB.` : "");
}

/** Linear interpolation of (t, y) at x (held at the ends). */
function interp(t, y, x) {
  if (x <= t[0]) return y[0];
  for (let k = 1; k < t.length; k++) if (t[k] >= x) return y[k - 1] + (y[k] - y[k - 1]) * (x - t[k - 1]) / (t[k] - t[k - 1]);
  return y[y.length - 1];
}

/** The flown / proposed / your-gains table. */
function renderCompare(v, live) {
  const cols = [v.current, v.proposed, live];
  const head = `<tr><th></th><th>flown</th><th>proposed</th><th class="live">your gains</th></tr>`;
  const keys = Object.keys((v.current || v.proposed).gains);
  const g = (c, k) => (c ? c.gains[k] : undefined);
  const rows = keys.map((k) => [`gain ${k}`, (c) => { const x = g(c, k); return x === undefined ? "—" : String(+x.toFixed(6)); }]);
  const m = (f, d) => (c) => (c ? fmt(f(c), d) : "—");
  rows.push(
    ["disk margin α", m((c) => c.margins.disk_alpha, 3)],
    ["  worst over uncertainty", m((c) => (c.worst_margins ? c.worst_margins.disk_alpha : NaN), 3)],
    ["gain margin [dB]", m((c) => c.margins.gain_margin_db, 2)],
    ["phase margin [deg]", m((c) => c.margins.phase_margin_deg, 1)],
    ["crossover [Hz]", m((c) => c.margins.crossover_hz, 2)],
    ["Ms", m((c) => c.margins.ms, 3)],
    ["  worst over uncertainty", m((c) => (c.worst_margins ? c.worst_margins.ms : NaN), 3)],
    ["step rise time [ms]", m((c) => 1e3 * c.rise_time_s, 1)],
    ["step overshoot [%]", m((c) => c.overshoot_pct, 1)],
    ["motor noise vs flown", (c) => noiseRatio(v, c)],
    ["6-DOF overshoot 200 deg/s [%]", (c) => (c && c.flight ? fmt(c.flight.doublets[0].overshoot_pct, 1) : c === live && c ? "tune only" : "—")],
  );
  $("compare").innerHTML = head + rows.map(([name, f]) =>
    `<tr><td>${name.replace(/^  /, "&nbsp;&nbsp;")}</td>${cols.map((c, i) => `<td class="${i === 2 ? "live" : ""}">${f(c)}</td>`).join("")}</tr>`).join("");
}

function noiseRatio(v, c) {
  if (!c) return "—";
  if (c === v.current) return v.noise ? "1.00" : "—";
  if (c === v.proposed) return v.noise ? `×${fmt(v.noise.proposed / v.noise.flown, 2)}` : "—";
  return c.noise ? `×${fmt(c.noise.proposed / c.noise.flown, 2)}` : "—";
}

// ---- sliders -------------------------------------------------------------------------------------

/** The knob values a retune request takes: the firmware's gain keys and the D-term cutoffs. */
function knobValues(k) {
  return Object.assign({}, k.gains, { dterm_hz: k.dterm.map((s) => s.cutoff_hz) });
}

function buildSliders(live) {
  const box = $("sliders");
  box.innerHTML = "";
  const integer = Object.values(live.flown.gains).every((x) => Number.isInteger(x));
  const header = state.tune.current ? state.tune.current.gains : {};
  const add = (key, label, flown, proposed, min, max, step, unit) => {
    // Betaflight's d_min: the flown tune is analysed at the D the firmware applied.
    const applied = header[key] !== undefined && header[key] !== flown ? ` (d_min; header ${header[key]})` : "";
    const row = document.createElement("label");
    row.className = "slider";
    row.innerHTML = `<span class="name">${label}</span><input type="range" min="${min}" max="${max}" step="${step}" data-key="${key}">` +
      `<output></output><span class="muted small">flown ${+flown.toFixed(4)}${unit}${applied}, proposed ${+proposed.toFixed(4)}${unit}</span>`;
    row.querySelector("input").addEventListener("input", onSlider);
    row.querySelector("input").addEventListener("change", onSlider);
    box.appendChild(row);
  };
  for (const [k, f] of Object.entries(live.flown.gains)) {
    const p = live.proposed.gains[k];
    const top = Math.max(2 * Math.max(f, p), integer ? 10 : 1e-3);
    add(k, k, f, p, 0, integer ? Math.round(top) : top, integer ? 1 : top / 400, "");
  }
  live.flown.dterm.forEach((s, i) => {
    if (!s.movable) return;
    add(`dterm_hz.${i}`, `D-term ${s.kind} [Hz]`, s.cutoff_hz, live.proposed.dterm[i].cutoff_hz,
      Math.round(s.cutoff_hz * 0.3), Math.round(s.cutoff_hz * 3), 1, " Hz");
  });
}

/** The knobs with the sliders' values (a cutoff's slider only when it was moved). */
function readSliders(moved) {
  const k = JSON.parse(JSON.stringify(state.knobs));
  for (const inp of $("sliders").querySelectorAll("input")) {
    const key = inp.dataset.key, val = Number(inp.value);
    if (key.startsWith("dterm_hz.")) { if (inp === moved) k.dterm[Number(key.split(".")[1])].cutoff_hz = val; }
    else k.gains[key] = val;
    if (!key.startsWith("dterm") || inp === moved) inp.parentElement.querySelector("output").textContent = key.startsWith("dterm") ? `${val} Hz` : String(+val.toFixed(6));
  }
  return k;
}

/** Puts the sliders at `k` and analyses `k` itself (a slider's step could round a cutoff). */
async function setKnobs(k) {
  state.knobs = JSON.parse(JSON.stringify(k));
  for (const inp of $("sliders").querySelectorAll("input")) {
    const key = inp.dataset.key;
    const val = key.startsWith("dterm_hz.") ? k.dterm[Number(key.split(".")[1])].cutoff_hz : k.gains[key];
    inp.value = val;
    inp.parentElement.querySelector("output").textContent = key.startsWith("dterm") ? `${val} Hz` : String(+val.toFixed(6));
  }
  await evaluate(state.knobs);
}

function onSlider(ev) {
  state.knobs = readSliders(ev.target);
  evaluate(state.knobs, ev.type === "change");
}

/**
 * Re-analyses the knobs: while a slider is dragged on the nominal plant (`robust` false), on
 * release over the whole uncertainty set. While one request runs only the latest waits (no
 * backlog); a waiting release keeps its robust analysis.
 */
async function evaluate(knobs, robust = true) {
  if (state.busy) {
    state.pending = { knobs, robust: robust || (state.pending !== null && state.pending.robust) };
    return;
  }
  state.busy = true;
  const t0 = performance.now();
  try {
    const r = await rpc("retune", { gains: Object.assign(knobValues(knobs), { robust }) });
    state.live = r;
    renderLive(r);
    timings.last_render_ms = performance.now() - t0;
    timings.renders = (timings.renders || 0) + 1;
    if (robust) timings.robust_renders = (timings.robust_renders || 0) + 1;
    $("timing").textContent = `re-verified in ${fmt(timings.last_compute_ms, 0)} ms, drawn in ${fmt(timings.last_render_ms - timings.last_compute_ms, 0)} ms`;
    showError($("error"), null);
  } catch (e) {
    showError($("error"), e);
  } finally {
    state.busy = false;
    if (state.pending) { const p = state.pending; state.pending = null; evaluate(p.knobs, p.robust); }
  }
}

function renderLive(r) {
  const v = state.tune, f = state.flownEval;
  renderBadge(r);
  renderCompare(v, r);
  renderBode($("plot-mag"), $("plot-phase"), [
    { label: "flown", e: f, color: COLORS.flown },
    { label: "your gains", e: r, color: COLORS.live },
  ], r.margins);
  nyquistPlot($("nyquist"), [
    { label: "flown", re: f.loop.re, im: f.loop.im, color: COLORS.flown },
    { label: "your gains", re: r.loop.re, im: r.loop.im, color: COLORS.live },
  ], r.disk);
  const st = v.proposed.step;
  linePlot($("plot-step"), {
    x: st.t_s.map((t) => 1e3 * t),
    series: [
      { label: "flown", y: f.step.y, color: COLORS.flown },
      { label: "proposed", y: v.proposed.step.y, color: COLORS.proposed, dash: [6, 4] },
      { label: "your gains", y: r.step.y, color: COLORS.live },
    ],
    xLabel: "time [ms]", yLabel: "gyro / setpoint step", height: 230,
  });
  renderNoise(r);
  renderCli(r);
}

function renderBadge(r) {
  // Judged on the worst case over the uncertainty set; while a slider is dragged, on the nominal.
  const m = r.margins, w = r.worst_margins || m;
  const level = !m.stable || !w.stable ? "bad" : w.disk_alpha >= 0.5 ? "good" : w.disk_alpha >= 0.3 ? "fair" : "bad";
  const word = { good: "robust", fair: "thin margins", bad: m.stable ? "fragile" : "UNSTABLE" }[level];
  $("badge").className = `badge ${level}`;
  $("badge").innerHTML = `<div class="big">${word}</div>
    <div>disk α <b>${fmt(m.disk_alpha, 3)}</b> <small>${r.worst_margins ? `(worst ${fmt(w.disk_alpha, 3)})` : "(nominal; worst case on release)"}</small></div>
    <div>GM <b>${fmt(m.gain_margin_db, 1)} dB</b> · PM <b>${fmt(m.phase_margin_deg, 1)}°</b></div>
    <div>Ms <b>${fmt(m.ms, 2)}</b> · crossover <b>${fmt(m.crossover_hz, 1)} Hz</b></div>`;
}

/** The first frequency above `from_hz` where the unwrapped phase crosses −180° (mod 360). */
function phaseCrossover(loop, from_hz) {
  const f = loop.freq_hz, ph = loop.phase_deg;
  for (let k = 1; k < f.length; k++) {
    if (f[k] <= from_hz) continue;
    const a = Math.floor((ph[k - 1] + 180) / 360), b = Math.floor((ph[k] + 180) / 360);
    if (a !== b) return f[k - 1] + (f[k] - f[k - 1]) * 0.5;
  }
  return NaN;
}

/** Bode magnitude and phase of several evaluations, with the last one's margins marked. */
function renderBode(magEl, phEl, curves, m) {
  const last = curves[curves.length - 1].e.loop;
  const x = last.freq_hz;
  const fgm = phaseCrossover(last, m.crossover_hz);
  const magAt = (fr) => interp(x, last.mag_db, fr);
  const phAt = (fr) => interp(x, last.phase_deg, fr);
  const marks = [
    { x: m.crossover_hz, y: 0, label: `crossover ${fmt(m.crossover_hz, 1)} Hz`, color: COLORS.live },
    { x: fgm, y: magAt(fgm), label: `GM ${fmt(m.gain_margin_db, 1)} dB`, color: "#9467bd" },
  ];
  linePlot(magEl, {
    x, logX: true, height: 200, xLabel: "frequency [Hz]", yLabel: "|L| [dB]",
    series: curves.map((c) => ({ label: c.label, y: c.e.loop.mag_db, color: c.color, dash: c.dash })),
    marks, hlines: [{ y: 0, label: "0 dB" }],
  });
  const pc = phAt(m.crossover_hz);
  const turn = Math.round((pc + 180) / 360) * 360 - 180;
  // A delay turns the phase without end: the window shows two turns around the −180° the margins read.
  const top = Math.max(...curves.map((c) => Math.max(...c.e.loop.phase_deg)));
  const yRange = [turn - 360, Math.min(top, turn + 360) + 20];
  linePlot(phEl, { yRange,
    x, logX: true, height: 200, xLabel: "frequency [Hz]", yLabel: "phase of L [deg]",
    series: curves.map((c) => ({ label: c.label, y: c.e.loop.phase_deg, color: c.color, dash: c.dash })),
    marks: [{ x: m.crossover_hz, y: pc, label: `PM ${fmt(m.phase_margin_deg, 1)}°`, color: COLORS.live },
      { x: fgm, y: phAt(fgm), label: "", color: "#9467bd" }],
    hlines: [{ y: turn, label: `${turn}°` }],
  });
}

function renderNoise(r) {
  const n = r.noise;
  if (!n) { $("noise-text").textContent = "no gyro spectrum in this log: noise not predicted"; return; }
  $("noise-text").textContent = `motor-command noise power in ${fmt(n.band_hz[0], 0)}–${fmt(n.band_hz[1], 0)} Hz: ×${fmt(n.proposed / n.flown, 2)} the flown tune's (the tuner's budget: ×1.25)` +
    (n.spectra ? "" : "; spectrum redrawn on release");
  const s = n.spectra;
  if (!s) return;
  const pos = (a) => a.map((y) => (y > 0 ? y : null));
  linePlot($("plot-noise"), {
    x: s.freq_hz, logX: true, logY: true, height: 230,
    xLabel: "frequency [Hz]", yLabel: "PSD [(PID unit)²/Hz]",
    series: [
      { label: "flown", y: pos(s.flown_output_psd), color: COLORS.flown },
      { label: "your gains", y: pos(s.proposed_output_psd), color: COLORS.live },
    ],
    marks: [{ x: n.band_hz[0], label: `noise band from ${fmt(n.band_hz[0], 0)} Hz`, color: "#444" }],
  });
}

function renderCli(r) {
  const v = state.tune;
  const same = JSON.stringify(r.gains) === JSON.stringify(v.proposed.gains) && JSON.stringify(state.knobs.dterm) === JSON.stringify(v.live.proposed.dterm);
  let lines = same && v.cli.length ? v.cli : r.cli.slice();
  if (!same) {
    // The proposal's d_min line (the library adds it to a Betaflight proposal when d_min flew).
    const dmin = (v.cli || []).find((l) => l.startsWith("set d_min_"));
    if (dmin) lines.splice(Math.max(0, lines.length - 1), 0, dmin);
  }
  const moved = state.knobs.dterm.some((s, i) => s.cutoff_hz !== v.live.flown.dterm[i].cutoff_hz);
  $("cli-for").textContent = same ? "(the proposal)" : "(your gains)";
  $("cli").textContent = lines.join("\n") + (moved ? "\n# D-term cutoffs moved: set them in the firmware's filter settings too" : "");
}

// ---- loop shaping --------------------------------------------------------------------------------

let ncfTimer = null, ncfLast = null;
function scheduleNcf() { clearTimeout(ncfTimer); ncfTimer = setTimeout(runNcf, 250); }

async function runNcf() {
  const opts = {
    plant: $("ncf-p").value, w1: $("ncf-w1").value, w2: $("ncf-w2").value,
    pade: Number($("ncf-pade").value), factor: Number($("ncf-factor").value),
  };
  $("ncf-status").textContent = "synthesizing …";
  const t0 = performance.now();
  try {
    const v = await rpc("ncfsyn", { opts });
    timings.ncfsyn_ms = performance.now() - t0;
    ncfLast = v;
    showError($("ncf-error"), null);
    renderNcf(v);
    $("ncf-status").textContent = `done in ${fmt(timings.ncfsyn_ms, 0)} ms`;
    $("ncf-json").disabled = $("ncf-c").disabled = false;
  } catch (e) {
    $("ncf-status").textContent = "";
    showError($("ncf-error"), e);
    $("ncf-json").disabled = $("ncf-c").disabled = true;
  }
}

function renderNcf(v) {
  const a = v.analysis, m = a.margins;
  $("ncf-out").innerHTML = `<div class="stat"><span>γ<sub>min</sub></span><b>${fmt(v.gamma_min, 4)}</b></div>
    <div class="stat"><span>γ</span><b>${fmt(v.gamma, 4)}</b></div>
    <div class="stat"><span>b(P,C)</span><b>${fmt(a.b_pc, 4)}</b></div>
    <div class="stat"><span>controller order</span><b>${a.order}</b></div>
    <div class="stat"><span>PM</span><b>${fmt(m.phase_margin_deg, 1)}° at ${fmt(m.crossover_hz, 2)} Hz</b></div>
    <div class="stat"><span>GM</span><b>${fmt(m.gain_margin_db, 2)} dB</b></div>
    <div class="stat"><span>disk α</span><b>${fmt(m.disk_alpha, 3)}</b></div>
    <div class="stat"><span>Ms</span><b>${fmt(m.ms, 3)}</b></div>
    <div class="stat"><span>closed loop</span><b>${m.stable ? "stable" : "UNSTABLE"}</b></div>`;
  renderBode($("ncf-mag"), $("ncf-phase"), [{ label: "L = P·C", e: { loop: a.loop }, color: COLORS.live }], m);
  const run = a.step[0];
  linePlot($("ncf-step"), {
    x: run.t_s, series: [{ label: "y / r", y: run.y[0][0], color: COLORS.proposed }],
    xLabel: "time [s]", yLabel: "output / reference step", height: 260,
  });
}

function download(name, text, type) {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(new Blob([text], { type }));
  a.download = name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

// ---- wiring --------------------------------------------------------------------------------------

function setMode(mode) {
  for (const t of document.querySelectorAll(".tab")) t.classList.toggle("active", t.dataset.mode === mode);
  $("mode-tune").hidden = mode !== "tune";
  $("mode-shape").hidden = mode !== "shape";
  if (mode === "shape" && !ncfLast) runNcf();
}

function wire() {
  for (const t of document.querySelectorAll(".tab")) t.addEventListener("click", () => setMode(t.dataset.mode));
  const readFile = async (file) => loadLog(file.name, new Uint8Array(await file.arrayBuffer()));
  $("file").addEventListener("change", (e) => e.target.files[0] && readFile(e.target.files[0]));
  const drop = $("drop");
  drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => {
    e.preventDefault(); drop.classList.remove("over");
    if (e.dataTransfer.files[0]) readFile(e.dataTransfer.files[0]);
  });
  $("run-tune").addEventListener("click", runTune);
  $("set-flown").addEventListener("click", () => state.tune && state.tune.live && setKnobs(state.tune.live.flown));
  $("set-proposed").addEventListener("click", () => state.tune && state.tune.live && setKnobs(state.tune.live.proposed));
  $("copy-cli").addEventListener("click", async () => {
    try { await navigator.clipboard.writeText($("cli").textContent); $("copy-cli").textContent = "Copied"; }
    catch { $("copy-cli").textContent = "Select the text and copy"; }
    setTimeout(() => { $("copy-cli").textContent = "Copy CLI lines"; }, 1500);
  });
  for (const id of ["ncf-p", "ncf-w1", "ncf-w2", "ncf-pade", "ncf-factor"]) $(id).addEventListener("input", scheduleNcf);
  $("ncf-json").addEventListener("click", () => ncfLast && download("controller.json", JSON.stringify(ncfLast.controller), "application/json"));
  $("ncf-c").addEventListener("click", async () => {
    if (!ncfLast) return;
    try {
      const text = await rpc("c_header", { controller: JSON.stringify(ncfLast.controller), dt: Number($("ncf-dt").value), name: "skyloop_ctrl" });
      download("skyloop_ctrl.h", text, "text/x-c");
    } catch (e) { showError($("ncf-error"), e); }
  });
}

/** ?demo=1: the bundled Betaflight log, tuned at once; ?mode=shape opens loop shaping. */
async function startFromQuery() {
  const q = new URLSearchParams(location.search);
  if (q.get("mode") === "shape") setMode("shape");
  const demo = q.get("demo");
  if (!demo) return;
  const name = demo === "1" ? "demo.bbl" : demo;
  const res = await fetch(`testdata/${name}`);
  if (!res.ok) { showError($("error"), new Error(`cannot load the demo log testdata/${name}: HTTP ${res.status}`)); return; }
  await loadLog(name, new Uint8Array(await res.arrayBuffer()));
  if (q.get("axis")) $("axis").value = q.get("axis");
  if (q.get("session")) $("session").value = q.get("session");
  await runTune();
}

window.skyloop = { rpc, state, timings, setKnobs };
wire();
startFromQuery();
