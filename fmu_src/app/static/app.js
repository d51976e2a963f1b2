// grubler app: the page.  Every number comes from the server (the library's own
// functions); this file draws, animates and plots what it is sent, and sends edits.
"use strict";

const $ = (id) => document.getElementById(id);
const SVG = "http://www.w3.org/2000/svg";
const COLOURS = ["#1f6feb", "#e8590c", "#2da44e", "#8250df", "#bf3989", "#0a7b83", "#9a6700"];
const state = {
  scene: null, analysis: null, run: null, box: null, trace: "",
  playing: false, t: 0, last: 0, panels: [], zoom: null,
  inflight: false, queued: null, dragging: null,
};
// latencies the benchmark reads (ms), each to the frame that shows its answer: a drag move, a click on
// Simulate, a servo re-run; and for each, where the time went (``parts``: see record below)
window.grublerStats = { drag: [], simulate: [], servo: [], parts: { drag: [], simulate: [], servo: [] } };

// one latency, once its answer is painted: the wait before the request, the server's action (its
// Server-Timing), the transfer (the rest of the round trip, JSON parsing included), the page's drawing,
// and the wait for the frame that shows it
function record(kind, start, timing) {
  const drawn = performance.now();
  requestAnimationFrame(() => setTimeout(() => {
    const shown = performance.now();
    window.grublerStats[kind].push(shown - start);
    window.grublerStats.parts[kind].push({
      before: timing.sent - start, server: timing.server, transfer: timing.answered - timing.sent - timing.server,
      draw: drawn - timing.answered, paint: shown - drawn,
    });
  }, 0));
}

// -- talking to the server --------------------------------------------------------------------------
async function api(name, body, timing) {
  if (state.kinematics && ANALYSED.has(name)) body = { ...body, kinematics: true };  // the analysis layer is on
  if (name === "simulate") { state.runScene = body.scene; state.instant = null; }  // its instants: of that scene
  const sent = performance.now();
  const r = await fetch("/api/" + name, {
    method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body || {}),
  });
  sessionCheck(r, name);
  const out = await r.json();
  if (timing) {
    const server = /dur=([0-9.]+)/.exec(r.headers.get("Server-Timing") || "");
    Object.assign(timing, { sent, answered: performance.now(), server: server ? Number(server[1]) : NaN });
  }
  if (out.error && !out.scene) {
    const e = new Error(out.error.reason);
    e.field = out.error.field;
    throw e;
  }
  return out;
}

// The app keeps the sessions of the pages used most recently (and none across a restart): told that it
// forgot this page's (X-Grubler-Session), the page forgets its run too, whose CSV and report were kept
// there, and says so, rather than an export failing later
function sessionCheck(r, name) {
  const lost = r.headers.get("X-Grubler-Session");
  if (!lost || name === "simulate" || !state.run) return;  // a new run starts the new session: nothing lost
  forgetRun();
  notice(lost === "evicted"
    ? "the app forgot this page's session to make room for newer pages, and its run with it: simulate again"
    : "the app does not know this page's session (was it restarted?): its run is gone; simulate again", true);
}

// a file the server answered with, saved; or its refusal (JSON) told
async function saveAnswer(r, name) {
  sessionCheck(r, name);
  if ((r.headers.get("Content-Type") || "").startsWith("application/json")) {
    const out = await r.json();
    if (out.error) notice(`${out.error.field}: ${out.error.reason}`, true);
    return;
  }
  const file = (r.headers.get("Content-Disposition") || "").match(/filename="([^"]+)"/);
  const a = document.createElement("a");
  a.download = file ? file[1] : "export";
  a.href = URL.createObjectURL(await r.blob());
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  notice("exported " + a.download);
}

// a spatial scene opened on this page: the 3D view shows it (handed over in this tab's session storage)
function openSpatial(spatial) {
  sessionStorage.setItem("grubler.spatial", JSON.stringify(spatial));
  location.href = "/static/view3d.html";
}

function notice(text, bad) {
  const n = $("notice");
  n.textContent = text;
  n.className = bad ? "bad" : "";
  if (!bad) setTimeout(() => { if (n.textContent === text) n.textContent = ""; }, 4000);
}

// -- the scene: facts, problems, form -----------------------------------------------------------------
async function analyse(body, opts = {}) {
  const out = await api(body.action || "analyse", { trace: state.trace, ...body, action: undefined });
  show(out, opts);
  return out;
}

function show(out, opts = {}) {
  state.scene = out.scene;
  // an answer without a sketch (a scene that does not build) keeps the facts and the drawing there were
  if (!out.frame && state.analysis && state.analysis.frame && opts.drag) {
    out = { ...state.analysis, scene: out.scene, fields: out.fields, error: out.error };
  }
  state.analysis = out;
  if (out.frame) state.drawn = out.sketch_of || out.scene;  // the scene the drawing is of
  showFacts(out);
  const problem = $("problem");
  problem.hidden = !out.problem;
  problem.textContent = out.problem ? `${out.problem.field}: ${sayMessage(out.problem.reason)}` : "";
  if (!opts.keepFields) renderFields(out.fields);
  document.querySelectorAll("#fields .err").forEach((e) => { e.textContent = ""; });
  const target = out.error && document.querySelector(`[data-err="${CSS.escape(out.error.field)}"]`);
  if (target) target.textContent = sayMessage(out.error.reason);
  const error = $("error");
  error.textContent = out.error && !target ? `${out.error.field}: ${sayMessage(out.error.reason)}` : "";
  error.hidden = !error.textContent;
  if (out.trace && !$("trace").value) $("trace").value = out.trace;
  if (out.frame) {
    if (opts.fit || !state.box) fitView([out.frame, out.curve]);
    pause();
    state.showingRun = false;
    $("edit-mode").disabled = true;
    drawScene(out);
  }
  if (!opts.dragging) { remember(); noteScene(state.scene); }  // the history (history.js) keeps it
}

// the facts panel, its lengths in the page's units (units.js)
function showFacts(out) {
  const c = out.class;
  $("kind").textContent = c ? c.name + (c.inversion ? " — " + c.inversion : "") : "–";
  $("grashof").textContent = c && c.grashof
    ? `${c.grashof.kind}: s + l = ${say(c.grashof.s_plus_l, "m")}, p + q = ${say(c.grashof.p_plus_q, "m")}`
    : (c ? "not a four-bar of pins" : "–");
  $("grashof").title = c && c.grashof ? c.grashof.detail : "";
  $("mobility").textContent = c ? String(c.mobility) : "–";
  $("branch").textContent = out.branch
    ? `${out.branch.angles.length ? sayMessage(out.branch.angles.join(", ")) : "the sketch's"}: one of ${out.branch.count} found with ${out.branch.drive} held`
    : (out.closed === false ? "the loop does not close" : "–");
}

// four significant digits, the zeros after a decimal point dropped (8000 stays 8000; 1.500e+6 is 1.5e6)
function fmt(v) { return trimZeros(Number(v).toPrecision(4)); }
function trimZeros(s) {
  const [mantissa, exponent] = s.split("e");
  const m = mantissa.includes(".") ? mantissa.replace(/\.?0+$/, "") : mantissa;
  return exponent === undefined ? m : m + "e" + exponent.replace(/^\+/, "");
}

