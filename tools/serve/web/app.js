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
const fragment = new URLSearchParams(location.hash.slice(1));
const token = fragment.get("token") || "";
// This page among the server's streams: its new stream of a kind replaces its old one.
const pageId = Array.from(crypto.getRandomValues(new Uint8Array(12)), b => b.toString(16).padStart(2, "0")).join("");
const NS = "http://www.w3.org/2000/svg";
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

function keyOf(c) { return c.host + "/" + c.name; }
function nameOk(c) { return c.name_ok === true; }
function errorText(c) { return c.state === "error" && c.last_error ? c.last_error : ""; }
function timingText(c) {
  const t = c.timing || {};
  // A composite of the paper's kind runs no loop: its members run on theirs (their lines).
  if (!(c.period_ns > 0))
    return `${c.kind || ""} · ${c.state} · ${c.members ? "no loop of its own: its members run on theirs" : "no periodic loop"}`;
  if (!t.cycles) return `${c.kind || ""} · ${c.state} · ${c.period_ns / 1e6} ms · no cycle run yet`;
  const p99 = t.lateness_p99_ns !== undefined ? (t.lateness_p99_ns / 1000).toFixed(0) + " µs" : "–";
  return `${c.kind || ""} · ${c.state} · ${(c.period_ns / 1e6) || "?"} ms · p99 ${p99} · overruns ${t.overruns ?? "–"}` +
    contractText(c.contract);
}
// " · contract met", or what was missed and how often; "" for a component not watched.
function contractText(k) {
  if (!k || !k.watched) return "";
  const missed = [];
  if (k.missed_deadline > 0) missed.push(`deadline ${(k.deadline_ns / 1000).toFixed(0)} µs missed ${k.missed_deadline}×`);
  if (k.over_budget > 0) missed.push(`budget ${(k.budget_ns / 1000).toFixed(0)} µs exceeded ${k.over_budget}×`);
  return missed.length ? " · " + missed.join(", ") : " · contract met";
}
// What the drawing depends on: not the timing and counters, which change every update and are
// written into the drawing in place, so that a drag or a click is never cut by a redraw.
function shapeOf(list) {
  return JSON.stringify(list.map(c => [c.host, c.name, c.name_ok, c.alive, c.state, c.unreachable, c.members, c.member_of,
    (c.ports || []).map(p => [p.name, p.type,
      (p.subscriptions || []).map(s => [s.peer, s.type, s.path || "", s.kind || "", s.policy || "", s.failures > 0,
        s.last_failure || ""])])]));
}

// A component whose name breaks the naming rule: its name as text, marked, and nothing to do.
function drawBadlyNamed(svg, { c, x, y }) {
  const g = el("g", { class: "badname" }, svg);
  el("rect", { class: "box", x, y, width: BOX_W, height: 58, rx: 6 }, g);
  el("text", { class: "name", x: x + 8, y: y + 16 }, g, c.name);
  el("text", { class: "mark", x: x + 8, y: y + 36, "font-size": 11 }, g,
     "not a valid name: bound by hand, not an RTM component; nothing here acts on it");
}

// ---- Layout: layered, left to right along the data ----------------------------------------
// Each level (the whole system, and inside each composite's frame) is laid out the same way:
// ranks by the longest path along the connections (loops broken where a depth-first walk
// meets its own path), dummies where a connection spans ranks, the order within each rank by
// the barycentre of the neighbours (a few sweeps each way), columns as wide as their widest box
// and gaps as wide as the connections running through them need. Each connection is routed
// orthogonally: horizontal at a port or through the slot of a dummy (kept free of boxes),
// vertical only in a gap between columns, and one going back (against the ranks) over a lane
// above every box. So a connection never crosses a box.
const BOX_W = 270, HEAD = 44, ROW = 18, VGAP = 28, LANE = 12, FRAME_PAD = 16, FRAME_HEAD = 38;

function ins(c) { return (c.ports || []).filter(p => p.direction === "in"); }
function outs(c) { return (c.ports || []).filter(p => p.direction === "out"); }
function boxHeight(c) {
  if (!nameOk(c)) return 58;
  if (c.alive === false || c.unreachable) return 48;
  return HEAD + 8 + ROW * Math.max(ins(c).length, outs(c).length, 1) + 18;
}
function portY(i) { return HEAD + 8 + i * ROW; }
function componentOf(address) { return address.slice(0, address.lastIndexOf(".")); }

