// Plots of the page: uPlot line charts (Bode, step, noise) and a Nyquist canvas. Every axis says
// its unit; margins are drawn where the CLI reads them.
"use strict";

const COLORS = { flown: "#8a8f98", proposed: "#1f77b4", live: "#d62728", measured: "#2ca02c", band: "rgba(44,160,44,0.15)" };

/** Width of a plot container (the card's column). */
function plotWidth(el) {
  return Math.max(320, Math.floor(el.getBoundingClientRect().width) - 4);
}

/**
 * A uPlot line chart in `el`, replaced when it exists. `spec`: {x, series: [{label, y, color,
 * dash}], xLabel, yLabel, logX, logY, height, marks: [{x, label, color}], hlines: [{y, label}],
 * yRange}. Returns the uPlot instance.
 */
function linePlot(el, spec) {
  if (el._plot) { el._plot.destroy(); el._plot = null; }
  const data = [spec.x, ...spec.series.map((s) => s.y)];
  const marks = spec.marks || [];
  const hlines = spec.hlines || [];
  const opts = {
    width: plotWidth(el),
    height: spec.height || 220,
    legend: { show: true, live: false },
    cursor: { drag: { x: true, y: false } },
    scales: {
      x: { time: false, distr: spec.logX ? 3 : 1 },
      y: Object.assign({ distr: spec.logY ? 3 : 1 }, spec.yRange ? { range: spec.yRange } : {}),
    },
    axes: [
      { label: spec.xLabel, labelSize: 18, size: 34 },
      { label: spec.yLabel, labelSize: 18, size: 60 },
    ],
    series: [{}, ...spec.series.map((s) => ({
      label: s.label, stroke: s.color, width: s.width || 2, dash: s.dash, points: { show: false },
      fill: s.fill,
    }))],
    hooks: { draw: [(u) => drawMarks(u, marks, hlines)] },
  };
  el._plot = new uPlot(opts, data, el);
  return el._plot;
}

/** Vertical marks (crossover, phase crossover) and horizontal reference lines with their labels. */
function drawMarks(u, marks, hlines) {
  const ctx = u.ctx;
  const { left, top, width, height } = u.bbox;
  const dpr = window.devicePixelRatio || 1;
  ctx.save();
  ctx.font = `${11 * dpr}px sans-serif`;
  ctx.lineWidth = 1 * dpr;
  for (const h of hlines) {
    const y = u.valToPos(h.y, "y", true);
    if (!(y >= top && y <= top + height)) continue;
    ctx.strokeStyle = "#444"; ctx.setLineDash([4 * dpr, 3 * dpr]);
    ctx.beginPath(); ctx.moveTo(left, y); ctx.lineTo(left + width, y); ctx.stroke();
    if (h.label) {
      ctx.fillStyle = "#444";
      ctx.fillText(h.label, left + width - ctx.measureText(h.label).width - 4 * dpr, y - 3 * dpr);
    }
  }
  let k = 0;
  for (const m of marks) {
    if (!(m.x > 0) || !isFinite(m.x)) continue;
    const x = u.valToPos(m.x, "x", true);
    if (!(x >= left && x <= left + width)) continue;
    ctx.strokeStyle = m.color || "#000"; ctx.setLineDash([2 * dpr, 2 * dpr]);
    ctx.beginPath(); ctx.moveTo(x, top); ctx.lineTo(x, top + height); ctx.stroke();
    if (m.label) {
      ctx.fillStyle = m.color || "#000";
      const tw = ctx.measureText(m.label).width;
      const tx = x + 4 * dpr + tw > left + width ? x - tw - 4 * dpr : x + 4 * dpr;
      ctx.fillText(m.label, tx, top + (12 + 13 * k) * dpr);
      k++;
    }
    if (m.y !== undefined && isFinite(m.y)) {
      const y = u.valToPos(m.y, "y", true);
      ctx.setLineDash([]); ctx.fillStyle = m.color || "#000";
      ctx.beginPath(); ctx.arc(x, y, 3.5 * dpr, 0, 2 * Math.PI); ctx.fill();
    }
  }
  ctx.restore();
}

/**
 * Nyquist of L on a canvas: the curve (and its mirror for negative frequencies, dashed), the
 * critical point −1, the unit circle, and the disk the disk margin keeps L out of.
 * `curves`: [{re, im, color, label}], `disk`: {center_re, radius} or null.
 */