function renderFields(fields) {
  const form = $("fields");
  const focused = document.activeElement && document.activeElement.dataset.key;
  form.textContent = "";
  let group = null;
  for (const f of fields || []) {
    const head = f.key.includes(".") ? f.key.split(".")[0] : "scene";
    if (head !== group) {
      group = head;
      const h = document.createElement("h3");
      h.textContent = head;
      form.appendChild(h);
    }
    const row = document.createElement("div");
    row.className = "row";
    const label = document.createElement("label");
    const id = "f-" + f.key.replace(/[^A-Za-z0-9]/g, "_");
    label.htmlFor = id;
    const leaf = f.key.slice(head === "scene" ? 0 : head.length + 1);
    label.innerHTML = "";
    label.append(leaf, " ");
    const si = f.text ? "" : f.unit;  // a number's unit as the page shows it (units.js); the value follows
    const unit = shownUnit(si).unit;
    if (unit) {
      const u = document.createElement("span");
      u.className = "unit";
      u.textContent = "(" + unit + ")";
      label.append(u);
    }
    label.title = f.key + (unit ? " in " + unit : "");
    const input = document.createElement(f.choices ? "select" : "input");
    input.id = id;
    input.dataset.key = f.key;
    for (const c of f.choices || []) {
      const o = document.createElement("option");
      o.textContent = c;
      input.appendChild(o);
    }
    const shown = fieldText(fieldShown(f.value, si));  // six digits; the scene's value kept (units.js)
    input.value = shown;
    input.addEventListener("change", () => edit(f.key, fieldSent(input.value, shown, f.value, si)));
    const err = document.createElement("div");
    err.className = "err";
    err.dataset.err = f.key;
    row.append(label, input, err);
    form.appendChild(row);
  }
  decorateElements(form);  // a force element's Remove (forces.js)
  if (focused) {
    const again = form.querySelector(`[data-key="${CSS.escape(focused)}"]`);
    if (again) again.focus();
  }
}

// one edit at a time, each on the scene the one before it answered with: a field changed while another's
// answer is on its way would otherwise be sent on the scene without that one, and its answer undo it
function edit(key, value) {
  state.pendingEdits = (state.pendingEdits || 0) + 1;
  state.edits = (state.edits || Promise.resolve()).then(async () => {
    try {
      await analyse({ action: "edit", scene: state.scene, key, value });
    } catch (e) { notice(`${e.field}: ${e.message}`, true); }
    finally { state.pendingEdits -= 1; }
  });
  return state.edits;
}

// -- the URL holds the scene, so a link can be shared ---------------------------------------------------
function b64(text) {
  const bytes = new TextEncoder().encode(text);
  let s = "";
  for (const b of bytes) s += String.fromCharCode(b);
  return btoa(s).replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "");
}
function unb64(s) {
  const bin = atob(s.replace(/-/g, "+").replace(/_/g, "/"));
  return new TextDecoder().decode(Uint8Array.from(bin, (c) => c.charCodeAt(0)));
}
function remember() {
  if (state.scene) history.replaceState(null, "", "#scene=" + b64(JSON.stringify(state.scene)));
}

