// The Web Worker that runs skyloop (WebAssembly): the page never waits on a computation.
// Protocol: the page posts {id, fn, args}; the worker answers {id, ok: true, result} or
// {id, ok: false, error}; a log tune's stages arrive as {progress: {axis, stage}}. A panic (a bug
// of ours) answers with its message and {dead: true}: the page then starts a fresh worker.
import init, * as sky from "./pkg/skyloop_web.js";

let panicMessage = null;
const ready = init({ module_or_path: new URL("./pkg/skyloop_web_bg.wasm", import.meta.url) }).then(() => {
  sky.set_progress(
    (axis, stage) => postMessage({ progress: { axis, stage } }),
    (msg) => { panicMessage = msg; },
  );
});

const FUNCS = {
  log_info: (a) => sky.log_info(a.bytes, a.name, a.session || 0),
  identify: (a) => sky.identify(a.bytes, a.name, JSON.stringify(a.opts || {})),
  tune_log: (a) => sky.tune_log(a.bytes, a.name, JSON.stringify(a.opts || {})),
  retune: (a) => sky.retune(JSON.stringify(a.gains)),
  margins: (a) => sky.margins(a.model),
  freqresp: (a) => sky.freqresp(a.model, a.hz ? JSON.stringify(a.hz) : ""),
  step: (a) => sky.step(a.model, !!a.closed_loop),
  ncfsyn: (a) => sky.ncfsyn(JSON.stringify(a.opts)),
  c_header: (a) => sky.c_header(a.controller, a.dt, a.name),
};

onmessage = async (ev) => {
  const { id, fn, args } = ev.data;
  try {
    await ready;
    const f = FUNCS[fn];
    if (!f) throw new Error(`unknown request ${fn}`);
    const t0 = performance.now();
    const text = f(args || {});
    const ms = performance.now() - t0;
    const result = fn === "c_header" ? text : JSON.parse(text);
    postMessage({ id, ok: true, result, ms });
  } catch (e) {
    if (panicMessage !== null || e instanceof WebAssembly.RuntimeError) {
      postMessage({ id, ok: false, error: panicMessage || `internal error (please report it): ${e}`, dead: true });
      return;
    }
    postMessage({ id, ok: false, error: e && e.message ? e.message : String(e) });
  }
};
