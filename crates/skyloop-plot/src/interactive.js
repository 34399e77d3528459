// skyloop-plot interactive figures: draws the figure data (JSON in a <script type="application/json">
// next to each .skl-int element) on a canvas; wheel zooms about the cursor (shift: x only, alt: y
// only), drag pans, double-click resets, hovering shows the nearest data point. Self-contained: no
// network, no libraries.
(function () {
  "use strict";
  var PREFIX = { "-12": "p", "-9": "n", "-6": "\u00b5", "-3": "m", "0": "", "3": "k", "6": "M", "9": "G", "12": "T" };
  function fmt(v, step) {
    if (!isFinite(v)) return "";
    if (!(step > 0)) step = Math.abs(v) || 1;
    if (Math.abs(v) < 1e-6 * step) return "0";
    var m = Math.abs(v), e3 = 0;
    if (m < 1e-3 || m >= 1e3) e3 = Math.floor(Math.floor(Math.log10(m) + 1e-9) / 3) * 3;
    if (e3 < -12 || e3 > 12) return v.toExponential(2).replace(/\.?0+e/, "e").replace("e+", "e");
    var s = v / Math.pow(10, e3), st = step / Math.pow(10, e3);
    var d = Math.max(0, Math.min(12, -Math.floor(Math.log10(st) - 1e-9)));
    var t = s.toFixed(d);
    if (t.indexOf(".") >= 0) t = t.replace(/0+$/, "").replace(/\.$/, "");
    if (t === "-0") t = "0";
    return t + PREFIX[String(e3)];
  }
  function niceStep(lo, hi, n) {
    var raw = Math.abs(hi - lo) / Math.max(2, n), p = Math.pow(10, Math.floor(Math.log10(raw)));
    var ms = [1, 2, 5, 10];
    for (var i = 0; i < ms.length; i++) if (ms[i] * p >= raw) return ms[i] * p;
    return 10 * p;
  }
  function linTicks(lo, hi, n, deg) {
    var step;
    var raw = Math.abs(hi - lo) / Math.max(2, n);
    if (deg && Math.abs(hi - lo) >= 60) {
      raw = Math.max(raw, 15);
      var ds = [15, 30, 45, 90, 180, 360, 720];
      step = ds[ds.length - 1];
      for (var k = 0; k < ds.length; k++) if (ds[k] >= raw) { step = ds[k]; break; }
      while (step < raw) step *= 2;
    } else step = niceStep(lo, hi, n);
    var out = [], a = Math.ceil((lo - 1e-9 * step) / step), b = Math.floor((hi + 1e-9 * step) / step);
    // Degrees are written in full ("-1440"), as the static rendering does.
    for (var i = a; i <= b && out.length < 200; i++)
      out.push({ v: i * step, l: deg && step >= 15 ? String(Math.round(i * step)) : fmt(i * step, step) });
    return out;
  }
  function fmtExp(v, step) { // dimensionless log axes: "1e-6", not "1µ"
    var m = Math.abs(v);
    if (v === 0 || (m >= 1e-3 && m < 1e4)) return fmt(v, step);
    var e = Math.floor(Math.log10(m) + 1e-9);
    return String(+(v / Math.pow(10, e)).toPrecision(3)) + "e" + e;
  }
  function logTicks(lo, hi, n, sci) { // lo, hi in log10 units
    var out = [], decades = hi - lo, every = Math.max(1, Math.ceil(decades / Math.max(1, n)));
    var few = decades <= 2 + 1e-9;
    if (decades > 40) return linTicks(lo, hi, n).map(function (t) { return { v: t.v, l: "1e" + t.l }; });
    for (var d = Math.floor(lo) ; d <= Math.ceil(hi); d++) {
      for (var m = 1; m <= 9; m++) {
        var t = d + Math.log10(m);
        if (t < lo - 1e-9 || t > hi + 1e-9) continue;
        var lab = (m === 1 && ((d % every) + every) % every === 0) || (few && (m === 2 || m === 5));
        out.push({ v: t, l: lab ? (sci ? fmtExp : fmt)(m * Math.pow(10, d), Math.pow(10, d)) : null });
      }
    }
    if (out.filter(function (t) { return t.l !== null; }).length < 2)
      out.forEach(function (t) { var v = Math.pow(10, t.v); t.l = fmt(v, Math.pow(10, Math.floor(t.v))); });
    return out;
  }
  function tr(v, log) { return log ? (v > 0 ? Math.log10(v) : NaN) : v; }

  function Plot(el, fig) {
    var cols = Math.max(1, Math.min(fig.columns || 1, fig.panels.length));
    var rows = Math.ceil(fig.panels.length / cols);
    var W = fig.width, PH = Math.min(fig.panelHeight, 420), H = PH * rows + (fig.title ? 30 : 6);
    var dpr = window.devicePixelRatio || 1;
    var cv = document.createElement("canvas");
    cv.width = W * dpr; cv.height = H * dpr; cv.style.width = "100%"; cv.style.maxWidth = W + "px";
    cv.style.border = "1px solid #ddd"; cv.style.cursor = "crosshair";
    el.appendChild(cv);
    var tip = document.createElement("div");
    tip.style.cssText = "position:absolute;pointer-events:none;background:rgba(255,255,255,.95);border:1px solid #999;padding:2px 6px;font:12px sans-serif;display:none;white-space:nowrap";
    el.style.position = "relative";
    el.appendChild(tip);
    var ctx = cv.getContext("2d");
    var top0 = fig.title ? 30 : 6;
    // Unlabelled curves (a phase under its magnitude, a mirror) are named after the labelled curve of
    // the same colour, so hovering tells which system a point belongs to.
    var byColor = {};
    fig.panels.forEach(function (p) { p.series.forEach(function (s) { if (s.label && !byColor[s.color]) byColor[s.color] = s.label; }); });
    var panels = fig.panels.map(function (p, i) {
      var r = Math.floor(i / cols), c = i % cols;
      var box = { x: c * W / cols, y: top0 + r * PH, w: W / cols, h: PH };
      var f = { l: box.x + 62, r: box.x + box.w - 14, t: box.y + (p.title ? 22 : 10), b: box.y + box.h - (p.xLabel ? 44 : 26) };
      var v = { x0: tr(p.xRange[0], p.xLog), x1: tr(p.xRange[1], p.xLog), y0: tr(p.yRange[0], p.yLog), y1: tr(p.yRange[1], p.yLog) };
      if (p.equal) {
        var ux = (v.x1 - v.x0) / (f.r - f.l), uy = (v.y1 - v.y0) / (f.b - f.t), cx, half;
        if (ux > uy) { cx = (v.y0 + v.y1) / 2; half = ux * (f.b - f.t) / 2; v.y0 = cx - half; v.y1 = cx + half; }
        else { cx = (v.x0 + v.x1) / 2; half = uy * (f.r - f.l) / 2; v.x0 = cx - half; v.x1 = cx + half; }
      }
      var series = p.series.map(function (s) {
        return { s: s, tx: s.x.map(function (x) { return x === null ? NaN : tr(x, p.xLog); }),
                 ty: s.y.map(function (y) { return y === null ? NaN : tr(y, p.yLog); }) };
      });
      return { p: p, col: c, f: f, v: v, home: Object.assign({}, v), series: series };
    });
    function sx(P, t) { return P.f.l + (t - P.v.x0) / (P.v.x1 - P.v.x0) * (P.f.r - P.f.l); }
    function sy(P, t) { return P.f.b - (t - P.v.y0) / (P.v.y1 - P.v.y0) * (P.f.b - P.f.t); }
    function draw() {
      ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
      ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, W, H);
      ctx.fillStyle = "#000"; ctx.font = "17px sans-serif"; ctx.textAlign = "center"; ctx.textBaseline = "top";
      if (fig.title) ctx.fillText(fig.title, W / 2, 6);
      panels.forEach(drawPanel);
    }
    function drawPanel(P) {
      var p = P.p, f = P.f, v = P.v;
      // The same densities as the static rendering (src/render.rs: axis_ticks).
      var nx = Math.max(2, Math.min(14, Math.floor((f.r - f.l) / 85))), ny = Math.max(2, Math.min(10, Math.floor((f.b - f.t) / 26)));
      var xt = p.xLog ? logTicks(v.x0, v.x1, Math.max(2, Math.floor((f.r - f.l) / 51))) : linTicks(v.x0, v.x1, nx, p.xDeg);
      var yt = p.yLog ? logTicks(v.y0, v.y1, Math.max(2, Math.floor((f.b - f.t) / 15.6)), true) : linTicks(v.y0, v.y1, ny, p.yDeg);
      ctx.lineWidth = 1;
      xt.forEach(function (t) { var u = Math.round(sx(P, t.v)) + 0.5; ctx.strokeStyle = t.l ? "#d7d7d7" : "#eee"; ctx.beginPath(); ctx.moveTo(u, f.t); ctx.lineTo(u, f.b); ctx.stroke(); });
      yt.forEach(function (t) { var w = Math.round(sy(P, t.v)) + 0.5; ctx.strokeStyle = t.l ? "#d7d7d7" : "#eee"; ctx.beginPath(); ctx.moveTo(f.l, w); ctx.lineTo(f.r, w); ctx.stroke(); });
      ctx.save();
      ctx.beginPath(); ctx.rect(f.l, f.t, f.r - f.l, f.b - f.t); ctx.clip();
      P.series.forEach(function (S) {
        var s = S.s, st = s.style;
        ctx.strokeStyle = ctx.fillStyle = s.color;
        ctx.lineWidth = st === "reference" ? 1 : 2;
        ctx.setLineDash(st === "dashed" ? [9, 5] : st === "reference" ? [5, 4] : []);
        if (st === "line" || st === "dashed" || st === "reference") {
          ctx.beginPath();
          var pen = false;
          for (var i = 0; i < S.tx.length; i++) {
            var a = S.tx[i], b = S.ty[i];
            if (!isFinite(a) || !isFinite(b)) { pen = false; continue; }
            var X = sx(P, a), Y = sy(P, b);
            // Canvas coordinates far outside the view are kept finite; the clip rectangle cuts them.
            X = Math.max(-1e6, Math.min(1e6, X)); Y = Math.max(-1e6, Math.min(1e6, Y));
            if (pen) ctx.lineTo(X, Y); else ctx.moveTo(X, Y);
            pen = true;
          }
          ctx.stroke();
        } else {
          ctx.setLineDash([]);
          for (var j = 0; j < S.tx.length; j++) {
            if (!isFinite(S.tx[j]) || !isFinite(S.ty[j])) continue;
            var x = sx(P, S.tx[j]), y = sy(P, S.ty[j]);
            ctx.beginPath();
            if (st === "crosses") { ctx.moveTo(x - 5, y - 5); ctx.lineTo(x + 5, y + 5); ctx.moveTo(x - 5, y + 5); ctx.lineTo(x + 5, y - 5); ctx.stroke(); }
            else if (st === "circles") { ctx.arc(x, y, 5, 0, 2 * Math.PI); ctx.stroke(); }
            else if (st === "stems") { ctx.moveTo(x, f.b); ctx.lineTo(x, y); ctx.stroke(); }
            else { ctx.arc(x, y, 3, 0, 2 * Math.PI); ctx.fill(); }
          }
        }
      });
      ctx.setLineDash([4, 4]); ctx.strokeStyle = "#6e6e6e"; ctx.lineWidth = 1;
      ctx.font = "12px sans-serif"; ctx.fillStyle = "#333";
      var rowsUsed = [];
      (p.markers || []).forEach(function (m) {
        if (m.kind === "vertical") {
          var u = sx(P, tr(m.x, p.xLog)); ctx.beginPath(); ctx.moveTo(u, f.t); ctx.lineTo(u, f.b); ctx.stroke();
          // Labels of neighbouring lines go in separate rows instead of over each other.
          var tw = ctx.measureText(m.label).width, right = u + 4 + tw <= f.r;
          var a = right ? u + 4 : u - 4 - tw, b = a + tw, row = 0;
          while ((rowsUsed[row] || []).some(function (s) { return !(b + 4 < s[0] || a > s[1] + 4); })) row++;
          (rowsUsed[row] = rowsUsed[row] || []).push([a, b]);
          ctx.textAlign = "left"; ctx.textBaseline = "top"; ctx.fillText(m.label, a, f.t + 3 + 15 * row);
        } else if (m.kind === "horizontal") {
          var w = sy(P, tr(m.y, p.yLog)); ctx.beginPath(); ctx.moveTo(f.l, w); ctx.lineTo(f.r, w); ctx.stroke();
          ctx.textAlign = "left"; ctx.textBaseline = "bottom"; ctx.fillText(m.label, f.l + 4, w - 2);
        } else if (m.kind === "point") {
          var px = sx(P, tr(m.x, p.xLog)), py = sy(P, tr(m.y, p.yLog));
          ctx.save(); ctx.setLineDash([]); ctx.strokeStyle = "#c80000"; ctx.lineWidth = 2;
          ctx.beginPath(); ctx.moveTo(px - 7, py); ctx.lineTo(px + 7, py); ctx.moveTo(px, py - 7); ctx.lineTo(px, py + 7); ctx.stroke(); ctx.restore();
          ctx.textAlign = "right"; ctx.textBaseline = "bottom"; ctx.fillText(m.label, px - 6, py - 6);
        } else if (m.kind === "note") {
          ctx.textAlign = "left"; ctx.textBaseline = "bottom";
          ctx.fillText(m.label, sx(P, tr(m.x, p.xLog)) + 6, sy(P, tr(m.y, p.yLog)) - 6);
        } else if (m.kind === "arrow" && !p.xLog && !p.yLog) {
          var ax = sx(P, m.x), ay = sy(P, m.y), ux = sx(P, m.x + m.dx * 1e-6) - ax, uy = sy(P, m.y + m.dy * 1e-6) - ay;
          var n = Math.hypot(ux, uy); if (!(n > 0)) return; ux /= n; uy /= n;
          ctx.save(); ctx.setLineDash([]); ctx.fillStyle = m.color; ctx.beginPath();
          ctx.moveTo(ax + 6.5 * ux, ay + 6.5 * uy);
          ctx.lineTo(ax - 6.5 * ux - 5.5 * uy, ay - 6.5 * uy + 5.5 * ux);
          ctx.lineTo(ax - 6.5 * ux + 5.5 * uy, ay - 6.5 * uy - 5.5 * ux); ctx.fill(); ctx.restore();
        }
      });
      ctx.restore();
      ctx.setLineDash([]); ctx.strokeStyle = "#000"; ctx.lineWidth = 1;
      ctx.strokeRect(f.l + 0.5, f.t + 0.5, f.r - f.l, f.b - f.t);
      ctx.fillStyle = "#000"; ctx.font = "12px sans-serif";
      ctx.textAlign = "center"; ctx.textBaseline = "top";
      xt.forEach(function (t) { if (t.l) { var u = sx(P, t.v); if (u >= f.l - 1 && u <= f.r + 1) ctx.fillText(t.l, u, f.b + 4); } });
      ctx.textAlign = "right"; ctx.textBaseline = "middle";
      var widest = 0;
      yt.forEach(function (t) { if (t.l) { var w = sy(P, t.v); if (w >= f.t - 1 && w <= f.b + 1) { ctx.fillText(t.l, f.l - 5, w); widest = Math.max(widest, ctx.measureText(t.l).width); } } });
      ctx.font = "13px sans-serif"; ctx.textAlign = "center";
      if (p.xLabel) { ctx.textBaseline = "top"; ctx.fillText(p.xLabel, (f.l + f.r) / 2, f.b + 22); }
      if (p.title) { ctx.textBaseline = "top"; ctx.fillText(p.title, (f.l + f.r) / 2, f.t - 20); }
      if (p.yLabel) {
        ctx.save(); ctx.translate(f.l - widest - 12, (f.t + f.b) / 2); ctx.rotate(-Math.PI / 2);
        ctx.textBaseline = "bottom"; ctx.fillText(p.yLabel, 0, 0); ctx.restore();
      }
      var named = P.series.filter(function (S) { return S.s.label; });
      if (named.length) {
        ctx.font = "12px sans-serif";
        var lw = 0; named.forEach(function (S) { lw = Math.max(lw, ctx.measureText(S.s.label).width); });
        var bx = f.r - lw - 44, by = f.t + 6;
        ctx.fillStyle = "rgba(255,255,255,.85)"; ctx.fillRect(bx, by, lw + 38, named.length * 17 + 6);
        ctx.strokeStyle = "#aaa"; ctx.strokeRect(bx + 0.5, by + 0.5, lw + 38, named.length * 17 + 6);
        named.forEach(function (S, i) {
          var y = by + 12 + 17 * i;
          ctx.strokeStyle = ctx.fillStyle = S.s.color; ctx.lineWidth = 2;
          ctx.setLineDash(S.s.style === "dashed" ? [6, 3] : []);
          ctx.beginPath(); ctx.moveTo(bx + 5, y); ctx.lineTo(bx + 25, y); ctx.stroke(); ctx.setLineDash([]);
          ctx.fillStyle = "#000"; ctx.textAlign = "left"; ctx.textBaseline = "middle"; ctx.fillText(S.s.label, bx + 30, y);
        });
      }
    }
    function at(ev) {
      var r = cv.getBoundingClientRect(), k = W / r.width;
      var x = (ev.clientX - r.left) * k, y = (ev.clientY - r.top) * k;
      for (var i = 0; i < panels.length; i++) { var f = panels[i].f; if (x >= f.l && x <= f.r && y >= f.t && y <= f.b) return { P: panels[i], x: x, y: y, k: k }; }
      return null;
    }
    // Panels stacked in one column with the same x scale move together (magnitude over phase).
    function linked(P) { return panels.filter(function (Q) { return Q === P || (Q.col === P.col && Q.p.xLog === P.p.xLog && Q.p.xLabel !== undefined && rows > 1 && !P.p.equal); }); }
    cv.addEventListener("wheel", function (ev) {
      var h = at(ev); if (!h) return; ev.preventDefault();
      var z = Math.exp((ev.deltaY > 0 ? 1 : -1) * 0.15), P = h.P, f = P.f;
      var tx = P.v.x0 + (h.x - f.l) / (f.r - f.l) * (P.v.x1 - P.v.x0), ty = P.v.y1 - (h.y - f.t) / (f.b - f.t) * (P.v.y1 - P.v.y0);
      if (!ev.altKey) linked(P).forEach(function (Q) { Q.v.x0 = tx + (Q.v.x0 - tx) * z; Q.v.x1 = tx + (Q.v.x1 - tx) * z; });
      if (!ev.shiftKey) { P.v.y0 = ty + (P.v.y0 - ty) * z; P.v.y1 = ty + (P.v.y1 - ty) * z; }
      draw();
    }, { passive: false });
    var drag = null;
    cv.addEventListener("mousedown", function (ev) { var h = at(ev); if (h) drag = { h: h, v: Object.assign({}, h.P.v), ex: ev.clientX, ey: ev.clientY }; });
    window.addEventListener("mouseup", function () { drag = null; });
    cv.addEventListener("mousemove", function (ev) {
      if (drag) {
        var P = drag.h.P, f = P.f, k = drag.h.k;
        var dx = (ev.clientX - drag.ex) * k / (f.r - f.l) * (drag.v.x1 - drag.v.x0), dy = (ev.clientY - drag.ey) * k / (f.b - f.t) * (drag.v.y1 - drag.v.y0);
        linked(P).forEach(function (Q) { var w = Q.v.x1 - Q.v.x0; Q.v.x0 = drag.v.x0 - dx; Q.v.x1 = Q.v.x0 + w; });
        P.v.y0 = drag.v.y0 + dy; P.v.y1 = drag.v.y1 + dy;
        draw(); tip.style.display = "none"; return;
      }
      var h = at(ev); if (!h) { tip.style.display = "none"; return; }
      var best = null, bd = 144;
      h.P.series.forEach(function (S) {
        if (S.s.style === "reference") return;
        for (var i = 0; i < S.tx.length; i++) {
          var dx = sx(h.P, S.tx[i]) - h.x, dy = sy(h.P, S.ty[i]) - h.y, d = dx * dx + dy * dy;
          if (d < bd) { bd = d; best = { S: S, i: i }; }
        }
      });
      if (!best) { tip.style.display = "none"; return; }
      var p = h.P.p, s = best.S.s;
      var xv = s.x[best.i], yv = s.y[best.i];
      var sig = function (v) { return v === null ? "–" : Math.abs(v) >= 1e4 || (Math.abs(v) < 1e-3 && v !== 0) ? v.toExponential(3) : String(+v.toPrecision(4)); };
      var name = s.label || byColor[s.color] || "";
      // A panel whose x axis is described only under the panel below (Bode magnitude) borrows it.
      var xName = p.xLabel;
      if (!xName) panels.forEach(function (Q) { if (!xName && Q.col === h.P.col && Q.p.xLabel) xName = Q.p.xLabel; });
      tip.textContent = (name ? name + ": " : "") + (xName || "x") + " = " + sig(xv) + ", " + (p.yLabel || "y") + " = " + sig(yv);
      tip.style.display = "block";
      tip.style.left = (sx(h.P, best.S.tx[best.i]) / h.k + 12) + "px";
      tip.style.top = (sy(h.P, best.S.ty[best.i]) / h.k - 28) + "px";
    });
    cv.addEventListener("mouseleave", function () { tip.style.display = "none"; });
    cv.addEventListener("dblclick", function () { panels.forEach(function (P) { P.v = Object.assign({}, P.home); }); draw(); });
    draw();
  }
  var els = document.querySelectorAll(".skl-int");
  for (var i = 0; i < els.length; i++) {
    var data = document.getElementById(els[i].getAttribute("data-src"));
    if (!data) continue;
    try {
      Plot(els[i], JSON.parse(data.textContent));
      // Drawn: the static copy above it (for pages without scripts) would show the figure twice.
      var fig = els[i].closest("figure");
      var st = fig && fig.querySelector(".skl-static");
      if (st) st.style.display = "none";
    } catch (e) { els[i].textContent = "interactive figure failed: " + e; }
  }
})();