// -- the drawing ---------------------------------------------------------------------------------------
function fitView(things) {
  // the links and handles, and of a curve what lies near them: a conchoid runs off to infinity
  const core = points(things.filter((f) => f && !Array.isArray(f)))
    .concat((state.analysis && state.analysis.handles || []).map((h) => h.xy));
  const box = (pts) => {
    const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
    return [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
  };
  let near = [];
  if (core.length) {
    const [a0, a1, b0, b1] = box(core), reach = 1.5 * Math.max(a1 - a0, b1 - b0, 1e-3);
    near = points(things.filter(Array.isArray)).filter((p) =>
      p[0] > a0 - reach && p[0] < a1 + reach && p[1] > b0 - reach && p[1] < b1 + reach);
  }
  const pts = core.length ? core.concat(near) : points(things);
  if (!pts.length) return;
  let [x0, x1, y0, y1] = box(pts);
  const span = Math.max(x1 - x0, y1 - y0, 1e-3);
  const pad = 0.15 * span;
  state.box = { x: x0 - pad, y: y0 - pad, w: x1 - x0 + 2 * pad, h: y1 - y0 + 2 * pad, span };
  setViewBox();
}

function setViewBox() {
  // world y points up: the content is drawn in a group flipped about y = 0
  $("drawing").setAttribute("viewBox", `${state.box.x} ${-(state.box.y + state.box.h)} ${state.box.w} ${state.box.h}`);
}

function points(things) {
  const out = [];
  for (const f of things) {
    if (!f) continue;
    if (Array.isArray(f)) { out.push(...f); continue; }
    f.bars.forEach((b) => { out.push(b, [b[2], b[3]]); });
    out.push(...f.joints, ...f.fixed, ...f.blocks);
    f.plates.forEach((pl) => out.push(...pl));
    (f.actuators || []).forEach((a) => out.push([a[0], a[1]], [a[2], a[3]]));
    out.push(...forcePoints(f));
  }
  return out;
}

function inView(things) {
  const b = state.box;
  return !!b && points(things).every((p) => p[0] >= b.x && p[0] <= b.x + b.w && p[1] >= b.y && p[1] <= b.y + b.h);
}

function frameMarkup(f, cls) {
  const s = state.box.span;
  const r = 0.012 * s;
  let out = `<g class="${cls || ""}">`;
  for (const g of f.guides) {
    const [x, y, a] = g, L = 0.6 * s;
    out += `<line class="guide" x1="${x - L * Math.cos(a)}" y1="${y - L * Math.sin(a)}" x2="${x + L * Math.cos(a)}" y2="${y + L * Math.sin(a)}"/>`;
  }
  for (const pl of f.plates) out += `<polygon class="plate" points="${pl.map((p) => p.join(",")).join(" ")}"/>`;
  for (const b of f.bars) out += `<line class="bar-link" x1="${b[0]}" y1="${b[1]}" x2="${b[2]}" y2="${b[3]}"/>`;
  for (const a of f.actuators || []) {  // a cylinder: the rod along its whole line, the barrel from its first point
    out += `<line class="rod" x1="${a[0]}" y1="${a[1]}" x2="${a[2]}" y2="${a[3]}"/>`;
    out += `<line class="barrel" x1="${a[0]}" y1="${a[1]}" x2="${a[4]}" y2="${a[5]}"/>`;
  }
  out += forcesMarkup(f, s);  // springs, torsion springs, loads (forces.js)
  for (const b of f.blocks) {
    const w = 4 * r, h = 2.6 * r, deg = (b[2] * 180) / Math.PI;
    out += `<rect class="block" x="${-w / 2}" y="${-h / 2}" width="${w}" height="${h}" transform="translate(${b[0]},${b[1]}) rotate(${deg})"/>`;
  }
  for (const p of f.fixed) {
    out += `<path class="fixed" d="M${p[0]},${p[1]} l${-1.6 * r},${-2.6 * r} h${3.2 * r} z"/>`;
  }
  for (const p of f.joints) out += `<circle class="joint" cx="${p[0]}" cy="${p[1]}" r="${r}"/>`;
  return out + "</g>";
}

function polyline(points, cls) {
  if (!points || points.length < 2) return "";
  return `<polyline class="${cls}" points="${points.map((p) => p[0] + "," + p[1]).join(" ")}"/>`;
}

// -- the analysis on the drawing: velocities, accelerations, instant centres, forces ----------------------
// the server computes them (grubler.mechanism.instant) when the layer is on; this draws them, each kind
// scaled to its largest: a velocity arrow of the fastest point is a fifth of the view
const ANALYSED = new Set(["analyse", "drag", "edit", "add_element", "remove_element"]);
const LAYER = { v: "velocity", a: "acceleration", ic: "instant centres", f: "joint forces" };

function setupAnalysis() {
  state.layer = new Set();
  document.querySelectorAll("#analysis-layer input").forEach((box) => box.addEventListener("change", async () => {
    if (box.checked) state.layer.add(box.dataset.kind); else state.layer.delete(box.dataset.kind);
    state.kinematics = state.layer.size > 0;
    state.instant = null;
    if (!state.kinematics) showAnalysisFacts(null);
    if (state.showingRun) { drawRunFrame(); return; }
    if (state.scene) {
      try { await analyse({ scene: state.scene }); } catch (e) { notice(`${e.field}: ${e.message}`, true); }
    }
  }));
}

// an angle modulo a turn, and a signed one, in the page's angle unit (units.js)
function fmtDeg(rad) { return say(((rad % (2 * Math.PI)) + 2 * Math.PI) % (2 * Math.PI), "rad"); }
function fmtAngle(deg) { return say((deg * Math.PI) / 180, "rad"); }

function arrowMarkup(at, vec, scale, cls, text) {
  const s = state.box.span, L = Math.hypot(vec[0], vec[1]) * scale;
  if (!(L > 1e-4 * s)) return "";
  const ux = (vec[0] * scale) / L, uy = (vec[1] * scale) / L, head = Math.min(0.022 * s, 0.5 * L);
  const tx = at[0] + ux * L, ty = at[1] + uy * L, bx = tx - ux * head, by = ty - uy * head;
  const w = 0.45 * head;
  return `<g class="arrow ${cls}"><line x1="${at[0]}" y1="${at[1]}" x2="${bx}" y2="${by}"/>` +
    `<polygon points="${tx},${ty} ${bx - uy * w},${by + ux * w} ${bx + uy * w},${by - ux * w}"/>` +
    labelMarkup([tx + ux * 0.01 * s, ty + uy * 0.01 * s], text, cls) + "</g>";
}

function labelMarkup(at, text, cls) {  // upright text in the flipped drawing
  const size = 0.026 * state.box.span;
  return `<text class="alabel ${cls || ""}" font-size="${size}" transform="translate(${at[0]},${at[1]}) scale(1,-1)">${escapeXml(text)}</text>`;
}

function largest(items, key) { return Math.max(1e-300, ...items.map((i) => Math.hypot(i[key][0], i[key][1]))); }

function analysisMarkup(a, shift) {
  if (!a || !state.kinematics || !state.box) return "";
  const s = state.box.span, show = state.layer;
  let html = `<g class="analysis">`;
  if (show.has("f") && a.forces) {
    html += forceArrows(a, s);  // the joints' and the force elements' (forces.js)
  }
  if (show.has("v")) {
    const k = (0.2 * s) / largest(a.points, "v");
    for (const p of a.points) html += arrowMarkup(p.at, p.v, k, "vel", say(Math.hypot(...p.v), "m/s"));
  }
  if (show.has("a")) {
    const k = (0.2 * s) / largest(a.points, "a");
    for (const p of a.points) html += arrowMarkup(p.at, p.a, k, "acc", say(Math.hypot(...p.a), "m/s^2"));
  }
  if (show.has("ic")) html += centresMarkup(a.centres, shift);
  for (const t of a.transmission) {
    html += labelMarkup([t.at[0] + 0.02 * s, t.at[1] - 0.045 * s], `μ${t.label.slice(2)} ${fmtAngle(t.deg)}`, "mu");
    if (t.least_at) {
      html += `<circle class="mark least" cx="${t.least_at[0]}" cy="${t.least_at[1]}" r="${0.012 * s}"/>`;
      html += labelMarkup([t.least_at[0] + 0.015 * s, t.least_at[1] + 0.015 * s],
        `μ${t.label.slice(2)} least ${fmtAngle(t.least_deg)}`, "mu");
    }
  }
  for (const t of a.toggles) {
    if (!t.at) continue;
    const r = 0.014 * s;
    html += `<rect class="mark toggle" x="${t.at[0] - r}" y="${t.at[1] - r}" width="${2 * r}" height="${2 * r}" transform="rotate(45 ${t.at[0]} ${t.at[1]})"/>`;
    html += labelMarkup([t.at[0] + 0.018 * s, t.at[1] - 0.03 * s], `toggle ${a.drive} ${fmtDeg(t.drive)}`, "toggle");
  }
  for (const t of a.limits || []) {
    if (!t.at) continue;
    html += `<circle class="mark limit" cx="${t.at[0]}" cy="${t.at[1]}" r="${0.013 * s}"/>`;
    html += labelMarkup([t.at[0] + 0.018 * s, t.at[1] - 0.03 * s], `limit ${a.drive} ${fmtDeg(t.drive)}`, "toggle");
  }
  return html + "</g>";
}

function centresMarkup(centres, shift) {
  // a centre out of view (or at infinity) is drawn on the view's edge, in its direction, with where it is
  const b = state.box, s = b.span, [sx, sy] = shift || [0, 0];
  const cx = b.x + b.w / 2 - sx, cy = b.y + b.h / 2 - sy, r = 0.011 * s;
  let html = "";
  for (const c of centres) {
    let at = c.at, text = c.label;
    if (!at && !c.direction) continue;  // the two move as one: no centre
    const inside = at && at[0] > b.x - sx && at[0] < b.x + b.w - sx && at[1] > b.y - sy && at[1] < b.y + b.h - sy;
    if (!inside) {
      const d = at ? [at[0] - cx, at[1] - cy] : c.direction, n = Math.hypot(d[0], d[1]) || 1;
      const reach = 0.46 * Math.min(b.w / Math.abs(d[0] / n || 1e-9), b.h / Math.abs(d[1] / n || 1e-9));
      at = [cx + (d[0] / n) * reach, cy + (d[1] / n) * reach];
      text += c.at ? ` (${fmt(c.at[0])}, ${fmt(c.at[1])})` : " ∞";
    }
    html += `<g class="centre${inside ? "" : " far"}"><path d="M${at[0] - r},${at[1]} h${2 * r} M${at[0]},${at[1] - r} v${2 * r}"/>` +
      labelMarkup([at[0] + 0.6 * r, at[1] + 0.6 * r], text, "ic") + "</g>";
  }
  return html;
}

function showAnalysisFacts(a) {
  const box = $("analysis-facts");
  if (!box) return;
  if (!a || !state.kinematics) { box.textContent = ""; return; }
  const parts = [a.state === "run" ? `the run at t = ${fmt(a.t)} s` : a.state];
  if (a.advantage) {
    parts.push(`mechanical advantage (${a.advantage.output} on ${a.drive}) ${a.advantage.value === null ? "∞: a toggle"
      : say(a.advantage.value, a.advantage.unit)}`);
  }
  for (const t of a.transmission) {
    parts.push(`transmission angle μ${t.label.slice(2)} ${fmtAngle(t.deg)}` +
      (t.least_deg !== undefined ? ` (least ${fmtAngle(t.least_deg)} at ${a.drive} ${fmtDeg(t.least_drive)})` : ""));
  }
  if (a.toggles.length) parts.push(`toggles at ${a.drive} ${a.toggles.map((t) => fmtDeg(t.drive)).join(", ")}`);
  if ((a.limits || []).length) {
    const deg = (rad) => say(rad, "rad");  // signed: the range runs up from the first
    parts.push(`${a.drive} turns only from ${deg(a.limits[0].drive)} to ${deg(a.limits[1].drive)} (its limits)`);
  }
  if (!a.forces) parts.push(`no forces: ${a.forces_reason}`);
  box.textContent = parts.join("; ");
}

// at a run's instant (paused or scrubbed): one request in flight, the newest time waiting behind it
function runInstantMarkup() {
  if (!state.kinematics || state.playing || !state.run) return "";
  const want = state.t;
  if (state.instant && state.instant.want === want) {
    return state.instant.analysis ? analysisMarkup(state.instant.analysis) : "";
  }
  state.instantQueued = want;
  pumpInstant();
  return state.instant && state.instant.analysis ? analysisMarkup(state.instant.analysis) : "";
}

async function pumpInstant() {
  if (state.instantBusy || state.instantQueued === undefined) return;
  const want = state.instantQueued;
  state.instantQueued = undefined;
  state.instantBusy = true;
  try {
    const out = await api("instant", { scene: state.runScene || state.scene, at: want, trace: state.trace });
    state.instant = { want, analysis: out.analysis };
    showAnalysisFacts(out.analysis);
  } catch (e) {
    state.instant = { want, analysis: null };
    $("analysis-facts").textContent = `${e.field}: ${e.message}`;
  } finally {
    state.instantBusy = false;
    if (state.instantQueued !== undefined) pumpInstant();
    else if (state.showingRun && !state.playing) drawRunFrame();
  }
}

function drawScene(out) {
  const s = state.box.span;
  // a six-bar's origin being dragged: its answer is measured from the moved origin, drawn where the drag began
  const [sx, sy] = out.shift || [0, 0];
  let html = `<g transform="scale(1,-1)">${gridMarkup()}<g transform="translate(${sx},${sy})">`;
  // the curve over the links' plates, which would hide it where it crosses them
  html += frameMarkup(out.frame, out.closed === false ? "open" : "");
  html += polyline(out.curve, "curve");
  for (const h of out.handles || []) {
    html += `<circle class="handle${state.dragging && state.dragging.id === h.id ? " active" : ""}" data-handle="${h.id}" cx="${h.xy[0]}" cy="${h.xy[1]}" r="${0.028 * s}"><title>drag: sets ${h.sets}</title></circle>`;
  }
  html += dimsMarkup(out.dims);
  html += analysisMarkup(out.analysis, [sx, sy]);
  showAnalysisFacts(out.analysis);
  $("drawing").innerHTML = html + "</g></g>";
}

function drawRunFrame() {
  const run = state.run;
  if (!run) return;
  state.showingRun = true;
  $("edit-mode").disabled = false;
  const i = frameAt(state.t);
  const path = run.path.slice(0, rowAt(state.t) + 1);
  let html = `<g transform="scale(1,-1)">` + frameMarkup(run.frames[i]) + polyline(run.path, "path");
  const p = path[path.length - 1];
  if (p) html += `<circle class="tracer" cx="${p[0]}" cy="${p[1]}" r="${0.01 * state.box.span}"/>`;
  html += runInstantMarkup();
  $("drawing").innerHTML = html + "</g>";
  $("clock").textContent = `t = ${state.t.toFixed(3)} s`;
  $("scrub").value = String(state.t);
  drawCursors();
}

function search(ts, t) {
  let lo = 0, hi = ts.length - 1;
  while (lo < hi) {
    const mid = (lo + hi + 1) >> 1;
    if (ts[mid] <= t + 1e-12) lo = mid; else hi = mid - 1;
  }
  return lo;
}
function frameAt(t) { return search(state.run.frame_t, t); }
function rowAt(t) { return search(state.run.t, t); }

function toWorld(evt) {
  const g = $("drawing").querySelector("g");
  const pt = new DOMPoint(evt.clientX, evt.clientY).matrixTransform(g.getScreenCTM().inverse());
  return [pt.x, pt.y];
}

// dragging a handle: one request in flight, the newest position waiting behind it
function setupDrag() {
  const svg = $("drawing");
  svg.addEventListener("pointerdown", (evt) => {
    const id = evt.target.dataset && evt.target.dataset.handle;
    if (!id || !state.scene) return;
    stopRun();
    state.dragging = { id, start: state.scene, drawn: state.drawn };
    state.lastMove = null;
    svg.setPointerCapture(evt.pointerId);
    evt.preventDefault();
  });
  svg.addEventListener("pointermove", (evt) => {
    if (!state.dragging) return;
    const [x, y] = snapToGrid(toWorld(evt));  // on the grid when it is on (drawtools.js)
    state.queued = { x, y, at: performance.now(), drag: state.dragging };
    pump();
  });
  // a double click on a link traces that point of it
  svg.addEventListener("dblclick", async (evt) => {
    if (!state.analysis || state.showingRun || (evt.target.dataset && evt.target.dataset.handle)) return;
    const [x, y] = toWorld(evt);
    try {
      const { trace } = await api("pick", { scene: state.scene, x, y });
      $("trace").value = trace;
      state.trace = trace;
      await analyse({ scene: state.scene });
      notice("tracing " + trace);
    } catch (e) { notice(`${e.field}: ${e.message}`, true); }
  });
  const end = () => {
    if (!state.dragging) return;
    state.dragging = null;
    state.settling = true;  // until the drag's last answer is on the page
    const settle = async () => {
      // the last move again, with the full curve: as a drag, so a joint the builder cannot place keeps its
      // message and the sketch it was dragged from
      const last = state.lastMove;
      if (last && !last.full && state.analysis && state.analysis.scene) {
        try {
          show(await api("drag", { scene: last.drag.start, handle: last.drag.id, x: last.x, y: last.y, trace: state.trace,
            drawn: last.drag.drawn }), { drag: true });
        } catch (e) { notice(`${e.field}: ${e.message}`, true); }
      }
      const a = state.analysis;
      if (a && a.shift) {  // the moved origin's coordinates from now on: the view moves with them, the drawing stays
        state.box.x -= a.shift[0];
        state.box.y -= a.shift[1];
        a.shift = null;
        setViewBox();
        drawScene(a);
      }
      // the drag may have carried the mechanism out of view: bring it back, handles included
      if (a && a.frame && !inView([a.frame, (a.handles || []).map((h) => h.xy)])) {
        fitView([a.frame, a.curve]);
        drawScene(a);
      }
      state.settling = false;
      noteScene(state.scene);  // the drag is one edit in the history (history.js)
    };
    const wait = () => (state.inflight || state.queued ? setTimeout(wait, 20) : settle());
    wait();
  };
  svg.addEventListener("pointerup", end);
  svg.addEventListener("pointercancel", end);
}

async function pump() {
  if (state.inflight || !state.queued) return;
  const { x, y, at, drag } = state.queued;  // the drag it belongs to: the last move may land after the release
  state.queued = null;
  state.inflight = true;
  try {
    const live = state.dragging === drag;  // the move after the release gets the full curve
    const move = { x, y, drag };
    state.lastMove = move;
    const timing = {};
    const out = await api("drag", { scene: drag.start, handle: drag.id, x, y, trace: state.trace, live, drawn: drag.drawn },
      timing);
    show(out, { dragging: true, drag: true });
    record("drag", at, timing);
    move.full = !live;  // an answer with the full curve: nothing to settle
  } catch (e) {
    notice(`${e.field}: ${e.message}`, true);
  } finally {
    state.inflight = false;
    if (state.queued) requestAnimationFrame(pump);
  }
}

// -- running and playing -------------------------------------------------------------------------------
async function simulate() {
  const t0 = performance.now();
  $("simulate").disabled = true;
  $("cancel").disabled = false;
  $("run-status").textContent = "simulating…";
  $("run-warnings").textContent = "";
  $("field-t_end").textContent = "";
  stopRun();
  try {
    const timing = {};
    const run = await api("simulate", {
      scene: state.scene, t_end: $("t_end").value, torque: $("torque").value, trace: state.trace,
      actuator_force: $("actuator-force").value,
    }, timing);
    decodeColumns(run.columns);
    state.run = run;
    state.t = 0;
    fitView([...run.frames.filter((_, i) => i % 10 === 0), run.path]);
    $("scrub").max = String(run.t[run.t.length - 1]);
    $("scrub").disabled = false;
    $("play").disabled = false;
    $("png").disabled = false;
    $("csv").classList.remove("disabled");
    $("csv").href = "/api/result.csv?name=" + encodeURIComponent(state.scene.name || "run");
    drawRunFrame();
    if (!state.panels.length) defaultPanels();
    drawPanels();
    record("simulate", t0, timing);
    $("run-status").textContent = run.summary;
    $("run-warnings").textContent = (run.warnings || []).map((w) => "warning: " + w).join("\n");
    play();
  } catch (e) {
    const at = e.field === "t_end" ? $("field-t_end") : $("run-status");
    at.textContent = `${e.field}: ${sayMessage(e.message)}`;
    if (at !== $("run-status")) $("run-status").textContent = "";
  } finally {
    $("simulate").disabled = false;
    $("cancel").disabled = true;
  }
}

function decodeColumns(columns, paren) {  // float32 columns, base64: decoded once, shown in the page's units
  for (const c of columns) {
    const bytes = Uint8Array.from(atob(c.f32), (ch) => ch.charCodeAt(0));
    c.values = new Float32Array(bytes.buffer);
    columnShown(c, paren);
  }
}

function play() {
  if (!state.run) return;
  const end = state.run.t[state.run.t.length - 1];
  if (state.t >= end) state.t = 0;
  state.playing = true;
  state.last = performance.now();
  $("play").textContent = "Pause";
  requestAnimationFrame(tick);
}
function pause() {
  if (!state.playing) return;
  state.playing = false;
  $("play").textContent = "Play";
}
function stopRun() {
  if (state.playing) pause();
}
function tick(now) {
  if (!state.playing) return;
  const end = state.run.t[state.run.t.length - 1];
  // true speed: simulated seconds follow the wall clock, times the chosen factor
  state.t = Math.min(end, state.t + ((now - state.last) / 1000) * Number($("speed").value));
  state.last = now;
  drawRunFrame();
  if (state.t >= end) { pause(); return; }
  requestAnimationFrame(tick);
}

// -- graphs --------------------------------------------------------------------------------------------
function defaultPanels() {
  const names = state.run.columns.map((c) => c.name);
  const drive = (state.analysis && state.analysis.drive) || names[1];
  state.panels = [[names.includes(drive) ? drive : names[1]], [names.includes("E") ? "E" : names[2]]];
  state.panels.push(...elementPanels(state.run));  // the force elements' forces, energies, balance (forces.js)
  renderPanelControls();
}

function renderPanelControls() {
  const host = $("panels");
  host.textContent = "";
  state.panels.forEach((series, k) => {
    const div = document.createElement("div");
    div.className = "panel";
    const bar = document.createElement("div");
    bar.className = "series";
    series.forEach((name, j) => {
      const chip = document.createElement("span");
      chip.className = "chip";
      chip.style.background = COLOURS[j % COLOURS.length];
      chip.textContent = label(name);
      const x = document.createElement("button");
      x.textContent = "×";
      x.title = "remove";
      x.addEventListener("click", () => { series.splice(j, 1); renderPanelControls(); drawPanels(); });
      chip.appendChild(x);
      bar.appendChild(chip);
    });
    const pick = document.createElement("select");
    pick.setAttribute("aria-label", "add a signal to these axes");
    pick.innerHTML = `<option value="">add signal…</option>`;
    for (const c of (state.run ? state.run.columns : [])) {
      if (c.name === "t") continue;
      const o = document.createElement("option");
      o.value = c.name;
      o.textContent = c.label;
      pick.appendChild(o);
    }
    pick.addEventListener("change", () => {
      if (pick.value && !series.includes(pick.value)) series.push(pick.value);
      renderPanelControls(); drawPanels();
    });
    const drop = document.createElement("button");
    drop.textContent = "Remove axes";
    drop.addEventListener("click", () => { state.panels.splice(k, 1); renderPanelControls(); drawPanels(); });
    bar.append(pick, drop);
    const svg = document.createElementNS(SVG, "svg");
    svg.dataset.panel = String(k);
    div.append(bar, svg);
    host.appendChild(div);
    setupZoom(svg);
  });
}

function label(name) {
  const c = state.run && state.run.columns.find((x) => x.name === name);
  return c ? c.label : name;
}

// about n round values over [lo, hi] (1, 2 or 5 times a power of ten apart), and that step
function ticks(lo, hi, n) {
  const step0 = (hi - lo) / n;
  const mag = Math.pow(10, Math.floor(Math.log10(step0)));
  const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= step0) || step0;
  const out = [];
  const first = Math.ceil(lo / step);
  for (let k = first; k * step <= hi + step * 1e-9; k++) out.push(k === 0 ? 0 : k * step);
  out.step = step;
  return out;
}