function nyquistPlot(canvas, curves, disk) {
  const dpr = window.devicePixelRatio || 1;
  const cssW = Math.max(320, Math.floor(canvas.parentElement.getBoundingClientRect().width) - 4);
  const cssH = Math.round(cssW * 0.78);
  canvas.style.width = cssW + "px"; canvas.style.height = cssH + "px";
  canvas.width = cssW * dpr; canvas.height = cssH * dpr;
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, cssW, cssH);
  // A window around the critical point: where the margins are read (L is huge at low frequency).
  const pad = { l: 58, r: 12, t: 12, b: 42 };
  const W = cssW - pad.l - pad.r, H = cssH - pad.t - pad.b;
  const xr = [-3.2, 1.2], yr = [-(xr[1] - xr[0]) * H / W / 2, (xr[1] - xr[0]) * H / W / 2];
  const X = (x) => pad.l + (x - xr[0]) / (xr[1] - xr[0]) * W;
  const Y = (y) => pad.t + (yr[1] - y) / (yr[1] - yr[0]) * H;
  ctx.font = "12px sans-serif";
  ctx.strokeStyle = "#ddd"; ctx.lineWidth = 1; ctx.fillStyle = "#333";
  for (let x = Math.ceil(xr[0]); x <= xr[1]; x += 1) {
    ctx.beginPath(); ctx.moveTo(X(x), pad.t); ctx.lineTo(X(x), pad.t + H); ctx.stroke();
    ctx.fillText(String(x), X(x) - 5, pad.t + H + 15);
  }
  for (let y = Math.ceil(yr[0]); y <= yr[1]; y += 1) {
    ctx.beginPath(); ctx.moveTo(pad.l, Y(y)); ctx.lineTo(pad.l + W, Y(y)); ctx.stroke();
    ctx.fillText(String(y), pad.l - 22, Y(y) + 4);
  }
  ctx.fillText("Re L (dimensionless)", pad.l + W / 2 - 55, cssH - 6);
  ctx.save(); ctx.translate(14, pad.t + H / 2 + 50); ctx.rotate(-Math.PI / 2);
  ctx.fillText("Im L (dimensionless)", 0, 0); ctx.restore();
  ctx.save();
  ctx.beginPath(); ctx.rect(pad.l, pad.t, W, H); ctx.clip();
  const sx = W / (xr[1] - xr[0]);
  ctx.strokeStyle = "#bbb"; ctx.setLineDash([3, 3]);
  ctx.beginPath(); ctx.arc(X(0), Y(0), sx, 0, 2 * Math.PI); ctx.stroke();
  ctx.setLineDash([]);
  if (disk) {
    ctx.fillStyle = "rgba(214,39,40,0.12)"; ctx.strokeStyle = "rgba(214,39,40,0.8)";
    ctx.beginPath(); ctx.arc(X(disk.center_re), Y(0), disk.radius * sx, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
  }
  for (const c of curves) {
    for (const mirror of [false, true]) {
      ctx.strokeStyle = c.color; ctx.lineWidth = mirror ? 1 : 2; ctx.setLineDash(mirror ? [4, 4] : []);
      ctx.beginPath();
      let started = false;
      for (let k = 0; k < c.re.length; k++) {
        const x = X(c.re[k]), y = Y(mirror ? -c.im[k] : c.im[k]);
        if (!isFinite(x) || !isFinite(y) || Math.abs(x) > 1e5 || Math.abs(y) > 1e5) { started = false; continue; }
        if (started) ctx.lineTo(x, y); else { ctx.moveTo(x, y); started = true; }
      }
      ctx.stroke();
    }
  }
  ctx.setLineDash([]);
  ctx.fillStyle = "#000"; ctx.font = "bold 14px sans-serif";
  ctx.fillText("×", X(-1) - 4, Y(0) + 5);
  ctx.font = "12px sans-serif";
  ctx.fillText("−1", X(-1) - 8, Y(0) - 8);
  ctx.restore();
  // Legend.
  let ly = pad.t + 16;
  for (const c of curves) {
    ctx.strokeStyle = c.color; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(pad.l + 8, ly - 4); ctx.lineTo(pad.l + 30, ly - 4); ctx.stroke();
    ctx.fillStyle = "#222"; ctx.fillText(c.label, pad.l + 36, ly); ly += 16;
  }
  if (disk) {
    ctx.fillStyle = "rgba(214,39,40,0.25)"; ctx.fillRect(pad.l + 8, ly - 10, 22, 10);
    ctx.fillStyle = "#222"; ctx.fillText("disk-margin disk (L stays outside)", pad.l + 36, ly);
  }
}