// nodes: [{id, w, h, ports: {key: {x, y}} (relative), rank?: fixed}], edges: [{id, from: [node,
// key], to: [node, key]}], hints: [[from, to]] (rank only). Returns {pos, routes, width, height}.
function layered(nodes, edges, hints, margin) {
  const byId = new Map(nodes.map(n => [n.id, n]));
  const out = new Map(nodes.map(n => [n.id, []]));
  const links = edges.filter(e => byId.has(e.from[0]) && byId.has(e.to[0]));
  for (const e of links) out.get(e.from[0]).push(e.to[0]);
  for (const [a, b] of hints) if (byId.has(a) && byId.has(b)) out.get(a).push(b);
  // Loops: an edge to a node on the walk's own path goes back; ranks ignore it.
  const state = new Map(), back = new Set();
  const walk = id => {
    state.set(id, 1);
    for (const t of out.get(id)) {
      if (state.get(t) === 1) back.add(id + "\n" + t); else if (!state.has(t)) walk(t);
    }
    state.set(id, 2);
  };
  nodes.forEach(n => { if (!state.has(n.id)) walk(n.id); });
  const rank = new Map(nodes.map(n => [n.id, n.rank === Infinity ? 0 : n.rank ?? 0]));
  for (let changed = true, guard = 0; changed && guard < nodes.length + 2; guard++) {
    changed = false;
    for (const n of nodes) for (const t of out.get(n.id)) {
      if (back.has(n.id + "\n" + t) || byId.get(t).rank !== undefined) continue;
      if (rank.get(t) < rank.get(n.id) + 1) { rank.set(t, rank.get(n.id) + 1); changed = true; }
    }
  }
  const last = Math.max(0, ...nodes.filter(n => n.rank !== Infinity).map(n => rank.get(n.id)));
  for (const n of nodes) if (n.rank === Infinity) rank.set(n.id, last + 1);  // a frame's exits
  const R = Math.max(0, ...[...rank.values()]) + 1;
  // Dummies: one per rank a forward edge spans.
  const layers = Array.from({ length: R }, () => []);
  const all = new Map();
  nodes.forEach(n => { all.set(n.id, { ...n, r: rank.get(n.id) }); layers[rank.get(n.id)].push(n.id); });
  const chains = new Map();  // edge id -> node ids along it (forward edges)
  for (const e of links) {
    const a = rank.get(e.from[0]), b = rank.get(e.to[0]);
    if (b <= a) continue;
    const chain = [e.from[0]];
    for (let r = a + 1; r < b; r++) {
      const id = `dummy\n${e.id}\n${r}`;
      all.set(id, { id, w: 0, h: 12, dummy: true, r, ports: {} });
      layers[r].push(id);
      chain.push(id);
    }
    chain.push(e.to[0]);
    chains.set(e.id, chain);
  }
  // Order: barycentre sweeps.
  const nbr = new Map([...all.keys()].map(id => [id, { up: [], down: [] }]));
  for (const chain of chains.values())
    for (let i = 1; i < chain.length; i++) { nbr.get(chain[i]).up.push(chain[i - 1]); nbr.get(chain[i - 1]).down.push(chain[i]); }
  for (const [a, b] of hints)
    if (all.has(a) && all.has(b) && all.get(b).r === all.get(a).r + 1) { nbr.get(b).up.push(a); nbr.get(a).down.push(b); }
  const index = new Map();
  const reindex = () => layers.forEach(l => l.forEach((id, i) => index.set(id, i)));
  reindex();
  for (let sweep = 0; sweep < 8; sweep++) {
    const down = sweep % 2 === 0;
    const order = down ? layers.keys() : [...layers.keys()].reverse();
    for (const r of order) {
      const bary = id => { const ns = nbr.get(id)[down ? "up" : "down"]; return ns.length ? ns.reduce((s, n) => s + index.get(n), 0) / ns.length : index.get(id); };
      const keyed = layers[r].map(id => [bary(id), index.get(id), id]);
      keyed.sort((p, q) => p[0] - q[0] || p[1] - q[1]);
      layers[r] = keyed.map(k => k[2]);
      layers[r].forEach((id, i) => index.set(id, i));
    }
  }
  // Gaps: one vertical channel per hop through them (gap g lies right of column g; -1: left margin).
  const gapUse = new Map(), useGap = g => { gapUse.set(g, (gapUse.get(g) || 0) + 1); };
  for (const chain of chains.values()) for (let i = 1; i < chain.length; i++) useGap(all.get(chain[i - 1]).r);
  const backEdges = links.filter(e => rank.get(e.to[0]) <= rank.get(e.from[0]));
  for (const e of backEdges) { useGap(rank.get(e.from[0])); useGap(rank.get(e.to[0]) - 1); }
  const gapWidth = g => Math.max(g < 0 || g >= R - 1 ? margin.side : 64, 16 * ((gapUse.get(g) || 0) + 1));
  const colX = [], colW = [];
  let x = gapWidth(-1);
  for (let r = 0; r < R; r++) {
    colX[r] = x;
    colW[r] = Math.max(0, ...layers[r].map(id => all.get(id).w));
    x += colW[r] + gapWidth(r);
  }
  const width = x;
  // Rows: stacked in order, each pulled down towards its upstream neighbours' ports.
  const top = margin.top + LANE * backEdges.length;
  const pos = new Map();
  const anchorY = id => { const n = all.get(id); return n.dummy ? 6 : n.h / 2; };
  for (let r = 0; r < R; r++) {
    let y = top;
    for (const id of layers[r]) {
      const n = all.get(id), ups = nbr.get(id).up.filter(u => pos.has(u));
      let want = y;
      if (ups.length) want = ups.reduce((s, u) => s + pos.get(u).y + anchorY(u), 0) / ups.length - anchorY(id);
      const at = Math.max(y, want);
      pos.set(id, { x: colX[r], y: at });
      y = at + n.h + (n.dummy ? 8 : VGAP);
    }
  }
  const height = Math.max(top, ...[...all.values()].map(n => pos.get(n.id).y + n.h)) + margin.bottom;
  // Channels: spread over each gap in the order they are asked for.
  const taken = new Map();
  const channel = g => {
    const k = taken.get(g) || 0; taken.set(g, k + 1);
    const left = g < 0 ? 0 : colX[g] + colW[g], right = g + 1 < R ? colX[g + 1] : width;
    return Math.round(left + (right - left) * (k + 1) / ((gapUse.get(g) || 0) + 1));
  };
  const portPoint = ([id, key], side) => {
    const n = all.get(id), p = pos.get(id), q = n.ports[key] || { x: side === "out" ? n.w : 0, y: n.h / 2 };
    return { x: p.x + q.x, y: p.y + q.y };
  };
  const routes = new Map();
  for (const e of links) {
    const a = portPoint(e.from, "out"), b = portPoint(e.to, "in");
    const pts = [a];
    const chain = chains.get(e.id);
    if (chain) {
      let cur = a;
      for (let i = 1; i < chain.length; i++) {
        const id = chain[i], n = all.get(id), g = all.get(chain[i - 1]).r, cx = channel(g);
        const enter = n.dummy ? { x: colX[n.r], y: pos.get(id).y + 6 } : b;
        pts.push({ x: cx, y: cur.y }, { x: cx, y: enter.y }, enter);
        if (n.dummy) { cur = { x: colX[n.r] + colW[n.r], y: enter.y }; pts.push(cur); }
      }
    } else {
      const lane = top - LANE * (backEdges.indexOf(e) + 1);
      const c1 = channel(rank.get(e.from[0])), c2 = channel(rank.get(e.to[0]) - 1);
      pts.push({ x: c1, y: a.y }, { x: c1, y: lane }, { x: c2, y: lane }, { x: c2, y: b.y }, b);
    }
    routes.set(e.id, pts);
  }
  return { pos, routes, width, height };
}

