/* loopsolve edit: the editor's page script (served inline by loopsolve/editor/page.py; no network but
 * its own server, no libraries). The drawing, plots, values, slider and playback are view.js's
 * (LoopsolveView.render); this script adds the editing around them.
 * Hooks kept for scripts and tests (DESIGN.md, "Editor"): #loopsolve-input carries data-value (the
 * input at the current row, model units); every draggable joint is an SVG circle data-joint="NAME"
 * whose cx, cy are its model coordinates at the current row; the share link is this page's URL
 * with #model=<base64url of the TOML>. */
(function () {
  "use strict";
  var NS = "http://www.w3.org/2000/svg";
  var TOKEN = new URLSearchParams(location.search).get("token") || "";
  var version = 0, state = null, view = null, tool = "drag", busy = 0, pendingLink = null, drawing = null;
  var handles = [], sketchWorld = null, curvePreview = null, synthTargets = null, job = null;
  var $ = function (id) { return document.getElementById(id); };

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
  function clear(e) { while (e.firstChild) e.removeChild(e.firstChild); return e; }
  function fmt(v, d) {
    if (v === null || v === undefined || !isFinite(v)) return "–";
    var a = Math.abs(v); d = d || 6;
    if (v === 0) return "0";
    if (a >= 1e6 || a < 1e-4) return v.toExponential(d - 2).replace("e+", "e");
    var s = v.toFixed(Math.max(0, d - 1 - Math.floor(Math.log10(a))));
    return s.indexOf(".") >= 0 ? s.replace(/0+$/, "").replace(/\.$/, "") : s;
  }
  function message(text, kind) {
    var m = $("le-message");
    m.textContent = text || "";
    m.className = kind || "";
  }

  /* ------------------------------------------------------------------ the server */
  function api(method, path, body) {
    var opts = {method: method, headers: {"X-Loopsolve-Token": TOKEN}, cache: "no-store"};
    if (body !== undefined) { opts.headers["Content-Type"] = "application/json"; opts.body = JSON.stringify(body); }
    busy++;
    document.body.classList.add("le-busy");
    return fetch(path, opts).then(function (r) {
      return r.json().then(function (j) { j.__status = r.status; return j; }, function () { return {__status: r.status, error: "HTTP " + r.status}; });
    }).finally(function () {
      busy--;
      if (!busy) document.body.classList.remove("le-busy");
    });
  }
  function edit(op) {
    return api("POST", "/api/edit", op).then(function (j) {
      if (j.__status !== 200) { message(j.error || "the edit failed", "error"); redrawHandles(); return false; }
      apply(j);
      message("");
      return true;
    });
  }

  /* ------------------------------------------------------------------ share link */
  function b64urlEncode(text) {
    var bytes = new TextEncoder().encode(text), bin = "";
    for (var i = 0; i < bytes.length; i++) bin += String.fromCharCode(bytes[i]);
    return btoa(bin).replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "");
  }
  function b64urlDecode(s) {
    s = s.replace(/-/g, "+").replace(/_/g, "/");
    while (s.length % 4) s += "=";
    var bin = atob(s), bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new TextDecoder("utf-8", {fatal: true}).decode(bytes);
  }
  function shareURL() {
    return location.origin + location.pathname + location.search + "#model=" + b64urlEncode(state.document.toml);
  }

  /* ------------------------------------------------------------------ applying a state */
  function currentValue() {
    var s = $("loopsolve-input"), v = s.getAttribute("data-value");
    return v === null ? null : +v;
  }
  function apply(j) {
    var keep = currentValue();
    state = j;
    var A = j.analysis, doc = j.document;
    history.replaceState(null, "", location.pathname + location.search + "#model=" + b64urlEncode(doc.toml));
    $("le-title").textContent = A.name || "loopsolve edit";
    document.title = (A.name || "model") + " · loopsolve edit";
    $("le-doc").textContent = (doc.path ? doc.path : "new model (not saved)") + (doc.dirty ? " · modified" : "");
    $("le-undo").disabled = !doc.undo;
    $("le-redo").disabled = !doc.redo;
    if (view) { view.destroy(); view = null; }
    sketchWorld = null;
    if (A.ok) {
      var X = A.page.input.x, row = 0;
      if (keep !== null) {
        var best = Infinity;
        for (var i = 0; i < X.length; i++) if (X[i] !== null && Math.abs(X[i] - keep) < best) { best = Math.abs(X[i] - keep); row = i; }
      }
      view = LoopsolveView.render(A.page, {row: row, onUpdate: onRow});
    } else {
      sketch(A);
      message(A.error || "not a mechanism", "error");
    }
    drawHandles();
    drawInfo();
    drawDims();
    drawForces();
    drawRange();
    drawSynthOverlay();
    onRow(view ? view.row() : 0);
    document.body.setAttribute("data-version", String(++version));
  }

  /* a model that is not (yet) a mechanism: its joints and links as declared */
  function sketch(A) {
    ["ls-diagram", "ls-plots", "ls-values", "ls-events", "ls-tabs", "ls-legend", "ls-marks"].forEach(function (id) { clear($(id)); });
    var svg = $("ls-diagram"), pts = A.joints.filter(function (j) { return j.at; });
    var xs = pts.map(function (j) { return j.at[0]; }), ys = pts.map(function (j) { return j.at[1]; });
    var x0 = Math.min.apply(null, xs.concat([0])), x1 = Math.max.apply(null, xs.concat([1]));
    var y0 = Math.min.apply(null, ys.concat([0])), y1 = Math.max.apply(null, ys.concat([1]));
    var pad = 0.15 * Math.max(x1 - x0, y1 - y0, 1);
    svg.setAttribute("viewBox", [x0 - pad, -(y1 + pad), x1 - x0 + 2 * pad, y1 - y0 + 2 * pad].join(" "));
    var world = el("g", {transform: "scale(1,-1)", id: "ls-world"}, svg);
    var at = {};
    pts.forEach(function (j) { at[j.name] = j.at; });
    var w = 0.012 * Math.max(x1 - x0, y1 - y0, 1);
    Object.keys(A.links).forEach(function (k) {
      var js = A.links[k].filter(function (n) { return at[n]; });
      for (var a = 0; a < js.length; a++) for (var b = a + 1; b < js.length; b++)
        el("line", {x1: at[js[a]][0], y1: at[js[a]][1], x2: at[js[b]][0], y2: at[js[b]][1], "class": k === "ground" ? "le-sketch-ground" : "le-sketch-link", "stroke-width": w}, world);
    });
    sketchWorld = world;
    $("loopsolve-input").setAttribute("max", "0");
    $("loopsolve-input").removeAttribute("data-value");
  }
  function world() { return view ? view.world : sketchWorld; }
  function size() {
    if (view) return view.size;
    var A = state.analysis, xs = A.joints.filter(function (j) { return j.at; }).map(function (j) { return j.at[0]; });
    return 0.04 * Math.max(1, Math.max.apply(null, xs.concat([1])) - Math.min.apply(null, xs.concat([0])));
  }
  function jointAt(name) {
    if (view) { var p = view.point(name); if (p && p[0] !== null && isFinite(p[0])) return p; }
    var j = state.analysis.joints.filter(function (q) { return q.name === name; })[0];
    return j && j.at ? j.at : null;
  }

  /* ------------------------------------------------------------------ joint handles and dragging */
  function drawHandles() {
    handles.forEach(function (hd) { if (hd.parentNode) hd.parentNode.removeChild(hd); });
    handles = [];
    var w = world();
    if (!w || state.analysis.kind !== "diagram") return;
    var g = el("g", {id: "le-handles"}, w), r = 0.42 * size();
    state.analysis.joints.forEach(function (j) {
      var c = el("circle", {r: r, "class": "le-handle" + (j.ground ? " le-ground" : "") + (j.point ? " le-point" : ""),
        "data-joint": j.name, tabindex: "0"}, g);
      el("title", {}, c).textContent = j.name + (j.ground ? " (ground pivot)" : j.point ? " (point)" : "");
      c.addEventListener("pointerdown", onHandleDown);
      handles.push(c);
    });
    handles.push(g);
    redrawHandles();
  }
  function redrawHandles() {
    handles.forEach(function (c) {
      var n = c.getAttribute && c.getAttribute("data-joint");
      if (!n) return;
      var p = jointAt(n);
      if (!p) { c.setAttribute("visibility", "hidden"); return; }
      c.setAttribute("visibility", "visible");
      c.setAttribute("cx", p[0]); c.setAttribute("cy", p[1]);
    });
  }
  function toModel(evt) {
    var w = world(), m = w.getScreenCTM();
    if (!m) return null;
    var pt = w.ownerSVGElement.createSVGPoint();
    pt.x = evt.clientX; pt.y = evt.clientY;
    var q = pt.matrixTransform(m.inverse());
    return [q.x, q.y];
  }
  function rowOp(op) {
    var v = currentValue();
    if (v !== null && isFinite(v)) op.at = v;
    if (view) { var m = view.modeOf(); if (m) op.mode = m; }
    return op;
  }
  var drag = null;
  function onHandleDown(evt) {
    if (drawing) return;  /* drawing a curve: the stroke may start on a joint */
    var name = evt.currentTarget.getAttribute("data-joint");
    if (tool === "drag") {
      evt.preventDefault();
      evt.stopPropagation();
      var c = evt.currentTarget;
      c.setPointerCapture(evt.pointerId);
      drag = {name: name, c: c, start: jointAt(name), to: null, id: evt.pointerId, ghosts: ghosts(name)};
      c.classList.add("le-dragging");
      c.addEventListener("pointermove", onDragMove);
      c.addEventListener("pointerup", onDragEnd);
      c.addEventListener("pointercancel", onDragEnd);
      return;
    }
    evt.stopPropagation();
    evt.preventDefault();
    toolOnJoint(name, evt);
  }
  function ghosts(name) {  /* dashed lines to the joints on the same links, following the pointer */
    var out = [], w = world(), links = state.analysis.links;
    Object.keys(links).forEach(function (k) {
      if (links[k].indexOf(name) < 0) return;
      links[k].forEach(function (o) {
        if (o === name) return;
        var p = jointAt(o);
        if (p) out.push([p, el("line", {"class": "le-ghost", "stroke-width": 0.12 * size(), x1: p[0], y1: p[1]}, w)]);
      });
    });
    return out;
  }
  function onDragMove(evt) {
    if (!drag || evt.pointerId !== drag.id) return;
    var p = toModel(evt);
    if (!p) return;
    drag.to = p;
    drag.c.setAttribute("cx", p[0]); drag.c.setAttribute("cy", p[1]);
    drag.ghosts.forEach(function (g) { g[1].setAttribute("x2", p[0]); g[1].setAttribute("y2", p[1]); });
    message(drag.name + " → (" + fmt(p[0], 6) + ", " + fmt(p[1], 6) + ") " + ((state.analysis.units || {}).length || ""));
  }
  function onDragEnd(evt) {
    if (!drag || evt.pointerId !== drag.id) return;
    var d = drag;
    drag = null;
    d.c.classList.remove("le-dragging");
    d.c.removeEventListener("pointermove", onDragMove);
    d.c.removeEventListener("pointerup", onDragEnd);
    d.c.removeEventListener("pointercancel", onDragEnd);
    d.ghosts.forEach(function (g) { if (g[1].parentNode) g[1].parentNode.removeChild(g[1]); });
    if (evt.type === "pointerup") { var p = toModel(evt); if (p) d.to = p; }
    if (!d.to || (d.start && Math.hypot(d.to[0] - d.start[0], d.to[1] - d.start[1]) < 1e-9 * size())) { redrawHandles(); return; }
    edit(rowOp({op: "move", joint: d.name, to: d.to}));
  }

  /* clicks on the drawing for the other tools */
  function nearestLink(p) {
    var links = state.analysis.links, best = null, bd = Infinity;
    Object.keys(links).forEach(function (k) {
      var js = links[k];
      for (var a = 0; a < js.length; a++) for (var b = a + 1; b < js.length; b++) {
        var A = jointAt(js[a]), B = jointAt(js[b]);
        if (!A || !B) continue;
        var dx = B[0] - A[0], dy = B[1] - A[1], L2 = dx * dx + dy * dy;
        var t = L2 > 0 ? Math.max(0, Math.min(1, ((p[0] - A[0]) * dx + (p[1] - A[1]) * dy) / L2)) : 0;
        var d = Math.hypot(p[0] - A[0] - t * dx, p[1] - A[1] - t * dy);
        if (d < bd) { bd = d; best = k; }
      }
    });
    return bd <= 1.2 * size() ? best : null;
  }
  function toolOnJoint(name, evt) {
    if (tool === "link") {
      if (!pendingLink) { pendingLink = {joints: [name], neu: {}}; message("link from " + name + ": click the other joint (or an empty place)"); return; }
      finishLink(name, null);
    } else if (tool === "delete") {
      edit({op: "delete", joint: name});
    } else if (tool === "slider") {
      ask("Slide direction of the block at " + name + " (degrees from +x)", "0").then(function (v) {
        if (v === null) return;
        var a = parseFloat(v) * Math.PI / 180;
        if (!isFinite(a)) { message("not an angle: " + v, "error"); return; }
        edit(rowOp({op: "add_slider", joint: name, guide: "ground", axis: [Math.cos(a), Math.sin(a)]}));
      });
    } else if (tool === "input") {
      edit({op: "input", joint: name});
    } else if (tool === "point") {
      var p = toModel(evt), k = p && nearestLink(p);
      if (k) edit(rowOp({op: "add_point", link: k, to: p}));
    }
  }
  function freeName(prefix) {
    var used = {};
    state.analysis.joints.forEach(function (j) { used[j.name] = 1; });
    Object.keys(state.analysis.links).forEach(function (k) { used[k] = 1; });
    if (pendingLink) Object.keys(pendingLink.neu).forEach(function (k) { used[k] = 1; });
    var k = 1;
    while (used[prefix + k]) k++;
    return prefix + k;
  }
  function finishLink(name, p) {
    if (!name) { name = freeName("J"); pendingLink.neu[name] = p; }
    if (pendingLink.joints.indexOf(name) >= 0) { message("a link joins two different joints", "error"); return; }
    pendingLink.joints.push(name);
    var op = {op: "add_link", joints: pendingLink.joints, "new": pendingLink.neu};
    pendingLink = null;
    edit(op);
  }
  function onDiagramDown(evt) {
    if (drawing) { startStroke(evt); return; }
    if (!state || tool === "drag" || evt.target.getAttribute("data-joint") || evt.button) return;
    var p = toModel(evt);
    if (!p) return;
    if (tool === "link") {
      if (!pendingLink) { var n = freeName("J"); pendingLink = {joints: [n], neu: {}}; pendingLink.neu[n] = p; message("link from a new joint " + n + ": click the other end"); }
      else finishLink(null, p);
    } else if (tool === "point" || tool === "delete") {
      var k = nearestLink(p);
      if (!k) return;
      if (tool === "point") edit(rowOp({op: "add_point", link: k, to: p}));
      else edit({op: "delete", link: k});
    }
  }

  function onRow(i) {
    redrawHandles();
    var v = currentValue(), mode = view ? view.modeOf(i) : "";
    ["png", "svg", "dxf", "tex"].forEach(function (f) {
      var a = $("le-export-" + f);
      a.setAttribute("href", "/api/export?format=" + f + (v !== null && isFinite(v) ? "&at=" + encodeURIComponent(v) : "") +
        (mode ? "&mode=" + encodeURIComponent(mode) : "") + "&token=" + encodeURIComponent(TOKEN));
    });
    drawForceRow(i);
    Array.prototype.forEach.call(document.querySelectorAll("#le-joint-table input[data-coord]"), function (inp) {
      if (inp === document.activeElement) return;
      var key = inp.getAttribute("data-coord"), p = jointAt(key.slice(0, -2));
      if (p) inp.value = fmt(p[key.slice(-1) === "x" ? 0 : 1], 10);
    });
  }

  /* ------------------------------------------------------------------ panels */
  function drawInfo() {
    var box = clear($("le-info")), A = state.analysis;
    if (!A.ok) { h("p", {"class": "le-error"}, box, A.error); return; }
    var ul = h("ul", {}, box), info = A.info || {};
    if (A.mode && A.mode.signature) h("li", {}, ul, "assembly mode " + (A.mode.label || A.mode.signature) + " (named by the drawn pose; kept by every edit)");
    h("li", {}, ul, "mobility " + info.mobility + " · input " + (A.input ? A.input.name : "?"));
    (info.fourbars || []).forEach(function (fb) {
      var li = h("li", {"class": "le-grashof"}, ul);
      li.textContent = "four-bar " + Object.keys(fb.links).map(function (k) { return fb.links[k]; }).join("–") + ": " + fb.grashof +
        " · input " + fb.input_motion + (fb.transmission_angle_range ? " · transmission " + fmt(fb.transmission_angle_range[0], 4) + "°–" + fmt(fb.transmission_angle_range[1], 4) + "°" : "");
    });
    var ranges = info.reachable_input_ranges || [];
    if (ranges.length) h("li", {}, ul, "input reaches " + ranges.map(function (r) { return "[" + fmt(r[0], 6) + ", " + fmt(r[1], 6) + "]"; }).join(", ") + " " + A.page.input.unit);
    var lim = (A.events || []).filter(function (e) { return e.kind === "limit"; });
    if (lim.length) h("li", {}, ul, "limit positions at " + lim.map(function (e) { return fmt(e.input, 6); }).join(", ") + " " + A.page.input.unit);
  }
  function drawRange() {
    var f = clear($("le-range")), A = state.analysis;
    if (!A.ok || !A.settings) return;
    h("span", {}, f, "sweep");
    var ins = {};
    [["from", "from"], ["to", "to"], ["step", "step"]].forEach(function (kv) {
      var l = h("label", {}, f, kv[1] + " ");
      ins[kv[0]] = h("input", {type: "text", size: "7", value: fmt(A.settings[kv[0]], 10), "data-field": kv[0]}, l);
    });
    var lt = h("label", {}, f, " through limits ");
    var th = h("input", {type: "checkbox"}, lt);
    th.checked = !!A.settings.through;
    var b = h("button", {type: "submit"}, f, "Sweep");
    f.onsubmit = function (e) {
      e.preventDefault();
      edit({op: "settings", from: +ins.from.value, to: +ins.to.value, step: +ins.step.value, through: th.checked});
    };
  }
  function drawDims() {
    var box = clear($("le-dims")), A = state.analysis;
    h("p", {"class": "le-note"}, box, "Type exact values; a unit may follow (25, 1.2in, 30mm). The linkage is re-solved at the current input in its mode.");
    var t = h("table", {"class": "le-table", id: "le-dim-table"}, box), unit = (A.units || {}).length || "";
    var hr = h("tr", {}, h("thead", {}, t));
    ["dimension", "value", ""].forEach(function (x) { h("th", {}, hr, x); });
    var tb = h("tbody", {}, t);
    (A.dimensions || []).forEach(function (d) {
      var tr = h("tr", {}, tb);
      h("td", {}, tr, d.name);
      var inp = h("input", {type: "text", size: "12", value: fmt(d.value, 12), "data-dimension": d.name}, h("td", {}, tr));
      h("td", {"class": "u"}, tr, d.kind === "angle" ? A.units.angle : d.kind === "length" ? unit : "");
      inp.addEventListener("change", function () {
        edit(rowOp({op: A.kind === "diagram" ? "dimension" : "parameter", name: d.name, value: inp.value.trim()}));
      });
    });
    if (A.kind === "diagram") {
      h("h3", {}, box, "joints (at the current input)");
      var jt = h("table", {"class": "le-table", id: "le-joint-table"}, box);
      var jh = h("tr", {}, h("thead", {}, jt));
      ["joint", "x", "y"].forEach(function (x) { h("th", {}, jh, x); });
      var jb = h("tbody", {}, jt);
      A.joints.forEach(function (j) {
        var tr = h("tr", {}, jb), p = jointAt(j.name) || j.at || [null, null];
        h("td", {}, tr, j.name + (j.ground ? " (ground)" : j.point ? " (point)" : ""));
        var xs = [0, 1].map(function (k) {
          return h("input", {type: "text", size: "10", value: fmt(p[k], 10), "data-coord": j.name + (k ? "_y" : "_x")}, h("td", {}, tr));
        });
        xs.forEach(function (inp) {
          inp.addEventListener("change", function () { edit(rowOp({op: "coords", joint: j.name, x: xs[0].value.trim(), y: xs[1].value.trim()})); });
        });
      });
    }
    h("h3", {}, box, "model");
    var f = h("div", {"class": "le-form"}, box);
    var nl = h("label", {}, f, "name ");
    var ni = h("input", {type: "text", size: "28", value: A.name || ""}, nl);
    ni.addEventListener("change", function () { edit({op: "name", name: ni.value}); });
    var sl = h("label", {}, f, " input speed ");
    var si = h("input", {type: "text", size: "8", placeholder: "10rpm", value: speedOf()}, sl);
    si.addEventListener("change", function () { edit({op: "rates", speed: si.value.trim()}); });
  }
  function speedOf() {
    var M = state.model || {}, holder = null;
    if (M.input) holder = M.input;
    else Object.keys(M.variables || {}).forEach(function (k) { var v = M.variables[k]; if (v && v.input) holder = v; });
    return holder && holder.speed !== undefined ? String(holder.speed) : "";
  }

  /* forces: masses, loads, gravity; the forces at the current row */
  function drawForces() {
    var box = clear($("le-forces")), A = state.analysis;
    if (A.kind !== "diagram") { h("p", {"class": "le-note"}, box, "Masses and loads are edited here for kinematic-diagram models; this model's [bodies] and [[loads]] are used as declared."); }
    h("p", {"class": "le-note"}, box, "Mass properties per moving link (mass with a unit, inertia about the centre of mass, e.g. 2.5e-4kg*m^2; centre of mass: a joint name or \"mid\" for the middle of the link). Results are SI, the same numbers as loopsolve forces.");
    var t = h("table", {"class": "le-table", id: "le-body-table"}, box);
    var hr = h("tr", {}, h("thead", {}, t));
    ["link", "mass", "inertia", "centre of mass", ""].forEach(function (x) { h("th", {}, hr, x); });
    var tb = h("tbody", {}, t), bodies = (state.model && state.model.bodies) || {};
    if (A.kind === "diagram") Object.keys(A.links).forEach(function (k) {
      if (k === "ground") return;
      var b = bodies[k] || {}, tr = h("tr", {}, tb);
      h("td", {}, tr, k);
      var m = h("input", {type: "text", size: "8", value: b.mass !== undefined ? String(b.mass) : "", "data-body-mass": k}, h("td", {}, tr));
      var i = h("input", {type: "text", size: "12", value: b.inertia !== undefined ? String(b.inertia) : "", "data-body-inertia": k}, h("td", {}, tr));
      var comv = typeof b.com === "string" ? b.com : (b.at || (b.com && b.com.at)) ? "drawn" : "";
      var c = h("input", {type: "text", size: "8", value: comv, placeholder: "mid", "data-body-com": k}, h("td", {}, tr));
      var btn = h("button", {type: "button"}, h("td", {}, tr), b.mass !== undefined || b.bar ? "Set" : "Add");
      btn.addEventListener("click", function () {
        if (!m.value.trim()) { edit({op: "body", link: k, props: null}); return; }
        var props = {mass: m.value.trim()};
        if (i.value.trim()) props.inertia = i.value.trim();
        var cv = c.value.trim();
        if (cv === "drawn" && (b.at || b.com)) { if (b.at) props.at = b.at; else props.com = b.com; }
        else if (!cv || cv === "mid") {
          var js = A.links[k].map(jointAt).filter(function (p) { return p; }), sx = 0, sy = 0;
          js.forEach(function (p) { sx += p[0]; sy += p[1]; });
          props.at = [sx / js.length, sy / js.length];
        } else props.com = cv;
        edit(rowOp({op: "body", link: k, props: props}));
      });
    });
    var g = h("div", {"class": "le-form"}, box);
    var gl = h("label", {}, g, "gravity [gx, gy] ");
    var gv = (state.model && state.model.gravity) || null;
    var gi = h("input", {type: "text", size: "22", value: gv ? gv.join(", ") : "", placeholder: "0, -9.81m/s^2", id: "le-gravity"}, gl);
    gi.addEventListener("change", function () {
      var s = gi.value.trim();
      edit({op: "gravity", gravity: s ? s.split(",").map(function (x) { x = x.trim(); return /^[-+0-9.eE]+$/.test(x) ? +x : x; }) : null});
    });
    h("h3", {}, box, "loads (one per line: body torque VALUE, or body at POINT force FX, FY)");
    var ta = h("textarea", {rows: "3", cols: "44", id: "le-loads", spellcheck: "false"}, box);
    ta.value = ((state.model && state.model.loads) || []).map(function (ld) {
      if (ld.torque !== undefined) return ld.body + " torque " + ld.torque;
      return (ld.body || "") + " at " + ld.at + " force " + (ld.force || []).join(", ");
    }).join("\n");
    var lb = h("button", {type: "button"}, box, "Set loads");
    lb.addEventListener("click", function () {
      var out = [], bad = null;
      ta.value.split("\n").forEach(function (line) {
        line = line.trim();
        if (!line) return;
        var m1 = line.match(/^(\w+)\s+torque\s+(.+)$/), m2 = line.match(/^(\w+)\s+at\s+(\w+)\s+force\s+([^,]+),\s*(.+)$/);
        var num = function (x) { x = x.trim(); return /^[-+0-9.eE]+$/.test(x) ? +x : x; };
        if (m1) out.push({body: m1[1], torque: num(m1[2])});
        else if (m2) out.push({at: m2[2], body: m2[1], force: [num(m2[3]), num(m2[4])]});
        else bad = line;
      });
      if (bad) { message("cannot read the load line: " + bad, "error"); return; }
      edit({op: "loads", loads: out});
    });
    h("h3", {}, box, "forces at the current row");
    h("table", {"class": "le-table", id: "le-force-row"}, box);
  }
  function drawForceRow(i) {
    var t = $("le-force-row");
    if (!t) return;
    clear(t);
    var F = state.analysis.forces;
    if (!F) { h("caption", {}, t, "no masses declared: add them above"); return; }
    var cols = F.columns, tb = h("tbody", {}, t);
    Object.keys(cols).forEach(function (k) {
      if (!/^(input_torque|input_force|F_|shaking_|kinetic_energy|potential_energy)/.test(k)) return;
      var tr = h("tr", {}, tb);
      h("td", {}, tr, k);
      h("td", {"data-force": k}, tr, fmt(cols[k][i], 6));
      h("td", {"class": "u"}, tr, F.units[k] || "");
    });
  }

  /* ------------------------------------------------------------------ synthesis */
  function drawSynthPanel() {
    var box = clear($("le-synth"));
    var f = h("div", {"class": "le-form"}, box);
    var ml = h("label", {}, f, "method ");
    var sel = h("select", {id: "le-synth-method"}, ml);
    [["shape", "shape: coupler curve of the drawn shape (atlas; any place, size, timing)"], ["path", "path: coupler curve through drawn points (free timing)"], ["freudenstein", "function: three precision points (Freudenstein)"]].forEach(function (o) {
      h("option", {value: o[0]}, sel, o[1]);
    });
    var pathBox = h("div", {id: "le-synth-path"}, box);
    h("p", {"class": "le-note", id: "le-synth-shape-note"}, pathBox, "Draw a curve on the diagram with the mouse (press Draw, then drag), or paste points x, y (one per line, model units). Shape: four-bars whose coupler curve has this shape, placed on it (a curve whose end is within 15 % of its size from its start is closed, else open); the first use builds the four-bar atlas into the cache (minutes, once).");
    var pathNote = h("p", {"class": "le-note", id: "le-synth-path-note", hidden: ""}, pathBox, "Path: the curve is resampled to N points met in order as the crank turns one way.");
    var row1 = h("div", {"class": "le-form"}, pathBox);
    var db = h("button", {type: "button", id: "le-draw"}, row1, "Draw curve");
    var shapeOpts = h("span", {id: "le-synth-shape-opts"}, row1);
    var kl = h("label", {}, shapeOpts, " curve ");
    var kSel = h("select", {id: "le-synth-closed"}, kl);
    [["auto", "auto"], ["closed", "closed"], ["open", "open"]].forEach(function (o) { h("option", {value: o[0]}, kSel, o[1]); });
    var tl = h("label", {}, shapeOpts, " candidates ");
    var tIn = h("input", {type: "number", min: "1", max: "10", value: "5", id: "le-synth-top", size: "3"}, tl);
    var pathOpts = h("span", {id: "le-synth-path-opts", hidden: ""}, row1);
    var nl = h("label", {}, pathOpts, " N ");
    var nIn = h("input", {type: "number", min: "3", max: "40", value: "8", id: "le-synth-n", size: "3"}, nl);
    var rl = h("label", {}, pathOpts, " runs ");
    var rIn = h("input", {type: "number", min: "1", max: "10", value: "2", id: "le-synth-runs", size: "3"}, rl);
    var cl = h("label", {}, row1, " crank ");
    var cIn = h("input", {type: "checkbox", id: "le-synth-crank"}, cl);
    var ta = h("textarea", {rows: "5", cols: "40", id: "le-synth-points", spellcheck: "false", placeholder: "x, y per line"}, pathBox);
    var fBox = h("div", {id: "le-synth-fn", hidden: ""}, box);
    h("p", {"class": "le-note"}, fBox, "Precision points: input angle, output angle (degrees), one per line; three are met exactly.");
    var fta = h("textarea", {rows: "4", cols: "30", id: "le-synth-fpoints", spellcheck: "false"}, fBox);
    fta.value = "49.019, 153.441\n75, 201.633\n100.981, 222.57";
    sel.addEventListener("change", function () {
      var curve = sel.value !== "freudenstein";
      pathBox.hidden = !curve;
      fBox.hidden = curve;
      shapeOpts.hidden = sel.value !== "shape";
      pathOpts.hidden = pathNote.hidden = sel.value !== "path";
    });
    var row2 = h("div", {"class": "le-form"}, box);
    var go = h("button", {type: "button", id: "le-synth-go"}, row2, "Find linkages");
    var cancel = h("button", {type: "button", id: "le-synth-cancel", disabled: ""}, row2, "Cancel");
    h("progress", {id: "le-synth-progress", max: "1", value: "0"}, row2);
    h("span", {id: "le-synth-status"}, row2);
    h("ol", {id: "le-candidates"}, box);
    db.addEventListener("click", function () {
      drawing = drawing ? null : {points: []};
      db.classList.toggle("on", !!drawing);
      message(drawing ? "drag on the diagram to draw the curve" : "");
    });
    ta.addEventListener("change", function () { synthTargets = parsePoints(ta.value); drawSynthOverlay(); });
    go.addEventListener("click", function () {
      var method = sel.value, params;
      if (method === "shape") {
        var spts = parsePoints(ta.value);
        if (!spts || spts.length < 5) { message("draw a curve or paste at least five points", "error"); return; }
        spts = spts.length > 40 ? resample(spts, 40) : spts;
        synthTargets = spts;
        drawSynthOverlay();
        params = {points: spts, closed: kSel.value === "auto" ? "auto" : kSel.value === "closed",
                  top: Math.max(1, Math.min(10, parseInt(tIn.value, 10) || 5)), crank: cIn.checked};
      } else if (method === "path") {
        var pts = parsePoints(ta.value);
        if (!pts || pts.length < 3) { message("draw a curve or paste at least three points", "error"); return; }
        var n = Math.max(3, Math.min(40, parseInt(nIn.value, 10) || 8));
        pts = pts.length > n ? resample(pts, n) : pts;
        synthTargets = pts;
        drawSynthOverlay();
        params = {points: pts, runs: Math.max(1, Math.min(10, parseInt(rIn.value, 10) || 1)), crank: cIn.checked};
      } else {
        var rows = parsePoints(fta.value);
        if (!rows || rows.length < 3) { message("give three precision points: input, output", "error"); return; }
        params = {points: rows};
      }
      api("POST", "/api/synthesis", {method: method, params: params}).then(function (j) {
        if (j.__status !== 200) { message(j.error, "error"); return; }
        job = j.id;
        cancel.disabled = false;
        go.disabled = true;
        clear($("le-candidates"));
        poll();
      });
    });
    cancel.addEventListener("click", function () {
      if (!job) return;
      api("POST", "/api/synthesis/" + job + "/cancel", {}).then(function (j) { showJob(j); });
    });
  }
  function parsePoints(text) {
    var out = [];
    text.split(/\n/).forEach(function (line) {
      var p = line.split(/[,;\s]+/).filter(function (x) { return x !== ""; }).map(Number);
      if (p.length >= 2 && isFinite(p[0]) && isFinite(p[1])) out.push([p[0], p[1]]);
    });
    return out;
  }
  function resample(pts, n) {
    var cum = [0];
    for (var i = 1; i < pts.length; i++) cum.push(cum[i - 1] + Math.hypot(pts[i][0] - pts[i - 1][0], pts[i][1] - pts[i - 1][1]));
    var L = cum[cum.length - 1], out = [], k = 0;
    for (var j = 0; j < n; j++) {
      var s = L * j / (n - 1);
      while (k < pts.length - 2 && cum[k + 1] < s) k++;
      var seg = cum[k + 1] - cum[k], t = seg > 0 ? (s - cum[k]) / seg : 0;
      out.push([pts[k][0] + t * (pts[k + 1][0] - pts[k][0]), pts[k][1] + t * (pts[k + 1][1] - pts[k][1])]);
    }
    return out;
  }
  function startStroke(evt) {
    evt.preventDefault();
    var svg = $("ls-diagram");
    svg.setPointerCapture(evt.pointerId);
    var p0 = toModel(evt);
    if (!p0) return;
    drawing.points = [p0];
    var move = function (e) { var p = toModel(e); if (p) { drawing.points.push(p); synthTargets = drawing.points; drawSynthOverlay(); } };
    var up = function (e) {
      svg.removeEventListener("pointermove", move);
      svg.removeEventListener("pointerup", up);
      var pts = drawing.points;
      drawing = null;
      $("le-draw").classList.remove("on");
      $("le-synth-points").value = pts.map(function (p) { return fmt(p[0], 10) + ", " + fmt(p[1], 10); }).join("\n");
      synthTargets = pts;
      drawSynthOverlay();
      message(pts.length + " points drawn: press Find linkages");
    };
    svg.addEventListener("pointermove", move);
    svg.addEventListener("pointerup", up);
  }
  function drawSynthOverlay() {
    var w = world();
    var old = $("le-synth-overlay");
    if (old && old.parentNode) old.parentNode.removeChild(old);
    if (!w) return;
    var g = el("g", {id: "le-synth-overlay"}, w), s = size();
    if (synthTargets && synthTargets.length) {
      el("polyline", {points: synthTargets.map(function (p) { return p[0] + "," + p[1]; }).join(" "), "class": "le-target-line", "stroke-width": 0.1 * s}, g);
    }
    if (curvePreview) el("polyline", {points: curvePreview.map(function (p) { return p[0] + "," + p[1]; }).join(" "), "class": "le-candidate-line", "stroke-width": 0.12 * s}, g);
  }
  function poll() {
    if (!job) return;
    api("GET", "/api/synthesis/" + job).then(function (j) {
      showJob(j);
      if (j.state === "running") setTimeout(poll, 500);
    });
  }
  function showJob(j) {
    $("le-synth-progress").value = j.progress || 0;
    $("le-synth-status").textContent = j.state + ": " + (j.message || "") + " (" + j.seconds + " s)";
    $("le-synth-status").setAttribute("data-state", j.state);
    if (j.state !== "running") { $("le-synth-go").disabled = false; $("le-synth-cancel").disabled = true; job = null; }
    if (j.state === "failed") message(j.error, "error");
    if (j.state === "done" && j.result) {
      var ol = clear($("le-candidates"));
      (j.result.notes || []).forEach(function (n) { h("li", {"class": "le-note"}, ol, n); });
      j.result.candidates.forEach(function (c, k) {
        var li = h("li", {"class": "le-candidate", "data-candidate": String(k)}, ol);
        var cert = c.certificate || {};
        h("span", {}, li, (c.grashof || "four-bar") + " · rms error " + fmt(c.rms, 4) + " · max " + fmt(c.max, 4) +
          (c.transmission ? " · transmission " + fmt(c.transmission[0], 3) + "°–" + fmt(c.transmission[1], 3) + "°" : "") +
          " · mode " + c.mode + " · certified" + ((cert.defects || []).length ? " (defects: " + cert.defects.join(", ") + ")" : ""));
        var use = h("button", {type: "button", "data-use": String(k)}, li, "Use");
        li.addEventListener("mouseenter", function () { curvePreview = c.curve; drawSynthOverlay(); });
        use.addEventListener("click", function () {
          curvePreview = null;
          edit({op: "replace", toml: c.toml, source: "synthesis candidate " + (k + 1)}).then(function (ok) {
            if (ok) message("candidate " + (k + 1) + " is now the edited mechanism (undo returns to the previous one)");
          });
        });
      });
    }
  }

  /* ------------------------------------------------------------------ dialogs, save, share */
  function ask(text, value, withInput) {
    return new Promise(function (resolve) {
      var d = $("le-dialog"), inp = $("le-dialog-input");
      $("le-dialog-text").textContent = text;
      inp.hidden = value === null && !withInput;
      inp.value = value || "";
      d.hidden = false;
      if (!inp.hidden) inp.focus();
      var done = function (ok) {
        d.hidden = true;
        $("le-dialog-ok").onclick = $("le-dialog-cancel").onclick = inp.onkeydown = null;
        resolve(ok ? (inp.hidden ? true : inp.value) : null);
      };
      $("le-dialog-ok").onclick = function () { done(true); };
      $("le-dialog-cancel").onclick = function () { done(false); };
      inp.onkeydown = function (e) { if (e.key === "Enter") done(true); if (e.key === "Escape") done(false); };
    });
  }
  function save(name, overwrite) {
    var body = {};
    if (name) body.name = name;
    if (overwrite) body.overwrite = true;
    return api("POST", "/api/save", body).then(function (j) {
      if (j.__status === 200) {
        state.document = j.document;
        $("le-doc").textContent = j.document.path + (j.document.dirty ? " · modified" : "");
        message("saved " + j.saved, "ok");
        return true;
      }
      if (j.__status === 409 && j.need === "name") {
        return ask("Save the model as (a .toml file under " + state.document.base + ")", "design.toml", true).then(function (n) {
          return n ? save(n, false) : false;
        });
      }
      if (j.__status === 409 && j.need === "confirm") {
        return ask(j.error, null).then(function (ok) { return ok ? save(name, true) : false; });
      }
      message(j.error || "cannot save", "error");
      return false;
    });
  }

  /* ------------------------------------------------------------------ wiring */
  function setTool(t) {
    tool = t;
    pendingLink = null;
    Array.prototype.forEach.call(document.querySelectorAll("#le-tools button"), function (b) { b.classList.toggle("on", b.getAttribute("data-tool") === t); });
    document.body.setAttribute("data-tool", t);
  }
  Array.prototype.forEach.call(document.querySelectorAll("#le-tools button"), function (b) {
    b.addEventListener("click", function () { setTool(b.getAttribute("data-tool")); });
  });
  Array.prototype.forEach.call(document.querySelectorAll("#le-panels button"), function (b) {
    b.addEventListener("click", function () {
      var k = b.getAttribute("data-panel");
      Array.prototype.forEach.call(document.querySelectorAll("#le-panels button"), function (c) { c.classList.toggle("on", c === b); });
      Array.prototype.forEach.call(document.querySelectorAll(".le-panel"), function (p) { p.classList.toggle("on", p.id === "le-panel-" + k); });
      if (view) view.update(view.row());
    });
  });
  $("ls-diagram").addEventListener("pointerdown", onDiagramDown);
  $("le-undo").addEventListener("click", function () { api("POST", "/api/undo", {}).then(function (j) { if (j.__status === 200) apply(j); else message(j.error, "error"); }); });
  $("le-redo").addEventListener("click", function () { api("POST", "/api/redo", {}).then(function (j) { if (j.__status === 200) apply(j); else message(j.error, "error"); }); });
  $("le-save").addEventListener("click", function () { save(null, false); });
  $("le-saveas").addEventListener("click", function () {
    ask("Save the model as (a .toml file under " + state.document.base + ")", state.document.path ? state.document.path.split("/").pop() : "design.toml", true).then(function (n) { if (n) save(n, false); });
  });
  $("le-share-btn").addEventListener("click", function () {
    var url = shareURL();
    ask("Share link (opens this design in loopsolve edit: paste it after the URL of your own session, or run loopsolve edit \"LINK\")", url, true);
    if (navigator.clipboard) navigator.clipboard.writeText(url).catch(function () {});
  });
  document.addEventListener("keydown", function (e) {
    var tag = (e.target && e.target.tagName) || "";
    if (tag === "INPUT" || tag === "TEXTAREA") return;
    if ((e.ctrlKey || e.metaKey) && (e.key === "z" || e.key === "Z")) { e.preventDefault(); $(e.shiftKey ? "le-redo" : "le-undo").click(); }
    else if ((e.ctrlKey || e.metaKey) && (e.key === "y" || e.key === "Y")) { e.preventDefault(); $("le-redo").click(); }
    else if (e.key === "Escape") { pendingLink = null; drawing = null; message(""); }
  });
  setTool("drag");
  drawSynthPanel();

  /* start: the design in the URL's fragment (a share link), else the server's document */
  var m = /(?:^#|&)model=([A-Za-z0-9_-]+)/.exec(location.hash);
  var start;
  if (m) {
    var text = null;
    try { text = b64urlDecode(m[1]); } catch (e) { message("the share link's model is not valid base64url text", "error"); }
    start = api("GET", "/api/state").then(function (j) {
      if (text === null || (j.__status === 200 && j.document.toml === text)) return j;
      return api("POST", "/api/edit", {op: "replace", toml: text, source: "share link"}).then(function (k) {
        if (k.__status !== 200) { message("the share link's model was refused: " + k.error, "error"); return j; }
        return k;
      });
    });
  } else start = api("GET", "/api/state");
  start.then(function (j) {
    if (j.__status !== 200) { message(j.error || "cannot reach the editor's server", "error"); return; }
    apply(j);
    document.body.setAttribute("data-ready", "1");
  });
  window.LoopsolveEditor = {state: function () { return state; }, edit: edit, save: save};
})();
