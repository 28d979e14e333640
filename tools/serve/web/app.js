// SPDX-License-Identifier: Apache-2.0
// rtm serve's page (index.html): the system as a graph, drag to connect, plots over one
// server-sent stream, details with editable parameters, save / preview / apply of system files.
//
// Whatever a component, a port or the naming service says (names, kinds, units, values,
// descriptions, errors) is someone else's text: it only ever becomes a node's text
// (textContent), a form field's value or a data-/title attribute, never markup, never an id,
// never an href, src, style or event attribute. Names in API paths are encoded one by one.
// A component whose name breaks the naming rule (the server says name_ok: false) is shown
// with a mark and offers nothing to click.
"use strict";
const token = new URLSearchParams(location.hash.slice(1)).get("token") || "";
// This page among the server's streams: its new stream of a kind replaces its old one.
const pageId = Array.from(crypto.getRandomValues(new Uint8Array(12)), b => b.toString(16).padStart(2, "0")).join("");
const NS = "http://www.w3.org/2000/svg";
const W = 300, ROW = 18, GAP = 70;
let system = [], portAt = new Map(), drag = null, shape = "", pending = false, proposal = null;
// Each drawn component's timing and error lines, by host and name: written in place.
let lines = new Map();

function api(method, path, body) {
  return fetch(path, { method, headers: { "X-RTM-Token": token, "Content-Type": "application/json" },
                       body: body ? JSON.stringify(body) : undefined })
    .then(r => r.json().then(j => { if (!r.ok) throw new Error(j.error || r.statusText); return j; }));
}
// "/api/components/<name>/on": every part encoded (a '\' or '/' in a name stays in its part).
function apiPath(...parts) { return "/api/" + parts.map(encodeURIComponent).join("/"); }

// Attributes set from this page's data: never one that loads, runs or styles something.
const unsafeAttribute = /^(on|href$|xlink:href$|src$|srcdoc$|style$|action$|formaction$)/i;
// An SVG element with attributes and, when given, text.
function el(name, attrs, parent, text) {
  const e = document.createElementNS(NS, name);
  for (const k in attrs) {
    if (unsafeAttribute.test(k)) throw new Error(`the page does not set ${k} from data`);
    e.setAttribute(k, attrs[k]);
  }
  if (text !== undefined) e.textContent = text;
  if (parent) parent.appendChild(e);
  return e;
}
// An HTML element with text.
function node(name, parent, text) {
  const e = document.createElement(name);
  if (text !== undefined) e.textContent = text;
  if (parent) parent.appendChild(e);
  return e;
}
function showError(text) { document.getElementById("error").textContent = text || ""; }

function layout() {
  const perRow = Math.max(1, Math.floor(1350 / (W + GAP)));
  return system.map((c, i) => ({ c, x: 20 + (i % perRow) * (W + GAP), y: 20 + Math.floor(i / perRow) * 220 }));
}

function keyOf(c) { return c.host + "/" + c.name; }
function nameOk(c) { return c.name_ok === true; }
function errorText(c) { return c.state === "error" && c.last_error ? c.last_error : ""; }
function timingText(c) {
  const t = c.timing || {};
  const p99 = t.lateness_p99_ns !== undefined ? (t.lateness_p99_ns / 1000).toFixed(0) + " µs" : "–";
  return `${c.kind || ""} · ${c.state} · ${(c.period_ns / 1e6) || "?"} ms · p99 ${p99} · overruns ${t.overruns ?? "–"}`;
}
// What the drawing depends on: not the timing and counters, which change every update and are
// written into the drawing in place, so that a drag or a click is never cut by a redraw.
function shapeOf(list) {
  return JSON.stringify(list.map(c => [c.host, c.name, c.name_ok, c.alive, c.state, c.unreachable,
    (c.ports || []).map(p => [p.name, p.type,
      (p.subscriptions || []).map(s => [s.peer, s.type, s.path || "", s.kind || "", s.policy || "", s.failures > 0,
        s.last_failure || ""])])]));
}