// The drawing's parts from the system: boxes, frames (a composite's members inside), and the
// connections between ports, each with where it starts and ends.
function plan() {
  const byName = new Map(system.filter(nameOk).map(c => [c.name, c]));
  const frameOf = new Map();  // member -> composite
  const frames = system.filter(c => nameOk(c) && Array.isArray(c.members) && c.alive !== false)
    .map(c => ({ c, members: c.members.filter(m => byName.has(m) && m !== c.name) }))
    .filter(f => f.members.length);
  frames.forEach(f => f.members.forEach(m => frameOf.set(m, f.c.name)));
  const connections = [];
  for (const c of system) {
    if (!nameOk(c)) continue;
    for (const p of c.ports || []) for (const s of p.subscriptions || []) {
      const to = componentOf(s.peer);
      if (byName.has(to)) connections.push({ c, p, s, from: `${c.name}.${p.name}`, to: s.peer, fromC: c.name, toC: to });
    }
  }
  connections.forEach((k, i) => { k.id = "e" + i; });
  return { byName, frames, frameOf, connections };
}

function boxNode(c) {
  const ports = {};
  ins(c).forEach((p, i) => { ports[p.name + "\nin"] = { x: 0, y: portY(i) }; });
  outs(c).forEach((p, i) => { ports[p.name + "\nout"] = { x: BOX_W, y: portY(i) }; });
  return { id: keyOf(c), w: BOX_W, h: boxHeight(c), ports, c };
}

// A composite's frame: its members laid out inside, its own InPorts on its left side (each
// wired inside to the member's port it is), the connections that cross it through points on
// its sides. Returns the top level's node for it and what to draw inside.
function frameLayout(f, connections, byName) {
  const inner = f.members.map(m => boxNode(byName.get(m)));
  const innerEdges = [], hints = [], borders = [];
  const own = new Map();  // "<member>.<port>" it exposes -> its own port's border id
  for (const p of ins(f.c)) {
    const id = `border\nin\n${p.name}`;
    borders.push({ id, w: 0, h: ROW, rank: 0, ports: {}, port: p, side: "in" });
    const m = f.members.find(m => ins(byName.get(m)).some(q => q.name === p.name && q.type === p.type));
    own.set(`${m}.${p.name}`, id);
    if (m) innerEdges.push({ id: `expose\n${p.name}`, from: [id, ""], to: [keyOf(byName.get(m)), p.name + "\nin"], expose: true });
  }
  for (const p of outs(f.c)) borders.push({ id: `border\nout\n${p.name}`, w: 0, h: ROW, rank: Infinity, ports: {}, port: p, side: "out" });
  const cross = new Map();  // connection id -> {inside edge id, border id, side}
  for (const k of connections) {
    const fromIn = f.members.includes(k.fromC), toIn = f.members.includes(k.toC);
    if (fromIn && toIn) {
      innerEdges.push({ id: k.id, from: [keyOf(k.c), k.p.name + "\nout"], to: [keyOf(byName.get(k.toC)), k.s.peer.slice(k.toC.length + 1) + "\nin"] });
    } else if (toIn) {
      let id = own.get(k.to);
      if (!id) { id = `border\nin\n${k.id}`; borders.push({ id, w: 0, h: ROW, rank: 0, ports: {}, side: "in" }); }
      const inside = `${k.id}\ninside`;
      if (own.get(k.to)) { cross.set(k.id, { border: id, inside: `expose\n${k.to.slice(k.toC.length + 1)}`, side: "in" }); }
      else { innerEdges.push({ id: inside, from: [id, ""], to: [keyOf(byName.get(k.toC)), k.s.peer.slice(k.toC.length + 1) + "\nin"] }); cross.set(k.id, { border: id, inside, side: "in" }); }
    } else if (fromIn) {
      const id = `border\nout\n${k.id}`, inside = `${k.id}\ninside`;
      borders.push({ id, w: 0, h: ROW, rank: Infinity, ports: {}, side: "out" });
      innerEdges.push({ id: inside, from: [keyOf(k.c), k.p.name + "\nout"], to: [id, ""] });
      cross.set(k.id, { border: id, inside, side: "out" });
    }
  }
  // Members not yet wired to each other: in the order the composite names them (its diagram's).
  if (!innerEdges.some(e => !e.expose && !e.id.includes("\ninside")))
    for (let i = 1; i < inner.length; i++) hints.push([inner[i - 1].id, inner[i].id]);
  const members = inner;
  const nodes = [...borders, ...members];
  // Members start at rank 1: rank 0 is the frame's left side.
  for (const n of members) hints.push(...borders.filter(b => b.side === "in").slice(0, 1).map(b => [b.id, n.id]));
  if (!borders.some(b => b.side === "in")) nodes.push({ id: "border\nleft", w: 0, h: 1, rank: 0, ports: {} }), members.forEach(n => hints.push(["border\nleft", n.id]));
  // Below the frame's head, a row for its ports' names, above the members.
  const L = layered(nodes, innerEdges, hints, { side: FRAME_PAD + 14, top: FRAME_HEAD + 24, bottom: FRAME_PAD });
  // The frame's left side is column 0 (its borders), its right side the last column's.
  const left = Math.min(...borders.filter(b => b.side === "in").map(b => L.pos.get(b.id).x), ...members.map(n => L.pos.get(n.id).x - FRAME_PAD - 14));
  const shift = -left;
  const right = Math.max(...members.map(n => L.pos.get(n.id).x + n.w + FRAME_PAD + 14), ...borders.filter(b => b.side === "out").map(b => L.pos.get(b.id).x));
  const w = right + shift;
  for (const b of borders) { const p = L.pos.get(b.id); p.x = b.side === "in" ? -shift : right; }
  const ports = {};
  for (const b of borders) ports[b.id] = { x: b.side === "in" ? 0 : w, y: L.pos.get(b.id).y + ROW / 2 };
  // Inside routes start or end at a border point: move them onto the frame's side.
  for (const e of innerEdges) {
    const pts = L.routes.get(e.id);
    if (!pts) continue;
    if (e.from[0].startsWith("border")) pts[0] = { x: -shift, y: pts[0].y };
    if (e.to[0].startsWith("border")) pts[pts.length - 1] = { x: right, y: pts[pts.length - 1].y };
  }
  return { node: { id: keyOf(f.c), w, h: L.height, ports, frame: true }, f, L, shift, borders, members, innerEdges, cross };
}