// a tick's label, exact to its step: as many decimals as the step has (0.25 apart: 2), in powers of ten
// beyond a million or below a ten-thousandth
function tickText(v, step) {
  if (v === 0) return "0";
  const place = (x) => Math.floor(Math.log10(Math.abs(x)) + 1e-9);
  if (Math.abs(v) >= 1e6 || step < 1e-4) {
    return trimZeros(v.toExponential(Math.min(20, Math.max(0, place(v) - place(step) + 1))));
  }
  return trimZeros(v.toFixed(Math.min(20, Math.max(0, -place(step) + 1))));
}

// the y-axis says what is plotted: one signal's words and unit, or the units of several
function axisLabel(cols) {
  if (cols.length === 1) return cols[0].unit ? `${cols[0].name}, ${cols[0].unit}` : cols[0].name;
  const units = [...new Set(cols.map((c) => c.unit || (/\(([^()]*)\)$/.exec(c.label) || [])[1] || ""))];
  return units.filter(Boolean).join(", ");
}

// one plot: signals against time over [t0, t1], with optional horizontal limit lines
function plot(svg, t, cols, t0, t1, opts = {}) {
  const W = svg.clientWidth || 800, H = opts.height || 220, L = 84, R = 12, T = 10, B = 26;
  svg.setAttribute("viewBox", `0 0 ${W} ${H}`);
  let lo = Infinity, hi = -Infinity;
  for (const c of cols) {
    for (let i = 0; i < t.length; i++) {
      const v = c.values[i];
      if (t[i] >= t0 && t[i] <= t1 && isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    }
  }
  for (const h of opts.limits || []) { lo = Math.min(lo, h.value); hi = Math.max(hi, h.value); }
  if (!isFinite(lo)) { lo = -1; hi = 1; }
  if (hi - lo < 1e-12 * Math.max(1, Math.abs(hi))) { lo -= 1; hi += 1; }
  const pad = 0.05 * (hi - lo);
  lo -= pad; hi += pad;
  const X = (v) => L + ((v - t0) / (t1 - t0 || 1)) * (W - L - R);
  const Y = (v) => T + (1 - (v - lo) / (hi - lo)) * (H - T - B);
  const text = (x, y, anchor, fill, body) =>
    `<text x="${x}" y="${y}" text-anchor="${anchor}" font-size="11" fill="${fill}" font-family="sans-serif">${escapeXml(body)}</text>`;
  let html = `<rect x="0" y="0" width="${W}" height="${H}" fill="#fff"/>`;
  const ys = ticks(lo, hi, 5), xs = ticks(t0, t1, 8);
  for (const v of ys) {
    html += `<line x1="${L}" x2="${W - R}" y1="${Y(v)}" y2="${Y(v)}" stroke="#e1e4e8"/>`;
    html += `<g class="ytick" data-y="${Y(v)}">` + text(L - 6, Y(v) + 4, "end", "#57606a", tickText(v, ys.step)) + "</g>";
  }
  for (const v of xs) {
    html += `<line x1="${X(v)}" x2="${X(v)}" y1="${T}" y2="${H - B}" stroke="#eef0f2"/>` + text(X(v), H - B + 15, "middle", "#57606a", tickText(v, xs.step));
  }
  html += text(W - R, H - 3, "end", "#57606a", "time, s");
  const ylabel = axisLabel(cols);
  if (ylabel) {
    const mid = (T + H - B) / 2;
    html += `<text class="ylabel" x="12" y="${mid}" text-anchor="middle" font-size="11" fill="#57606a" font-family="sans-serif" transform="rotate(-90 12 ${mid})">${escapeXml(ylabel)}</text>`;
  }
  html += `<rect x="${L}" y="${T}" width="${W - L - R}" height="${H - T - B}" fill="none" stroke="#afb8c1"/>`;
  for (const h of opts.limits || []) {
    html += `<line x1="${L}" x2="${W - R}" y1="${Y(h.value)}" y2="${Y(h.value)}" stroke="#b42318" stroke-dasharray="6 3"/>`;
    html += text(W - R - 4, Y(h.value) - 3, "end", "#b42318", h.label);
  }
  cols.forEach((c, j) => {
    let d = "";
    const step = Math.max(1, Math.floor(t.length / (4 * W)));  // no more points than the pixels show
    for (let i = 0; i < t.length; i += step) {
      const v = c.values[i];
      if (!isFinite(v) || t[i] < t0 || t[i] > t1) continue;
      d += (d ? "L" : "M") + X(t[i]).toFixed(1) + "," + Y(v).toFixed(1);
    }
    const colour = COLOURS[j % COLOURS.length];
    html += `<path d="${d}" fill="none" stroke="${colour}" stroke-width="1.5"/>`;
    html += `<text x="${L + 8}" y="${T + 14 + 14 * j}" font-size="11.5" fill="${colour}" font-family="sans-serif">${escapeXml(c.label)}</text>`;
  });
  if (opts.cursor !== undefined) {
    html += `<line class="cursor" x1="${X(opts.cursor)}" x2="${X(opts.cursor)}" y1="${T}" y2="${H - B}" stroke="#1d232a" stroke-dasharray="3 3"/>`;
    html += `<rect class="zoombox" x="0" y="${T}" width="0" height="${H - T - B}"/>`;
  }
  svg.innerHTML = html;
  svg.dataset.x0 = t0; svg.dataset.x1 = t1; svg.dataset.l = L; svg.dataset.r = W - R;
}

function drawPanels() {
  if (!state.run) return;
  const t = state.run.t;
  const [t0, t1] = state.zoom || [t[0], t[t.length - 1]];
  document.querySelectorAll("#panels svg").forEach((svg) => {
    const series = state.panels[Number(svg.dataset.panel)] || [];
    const cols = series.map((n) => state.run.columns.find((c) => c.name === n)).filter(Boolean);
    plot(svg, t, cols, t0, t1, { cursor: state.t });
  });
}

function drawCursors() {
  document.querySelectorAll("#panels svg").forEach((svg) => {
    const c = svg.querySelector(".cursor");
    if (!c) return;
    const L = +svg.dataset.l, Rr = +svg.dataset.r, t0 = +svg.dataset.x0, t1 = +svg.dataset.x1;
    const x = L + ((state.t - t0) / (t1 - t0 || 1)) * (Rr - L);
    c.setAttribute("x1", x); c.setAttribute("x2", x);
  });
}

function escapeXml(s) { return String(s).replace(/[<>&"]/g, (c) => ({ "<": "&lt;", ">": "&gt;", "&": "&amp;", '"': "&quot;" })[c]); }

function setupZoom(svg) {
  let from = null;
  const xAt = (evt) => {
    const box = svg.getBoundingClientRect();
    const vb = svg.viewBox.baseVal;
    return ((evt.clientX - box.left) / box.width) * vb.width;
  };
  const timeAt = (x) => +svg.dataset.x0 + ((x - +svg.dataset.l) / (+svg.dataset.r - +svg.dataset.l)) * (+svg.dataset.x1 - +svg.dataset.x0);
  svg.addEventListener("pointerdown", (evt) => { from = xAt(evt); svg.setPointerCapture(evt.pointerId); });
  svg.addEventListener("pointermove", (evt) => {
    if (from === null) return;
    const z = svg.querySelector(".zoombox");
    const x = xAt(evt);
    if (z) { z.setAttribute("x", Math.min(from, x)); z.setAttribute("width", Math.abs(x - from)); }
  });
  svg.addEventListener("pointerup", (evt) => {
    if (from === null) return;
    const x = xAt(evt);
    const a = timeAt(Math.min(from, x)), b = timeAt(Math.max(from, x));
    from = null;
    // a click is no zoom, and redraws nothing: a redraw between the two clicks of a
    // double click would replace the element under the mouse, and the double click is lost
    if (b - a > 0.01 * (+svg.dataset.x1 - +svg.dataset.x0)) {
      state.zoom = [a, b];
      drawPanels();
    } else {
      const z = svg.querySelector(".zoombox");
      if (z) z.setAttribute("width", 0);
    }
  });
  svg.addEventListener("dblclick", () => { state.zoom = null; drawPanels(); });
}

async function exportPng() {
  const svgs = [...document.querySelectorAll("#panels svg")];
  if (!svgs.length) return;
  const W = Math.max(...svgs.map((s) => s.viewBox.baseVal.width)), H = 220;
  const canvas = document.createElement("canvas");
  canvas.width = W * 2; canvas.height = H * svgs.length * 2;
  const ctx = canvas.getContext("2d");
  ctx.scale(2, 2);
  for (let k = 0; k < svgs.length; k++) {
    const copy = svgs[k].cloneNode(true);
    copy.setAttribute("xmlns", SVG);
    copy.setAttribute("width", W); copy.setAttribute("height", H);
    copy.querySelectorAll(".zoombox").forEach((z) => z.remove());
    const url = "data:image/svg+xml;charset=utf-8," + encodeURIComponent(new XMLSerializer().serializeToString(copy));
    const img = new Image();
    await new Promise((ok, fail) => { img.onload = ok; img.onerror = fail; img.src = url; });
    ctx.drawImage(img, 0, H * k, W, H);
  }
  const a = document.createElement("a");
  a.download = (state.scene && state.scene.name || "run") + "-graphs.png";
  a.href = canvas.toDataURL("image/png");
  a.click();
}

// -- the servo drive and the sizing study -------------------------------------------------------------------
function servoSettings() {
  const out = {};
  // a length or an angle (data-unit, its SI unit) as typed in the page's units: sent in SI; one left as it was
  // filled, as the number it was filled from (a default of 20 rad/s^2 shown in deg/s^2 is not read back rounded)
  document.querySelectorAll("#servo-form [data-key]").forEach((e) => {
    out[e.dataset.key] = e.dataset.unit && e.value === e.dataset.shown ? e.dataset.si : fieldSI(e.value, e.dataset.unit);
  });
  return out;
}

async function setupServo() {
  const d = await api("servo_defaults", {});
  const sel = $("s-motor");
  for (const m of d.motors) {
    const o = document.createElement("option");
    o.textContent = m;
    sel.appendChild(o);
  }
  state.servoDefaults = d;
  if ($("force-box").hidden) fillServo(d);  // a motor's scene (a cylinder's fills its own)
  $("servo-run").addEventListener("click", runServo);
  $("sizing-run").addEventListener("click", runSizing);
  // a new gain re-runs the response at once, once there is one to compare
  document.querySelectorAll("#servo-form .gain").forEach((e) => e.addEventListener("change", () => {
    if (state.servo) runServo();
  }));
}

async function runServo() {
  const t0 = performance.now();
  $("servo-run").disabled = true;
  $("cancel").disabled = false;  // the session's run under way, a co-simulation too
  $("servo-error").textContent = "";
  $("servo-status").textContent = "co-simulating…";
  try {
    const timing = {};
    const out = await api("servo", { scene: state.scene, servo: servoSettings(), trace: state.trace }, timing);
    decodeColumns(out.columns, true);
    state.servo = out;
    drawServo();
    servoRunShown(out);  // its animation on the drawing (servoplay.js)
    record("servo", t0, timing);
    $("servo-status").textContent = sayMessage(out.summary) + `; on screen ${((performance.now() - t0) / 1000).toFixed(2)} s after the click`;
  } catch (e) {
    $("servo-error").textContent = `${e.field}: ${e.message}`;
    $("servo-status").textContent = "";
  } finally {
    $("servo-run").disabled = false;
    $("cancel").disabled = true;
  }
}

// the servo run's graphs, each with a cursor at the instant its animation shows
function drawServo() {
  const out = state.servo;
  if (!out) return;
  const col = (n) => out.columns.find((c) => c.name === n);
  const lim = out.limits;
  const host = $("servo-plots");
  host.textContent = "";
  const supply = lim.supply_pressure ? [{ value: lim.supply_pressure, label: "supply (rated)" }] : [];
  const panels = out.kind === "cylinder" ? [
    [[col("error")], []], [[col("setpoint"), col("response")], []],
    [[col("pressure_a"), col("pressure_b")], supply], [[col("force")], []],
  ] : [
    [[col("error")], []],
    [[col("current")], [{ value: lim.current_limit, label: "drive's current limit" },
      { value: -lim.current_limit, label: "" }].concat(lim.nominal_current
      ? [{ value: lim.nominal_current, label: "motor's nominal (continuous) current" }] : [])],
    [[col("voltage"), col("command")], [{ value: lim.supply_voltage, label: "supply" }, { value: -lim.supply_voltage, label: "" }]],
  ];
  for (const [cols, limits] of panels) {
    const svg = document.createElementNS(SVG, "svg");
    host.appendChild(svg);
    plot(svg, out.t, cols, out.t[0], out.t[out.t.length - 1], { height: 180, limits, cursor: state.servoT || 0 });
  }
}

async function runSizing() {
  $("sizing-run").disabled = true;
  $("servo-error").textContent = "";
  $("sizing-status").textContent = "sizing: every motor at every ratio…";
  try {
    const out = await api("sizing", { scene: state.scene, servo: servoSettings() });
    const table = $("sizing");
    const cylinder = out.kind === "cylinder";  // bore x supply pressure, as `grubler size --cylinder` ranks them
    table.innerHTML = (cylinder
      ? "<tr><th>#</th><th>cylinder</th><th>rod, mm</th><th>margin</th><th>binding limit</th><th>installed power, kW</th>"
      : "<tr><th>#</th><th>motor</th><th>ratio</th><th>margin</th><th>binding limit</th>" +
        "<th>peak current, A</th><th>peak voltage, V</th><th>motor speed, rpm</th>") + "<th class=\"why\">why not</th></tr>";
    const fits = out.rows.filter((r) => r.fits).length;
    const shown = out.rows.slice(0, fits + 5);  // the ones that fit, and the nearest misses
    shown.forEach((r, k) => {
      const tr = document.createElement("tr");
      if (!r.fits) tr.className = "no";
      const cells = cylinder ? [r.cylinder, r.rod, r.margin, r.binding, r.power]
        : [r.motor, r.ratio, r.margin, r.binding, r.peak_current, r.peak_voltage, r.rpm];
      for (const v of [r.fits ? k + 1 : "×", ...cells]) {
        const td = document.createElement("td");
        td.textContent = String(v);
        tr.appendChild(td);
      }
      const why = document.createElement("td");
      why.className = "why";
      why.textContent = r.why_not;
      tr.appendChild(why);
      table.appendChild(tr);
    });
    $("sizing-status").textContent = `${out.cycle}: ${fits} of ${out.rows.length} ` +
      (cylinder ? "bore × pressure combinations fit, least installed power first" : "motor × ratio combinations fit, best first") + (out.rows.length > shown.length ? `; the ${out.rows.length - shown.length} further misses are not shown` : "");
  } catch (e) {
    $("servo-error").textContent = `${e.field}: ${e.message}`;
    $("sizing-status").textContent = "";
  } finally {
    $("sizing-run").disabled = false;
  }
}

// -- files ---------------------------------------------------------------------------------------------
async function download() {
  const { toml } = await api("toml", { scene: state.scene });
  const a = document.createElement("a");
  a.download = (state.scene.name || "scene") + ".toml";
  a.href = URL.createObjectURL(new Blob([toml], { type: "text/plain" }));
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

// an export is a file, or a refusal in JSON
async function exportFile(kind) {
  if (kind === "pdf" && !state.run) {  // the session's run may be another scene's, which the page has left
    notice("report: simulate first: the report is of this scene's run", true);
    return;
  }
  notice(`exporting ${kind}…`);
  const r = await fetch("/api/export", {
    method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ kind, scene: state.scene, servo: servoSettings() }),
  });
  await saveAnswer(r, "export");
}

async function listFiles() {
  const { files } = await api("files", {});
  const sel = $("files");
  sel.innerHTML = `<option value="">open…</option>`;
  for (const f of files) {
    const o = document.createElement("option");
    o.textContent = f;
    sel.appendChild(o);
  }
}

// the page without a run: no graphs, nothing to play or export, the scene's drawing
function forgetRun() {
  pause();
  state.run = null;
  state.panels = [];
  state.zoom = null;
  state.t = 0;
  $("clock").textContent = "t = 0 s";
  $("panels").textContent = "";
  $("play").disabled = true;
  $("scrub").disabled = true;
  $("png").disabled = true;
  $("csv").classList.add("disabled");
  $("run-status").textContent = "";
  $("run-warnings").textContent = "";
  if (state.showingRun && state.analysis) {
    state.showingRun = false;
    $("edit-mode").disabled = true;
    fitView([state.analysis.frame, state.analysis.curve]);
    drawScene(state.analysis);
  }
}

async function loadData(data, label) {
  forgetRun();
  $("trace").value = "";
  state.trace = "";
  // a run's length and efforts are the new scene's own (its form's) until typed again
  for (const id of ["t_end", "torque", "actuator-force"]) $(id).value = "";
  $("field-t_end").textContent = "";
  showSource(data);
  await showDrives(data);  // before the drawing: the page is the new scene's once its sketch is on it
  await analyse({ scene: data }, { fit: true });
  if (label) notice(label);
}

// what drives the scene: a cylinder's force box for Simulate, and the servo that fits it (the cylinder's
// valve under position control of its length, or a DC motor on the drive joint), from its defaults
async function showDrives(data) {
  const acts = (Array.isArray(data && data.actuator) ? data.actuator : []).map((a) => String(a && a.name));
  const cylinder = acts.length > 0;
  $("force-box").hidden = !cylinder;
  $("force-name").textContent = cylinder ? acts[0] + " force" : "";
  $("drive-note").textContent = cylinder
    ? `this scene is driven by its cylinder ${acts[0]}: Simulate pushes it with the force given (none: 0 N, and ` +
      "the mechanism falls); Run servo puts it under position control"
    : "";
  $("sizing-run").textContent = cylinder ? "Size the cylinder" : "Size the motor";
  document.querySelectorAll("#servo .motor-only").forEach((e) => { e.hidden = cylinder; });
  document.querySelectorAll("#servo .cyl-only").forEach((e) => { e.hidden = !cylinder; });
  $("k-unit").textContent = cylinder ? "1/m" : "V/rad";
  $("s-actuator").textContent = cylinder ? acts[0] + ", a cylinder" : "cylinder";
  // the last scene's servo run is not this one's: its graphs go, and a gain typed now does not re-run it
  state.servo = null;
  $("servo-plots").textContent = "";
  $("servo-status").textContent = "";
  $("servo-error").textContent = "";
  try {
    const d = cylinder ? (await api("servo_defaults", { scene: data })).cylinder : state.servoDefaults;
    if (d) fillServo(d);
  } catch (e) { $("servo-error").textContent = `${e.field}: ${e.message}`; }
}

function fillServo(d) {
  document.querySelectorAll("#servo-form [data-key]").forEach((e) => {
    const v = d[e.dataset.key];
    if (v === undefined || v === null) return;
    e.value = String(v === "" ? v : e.dataset.unit ? fieldText(fieldShown(v, e.dataset.unit)) : v);
    if (e.dataset.unit) Object.assign(e.dataset, { si: String(v), shown: e.value });
  });
}

// the Preset and Type menus name the scene's preset (by its name) and its mechanism's type, or none
function showSource(data) {
  const name = data && data.name;
  $("preset").value = [...$("preset").options].some((o) => o.value === name) ? name : "";
  const type = data && data.mechanism && data.mechanism.type;
  const option = [...$("type").options].find((o) => o.value && o.textContent === type);
  $("type").value = option ? option.value : "";
}

async function start() {
  const cat = await api("catalog", {});
  state.coil = cat.coil;  // a torsion spring's drawing (forces.js)
  for (const p of cat.presets) {
    const o = document.createElement("option");
    o.value = p.name;
    o.textContent = `${p.name} (${p.kind})`;
    o.title = p.description;
    $("preset").appendChild(o);
  }
  for (const t of cat.types) {
    const o = document.createElement("option");
    o.value = t.example;
    o.textContent = t.type;
    o.title = t.doc;
    $("type").appendChild(o);
  }
  $("preset").addEventListener("change", async () => {
    if (!$("preset").value) return;
    const { scene } = await api("preset", { name: $("preset").value });
    await loadData(scene);
  });
  $("type").addEventListener("change", async () => {
    if (!$("type").value) return;
    const said = `a ${$("type").selectedOptions[0].textContent} from the ${$("type").value} preset's dimensions`;
    const { scene } = await api("preset", { name: $("type").value });
    await loadData(scene, said);
  });
  $("files").addEventListener("change", async () => {
    if (!$("files").value) return;
    try {
      const { scene, spatial } = await api("open", { file: $("files").value });
      if (spatial) { openSpatial(spatial); return; }
      await loadData(scene, "opened " + $("files").value);
    } catch (e) { notice(`${e.field}: ${e.message}`, true); }
  });
  $("upload").addEventListener("change", async () => {
    const file = $("upload").files[0];
    if (!file) return;
    try {
      const { scene, spatial } = await api("parse", { toml: await file.text() });
      if (spatial) { openSpatial(spatial); return; }  // dimension = 3: the 3D view shows it
      await loadData(scene, "opened " + file.name);
    } catch (e) { notice(`${file.name}: ${e.field}: ${e.message}`, true); }
    $("upload").value = "";
  });
  $("save").addEventListener("click", async () => {
    try {
      const file = $("save-name").value.trim() || (state.scene.name || "scene") + ".toml";
      const { saved } = await api("save", { scene: state.scene, file });
      notice("saved " + saved);
      listFiles();
    } catch (e) { notice(`${e.field}: ${e.message}`, true); }
  });
  $("download").addEventListener("click", download);
  $("export").addEventListener("change", async () => {
    const kind = $("export").value;
    $("export").value = "";
    if (kind) await exportFile(kind);
  });
  $("share").addEventListener("click", async () => {
    remember();
    try { await navigator.clipboard.writeText(location.href); notice("link copied"); }
    catch (e) { notice("copy the address bar: it holds the scene"); }
  });
  $("simulate").addEventListener("click", simulate);
  $("cancel").addEventListener("click", () => api("cancel", {}));
  $("play").addEventListener("click", () => (state.playing ? pause() : play()));
  $("scrub").addEventListener("input", () => { pause(); state.t = Number($("scrub").value); drawRunFrame(); });
  $("edit-mode").addEventListener("click", () => {
    pause();
    state.showingRun = false;
    $("edit-mode").disabled = true;
    if (state.analysis) { fitView([state.analysis.frame, state.analysis.curve]); drawScene(state.analysis); }
  });
  $("fit").addEventListener("click", () => {
    if (state.run && state.showingRun) { fitView([...state.run.frames, state.run.path]); drawRunFrame(); }
    else if (state.analysis) { fitView([state.analysis.frame, state.analysis.curve]); drawScene(state.analysis); }
  });
  $("trace").addEventListener("change", async () => {
    state.trace = $("trace").value.trim();
    await analyse({ scene: state.scene });
  });
  $("add-axes").addEventListener("click", () => { state.panels.push([]); renderPanelControls(); drawPanels(); });
  $("png").addEventListener("click", exportPng);
  $("csv").addEventListener("click", async (evt) => {  // fetched: a refusal is told here, not opened as a page
    evt.preventDefault();
    if ($("csv").classList.contains("disabled")) return;
    await saveAnswer(await fetch($("csv").href), "csv");
  });
  window.addEventListener("resize", drawPanels);
  document.addEventListener("keydown", (evt) => {
    const typing = /^(INPUT|SELECT|TEXTAREA|BUTTON)$/.test(document.activeElement.tagName);
    if (evt.key === " " && !typing && state.run) {
      evt.preventDefault();
      if (state.playing) pause(); else play();
    }
  });
  setupDrag();
  listFiles();
  setupServo();
  setupAnalysis();
  let data = cat.start;
  const m = location.hash.match(/^#scene=([A-Za-z0-9_-]+)$/);
  if (m) {
    try { data = JSON.parse(unb64(m[1])); } catch (e) { notice("the link's scene cannot be read", true); }
  }
  if (!data) data = (await api("preset", { name: "fourbar-crank-rocker" })).scene;
  await loadData(data);
}

start();