// A component whose name breaks the naming rule: its name as text, marked, and nothing to do.
function drawBadlyNamed(svg, { c, x, y }) {
  const g = el("g", { class: "badname" }, svg);
  el("rect", { class: "box", x, y, width: W, height: 58, rx: 6 }, g);
  el("text", { class: "name", x: x + 8, y: y + 16 }, g, c.name);
  el("text", { class: "mark", x: x + 8, y: y + 36, "font-size": 11 }, g,
     "not a valid name: bound by hand, not an RTM component; nothing here acts on it");
}

function drawComponent(svg, item) {
  const { c, x, y } = item;
  if (!nameOk(c)) { drawBadlyNamed(svg, item); return; }
  const ins = (c.ports || []).filter(p => p.direction === "in"), outs = (c.ports || []).filter(p => p.direction === "out");
  const h = 58 + ROW * Math.max(ins.length, outs.length, 1);
  const g = el("g", { class: c.alive === false ? "dead" : c.state || "" }, svg);
  el("rect", { class: "box", x, y, width: W, height: h, rx: 6 }, g);
  const title = el("text", { class: "name", x: x + 8, y: y + 16, "data-component": c.name }, g, c.name);
  title.addEventListener("click", () => showDetails(c.name));
  if (c.alive === false) { el("text", { x: x + 8, y: y + 34 }, g, "dead: " + (c.dead_reason || "")); return; }
  if (c.unreachable) { el("text", { x: x + 8, y: y + 34 }, g, c.unreachable); return; }
  lines.set(keyOf(c), {
    timing: el("text", { x: x + 8, y: y + 32, "font-size": 11 }, g, timingText(c)),
    error: el("text", { x: x + 8, y: y + h + 14, class: "msg", "font-size": 11 }, g, errorText(c)),
  });
  ["on", "off", "reset"].forEach((verb, k) => {
    const b = el("text", { class: "btn", x: x + W - 80 + k * 26, y: y + 16, "font-size": 11 }, g, verb);
    b.addEventListener("click", () => api("POST", apiPath("components", c.name, verb)).then(done).catch(e => showError(e.message)));
  });
  ins.forEach((p, i) => drawPort(svg, g, c, p, x, y + 50 + i * ROW, "in"));
  outs.forEach((p, i) => drawPort(svg, g, c, p, x + W, y + 50 + i * ROW, "out"));
}

function drawPort(svg, g, c, p, px, py, side) {
  const address = `${c.name}.${p.name}`;
  portAt.set(address, { x: px, y: py });
  const circle = el("circle", { class: "port", cx: px, cy: py, r: 6, "data-port": address, "data-type": p.type }, g);
  el("title", {}, circle, `${address} : ${p.type}` + (p.description ? ` (${p.description})` : ""));
  el("text", { x: side === "in" ? px + 10 : px - 10, y: py + 4, "text-anchor": side === "in" ? "start" : "end",
               "font-size": 11 }, g, `${p.name} : ${String(p.type).replace("RTM::", "")}`);
  if (side === "out") {
    circle.addEventListener("mousedown", ev => {
      drag = { from: address, line: el("line", { x1: px, y1: py, x2: px, y2: py, stroke: "#999", "pointer-events": "none" }, svg) };
      ev.preventDefault();
    });
    circle.addEventListener("click", () => startPlot(address));
  } else {
    circle.addEventListener("mouseup", () => { if (drag) connect(drag.from, address, circle); });
  }
}

function curve(a, b) { return `M${a.x},${a.y} C${a.x + 60},${a.y} ${b.x - 60},${b.y} ${b.x},${b.y}`; }

function drawEdges(svg) {
  for (const c of system) {
    if (!nameOk(c)) continue;
    for (const p of c.ports || [])
      for (const s of p.subscriptions || []) {
        const from = `${c.name}.${p.name}`, a = portAt.get(from), b = portAt.get(s.peer);
        if (!a || !b) continue;
        // A subscription whose deliveries fail (a refusal by access control, a stalled reader)
        // says so on its edge, with why.
        const failing = s.failures > 0;
        const path = el("path", { class: "edge " + (s.type === "once" ? "once" : "repeated") + (failing ? " failing" : ""),
                                  "data-from": from, "data-to": s.peer, d: curve(a, b) }, svg);
        const why = failing ? `; failing ×${s.failures}${s.last_failure ? ": " + s.last_failure : ""}` : "";
        const via = s.kind ? `, ${s.kind}` : s.path ? `, ${s.path}` : "";
        const policy = s.policy && s.policy !== s.type ? `; policy ${s.policy}` : "";
        el("title", {}, path, `${from} → ${s.peer} (${s.type}${via})${policy}${why}; click to disconnect`);
        path.addEventListener("click", () => api("POST", "/api/disconnect", { from, to: s.peer, type: s.type })
          .then(done).catch(e => showError(e.message)));
      }
  }
}