function layout() {
  const { byName, frames, frameOf, connections } = plan();
  const framed = frames.map(f => frameLayout(f, connections, byName));
  const frameById = new Map(framed.map(F => [F.f.c.name, F]));
  const top = [];
  for (const c of system) {
    if (nameOk(c) && (frameById.has(c.name) || frameOf.has(c.name))) continue;
    top.push(boxNode(c));
  }
  framed.forEach(F => top.push(F.node));
  // The top level's connections: a member's end is its frame's border point.
  const edges = [];
  for (const k of connections) {
    const fa = frameOf.get(k.fromC), fb = frameOf.get(k.toC);
    if (fa && fa === fb) continue;
    const from = fa ? [keyOf(byName.get(fa)), frameById.get(fa).cross.get(k.id).border] : [keyOf(k.c), k.p.name + "\nout"];
    const to = fb ? [keyOf(byName.get(fb)), frameById.get(fb).cross.get(k.id).border]
                  : [keyOf(byName.get(k.toC)), k.s.peer.slice(k.toC.length + 1) + "\nin"];
    edges.push({ id: k.id, from, to });
  }
  // The system in its order (by host and name) before the sweeps.
  const L = layered(top, edges, [], { side: 24, top: 24, bottom: 40 });
  return { L, top, framed, connections, frameOf, frameById, byName };
}

function pathOf(points) {
  const pts = points.filter((p, i) => i === 0 || p.x !== points[i - 1].x || p.y !== points[i - 1].y);
  return "M" + pts.map(p => `${Math.round(p.x)},${Math.round(p.y)}`).join(" L");
}

function drawComponent(svg, c, x, y) {
  if (!nameOk(c)) { drawBadlyNamed(svg, { c, x, y }); return; }
  const h = boxHeight(c);
  const g = el("g", { class: c.alive === false ? "dead" : c.state || "", "data-box": c.name }, svg);
  el("rect", { class: "box", x, y, width: BOX_W, height: h, rx: 6 }, g);
  drawHead(g, c, x, y, BOX_W);
  if (c.alive === false || c.unreachable) return;
  lines.get(keyOf(c)).error = el("text", { x: x + 8, y: y + h - 6, class: "msg", "font-size": 11 }, g, errorText(c));
  ins(c).forEach((p, i) => drawPort(svg, g, c, p, x, y + portY(i), "in"));
  outs(c).forEach((p, i) => drawPort(svg, g, c, p, x + BOX_W, y + portY(i), "out"));
}

// A box's or a frame's first lines: the name (click: details), on/off/reset, timing.
function drawHead(g, c, x, y, w) {
  const title = el("text", { class: "name", x: x + 8, y: y + 16, "data-component": c.name }, g, c.name);
  title.addEventListener("click", () => showDetails(c.name));
  if (c.alive === false) { el("text", { x: x + 8, y: y + 34 }, g, "dead: " + (c.dead_reason || "")); return; }
  if (c.unreachable) { el("text", { x: x + 8, y: y + 34 }, g, c.unreachable); return; }
  lines.set(keyOf(c), { timing: el("text", { x: x + 8, y: y + 32, "font-size": 11, class: "timing" }, g, timingText(c)), error: null });
  ["on", "off", "reset"].forEach((verb, k) => {
    const b = el("text", { class: "btn", x: x + w - 80 + k * 26, y: y + 16, "font-size": 11 }, g, verb);
    b.addEventListener("click", () => api("POST", apiPath("components", c.name, verb)).then(done).catch(e => showError(e.message)));
  });
}

// The frame and its lines beneath the edges (which run inside it), its members and ports above.
function drawFrame(svg, under, F, x, y) {
  const c = F.f.c;
  const g = el("g", { class: "composite " + (c.state || ""), "data-frame": c.name, "data-members": F.f.members.join(" ") }, under);
  el("rect", { class: "frame", x, y, width: F.node.w, height: F.node.h, rx: 10 }, g);
  drawHead(g, c, x, y + 2, F.node.w);
  if (lines.has(keyOf(c))) lines.get(keyOf(c)).error = el("text", { x: x + 8, y: y + F.node.h - 4, class: "msg", "font-size": 11 }, g, errorText(c));
  const ox = x + F.shift, oy = y;
  for (const n of F.members) { const p = F.L.pos.get(n.id); drawComponent(svg, n.c, ox + p.x, oy + p.y); }
  // Its own ports on its sides (drag onto them as onto any port).
  for (const b of F.borders) {
    if (!b.port) continue;
    const q = F.node.ports[b.id];
    drawPort(svg, el("g", { class: "composite-port" }, svg), c, b.port, x + q.x, y + q.y, b.side);
  }
  return { ox, oy };
}

