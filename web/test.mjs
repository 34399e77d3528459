// The browser test of the page in web/dist (build it first with web/build.sh):
//   cd web && npm ci && node test.mjs
// Serves web/dist on a local port, opens it in headless Chromium (Debian's /usr/bin/chromium, or
// $CHROMIUM), and checks that
//   - ?demo=1 tunes the bundled Betaflight log and shows the same gains, margins and CLI lines as
//     `skyloop tune LOG --axis roll --firmware betaflight --json` (the CLI binary: $SKYLOOP_CLI, or
//     target/release/skyloop, or target/debug/skyloop), to 1e-6;
//   - the live re-analysis at the proposed gains equals the CLI's proposed margins;
//   - moving a slider changes the plots' data and the robustness badge;
//   - a file that is not a log gives an error on the page;
//   - loop shaping shows the CLI's ncfsyn γ for the same plant and weights.
// Prints two speed figures (parse + identify of the ~2-minute log, slider re-render), saves
// screenshots to web/screenshots/, exits 1 on a failed check.
import { chromium } from "playwright-core";
import { execFileSync } from "node:child_process";
import { createServer } from "node:http";
import { existsSync, mkdirSync, readFileSync, statSync } from "node:fs";
import { dirname, extname, join, normalize } from "node:path";
import { fileURLToPath } from "node:url";

const here = dirname(fileURLToPath(import.meta.url));
const root = join(here, "..");
const dist = join(here, "dist");
const shots = join(here, "screenshots");
const LOG = join(root, "testdata/logs/btfl_all.bbl");
const TOL = 1e-6;
let failures = 0;

function check(ok, what) {
  console.log(`${ok ? "ok  " : "FAIL"}  ${what}`);
  if (!ok) failures++;
}
let worstRel = 0;
const close = (a, b) => {
  if (typeof a !== "number" || typeof b !== "number") return false;
  worstRel = Math.max(worstRel, Math.abs(a - b) / Math.max(1, Math.abs(b)));
  return Math.abs(a - b) <= TOL * Math.max(1, Math.abs(b));
};

function cliBinary() {
  for (const p of [process.env.SKYLOOP_CLI, join(root, "target/release/skyloop"), join(root, "target/debug/skyloop")]) {
    if (p && existsSync(p)) return p;
  }
  throw new Error("no skyloop CLI binary: build it (cargo build --release -p skyloop-cli) or set SKYLOOP_CLI");
}

function cliJson(args) {
  return JSON.parse(execFileSync(cliBinary(), args, { cwd: root, maxBuffer: 1 << 28, stdio: ["ignore", "pipe", "ignore"] }).toString());
}

const MIME = { ".html": "text/html", ".js": "text/javascript", ".mjs": "text/javascript", ".css": "text/css", ".wasm": "application/wasm", ".json": "application/json" };
function serve() {
  const server = createServer((req, res) => {
    const path = normalize(decodeURIComponent(new URL(req.url, "http://x").pathname)).replace(/^(\.\.[/\\])+/, "");
    let file = join(dist, path);
    if (existsSync(file) && statSync(file).isDirectory()) file = join(file, "index.html");
    if (!file.startsWith(dist) || !existsSync(file)) { res.writeHead(404); res.end("not found"); return; }
    res.writeHead(200, { "content-type": MIME[extname(file)] || "application/octet-stream" });
    res.end(readFileSync(file));
  });
  return new Promise((resolve) => server.listen(0, "127.0.0.1", () => resolve(server)));
}

/** Every (path, value) number of `ref` at the given paths equals the page's. */
function compareAt(page, ref, paths, label) {
  for (const p of paths) {
    const get = (o) => p.split(".").reduce((x, k) => (x === null || x === undefined ? x : x[k]), o);
    const a = get(page), b = get(ref);
    check(close(a, b), `${label} ${p}: page ${a}, CLI ${b}`);
  }
}