function render() {
  const svg = document.getElementById("svg");
  svg.replaceChildren();
  portAt = new Map();
  lines = new Map();
  const edges = el("g", {}, svg);  // beneath the components: an edge never covers a port
  const items = layout();
  // Tall enough for every row (a box is at most 220 px apart from the next row's).
  svg.setAttribute("height", Math.max(900, ...items.map(i => i.y + 240)));
  items.forEach(item => drawComponent(svg, item));
  drawEdges(edges);
  drawProposed();
}

function connect(from, to, circle) {
  const line = drag.line; drag = null; line.remove();
  api("POST", "/api/connect", { from, to, type: "repeated" }).then(done).catch(e => {
    showError(e.message);
    const m = el("text", { class: "msg", x: +circle.getAttribute("cx") + 10, y: +circle.getAttribute("cy") - 8, "font-size": 11 },
                 document.getElementById("svg"), e.message);
    setTimeout(() => m.remove(), 6000);
  });
}
document.addEventListener("mousemove", ev => {
  if (!drag) return;
  const r = document.getElementById("svg").getBoundingClientRect();
  drag.line.setAttribute("x2", ev.clientX - r.left); drag.line.setAttribute("y2", ev.clientY - r.top);
});
document.addEventListener("mouseup", () => {
  if (drag) { drag.line.remove(); drag = null; }
  if (pending) { shape = shapeOf(system); pending = false; render(); }
});

// Plots: each OutPort clicked gets one, the last 200 values of each of its fields as a line on
// a canvas; a second click removes it. The server sends every plotted port's latest datum 25
// times a second on one stream (/api/values/stream), opened afresh when the set changes.
const plots = new Map();
let valuesStream = null, drawQueued = false;
function startPlot(address) {
  if (plots.has(address)) { plots.get(address).div.remove(); plots.delete(address); openValues(); return; }
  if (plots.size >= 10) { showError("at most 10 plots: click a plotted port to remove its plot"); return; }
  const div = node("div", document.getElementById("plots"));
  div.className = "plot"; div.dataset.port = address;
  node("b", div, address);
  node("br", div);
  const canvas = node("canvas", div); canvas.width = 360; canvas.height = 120;
  node("div", div).className = "info";
  plots.set(address, { address, div, canvas, series: [], received: 0, failed: 0, drops: 0, started: performance.now(), last: null, infoAt: 0 });
  openValues();
}
function openValues() {
  if (valuesStream) valuesStream.close();
  valuesStream = null;
  if (!plots.size) return;
  const ports = [...plots.keys()].map(encodeURIComponent).join(",");
  valuesStream = new EventSource(`/api/values/stream?ports=${ports}&page=${pageId}&token=${encodeURIComponent(token)}`);
  valuesStream.addEventListener("values", ev => showValues(JSON.parse(ev.data)));
  valuesStream.onerror = () => plots.forEach(p => p.failed++);
}
function showValues(all) {
  for (const [address, d] of Object.entries(all)) {
    const plot = plots.get(address);
    if (!plot) continue;
    if (d.error) { plot.failed++; continue; }
    const stamp = JSON.stringify(d.time);
    if (stamp !== plot.last) {
      plot.last = stamp; plot.received++;
      // Drops: data the port published between two shown, counted from the stamps and the
      // writing component's period (none known for a port written on arrival).
      const t = d.time ? d.time.sec * 1e3 + d.time.nsec / 1e6 : null, period = periodOf(address);
      if (t !== null && plot.lastMs !== undefined && period > 0) plot.drops += Math.max(0, Math.round((t - plot.lastMs) / period) - 1);
      plot.lastMs = t ?? undefined;
    }
    (d.values || []).forEach((v, i) => { (plot.series[i] = plot.series[i] || []).push(+v); if (plot.series[i].length > 200) plot.series[i].shift(); });
    plot.dirty = true;
  }
  if (!drawQueued) {  // drawn once per frame, not per event
    drawQueued = true;
    requestAnimationFrame(() => { drawQueued = false; plots.forEach(p => { if (p.dirty) { p.dirty = false; drawPlot(p); } }); });
  }
}
// The period in ms of the component that writes an OutPort ("<component>.<port>"), 0 if none.
function periodOf(address) {
  const c = system.find(x => x.name === address.slice(0, address.lastIndexOf(".")));
  return c && c.period_ns ? c.period_ns / 1e6 : 0;
}
// On a canvas: lines on an SVG cost the browser a layout of every point at every frame.
function drawPlot(plot) {
  const canvas = plot.canvas, g = canvas.getContext("2d");
  let lo = Infinity, hi = -Infinity;
  for (const s of plot.series) for (const v of s) { if (v < lo) lo = v; if (v > hi) hi = v; }
  if (lo === Infinity) return;
  if (hi === lo) { hi += 1; lo -= 1; }
  const colours = ["#d22", "#2a2", "#36c", "#c6c", "#c90", "#099"];
  g.clearRect(0, 0, canvas.width, canvas.height);
  plot.series.forEach((s, i) => {
    g.beginPath();
    g.strokeStyle = colours[i % 6];
    s.forEach((v, k) => { const x = k * 1.8, y = 115 - (v - lo) / (hi - lo) * 110; if (k) g.lineTo(x, y); else g.moveTo(x, y); });
    g.stroke();
  });
  canvas.dataset.series = plot.series.length;
  const now = performance.now();
  if (now - plot.infoAt < 250) return;  // the text four times a second: each change is a layout
  plot.infoAt = now;
  const seconds = (now - plot.started) / 1000;
  plot.div.querySelector(".info").textContent =
    `${(plot.received / seconds).toFixed(1)} new data/s shown · ${periodOf(plot.address) > 0 ? plot.drops + " not shown (published between updates)" : "drops unknown (written on arrival)"} · ${plot.failed} errors · range ${lo.toPrecision(4)} … ${hi.toPrecision(4)}`;
}