function render() {
  const svg = document.getElementById("svg");
  svg.replaceChildren();
  portAt = new Map();
  lines = new Map();
  const frameLayer = el("g", {}, svg);  // frames beneath the edges that run inside them
  const edgeLayer = el("g", {}, svg);  // beneath the components: an edge never covers a port
  const { L, top, framed, connections, frameOf, frameById } = layout();
  svg.setAttribute("width", Math.max(L.width, 400));
  svg.setAttribute("height", Math.max(L.height, 300));
  const origin = new Map();
  for (const n of top) {
    const p = L.pos.get(n.id);
    if (n.frame) origin.set(n.id, drawFrame(svg, frameLayer, framed.find(F => F.node === n), p.x, p.y));
    else drawComponent(svg, n.c, p.x, p.y);
  }
  // The wiring inside each frame that is no connection of its own: a composite's port is its member's.
  for (const F of framed) {
    const o = origin.get(F.node.id);
    for (const e of F.innerEdges.filter(e => e.expose)) {
      const pts = F.L.routes.get(e.id);
      if (pts) el("path", { class: "expose", d: pathOf(pts.map(p => ({ x: p.x + o.ox, y: p.y + o.oy }))) }, edgeLayer);
    }
  }
  for (const k of connections) {
    const fa = frameOf.get(k.fromC), fb = frameOf.get(k.toC);
    const inside = (name, id) => { const F = frameById.get(name), o = origin.get(F.node.id);
      return (F.L.routes.get(id) || []).map(p => ({ x: p.x + o.ox, y: p.y + o.oy })); };
    let pts;
    if (fa && fa === fb) pts = inside(fa, k.id);
    else {
      pts = [...(L.routes.get(k.id) || [])];
      if (fa) pts = [...inside(fa, frameById.get(fa).cross.get(k.id).inside), ...pts];
      if (fb) pts = [...pts, ...inside(fb, frameById.get(fb).cross.get(k.id).inside)];
    }
    if (pts.length >= 2) drawEdge(edgeLayer, k, pts);
  }
  drawProposed();
}

function drawEdge(layer, k, pts) {
  const { s, from } = k;
  // A subscription whose deliveries fail (a refusal by access control, a stalled reader)
  // says so on its edge, with why.
  const failing = s.failures > 0;
  const path = el("path", { class: "edge " + (s.type === "once" ? "once" : "repeated") + (failing ? " failing" : ""),
                            "data-from": from, "data-to": s.peer, d: pathOf(pts) }, layer);
  const why = failing ? `; failing ×${s.failures}${s.last_failure ? ": " + s.last_failure : ""}` : "";
  const via = s.kind ? `, ${s.kind}` : s.path ? `, ${s.path}` : "";
  const policy = s.policy && s.policy !== s.type ? `; policy ${s.policy}` : "";
  el("title", {}, path, `${from} → ${s.peer} (${s.type}${via})${policy}${why}; click to disconnect`);
  path.addEventListener("click", () => api("POST", "/api/disconnect", { from, to: s.peer, type: s.type })
    .then(done).catch(e => showError(e.message)));
}

