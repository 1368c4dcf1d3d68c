/* loopsolve interactive page (inlined into every page by loopsolve/view.py; no network, no libraries).
 * Hooks kept for scripts and tests (see DESIGN.md, "Interactive page"):
 *   the range input #loopsolve-input: its value is the row index; an `input` event redraws;
 *   its data-value attribute is the input's value at that row (model units);
 *   every named point is an SVG circle with data-point="NAME" whose cx, cy are the point's model
 *   coordinates at the current row (the y-up flip is the parent group's transform).
 * The page renders itself from the JSON in #ls-data; the editor (loopsolve edit) calls
 * LoopsolveView.render(data, options) again after every edit: options.row (the row to show first),
 * options.onUpdate(row) (called after every redraw); render returns {update, row, world, destroy}. */
(function () {
  "use strict";
  function render(D, opts) {
  opts = opts || {};
  var listeners = [];
  function listen(target, type, fn) { target.addEventListener(type, fn); listeners.push([target, type, fn]); }
  ["ls-diagram", "ls-legend", "ls-plots", "ls-tabs", "ls-values", "ls-events", "ls-marks"].forEach(function (id) {
    var e = document.getElementById(id);
    if (e) while (e.firstChild) e.removeChild(e.firstChild);
  });
  var S = D.scene, N = D.rows, T = S.traj, A = S.angles, size = S.size, pt = 0.054 * size;
  var NS = "http://www.w3.org/2000/svg";
  var COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];
  var MODE_COLORS = ["#c7d7ea", "#f3d1b5", "#cfe8c6", "#e6cbe6", "#f1e3a6", "#c9e6e6"];
  var row = 0, playing = false, speed = 1, quantity = 0, lastTime = null, acc = 0;

  function el(tag, attrs, parent) {
    var e = document.createElementNS(NS, tag);
    for (var k in attrs) e.setAttribute(k, attrs[k]);
    if (parent) parent.appendChild(e);
    return e;
  }
  function h(tag, attrs, parent, text) {
    var e = document.createElement(tag);
    for (var k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }
  function show(e, on) {
    if (e._on !== on) { e._on = on; e.setAttribute("visibility", on ? "visible" : "hidden"); }
  }
  function fin(v) { return v !== null && v !== undefined && isFinite(v); }
  function X(t, i) { var a = T[t]; return a.length === 2 ? a[0] : a[2 * i]; }
  function Y(t, i) { var a = T[t]; return a.length === 2 ? a[1] : a[2 * i + 1]; }
  function ang(k, i) { var a = A[k]; return typeof a === "number" ? a : a[i]; }
  function fmt(v, digits) {
    if (!fin(v)) return "–";
    if (v === 0) return "0";
    var a = Math.abs(v), d = digits || 5;
    if (a >= 1e6 || a < 1e-4) return v.toExponential(d - 2).replace("e+", "e");
    var s = v.toFixed(Math.max(0, d - 1 - Math.floor(Math.log10(a))));
    return s.indexOf(".") >= 0 ? s.replace(/0+$/, "").replace(/\.$/, "") : s;
  }
  function nameHTML(label) {
    var b = document.createElement("span");
    b.textContent = label[0];
    if (label[1]) { var s = document.createElement("sub"); s.textContent = label[1]; b.appendChild(s); }
    return b;
  }
  function nameSVG(parent, label) {
    el("tspan", {}, parent).textContent = label[0];
    if (label[1]) { var s = el("tspan", {"baseline-shift": "sub", "font-size": "80%"}, parent); s.textContent = label[1]; }
  }
  function nameText(label) { return label[0] + (label[1] ? "_" + label[1] : ""); }

  /* ------------------------------------------------------------------ the diagram */
  var svg = document.getElementById("ls-diagram");
  var ext = S.extent, x0 = ext[0], y0 = ext[1], x1 = ext[2], y1 = ext[3];
  svg.setAttribute("viewBox", [x0, -y1, x1 - x0, y1 - y0].join(" "));
  svg.setAttribute("preserveAspectRatio", "xMidYMid meet");
  var defs = el("defs", {}, svg);
  var hs = 0.22 * size;
  var pat = el("pattern", {id: "ls-hatch", patternUnits: "userSpaceOnUse", width: hs, height: hs,
    patternTransform: "rotate(45)"}, defs);
  el("line", {x1: 0, y1: 0, x2: 0, y2: hs, "class": "ls-hatch-line", "stroke-width": 0.3 * hs}, pat);
  drawGrid();
  var world = el("g", {transform: "scale(1,-1)", id: "ls-world"}, svg);
  var gStatic = el("g", {}, world), gPairs = el("g", {}, world), gPaths = el("g", {}, world), gLevers = el("g", {}, world),
    gLinks = el("g", {}, world), gGuides = el("g", {}, world), gBlocks = el("g", {}, world),
    gJoints = el("g", {}, world), gPoints = el("g", {}, world);
  var gLabels = el("g", {}, svg);

  function drawGrid() {
    var g = el("g", {}, svg), w = x1 - x0, hgt = y1 - y0;
    var step = niceStep(Math.max(w, hgt) / 8);
    for (var x = Math.ceil(x0 / step) * step; x <= x1; x += step)
      el("line", {x1: x, y1: -y1, x2: x, y2: -y0, "class": "grid", "stroke-width": 0.6 * pt}, g);
    for (var y = Math.ceil(y0 / step) * step; y <= y1; y += step)
      el("line", {x1: x0, y1: -y, x2: x1, y2: -y, "class": "grid", "stroke-width": 0.6 * pt}, g);
    var fs = 0.42 * size;
    for (x = Math.ceil(x0 / step) * step; x <= x1 - 0.5 * step; x += step)
      el("text", {x: x + 0.15 * fs, y: -y0 - 0.3 * fs, "font-size": fs, "class": "tick"}, g).textContent = fmt(x, 4);
    for (y = Math.ceil(y0 / step) * step + step; y <= y1; y += step)
      el("text", {x: x0 + 0.25 * fs, y: -y + 1.1 * fs, "font-size": fs, "class": "tick"}, g).textContent = fmt(y, 4);
    el("text", {x: x1 - 0.3 * fs, y: -y0 - 0.3 * fs, "font-size": fs, "class": "tick", "text-anchor": "end"}, g)
      .textContent = S.unit;
  }

  S["static"].forEach(function (s) {
    var p = s.p, w = s.c === "ground-line" ? 1.0 : s.c === "axis" ? 0.8 : s.c === "pivot" ? 1.2 : 1.6;
    if (s.k === "line") {
      var ln = el("line", {x1: p[0], y1: p[1], x2: p[2], y2: p[3], "class": s.c, "stroke-width": w * pt}, gStatic);
      if (s.c === "ground-line") ln.setAttribute("stroke-dasharray", [6 * pt, 3 * pt].join(" "));
      if (s.c === "axis") ln.setAttribute("stroke-dasharray", [8 * pt, 3 * pt, 2 * pt, 3 * pt].join(" "));
    } else {
      var pts = [];
      for (var i = 0; i < p.length; i += 2) pts.push(p[i] + "," + p[i + 1]);
      el("polygon", {points: pts.join(" "), "class": s.c, "stroke-width": w * pt}, gStatic);
    }
  });

  // traces of the moving points: the whole path dotted, the path so far solid (a dash as long as it)
  var traces = [], traced = {};
  S.points.forEach(function (p) {
    if (!p.moves) return;
    if (p.path in traced) { traced[p.path].name += ", " + p.name; return; } // coincident points: one path
    var color = COLORS[traces.length % COLORS.length], d = "", cum = [], len = 0, prev = null;
    for (var i = 0; i < N; i++) {
      var x = X(p.t, i), y = Y(p.t, i);
      if (!fin(x) || !fin(y)) { prev = null; cum.push(len); continue; }
      if (prev) len += Math.hypot(x - prev[0], y - prev[1]);
      d += (prev ? "L" : "M") + x + " " + y;
      prev = [x, y];
      cum.push(len);
    }
    el("path", {d: d, "class": "path-all", stroke: color, "stroke-width": 1.3 * pt,
      "stroke-dasharray": [1.2 * pt, 2.2 * pt].join(" ")}, gPaths);
    var done = el("path", {d: d, "class": "path-done", stroke: color, "stroke-width": 1.8 * pt}, gPaths);
    traces.push(traced[p.path] = {name: p.name, color: color, el: done, cum: cum, len: len});
  });
  var legend = document.getElementById("ls-legend");
  if (traces.length) {
    h("span", {}, legend, "paths:");
    traces.forEach(function (tr) {
      var s = h("span", {}, legend); var i = h("i", {style: "border-color:" + tr.color}, s);
      s.appendChild(document.createTextNode(tr.name));
    });
  }

  var levers = S.levers.map(function (lv) {
    return {d: lv, bar: el("line", {"class": "lever", "stroke-width": 7.5 * pt}, gLevers),
      slot: el("line", {"class": "slot", "stroke-width": 2 * pt}, gLevers)};
  });
  var links = S.links.map(function (lk) {
    if (lk.poly) return {d: lk, poly: el("polygon", {"class": "link-poly", fill: lk.color, "fill-opacity": 0.35,
      stroke: lk.color, "stroke-width": 2.5 * pt}, gLinks)};
    var bars = [];
    for (var a = 0; a < lk.n.length; a++) for (var b = a + 1; b < lk.n.length; b++)
      bars.push([lk.n[a], lk.n[b], el("line", {"class": "link-bar", stroke: lk.color, "stroke-width": 4.5 * pt}, gLinks)]);
    return {d: lk, bars: bars};
  });
  var guides = S.guides.map(function (g) {
    return {d: g, line: el("line", {"class": "mguide", "stroke-width": 1.6 * pt}, gGuides)};
  });
  var blocks = S.blocks.map(function (b) {
    return {d: b, poly: el("polygon", {"class": "block", "stroke-width": 1.4 * pt}, gBlocks)};
  });
  // gears (pitch circles), cams (profile and follower), slots: see loopsolve/output/pairdraw.py
  var pairs = (S.pairs || []).map(function (p) {
    var cls = "pair-" + p.c, w = (p.c === "gear" ? 1.4 : 1.8) * pt;
    if (p.k === "circle") return {d: p, e: el("circle", {r: p.r, "class": cls, "stroke-width": w}, gPairs)};
    return {d: p, e: el(p.k === "rot" || p.closed ? "polygon" : "polyline", {"class": cls, "stroke-width": w}, gPairs)};
  });
  var joints = S.joints.map(function (t) {
    return {t: t, c: el("circle", {r: 0.22 * size, "class": "joint", "stroke-width": 1.3 * pt}, gJoints)};
  });
  var points = S.points.map(function (p) {
    var c = el("circle", {r: (p.pin ? 0.07 : 0.16) * size, "class": p.pin ? "pin" : "dot", "data-point": p.name}, gPoints);
    el("title", {}, c).textContent = p.name;
    return {d: p, c: c};
  });
  var labels = S.labels.map(function (l) {
    var t = el("text", {"class": "label", "font-size": 0.62 * size, "stroke-width": 0.16 * size}, gLabels);
    t.textContent = l.text;
    return {d: l, el: t, last: -1};
  });
  var CAND = [];
  for (var c = 0; c < 24; c++) CAND.push([Math.cos(2 * Math.PI * c / 24), Math.sin(2 * Math.PI * c / 24)]);

  function unit(x, y) { var n = Math.hypot(x, y); return n > 0 ? [x / n, y / n] : [0, 0]; }
  function setLine(e, ax, ay, bx, by) {
    if (!(fin(ax) && fin(ay) && fin(bx) && fin(by))) { show(e, false); return; }
    show(e, true);
    e.setAttribute("x1", ax); e.setAttribute("y1", ay); e.setAttribute("x2", bx); e.setAttribute("y2", by);
  }
  function setPoly(e, xy) {
    var s = [];
    for (var k = 0; k < xy.length; k++) {
      if (!fin(xy[k][0]) || !fin(xy[k][1])) { show(e, false); return; }
      s.push(xy[k][0] + "," + xy[k][1]);
    }
    show(e, true);
    e.setAttribute("points", s.join(" "));
  }
  function setCircle(e, x, y) {
    if (!(fin(x) && fin(y))) { show(e, false); return; }
    show(e, true);
    e.setAttribute("cx", x); e.setAttribute("cy", y);
  }

  function drawDiagram(i) {
    levers.forEach(function (lv) {
      var x = X(lv.d.t, i), y = Y(lv.d.t, i), a = ang(lv.d.a, i), L = lv.d.len;
      setLine(lv.bar, x, y, x + L * Math.cos(a), y + L * Math.sin(a));
      setLine(lv.slot, x, y, x + L * Math.cos(a), y + L * Math.sin(a));
    });
    links.forEach(function (lk) {
      if (lk.poly) setPoly(lk.poly, lk.d.n.map(function (t) { return [X(t, i), Y(t, i)]; }));
      else lk.bars.forEach(function (b) { setLine(b[2], X(b[0], i), Y(b[0], i), X(b[1], i), Y(b[1], i)); });
    });
    guides.forEach(function (g) {
      var x = X(g.d.t, i), y = Y(g.d.t, i), a = ang(g.d.a, i), L = 3 * size;
      setLine(g.line, x - L * Math.cos(a), y - L * Math.sin(a), x + L * Math.cos(a), y + L * Math.sin(a));
    });
    blocks.forEach(function (b) {
      var x = X(b.d.t, i), y = Y(b.d.t, i), a = ang(b.d.a, i), dx = Math.cos(a), dy = Math.sin(a);
      var p = 0.95 * size, q = 0.5 * size;
      setPoly(b.poly, [[x - dx * p + dy * q, y - dy * p - dx * q], [x + dx * p + dy * q, y + dy * p - dx * q],
        [x + dx * p - dy * q, y + dy * p + dx * q], [x - dx * p - dy * q, y - dy * p + dx * q]]);
    });
    pairs.forEach(function (p) {
      var d = p.d;
      if (d.k === "circle") { setCircle(p.e, X(d.t, i), Y(d.t, i)); return; }
      if (d.k === "rot") {
        var cx = X(d.t, i), cy = Y(d.t, i), a = ang(d.a, i), c = Math.cos(a), s = Math.sin(a), xy = [];
        for (var k = 0; k < d.p.length; k += 2) xy.push([cx + c * d.p[k] - s * d.p[k + 1], cy + s * d.p[k] + c * d.p[k + 1]]);
        setPoly(p.e, xy);
        return;
      }
      setPoly(p.e, d.n.map(function (t) { return [X(t, i), Y(t, i)]; }));
    });
    joints.forEach(function (j) { setCircle(j.c, X(j.t, i), Y(j.t, i)); });
    points.forEach(function (p) { setCircle(p.c, X(p.d.t, i), Y(p.d.t, i)); });
    traces.forEach(function (tr) {
      tr.el.setAttribute("stroke-dasharray", tr.cum[i] + " " + (tr.len + 1));
    });
    labels.forEach(function (l) { placeLabel(l, i); });
  }

  function placeLabel(l, i) {
    var px = X(l.d.t, i), py = Y(l.d.t, i);
    if (!fin(px) || !fin(py)) { show(l.el, false); return; }
    show(l.el, true);
    var dirs = [], radius = 0.75 * size, tol = 1e-9 * size;
    l.d.nb.forEach(function (t) {
      var qx = X(t, i), qy = Y(t, i);
      if (fin(qx) && Math.hypot(qx - px, qy - py) > tol) dirs.push(unit(qx - px, qy - py));
    });
    l.d.lev.forEach(function (k) { var a = ang(k, i); dirs.push([Math.cos(a), Math.sin(a)]); });
    l.d.blk.forEach(function (k) {
      var a = ang(k, i); dirs.push([Math.cos(a), Math.sin(a)], [-Math.cos(a), -Math.sin(a)]); radius = 1.0 * size;
    });
    l.d.dirs.forEach(function (d) { dirs.push(d); });
    var sx = 0, sy = 0;
    dirs.forEach(function (d) { sx += d[0]; sy += d[1]; });
    var want = dirs.length ? unit(-sx, -sy) : [0.6, 0.8], best = 0, bestScore = -Infinity;
    for (var k = 0; k < CAND.length; k++) {
      var c = CAND[k], clear = Math.PI;
      for (var m = 0; m < dirs.length; m++)
        clear = Math.min(clear, Math.acos(Math.max(-1, Math.min(1, c[0] * dirs[m][0] + c[1] * dirs[m][1]))));
      var score = clear + 0.25 * (c[0] * want[0] + c[1] * want[1]) + 0.05 * c[1] + (k === l.last ? 0.12 : 0);
      if (score > bestScore) { bestScore = score; best = k; }
    }
    l.last = best;
    var c = CAND[best];
    l.el.setAttribute("x", px + c[0] * radius);
    l.el.setAttribute("y", -(py + c[1] * radius));
    l.el.setAttribute("text-anchor", c[0] > 0.35 ? "start" : c[0] < -0.35 ? "end" : "middle");
    l.el.setAttribute("dominant-baseline", c[1] > 0.35 ? "text-after-edge" : c[1] < -0.35 ? "hanging" : "central");
  }

  /* ------------------------------------------------------------------ the plots */
  var XIN = D.input.x, panels = [], plotsBox = document.getElementById("ls-plots");
  var groups = {}, order = [];
  D.series.forEach(function (s) {
    var key = s.unit + (s.angular ? "/a" : "");
    if (!(key in groups)) { groups[key] = []; order.push(key); }
    groups[key].push(s);
  });
  order.forEach(function (key) { panels.push({members: groups[key], extra: false}); });
  var egroups = {}, eorder = [];
  D.extra.forEach(function (s) {
    if (!(s.unit in egroups)) { egroups[s.unit] = []; eorder.push(s.unit); }
    egroups[s.unit].push(s);
  });
  eorder.forEach(function (u) { panels.push({members: egroups[u], extra: true}); });
  var colorOf = {}, nColor = 0;
  D.series.concat(D.extra).forEach(function (s) { colorOf[s.name] = COLORS[nColor++ % COLORS.length]; });
  panels.forEach(function (p) { p.div = h("div", {"class": "ls-panel"}, plotsBox); });

  var tabs = document.getElementById("ls-tabs");
  ["position", "velocity", "acceleration"].forEach(function (t, k) {
    var b = h("button", {type: "button", "class": k === 0 ? "on" : ""}, tabs, t);
    listen(b, "click", function () {
      quantity = k;
      Array.prototype.forEach.call(tabs.children, function (c, j) { c.className = j === k ? "on" : ""; });
      drawPlots(); update(row);
    });
  });

  function niceStep(raw) {
    var e = Math.pow(10, Math.floor(Math.log10(raw))), f = raw / e;
    return (f <= 1 ? 1 : f <= 2 ? 2 : f <= 2.5 ? 2.5 : f <= 5 ? 5 : 10) * e;
  }
  function ticks(lo, hi, n, degrees) {
    var step = niceStep((hi - lo) / n || 1);
    if (degrees && hi - lo >= 90) [15, 30, 45, 90, 180, 360].some(function (s) { return (hi - lo) / s <= n * 1.5 && (step = s); });
    var out = [];
    for (var v = Math.ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * step; v += step) out.push(Math.abs(v) < 1e-12 * step ? 0 : v);
    return out;
  }
  function range(arrs) {
    var lo = Infinity, hi = -Infinity;
    arrs.forEach(function (a) { for (var i = 0; i < a.length; i++) if (fin(a[i])) { if (a[i] < lo) lo = a[i]; if (a[i] > hi) hi = a[i]; } });
    if (!isFinite(lo)) { lo = 0; hi = 1; }
    if (hi - lo < 1e-12 * Math.max(1, Math.abs(hi))) { var m = Math.max(Math.abs(hi) * 0.05, 1e-9); lo -= m; hi += m; }
    return [lo, hi];
  }
  var xr = range([XIN, D.events.map(function (e) { return e.input; })]);
  var xDeg = D.input.unit === "deg";

  function drawPlots() {
    panels.forEach(function (p) {
      p.div.innerHTML = "";
      var W = Math.max(240, p.div.clientWidth || plotsBox.clientWidth || 400), H = 150;
      var L = 58, R = 10, Tp = 20, B = 26, pw = W - L - R, ph = H - Tp - B;
      var q = p.extra ? 0 : quantity;
      var ys = p.members.map(function (s) { return s.q[q]; });
      var yr = range(ys), pad = 0.06 * (yr[1] - yr[0]);
      yr = [yr[0] - pad, yr[1] + pad];
      var sx = function (v) { return L + (v - xr[0]) / (xr[1] - xr[0]) * pw; };
      var sy = function (v) { return Tp + (yr[1] - v) / (yr[1] - yr[0]) * ph; };
      var s = el("svg", {viewBox: "0 0 " + W + " " + H, height: H}, p.div);
      el("rect", {x: L, y: Tp, width: pw, height: ph, fill: "#fbfcfd", stroke: "#d0d5dc"}, s);
      ticks(xr[0], xr[1], Math.max(3, Math.floor(pw / 70)), xDeg).forEach(function (v) {
        el("line", {x1: sx(v), x2: sx(v), y1: Tp, y2: Tp + ph, stroke: "#eceff3"}, s);
        el("text", {x: sx(v), y: H - B + 14, "text-anchor": "middle"}, s).textContent = fmt(v, 4);
      });
      ticks(yr[0], yr[1], 4, false).forEach(function (v) {
        el("line", {x1: L, x2: L + pw, y1: sy(v), y2: sy(v), stroke: v === 0 ? "#b8bfc8" : "#eceff3"}, s);
        el("text", {x: L - 5, y: sy(v) + 4, "text-anchor": "end"}, s).textContent = fmt(v, 4);
      });
      var unitLabel = p.extra ? p.members[0].unit : p.members[0].units[q];
      var kind = p.extra ? "" : (p.members[0].angular ? ["angle", "angular velocity", "angular acceleration"]
        : ["position", "velocity", "acceleration"])[q];
      var ttl = el("text", {x: L, y: 13, "class": "ls-title"}, s);
      p.members.forEach(function (m, k) {
        if (k) ttl.appendChild(document.createTextNode(", "));
        var sp = el("tspan", {fill: colorOf[m.name], "font-weight": 600}, ttl); nameSVG(sp, m.label);
      });
      el("tspan", {}, ttl).textContent = "  " + (kind ? kind + " " : "") + (unitLabel ? "[" + unitLabel + "]" : "");
      var xl = el("text", {x: L + pw, y: 13, "text-anchor": "end"}, s);
      nameSVG(xl, D.input.label); el("tspan", {}, xl).textContent = " [" + D.input.unit + "] →";
      D.events.forEach(function (ev) {
        if (!fin(ev.input)) return;
        var ln = el("line", {x1: sx(ev.input), x2: sx(ev.input), y1: Tp, y2: Tp + ph, stroke: ev.color,
          "stroke-width": ev.kind === "limit" ? 2 : 1.3, "stroke-dasharray": ev.dash}, s);
        el("title", {}, ln).textContent = ev.kind + " at " + fmt(ev.input, 6) + ": " + ev.message;
      });
      var clip = "ls-clip-" + panels.indexOf(p);
      el("rect", {x: L, y: Tp, width: pw, height: ph}, el("clipPath", {id: clip}, el("defs", {}, s)));
      var gl = el("g", {"clip-path": "url(#" + clip + ")"}, s);
      p.dots = [];
      p.members.forEach(function (m, k) {
        var y = m.q[q], d = "", on = false;
        for (var i = 0; i < N; i++) {
          if (!fin(XIN[i]) || !fin(y[i])) { on = false; continue; }
          d += (on ? "L" : "M") + sx(XIN[i]).toFixed(2) + " " + sy(y[i]).toFixed(2);
          on = true;
        }
        el("path", {d: d, fill: "none", stroke: colorOf[m.name], "stroke-width": 1.7, "stroke-linejoin": "round"}, gl);
        p.dots.push([m, el("circle", {r: 4, fill: colorOf[m.name], stroke: "#fff", "stroke-width": 1.5}, s)]);
      });
      p.cursor = el("line", {y1: Tp, y2: Tp + ph, stroke: "#1d2733", "stroke-width": 1, opacity: 0.55}, s);
      p.sx = sx; p.sy = sy; p.q = q;
      s.insertBefore(p.cursor, p.dots.length ? p.dots[0][1] : null);
      s.addEventListener("click", function (evt) {
        var r = s.getBoundingClientRect(), v = xr[0] + ((evt.clientX - r.left) * W / r.width - L) / pw * (xr[1] - xr[0]);
        var best = row, bd = Infinity;
        for (var i = 0; i < N; i++) if (fin(XIN[i]) && Math.abs(XIN[i] - v) < bd) { bd = Math.abs(XIN[i] - v); best = i; }
        go(best);
      });
    });
  }
  function drawCursor(i) {
    panels.forEach(function (p) {
      var x = XIN[i];
      p.cursor.setAttribute("visibility", fin(x) ? "visible" : "hidden");
      if (fin(x)) { p.cursor.setAttribute("x1", p.sx(x)); p.cursor.setAttribute("x2", p.sx(x)); }
      p.dots.forEach(function (md) {
        var y = md[0].q[p.q][i];
        if (fin(x) && fin(y)) { md[1].setAttribute("visibility", "visible"); md[1].setAttribute("cx", p.sx(x)); md[1].setAttribute("cy", p.sy(y)); }
        else md[1].setAttribute("visibility", "hidden");
      });
    });
  }

  /* ------------------------------------------------------------------ values, modes, events */
  var table = document.getElementById("ls-values");
  var thead = h("tr", {}, h("thead", {}, table));
  ["", "position", "velocity", "acceleration"].forEach(function (t) { h("th", {}, thead, t); });
  var tbody = h("tbody", {}, table), cells = [];
  function valueRow(label, units, getters, cls) {
    var tr = h("tr", cls ? {"class": cls} : {}, tbody), td = h("td", {}, tr);
    td.appendChild(nameHTML(label));
    var cs = [];
    for (var k = 0; k < 3; k++) {
      var c = h("td", {}, tr);
      if (!getters[k]) continue;
      var v = h("span", {}, c);
      h("span", {"class": "u"}, c, units[k] || "");
      cs.push([v, getters[k]]);
    }
    cells.push(cs);
  }
  function wrap(v, period) {
    if (!period || !fin(v)) return v;
    var half = period / 2, y = ((v + half) % period + period) % period - half;
    return y === -half ? half : y;
  }
  valueRow(D.input.label, D.input.units,
    [function (i) { return XIN[i]; }, function (i) { return D.input.vel[i]; }, function (i) { return D.input.acc[i]; }]);
  D.series.forEach(function (s) {
    valueRow(s.label, s.units, [0, 1, 2].map(function (k) {
      return function (i) { return k === 0 ? wrap(s.q[0][i], s.wrap) : s.q[k][i]; };
    }));
  });
  D.extra.forEach(function (s) { valueRow(s.label, [s.unit], [function (i) { return s.q[0][i]; }]); });
  var modeCells = [];
  if (D.modes.parts.length && D.modes.runs.some(function (r) { return r[2]; })) {
    var tr = h("tr", {"class": "ls-mode"}, tbody);
    var td = h("td", {colspan: 4}, tr);
    td.appendChild(document.createTextNode("mode "));
    var sig = h("b", {}, td);
    modeCells.push(sig);
    var parts = h("span", {"class": "u"}, td);
    modeCells.push(parts);
  }
  var modeOfRow = new Array(N), shownMode = null;
  D.modes.runs.forEach(function (r) { for (var i = r[0]; i <= r[1]; i++) modeOfRow[i] = r[2]; });

  function drawValues(i) {
    cells.forEach(function (cs) { cs.forEach(function (c) { c[0].textContent = fmt(c[1](i), 6); }); });
    var m = modeOfRow[i] || "";
    if (modeCells.length && m !== shownMode) {
      shownMode = m;
      modeCells[0].textContent = D.modes.labels[m] || m;
      modeCells[1].innerHTML = "";
      if (D.modes.parts.length > 1) D.modes.parts.forEach(function (names, k) {
        modeCells[1].appendChild(document.createTextNode(k ? "  ·  " : "   parts: "));
        names.forEach(function (nm, j) {
          if (j) modeCells[1].appendChild(document.createTextNode(", "));
          modeCells[1].appendChild(nameHTML(nm));
        });
        modeCells[1].appendChild(document.createTextNode(" " + (m.charAt(k) || "?")));
      });
    }
    var status = document.getElementById("ls-status");
    status.innerHTML = "";
    status.appendChild(nameHTML(D.input.label));
    var b = h("b", {}, status, " = " + fmt(XIN[i], 6) + " " + D.input.unit);
    if (m) status.appendChild(document.createTextNode("  ·  mode " + (D.modes.labels[m] || m)));
    var ev = D.events.filter(function (e) { return e.row === i; });
    if (ev.length) status.appendChild(document.createTextNode("  ·  " + ev.map(function (e) { return e.kind; }).join(", ")));
    document.getElementById("ls-row").textContent = "row " + (i + 1) + " / " + N;
  }

  var evList = document.getElementById("ls-events");
  D.events.forEach(function (ev) {
    var li = h("li", {style: "color:" + ev.color}, evList);
    h("span", {style: "color:var(--ink)"}, li, ev.kind + " at " + fmt(ev.input, 6) + " " + D.input.unit + " (row " + (ev.row + 1) + ")");
    li.title = ev.message;
    li.addEventListener("click", function () { go(ev.row); });
  });

  /* ------------------------------------------------------------------ slider, marks, playback */
  var slider = document.getElementById("loopsolve-input"), marks = document.getElementById("ls-marks");
  function drawMarks() {
    marks.innerHTML = "";
    var W = marks.clientWidth || slider.clientWidth || 300, r = 8, span = Math.max(1, W - 2 * r);
    marks.setAttribute("viewBox", "0 0 " + W + " 12");
    var pos = function (i) { return r + (N > 1 ? i / (N - 1) : 0) * span; };
    if (D.modes.changes) {
      var colorIdx = {};
      D.modes.runs.forEach(function (run) {
        if (!(run[2] in colorIdx)) colorIdx[run[2]] = Object.keys(colorIdx).length;
        var a = pos(Math.max(0, run[0] - 0.5)), b = pos(Math.min(N - 1, run[1] + 0.5));
        var rc = el("rect", {x: a, y: 3, width: Math.max(1, b - a), height: 6, fill: MODE_COLORS[colorIdx[run[2]] % MODE_COLORS.length]}, marks);
        el("title", {}, rc).textContent = "mode " + (D.modes.labels[run[2]] || run[2]) + ", rows " + (run[0] + 1) + "–" + (run[1] + 1);
      });
    }
    var order = D.events.slice().sort(function (a, b) { return (a.kind === "limit") - (b.kind === "limit"); });
    order.forEach(function (ev) { // a limit drawn last: on top of the mode change at the same row
      var x = pos(ev.row);
      var m = el("path", {d: "M" + x + " 0 L" + (x - 4) + " 11 L" + (x + 4) + " 11 Z", fill: ev.color}, marks);
      el("title", {}, m).textContent = ev.kind + " at " + fmt(ev.input, 6) + " " + D.input.unit;
    });
  }

  function update(i) {
    i = Math.max(0, Math.min(N - 1, Math.round(i)));
    row = i;
    if (+slider.value !== i) slider.value = i;
    slider.setAttribute("data-value", String(XIN[i]));
    drawDiagram(i);
    drawCursor(i);
    drawValues(i);
    if (opts.onUpdate) opts.onUpdate(i);
  }
  function go(i) { if (playing) toggle(); update(i); }
  slider.setAttribute("max", String(N - 1));
  listen(slider, "input", function () { update(+slider.value); });
  var playBtn = document.getElementById("ls-play");
  function toggle() {
    playing = !playing;
    playBtn.textContent = playing ? "❚❚" : "▶";
    lastTime = null; acc = 0;
    if (playing) requestAnimationFrame(tick);
  }
  function tick(t) {
    if (!playing) return;
    if (lastTime !== null) {
      var rate = Math.max(N / 6, 8) * speed; // rows per second: one pass in about six seconds at 1×
      acc += (t - lastTime) / 1000 * rate;
      var steps = Math.floor(acc);
      if (steps > 0) { acc -= steps; update((row + steps) % N); }
    }
    lastTime = t;
    requestAnimationFrame(tick);
  }
  listen(playBtn, "click", toggle);
  var speedSel = document.getElementById("ls-speed");
  speed = +speedSel.value || 1;
  listen(speedSel, "change", function (e) { speed = +e.target.value; });
  listen(document, "keydown", function (e) {
    var tag = (e.target && e.target.tagName) || "";
    if (tag === "TEXTAREA" || (tag === "INPUT" && e.target.type !== "range") || (e.target && e.target.isContentEditable)) return;
    if (e.key === " " && tag !== "BUTTON" && tag !== "SELECT") { e.preventDefault(); toggle(); return; }
    if (tag === "INPUT" || tag === "SELECT" || tag === "TEXTAREA") return; // the slider steps by itself
    var k = e.shiftKey ? 10 : 1;
    if (e.key === "ArrowRight" || e.key === "ArrowUp") { e.preventDefault(); go(row + k); }
    else if (e.key === "ArrowLeft" || e.key === "ArrowDown") { e.preventDefault(); go(row - k); }
    else if (e.key === "PageUp") go(row + 10);
    else if (e.key === "PageDown") go(row - 10);
    else if (e.key === "Home") go(0);
    else if (e.key === "End") go(N - 1);
  });
  var resizeTimer = null;
  listen(window, "resize", function () {
    clearTimeout(resizeTimer);
    resizeTimer = setTimeout(function () { drawPlots(); drawMarks(); update(row); }, 80);
  });
  drawPlots();
  drawMarks();
  update(opts.row || 0);
  return {
    update: go, world: world, svg: svg, size: size,
    row: function () { return row; },
    input: function (i) { return XIN[i === undefined ? row : i]; },
    modeOf: function (i) { return modeOfRow[i === undefined ? row : i] || ""; },
    point: function (name, i) {
      var p = S.points.filter(function (q) { return q.name === name; })[0];
      if (!p) return null;
      i = i === undefined ? row : i;
      return [X(p.t, i), Y(p.t, i)];
    },
    destroy: function () {
      playing = false;
      listeners.forEach(function (l) { l[0].removeEventListener(l[1], l[2]); });
      listeners = [];
    }
  };
  }
  window.LoopsolveView = {render: render};
  var holder = document.getElementById("ls-data");
  if (holder && holder.textContent.trim()) render(JSON.parse(holder.textContent));
})();