// A component's description, statistics and parameters; a parameter the component lets change
// is an input.
function showDetails(name) {
  api("GET", apiPath("components", name)).then(c => {
    const box = document.getElementById("details");
    box.replaceChildren();
    node("h3", box, name);
    if (c.description) node("p", box, c.description);
    const stats = node("table", box), params = node("table", box);
    stats.id = "stats"; params.id = "params";
    for (const [k, s] of Object.entries(c.statistics || {})) {
      const row = stats.insertRow();
      row.title = s.description || "";
      for (const text of [k, String(s.value), s.unit || ""]) row.insertCell().textContent = text;
    }
    for (const [k, p] of Object.entries(c.parameters || {})) {
      const row = params.insertRow();
      row.insertCell().textContent = k;
      const cell = row.insertCell();
      cell.title = `${p.description || ""} (${p.access})`;
      if (p.access === "fixed") { cell.textContent = p.value; } else {
        const input = node("input", cell);
        input.value = p.value; input.dataset.parameter = k;
        input.addEventListener("change", () => api("POST", apiPath("components", name, "parameters", k), { value: input.value })
          .then(r => { input.value = r.value; showError(); }).catch(e => showError(e.message)));
      }
      row.insertCell().textContent = p.unit || "";
    }
  }).catch(e => showError(e.message));
}