async function demo(browser, base, ref) {
  const page = await browser.newPage({ viewport: { width: 1360, height: 1000 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  await page.goto(`${base}/index.html?demo=1`);
  await page.waitForFunction(() => window.skyloop && window.skyloop.state.live, null, { timeout: 600000 });
  await page.waitForTimeout(300);
  const v = await page.evaluate(() => window.skyloop.state.tune);
  const timings = await page.evaluate(() => window.skyloop.timings);
  console.log(`page: log info ${timings.log_info_ms.toFixed(0)} ms, whole tune ${(timings.tune_ms / 1000).toFixed(1)} s`);
  const margins = ["disk_alpha", "gain_margin_db", "phase_margin_deg", "crossover_hz", "ms", "mt"];
  compareAt(v, ref, [...margins.map((m) => `proposed.margins.${m}`), ...margins.map((m) => `current.margins.${m}`),
    ...margins.map((m) => `proposed.worst_margins.${m}`), "identification.params.K", "identification.params.tau",
    "identification.params.Td", "noise.ratio", "causal_step_rms"], "tune");
  for (const k of Object.keys(ref.gains)) compareAt(v, ref, [`gains.${k}`, `current.gains.${k}`], "gain");
  check(JSON.stringify(v.cli) === JSON.stringify(ref.cli), `CLI lines: page ${JSON.stringify(v.cli)}, CLI ${JSON.stringify(ref.cli)}`);
  check(v.verdict.text === ref.verdict.text, `verdict: ${v.verdict.text}`);
  // The live re-analysis at the proposed gains: the same library call as the CLI's proposal check.
  const live = await page.evaluate(() => window.skyloop.state.live);
  for (const m of margins) check(close(live.margins[m], ref.proposed.margins[m]), `live ${m} ${live.margins[m]} = CLI proposed ${ref.proposed.margins[m]}`);
  // What the page shows: the badge and the table carry the CLI's numbers.
  const badge = await page.textContent("#badge");
  check(badge.includes(ref.proposed.margins.disk_alpha.toFixed(3)), `badge shows disk α ${ref.proposed.margins.disk_alpha.toFixed(3)}: "${badge.replace(/\s+/g, " ").trim()}"`);
  const cells = await page.$$eval("#compare tr", (rows) => rows.map((r) => [...r.children].map((c) => c.textContent)));
  for (const k of Object.keys(ref.gains)) {
    const row = cells.find((r) => r[0] === `gain ${k}`);
    check(row && Number(row[2]) === ref.gains[k] && Number(row[1]) === ref.current.gains[k], `table gain ${k}: flown ${row && row[1]} proposed ${row && row[2]} (CLI ${ref.current.gains[k]} → ${ref.gains[k]})`);
  }
  const alphaRow = cells.find((r) => r[0] === "disk margin α");
  check(alphaRow && alphaRow[2] === ref.proposed.margins.disk_alpha.toFixed(3), `table disk α proposed ${alphaRow && alphaRow[2]}`);
  check((await page.textContent("#cli")).trim() === ref.cli.join("\n"), "the lines to paste are the CLI's");
  mkdirSync(shots, { recursive: true });
  await page.screenshot({ path: join(shots, "tune-demo.png"), fullPage: true });
  await sliders(page);
  await speed(page);
  await badInput(page);
  check(errors.length === 0, `no page errors ${errors.join("; ")}`);
  await page.close();
}

async function sliders(page) {
  const before = await page.evaluate(() => ({ live: window.skyloop.state.live, badge: document.querySelector("#badge").textContent, renders: window.skyloop.timings.renders }));
  const times = [], computeTimes = [];
  const pInput = "#sliders input[data-key=p]";
  const pMax = Number(await page.getAttribute(pInput, "max"));
  const p0 = Number(await page.inputValue(pInput));
  const values = [0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9].map((f) => Math.round(f * pMax)).filter((x) => x !== p0);
  for (const x of values) {
    const n = await page.evaluate(() => window.skyloop.timings.renders);
    await page.$eval(pInput, (el, val) => { el.value = String(val); el.dispatchEvent(new Event("input")); }, x);
    await page.waitForFunction((m) => window.skyloop.timings.renders > m, n, { timeout: 60000 });
    times.push(await page.evaluate(() => window.skyloop.timings.last_render_ms));
    computeTimes.push(await page.evaluate(() => window.skyloop.timings.last_compute_ms));
  }
  // Released: the whole uncertainty set again.
  const nr = await page.evaluate(() => window.skyloop.timings.robust_renders);
  await page.$eval(pInput, (el) => el.dispatchEvent(new Event("change")));
  await page.waitForFunction((m) => window.skyloop.timings.robust_renders > m, nr, { timeout: 60000 });
  const nPlants = await page.evaluate(() => window.skyloop.state.tune.identification.plants);
  const robustMs = await page.evaluate(() => [window.skyloop.timings.last_render_ms, window.skyloop.timings.last_compute_ms]);
  const after = await page.evaluate(() => ({ live: window.skyloop.state.live, badge: document.querySelector("#badge").textContent }));
  check(after.live.worst_margins !== null, "on release the worst case over the uncertainty set is back");
  check(after.live.gains.p !== before.live.gains.p, `slider moved P ${before.live.gains.p} → ${after.live.gains.p}`);
  check(after.live.loop.mag_db[10] !== before.live.loop.mag_db[10], "the Bode data changed");
  check(JSON.stringify(after.live.step.y) !== JSON.stringify(before.live.step.y), "the step changed");
  check(after.badge !== before.badge, `the badge changed: "${after.badge.replace(/\s+/g, " ").trim()}"`);
  await page.screenshot({ path: join(shots, "tune-slider.png"), fullPage: true });
  times.sort((a, b) => a - b);
  computeTimes.sort((a, b) => a - b);
  console.log(`SPEED slider re-render (re-verify in wasm + redraw): median ${times[times.length >> 1].toFixed(1)} ms, max ${times[times.length - 1].toFixed(1)} ms over ${times.length} moves while dragging (nominal plant), of which the wasm re-analysis median ${computeTimes[computeTimes.length >> 1].toFixed(1)} ms (target ≤ 50 ms); on release (all ${nPlants} plants of the uncertainty set) ${robustMs[0].toFixed(1)} ms, of which wasm ${robustMs[1].toFixed(1)} ms`);
}

async function speed(page) {
  const ms = await page.evaluate(async () => {
    const bytes = new Uint8Array(await (await fetch("testdata/demo.bbl")).arrayBuffer());
    const t0 = performance.now();
    const id = await window.skyloop.rpc("identify", { bytes, name: "demo.bbl", opts: { axis: "roll" } });
    return { ms: performance.now() - t0, fit: id.fit };
  });
  console.log(`SPEED parse + identify (roll) of btfl_all.bbl (Betaflight, session 4: ~145 s of flight, 2.4 MB): ${(ms.ms / 1000).toFixed(2)} s (target ≤ 5 s)`);
}

async function badInput(page) {
  await page.setInputFiles("#file", { name: "not-a-log.bin", mimeType: "application/octet-stream", buffer: Buffer.from([0xff, 0xfe, 0x00, 0x13, 0x37, 0x00, 0xc3, 0x28]) });
  await page.waitForSelector("#error:not([hidden])", { timeout: 30000 });
  const text = await page.textContent("#error");
  check(/not a ULog, blackbox, DataFlash or CSV file/.test(text), `a non-log file shows an error: "${text}"`);
}

async function shaping(browser, base) {
  const w1 = "0.03511*(s+0.3419)/s", w2 = "307.5*(s+3.816)/((s+11.35)*(s+103.4))";
  const p = "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2-s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)";
  const ref = cliJson(["ncfsyn", p, "--w1", w1, "--w2", w2, "--pade", "3", "--factor", "1.1", "--json"]);
  const page = await browser.newPage({ viewport: { width: 1360, height: 900 } });
  await page.goto(`${base}/index.html?mode=shape`);
  await page.waitForFunction(() => window.skyloop && window.skyloop.timings.ncfsyn_ms, null, { timeout: 120000 });
  await page.waitForTimeout(300);
  const v = await page.evaluate(() => window.skyloop.rpc("ncfsyn", { opts: {
    plant: document.querySelector("#ncf-p").value, w1: document.querySelector("#ncf-w1").value,
    w2: document.querySelector("#ncf-w2").value, pade: 3, factor: 1.1 } }));
  compareAt(v, ref, ["gamma_min", "gamma"], "ncfsyn");
  const flat = (c) => [c.a, c.b, c.c, c.d].flat(2);
  const [ca, cb] = [flat(v.controller), flat(ref.controller)];
  const scale = Math.max(...cb.map(Math.abs));
  check(ca.length === cb.length && ca.every((x, k) => Math.abs(x - cb[k]) <= TOL * scale),
    `ncfsyn controller matrices equal the CLI's to 1e-6 of the largest entry (${ca.length} numbers)`);
  const shown = await page.textContent("#ncf-out");
  check(shown.includes(ref.gamma_min.toFixed(4)), `γmin ${ref.gamma_min.toFixed(4)} shown`);
  const margins = cliJson(["margins", "2*exp(-0.1*s)/(s*(s+1))", "--json"]);
  const pm = await page.evaluate(() => window.skyloop.rpc("margins", { model: "2*exp(-0.1*s)/(s*(s+1))" }));
  compareAt(pm, margins, ["phase_margin_deg", "gain_margin_db", "disk_margin.alpha", "delay_margin_s"], "margins");
  await page.screenshot({ path: join(shots, "loop-shaping.png"), fullPage: true });
  await page.close();
}

const server = await serve();
const base = `http://127.0.0.1:${server.address().port}`;
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"],
});
try {
  const ref = cliJson(["tune", LOG, "--axis", "roll", "--firmware", "betaflight", "--json"]);
  await demo(browser, base, ref);
  await shaping(browser, base);
} finally {
  await browser.close();
  server.close();
}
console.log(`largest page-vs-CLI difference of the compared numbers: ${worstRel.toExponential(2)} (relative, or absolute below 1)`);
console.log(failures ? `${failures} checks failed` : "all checks passed");
process.exit(failures ? 1 : 0);