function drawPort(svg, g, c, p, px, py, side) {
  const address = `${c.name}.${p.name}`;
  if (!portAt.has(address) || !c.members) portAt.set(address, { x: px, y: py });
  const circle = el("circle", { class: "port", cx: px, cy: py, r: 6, "data-port": address, "data-type": p.type }, g);
  const units = (p.elements || []).map(e => e.unit ? `${e.name} [${e.unit}]` : e.name).join(", ");
  el("title", {}, circle, `${address} : ${p.type}` + (p.description ? ` (${p.description})` : "") + (units ? ` — ${units}` : ""));
  const label = `${p.name} : ${String(p.type).replace("RTM::", "")}`;
  if (c.members) el("text", { x: side === "in" ? px + 8 : px - 8, y: py - 11, "text-anchor": side === "in" ? "start" : "end", "font-size": 11, class: "frameport" }, g, label);
  else el("text", { x: side === "in" ? px + 10 : px - 10, y: py + 4, "text-anchor": side === "in" ? "start" : "end", "font-size": 11 }, g, label);
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

// Plots: each OutPort clicked gets one (a second click removes it; the URL's fragment lists
// them: #token=…&plot=sensor0.wrench&plot=…, so a page opened from it plots them again). The
// server subscribes to each plotted port and sends every datum it wrote on one stream
// (/api/values/stream), 25 events a second, with the count it sent and the count lost on the
// way. The plot keeps the last WINDOW_S seconds; where a pixel column holds more than one datum
// it draws their minimum to maximum (an envelope), so that no datum is left out of the drawing.
const plots = new Map();
const WINDOW_S = 10, PLOT_W = 360, PLOT_H = 170, AX_L = 52, AX_B = 22, AX_T = 8, AX_R = 8;
const COLOURS = ["#d22", "#2a2", "#36c", "#c6c", "#c90", "#099"];
let valuesStream = null, drawQueued = false;
const replacedStreams = new Set();  // old plots' streams the server has yet to end

function writeUrl() {
  const q = new URLSearchParams();
  q.set("token", token);
  for (const address of plots.keys()) q.append("plot", address);
  history.replaceState(null, "", "#" + q.toString());
}
// A plot's elements under #plots: its title, axis line, canvas, legend and info line.
function plotParts(className, title) {
  const div = node("div", document.getElementById("plots"));
  div.className = className;
  node("b", div, title);
  const axis = node("div", div); axis.className = "axis";
  const canvas = node("canvas", div); canvas.width = PLOT_W; canvas.height = PLOT_H;
  const legend = node("div", div); legend.className = "legend";
  node("div", div).className = "info";
  return { div, canvas, axis, legend };
}
function startPlot(address) {
  if (plots.has(address)) { plots.get(address).div.remove(); plots.delete(address); writeUrl(); openValues(); return; }
  if (plots.size >= 10) { showError("at most 10 plots: click a plotted port to remove its plot"); return; }
  const parts = plotParts("plot", address);
  parts.div.dataset.port = address;
  plots.set(address, { address, ...parts, t: [], cols: [], start: 0, t0: null, received: 0, sent: 0,
                       lost: 0, failed: 0, error: "", type: "", stamped: true, shownLegend: "", infoAt: 0 });
  writeUrl();
  openValues();
}
// A new stream replaces the page's old one on the server, which hands it the subscriptions
// of the ports both plot; the old one is left open until the server ends it, so that what it
// sent last still arrives (closed here first, those data would be sent and never received).
function openValues() {
  const old = valuesStream;
  valuesStream = null;
  if (old) replacedStreams.add(old);
  if (!plots.size) { closeReplacedStreams(); return; }
  const ports = [...plots.keys()].map(encodeURIComponent).join(",");
  const stream = new EventSource(`/api/values/stream?ports=${ports}&page=${pageId}&token=${encodeURIComponent(token)}`);
  valuesStream = stream;
  stream.addEventListener("values", ev => showValues(JSON.parse(ev.data)));
  stream.onerror = () => {
    if (stream !== valuesStream) { stream.close(); replacedStreams.delete(stream); return; }  // ended: no reconnect
    plots.forEach(p => p.failed++);
  };
}
// The port's description: its elements' names and units, from the system.
function portOf(address) {
  const c = system.find(x => x.name === componentOf(address));
  return c && (c.ports || []).find(p => p.name === address.slice(address.lastIndexOf(".") + 1));
}
function showValues(all) {
  for (const [address, d] of Object.entries(all)) {
    const plot = plots.get(address);
    if (!plot) continue;
    if (d.error) { plot.error = d.error; plot.dirty = true; continue; }
    plot.error = ""; plot.type = d.type || ""; plot.stamped = d.stamped !== false;
    const t = d.t || [], v = d.v || [];
    if (t.length && plot.t0 === null) plot.t0 = Math.floor(t[0]);
    for (let i = 0; i < t.length; i++) plot.t.push(t[i] - plot.t0);  // seconds from t0: a double keeps ns
    v.forEach((col, k) => { const c = plot.cols[k] || (plot.cols[k] = new Array(plot.t.length - t.length).fill(null)); for (const x of col) c.push(x); });
    plot.received += t.length;
    plot.sent = d.sent ?? plot.sent; plot.lost = d.lost ?? plot.lost;
    // Data older than the window go (in one cut now and then, not one shift per datum).
    const newest = plot.t[plot.t.length - 1];
    while (plot.start < plot.t.length && plot.t[plot.start] < newest - WINDOW_S) plot.start++;
    if (plot.start > 4096) { plot.t = plot.t.slice(plot.start); plot.cols = plot.cols.map(c => c.slice(plot.start)); plot.start = 0; }
    plot.dirty = true;
  }
  if (!drawQueued) {  // drawn once per frame, not per event
    drawQueued = true;
    requestAnimationFrame(() => { drawQueued = false; plots.forEach(p => { if (p.dirty) { p.dirty = false; drawPlot(p); } }); });
  }
}
// Ticks at 1, 2 or 5 times a power of ten, about n of them over [lo, hi].
function ticks(lo, hi, n) {
  const raw = (hi - lo) / n, mag = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map(m => m * mag).find(s => s >= raw) || raw;
  const out = [];
  for (let x = Math.ceil(lo / step) * step; x <= hi + step * 1e-9; x += step) out.push(Math.abs(x) < step * 1e-9 ? 0 : x);
  return { out, step };
}
function tickText(x, step) { const d = Math.max(0, -Math.floor(Math.log10(step))); return x.toFixed(Math.min(d, 6)); }
// The legend (HTML, as text): one line per element, its colour, name and unit.
function drawLegend(plot) {
  const p = plot.elements ? { elements: plot.elements } : portOf(plot.address), n = plot.cols.length;
  const elements = p && p.elements && p.elements.length === n ? p.elements : Array.from({ length: n }, (_, i) => ({ name: `value ${i}`, unit: "" }));
  const key = JSON.stringify(elements);
  if (key === plot.shownLegend) return;
  plot.shownLegend = key;
  plot.legend.replaceChildren();
  elements.forEach((e, i) => {
    const item = node("span", plot.legend); item.className = "item";
    node("span", item, "■").className = "c" + (i % COLOURS.length);
    node("span", item, e.unit ? `${e.name} [${e.unit}]` : `${e.name}`).dataset.element = e.name;
  });
  const units = [...new Set(elements.map(e => e.unit))];
  plot.axis.textContent = units.length === 1 ? `value [${units[0] || "no unit"}] over time [s]`
                                             : `value [${units.join(", ")}: see the legend] over time [s]`;
  plot.canvas.dataset.units = units.join(",");
}
// On a canvas: lines on an SVG cost the browser a layout of every point at every frame.
function drawPlot(plot) {
  const canvas = plot.canvas, g = canvas.getContext("2d");
  g.clearRect(0, 0, canvas.width, canvas.height);
  drawLegend(plot);
  const n = plot.t.length - plot.start;
  const x0 = AX_L, x1 = canvas.width - AX_R, y0 = AX_T, y1 = canvas.height - AX_B, px = x1 - x0;
  const W = plot.window || WINDOW_S;  // a recording's plot spans the whole recording
  const o = plot.overlay;
  if (o && o.at === null) o.at = n ? plot.t[plot.t.length - 1] : 0;  // the live plot's newest when laid over
  // With no live datum yet the window shows the recording's first seconds.
  const newest = n ? plot.t[plot.t.length - 1] : o && o.t.length ? Math.min(o.t[o.t.length - 1], W) : 0, from = newest - W;
  let lo = Infinity, hi = -Infinity;
  for (const c of plot.cols) for (let i = plot.start; i < c.length; i++) { const v = c[i]; if (v !== null) { if (v < lo) lo = v; if (v > hi) hi = v; } }
  const shown = i => o.t[i] + o.at >= from && o.t[i] + o.at <= newest;
  if (o) for (const c of o.cols) for (let i = 0; i < c.length; i++) { const v = c[i]; if (v !== null && shown(i)) { if (v < lo) lo = v; if (v > hi) hi = v; } }
  if (lo === Infinity) { lo = -1; hi = 1; }
  if (hi === lo) { hi += Math.abs(hi) * 0.1 || 1; lo -= Math.abs(lo) * 0.1 || 1; }
  const pad = (hi - lo) * 0.05; lo -= pad; hi += pad;
  const X = t => x0 + (t - from) / W * px, Y = v => y1 - (v - lo) / (hi - lo) * (y1 - y0);
  // Axes, ticks and their numbers (numbers only: names and units are the legend's, as text).
  g.strokeStyle = "#999"; g.fillStyle = "#444"; g.font = "10px sans-serif"; g.lineWidth = 1;
  g.beginPath(); g.moveTo(x0, y0); g.lineTo(x0, y1); g.lineTo(x1, y1); g.stroke();
  const vt = ticks(lo, hi, 5);
  g.textAlign = "right"; g.textBaseline = "middle";
  for (const v of vt.out) { const y = Y(v); g.strokeStyle = "#eee"; g.beginPath(); g.moveTo(x0 + 1, y); g.lineTo(x1, y); g.stroke();
    g.strokeStyle = "#999"; g.beginPath(); g.moveTo(x0 - 4, y); g.lineTo(x0, y); g.stroke(); g.fillText(tickText(v, vt.step), x0 - 6, y); }
  g.textAlign = "center"; g.textBaseline = "top";
  const tt = ticks(-W, 0, 5);
  for (const s of tt.out) { const x = X(newest + s); g.beginPath(); g.moveTo(x, y1); g.lineTo(x, y1 + 4); g.stroke(); g.fillText(s === 0 ? "0 s" : tickText(s, tt.step), x, y1 + 6); }
  canvas.dataset.vticks = vt.out.length; canvas.dataset.tticks = tt.out.length;
  // Every datum in the window: a line through each where they are fewer than the pixels, else
  // per pixel column the minimum to maximum of the data in it, joined to the next.
  let envelope = false;
  g.save(); g.beginPath(); g.rect(x0, y0 - 1, px + 1, y1 - y0 + 2); g.clip();
  plot.cols.forEach((c, k) => {
    g.strokeStyle = COLOURS[k % COLOURS.length]; g.beginPath();
    if (n <= px) {
      let pen = false;
      for (let i = plot.start; i < c.length; i++) { if (c[i] === null) { pen = false; continue; } const x = X(plot.t[i]), y = Y(c[i]); if (pen) g.lineTo(x, y); else g.moveTo(x, y); pen = true; }
    } else {
      envelope = true;
      let col = -1, mn = 0, mx = 0, pen = false;
      const flush = () => { if (col < 0) return; const x = x0 + col + 0.5; if (pen) g.lineTo(x, Y(mn)); else g.moveTo(x, Y(mn)); g.lineTo(x, Y(mx)); pen = true; };
      for (let i = plot.start; i < c.length; i++) {
        if (c[i] === null) continue;
        const here = Math.min(px - 1, Math.max(0, Math.floor((plot.t[i] - from) / W * px)));
        if (here !== col) { flush(); col = here; mn = mx = c[i]; } else { if (c[i] < mn) mn = c[i]; if (c[i] > mx) mx = c[i]; }
      }
      flush();
    }
    g.stroke();
  });
  let overlaid = 0;
  if (o) {
    g.setLineDash([5, 3]);
    o.cols.forEach((c, k) => {
      g.strokeStyle = COLOURS[k % COLOURS.length]; g.beginPath();
      let pen = false;
      for (let i = 0; i < c.length; i++) {
        if (c[i] === null || !shown(i)) { pen = false; continue; }
        const x = X(o.t[i] + o.at), y = Y(c[i]);
        if (pen) g.lineTo(x, y); else g.moveTo(x, y);
        pen = true;
        if (k === 0) overlaid++;
      }
      g.stroke();
    });
    g.setLineDash([]);
  }
  g.restore();
  canvas.dataset.overlay = overlaid;
  canvas.dataset.overlaySeries = o ? o.cols.length : 0;
  canvas.dataset.series = plot.cols.length;
  canvas.dataset.received = plot.received;
  canvas.dataset.sent = plot.sent;
  canvas.dataset.lost = plot.lost;
  canvas.dataset.drawn = n;
  canvas.dataset.envelope = envelope ? "1" : "0";
  const now = performance.now();
  if (now - plot.infoAt < 250 && !plot.error) return;  // the text four times a second: each change is a layout
  plot.infoAt = now;
  const span = n > 1 ? plot.t[plot.t.length - 1] - plot.t[plot.start] : 0;
  if (plot.recorded) {
    plot.div.querySelector(".info").textContent = plot.error ? "cannot plot: " + plot.error :
      `recorded: ${n} of ${plot.total} data shown${n < plot.total ? " (evenly taken)" : ""} over ${span.toFixed(3)} s` +
      `${envelope ? " · min–max per pixel" : ""}`;
    return;
  }
  plot.div.querySelector(".info").textContent = (plot.error ? "cannot plot: " + plot.error :
    `${plot.received} data received of ${plot.sent} sent · ${plot.lost} lost before the page` +
    ` · ${n} in the last ${WINDOW_S} s (${span > 0 ? ((n - 1) / span).toFixed(0) : "–"}/s${plot.stamped ? "" : ", by arrival: the datum has no stamp"})` +
    `${envelope ? " · min–max per pixel" : ""} · ${plot.failed} stream errors`) +
    (o ? ` · dashed: as recorded (${overlaid} of ${o.t.length} shown${o.t.length < o.total ? `, ${o.total} in the file` : ""}), from where the live plot was when laid over` : "");
}

// A recording (rtm record's MCAP file, on the server's machine): its channels, each plotted
// whole on a plot like a port's, drawn the same way (the time axis is the recording's span).
// Click a channel again to remove its plot.
const recordedPlots = new Map();
function openRecording() {
  const file = document.getElementById("recording").value.trim();
  const list = document.getElementById("recording-channels");
  list.replaceChildren();
  if (!file) return;
  api("GET", "/api/recording?file=" + encodeURIComponent(file)).then(r => {
    node("div", list, `${r.channels.length} channels over ${((r.end_ns - r.start_ns) / 1e9).toFixed(1)} s`);
    for (const c of r.channels) {
      const b = node("button", list, `${c.topic} (${c.type}, ${c.count})`);
      b.className = "channel"; b.dataset.topic = c.topic;
      b.addEventListener("click", () => plotRecorded(file, c));
      const o = node("button", list, "on the live plot");
      o.className = "overlay"; o.dataset.topic = c.topic;
      o.title = `${c.topic} as recorded, dashed over the live plot of ${c.topic}`;
      o.addEventListener("click", () => overlayRecorded(file, c));
    }
  }).catch(e => { node("div", list, "cannot open: " + e.message).className = "err"; });
}
function plotRecorded(file, channel) {
  const key = file + "\n" + channel.topic;
  if (recordedPlots.has(key)) { recordedPlots.get(key).div.remove(); recordedPlots.delete(key); return; }
  const parts = plotParts("plot recorded", `${channel.topic} (recorded)`);
  parts.div.dataset.recording = file; parts.div.dataset.topic = channel.topic;
  const plot = { address: channel.topic, ...parts, t: [], cols: [], start: 0, received: 0, sent: 0,
                 lost: 0, failed: 0, error: "", type: channel.type, stamped: true, shownLegend: "", infoAt: 0,
                 recorded: true, total: channel.count, elements: channel.elements.length ? channel.elements : null };
  recordedPlots.set(key, plot);
  const q = `file=${encodeURIComponent(file)}&topic=${encodeURIComponent(channel.topic)}`;
  api("GET", "/api/recording/values?" + q).then(d => {
    const t = d.t || [];
    const t0 = t.length ? Math.floor(t[0]) : 0;
    plot.t = t.map(x => x - t0);
    plot.cols = (d.v || []).map(col => col.slice());
    plot.total = d.total;
    plot.received = plot.t.length;
    plot.window = plot.t.length > 1 ? Math.max(plot.t[plot.t.length - 1] - plot.t[0], 1e-3) : 1;
    drawPlot(plot);
  }).catch(e => { plot.error = e.message; drawPlot(plot); });
}
// A recorded channel on the live plot of the port it was recorded from (started if need be):
// dashed, in the same colours, its first datum placed where the live plot's newest datum was
// when it was laid over, so that it runs along the live data as if it were playing now: a run
// beside a recorded one. Click again to take it off.
function overlayRecorded(file, channel) {
  const key = file + "\n" + channel.topic;
  if (!plots.has(channel.topic)) startPlot(channel.topic);
  const plot = plots.get(channel.topic);
  if (!plot) return;  // refused (at most 10 plots): said by startPlot
  if (plot.overlay && plot.overlay.key === key) { plot.overlay = null; plot.infoAt = 0; drawPlot(plot); return; }
  const q = `file=${encodeURIComponent(file)}&topic=${encodeURIComponent(channel.topic)}`;
  api("GET", "/api/recording/values?" + q).then(d => {
    const t = d.t || [];
    const t0 = t.length ? t[0] : 0;
    plot.overlay = { key, t: t.map(x => x - t0), cols: (d.v || []).map(col => col.slice()), at: null, total: d.total };
    plot.infoAt = 0;  // its info line says so at once
    drawPlot(plot);
  }).catch(e => showError("cannot lay the recording over the live plot: " + e.message));
}
document.getElementById("open-recording").addEventListener("click", openRecording);
document.getElementById("recording").addEventListener("keydown", ev => { if (ev.key === "Enter") openRecording(); });

// A component's description, statistics and parameters; a parameter the component lets change
// is an input.
function showDetails(name) {
  api("GET", apiPath("components", name)).then(c => {
    const box = document.getElementById("details");
    box.replaceChildren();
    node("h3", box, name);
    if (c.description) node("p", box, c.description);
    const k = c.contract;
    if (k && k.watched) {
      // Numbers and words of our own: node() sets text, never markup.
      const worst = ns => `${(ns.max / 1000).toFixed(1)} µs` + (ns.max_at_ns > 0 ? ` at ${new Date(ns.max_at_ns / 1e6).toLocaleTimeString()}` : "");
      const line = node("p", box,
        `contract: deadline ${(k.deadline_ns / 1000).toFixed(0)} µs ${k.deadline_met ? "met" : `missed ${k.missed_deadline}×`}` +
        ` (response p99 ${(k.response_ns.p99 / 1000).toFixed(1)} µs, worst ${worst(k.response_ns)})` +
        (k.budget_ns > 0 ? `; budget ${(k.budget_ns / 1000).toFixed(0)} µs ${k.budget_met ? "met" : `exceeded ${k.over_budget}×`}` : "; no budget") +
        ` (cycle p99 ${(k.cycle_ns.p99 / 1000).toFixed(1)} µs, worst ${worst(k.cycle_ns)})`);
      line.id = "contract";
      line.className = k.deadline_met && k.budget_met !== false ? "met" : "missed";
    }
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
      if (shown) { shown.timing.textContent = timingText(c); if (shown.error) shown.error.textContent = errorText(c); }
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
// The first look asked at once (all components in parallel), not left for the stream's first
// poll. It is the one synchronous call of the page, on purpose: the page's load event waits for
// it, so whatever waits for the load (a one-shot headless screenshot, a test driver) sees the
// graph, not the placeholder. The server bounds each component's calls, so it cannot hang.
function firstLook() {
  if (!token) { document.getElementById("status").textContent = "no token in the URL: open the URL rtm serve printed"; return; }
  const request = new XMLHttpRequest();
  try {
    request.open("GET", "/api/system", false);
    request.setRequestHeader("X-RTM-Token", token);
    request.send();
    const data = JSON.parse(request.responseText);
    if (request.status !== 200) throw new Error(data.error || request.statusText);
    showSystem(data);
  } catch (e) {
    showError(e.message);
  }
}
function closeReplacedStreams() { replacedStreams.forEach(s => s.close()); replacedStreams.clear(); }
window.addEventListener("pagehide", () => {
  clearTimeout(eventsRetry); events.close(); closeReplacedStreams();
  if (valuesStream) valuesStream.close();
});
window.addEventListener("pageshow", ev => { if (ev.persisted) { openEvents(); openValues(); } });
firstLook();
openEvents();
// Plots named in the URL's fragment (#token=…&plot=a.out&plot=…), opened as a click opens them;
// and again when the fragment is edited (the page's own updates replace it without an event).
function plotsFromUrl() {
  const wanted = new URLSearchParams(location.hash.slice(1)).getAll("plot").slice(0, 10);
  for (const address of [...plots.keys()]) if (!wanted.includes(address)) startPlot(address);
  for (const address of wanted) if (!plots.has(address)) startPlot(address);
}
window.addEventListener("hashchange", plotsFromUrl);
plotsFromUrl();