document.getElementById("save").addEventListener("click", () => api("GET", "/api/system-file?name=saved").then(r => {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(new Blob([r.yaml], { type: "text/yaml" }));  // our own blob, never remote text
  a.download = "saved.yaml"; a.click();
  document.getElementById("applied").textContent = r.left_out.length
    ? "left out: " + r.left_out.map(x => `${x.name} (${x.why})`).join(", ") : "saved";
}).catch(e => showError(e.message)));
// A system file is shown before it is applied: its connections drawn dashed over the graph and
// listed with what applying would do; "apply" sends it, "cancel" forgets it.
function postYaml(path, text) {
  return fetch(path, { method: "POST", headers: { "X-RTM-Token": token }, body: text })
    .then(r => r.json()).then(r => { if (r.error) throw new Error(r.error); return r; });
}
// The connections a shown system file would make, dashed over the graph (again after redraws).
function drawProposed() {
  document.querySelectorAll(".proposed").forEach(e => e.remove());
  if (!proposal) return;
  for (const c of proposal.connections) {
    const a = portAt.get(c.from), b = portAt.get(c.to);
    if (c.status !== "to connect" || !a || !b) continue;
    const path = el("path", { class: "proposed", "data-from": c.from, "data-to": c.to, d: curve(a, b) },
                    document.getElementById("svg"));
    el("title", {}, path, `${c.from} → ${c.to}: the shown system file would connect it`);
  }
}
function clearPreview() {
  proposal = null;
  document.getElementById("preview").replaceChildren();
  document.querySelectorAll(".proposed").forEach(e => e.remove());
  document.getElementById("load").value = "";
}
function showPreview(text, r) {
  clearPreview();
  const div = document.getElementById("preview");
  node("b", div, `system file "${r.name}": what applying it would do`);
  const table = node("table", div);
  const row = (...cells) => { const tr = table.insertRow(); cells.forEach(c => { tr.insertCell().textContent = c; }); return tr; };
  for (const c of r.connections) {
    const tr = row(`${c.from} → ${c.to}`, c.type, c.status === "error" ? "cannot: " + c.error : c.status);
    tr.dataset.connection = `${c.from}>${c.to}`; if (c.status === "error") tr.className = "err";
  }
  proposal = r;
  drawProposed();
  for (const a of r.activate) row(`on ${a.name}`, "", `now ${a.now}`);
  if (r.not_running.length) row("not running (rtm up starts them)", "", r.not_running.join(", "));
  const apply = node("button", div, "apply"); apply.id = "apply";
  const cancel = node("button", div, "cancel"); cancel.id = "cancel";
  cancel.addEventListener("click", clearPreview);
  apply.addEventListener("click", () => postYaml("/api/system-file", text).then(r => {
    clearPreview();
    document.getElementById("applied").textContent = [...r.done, ...r.failed.map(f => "FAILED " + f)].join("\n");
    return done();
  }).catch(e => showError(e.message)));
}
document.getElementById("load").addEventListener("change", ev => ev.target.files[0].text().then(text =>
  postYaml("/api/system-file/preview", text).then(r => showPreview(text, r))).catch(e => showError(e.message)));

function onSystem(ev) { showSystem(JSON.parse(ev.data)); }
// After an action of this page: the system asked at once, not left for the stream's next look.
function done() { showError(); return api("GET", "/api/system").then(showSystem).catch(e => showError(e.message)); }
function showSystem(data) {
  if (data.error) { showError(data.error); return; }
  // By host and name: the naming service lists in no fixed order, and boxes must not move.
  system = data.sort((a, b) => keyOf(a).localeCompare(keyOf(b)));
  const now = shapeOf(system);
  if (now !== shape || pending) {
    if (drag) { pending = true; } else { shape = now; pending = false; render(); }
  } else {
    for (const c of system) {
      const shown = lines.get(keyOf(c));
      if (shown) { shown.timing.textContent = timingText(c); shown.error.textContent = errorText(c); }
    }
  }
  document.getElementById("status").textContent = `${system.length} components · updated ${new Date().toLocaleTimeString()}`;
}
// The streams are closed when the page is left: a page kept for "back" would otherwise hold one
// of the browser's six connections to the server, and the next page's calls would wait behind it.
// A stream the server refused (too many open) is asked for again a few seconds later.
let events = null, eventsRetry = null;
function openEvents() {
  clearTimeout(eventsRetry);
  events = new EventSource(`/api/events?page=${pageId}&token=${encodeURIComponent(token)}`);
  events.addEventListener("system", onSystem);
  events.onerror = () => {
    const refused = events.readyState === EventSource.CLOSED;
    document.getElementById("status").textContent = refused
      ? "the server refused the event stream (too many open); asking again in 5 s" : "connection lost; retrying…";
    if (refused) eventsRetry = setTimeout(openEvents, 5000);
  };
}
window.addEventListener("pagehide", () => { clearTimeout(eventsRetry); events.close(); if (valuesStream) valuesStream.close(); });
window.addEventListener("pageshow", ev => { if (ev.persisted) { openEvents(); openValues(); } });
openEvents();
