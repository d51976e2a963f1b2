// The 3D view of a spatial preset (view3d.html): plain JS, no build step, no library.
// The server (action "spatial", grubler.app.spatial_view) sends the sketch (which points make which tubes,
// axes, guides and joints), every point's world position per frame, the floor grid and the fitted camera;
// this page projects them with the pinhole of grubler.views.perspective and paints them far to near,
// turning (drag), moving (shift-drag) and zooming (wheel) the camera.
"use strict";

const $ = (id) => document.getElementById(id);
const INKS = ["#1f4e79", "#c05f00", "#2e7d32", "#7b1fa2", "#00838f", "#ad1457", "#6d4c41", "#455a64"];
const KIND_INK = { ground: "#6b6b6b", axis: "#202020", guide: "#7f7f7f", revolute: "#d62728", ball: "#d62728",
                   slide: "#2ca02c", fixed: "#404040", pin: "#404040" };
const view = { data: null, frame: 0, playing: false, cam: null, last: 0 };

async function api(name, body) {
  const r = await fetch("/api/" + name, { method: "POST", headers: { "Content-Type": "application/json" },
                                          body: JSON.stringify(body || {}) });
  const out = await r.json();
  if (out.error) { const e = new Error(out.error.reason); e.field = out.error.field; throw e; }
  return out;
}

function notice(text, bad) { const n = $("notice3d"); n.textContent = text; n.className = bad ? "bad" : ""; }

// -- vectors and the camera (as grubler.views.perspective) ------------------------------------------------
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a) => mul(a, 1 / Math.hypot(...a));

function horizontal(up) {  // world x made square to up (world y where up is along x)
  for (const e of [[1, 0, 0], [0, 1, 0]]) {
    const h = sub(e, mul(up, dot(e, up)));
    if (Math.hypot(...h) > 1e-6) return unit(h);
  }
}

function basis(cam) {  // the picture's right and up, the view direction, and the camera's place
  const up = cam.up, h1 = horizontal(up), h2 = cross(up, h1);
  const toward = add(mul(add(mul(h1, Math.cos(cam.azimuth)), mul(h2, Math.sin(cam.azimuth))), Math.cos(cam.elevation)),
                     mul(up, Math.sin(cam.elevation)));
  const position = add(cam.target, mul(toward, cam.distance));
  const f = mul(toward, -1);
  let r = cross(f, up);
  r = Math.hypot(...r) < 1e-9 ? unit(cross(f, h1)) : unit(r);
  return { r, u: cross(r, f), f, position };
}

function projector(cam, canvas) {
  // the fitted lens and picture centre (grubler.views.perspective.fit_camera) are kept as the view turns
  const b = basis(cam), focal = cam.zoom * canvas.height / 2 / Math.tan(cam.fov / 2);
  const cu = cam.centre[0] * canvas.width, cv = cam.centre[1] * canvas.height;
  return (p) => {
    const q = sub(p, b.position), depth = dot(q, b.f);
    return [cu + focal * dot(q, b.r) / depth, cv - focal * dot(q, b.u) / depth, depth];
  };
}

// -- painting -------------------------------------------------------------------------------------------------------
function shade(ink, s) {  // s in [0, 1]: the nearest full, the farthest mixed half with white
  const c = [1, 3, 5].map((i) => parseInt(ink.slice(i, i + 2), 16));
  return `rgb(${c.map((v) => Math.round(v + (255 - v) * 0.5 * s)).join(",")})`;
}

function draw() {
  const d = view.data, canvas = $("view3d"), g = canvas.getContext("2d");
  g.fillStyle = "#fff";  // painted, not transparent: a saved picture has the background it is seen on
  g.fillRect(0, 0, canvas.width, canvas.height);
  if (!d) return;
  const project = projector(view.cam, canvas), reference = view.cam.distance;
  g.lineCap = "round";
  g.strokeStyle = "#dcdcdc"; g.lineWidth = 1;
  for (const line of d.grid) {
    const a = project(line.slice(0, 3)), b = project(line.slice(3));
    if (a[2] > 0 && b[2] > 0) { g.beginPath(); g.moveTo(a[0], a[1]); g.lineTo(b[0], b[1]); g.stroke(); }
  }
  const pts = d.frames[view.frame].map(project);
  const seen = pts.map((p) => p[2]).filter((z) => z > 0);
  const near = Math.min(...seen), far = Math.max(...seen), s = (z) => (far > near ? (z - near) / (far - near) : 0);
  const parts = [];
  for (const [i, j, body, kind] of d.segments) {
    if (pts[i][2] > 0 && pts[j][2] > 0) parts.push({ seg: true, i, j, body, kind, key: Math.max(pts[i][2], pts[j][2]) });
  }
  for (const [i, body, kind] of d.markers) {
    if (pts[i][2] > 0) parts.push({ seg: false, i, body, kind, key: pts[i][2] * (1 - 1e-9) });
  }
  parts.sort((a, b) => b.key - a.key);  // far to near: a tube by its farther end, its joints drawn over it
  for (const p of parts) {
    if (p.seg) {
      const a = pts[p.i], b = pts[p.j], depth = p.key, grow = reference / depth;
      const ink = p.kind === "link" ? INKS[p.body % INKS.length] : KIND_INK[p.kind];
      g.strokeStyle = shade(ink, s(depth));
      g.lineWidth = p.kind === "link" ? 9 * grow : p.kind === "ground" ? 6 * grow : p.kind === "guide" ? 3 : 2;
      g.beginPath(); g.moveTo(a[0], a[1]); g.lineTo(b[0], b[1]); g.stroke();
    } else {
      const [x, y, depth] = pts[p.i], r = 7.5 * (reference / depth) * (p.kind === "ball" ? 1.3 : 1);
      const ink = shade(KIND_INK[p.kind], s(depth));
      g.lineWidth = Math.max(2, r / 3);
      if (["slide", "pin", "fixed"].includes(p.kind)) {
        const h = p.kind === "slide" ? 1.6 * r : r;
        g.fillStyle = ink; g.strokeStyle = "#000"; g.lineWidth = 1;
        g.fillRect(x - h, y - h, 2 * h, 2 * h); g.strokeRect(x - h, y - h, 2 * h, 2 * h);
      } else {
        g.beginPath(); g.arc(x, y, r, 0, 2 * Math.PI);
        g.fillStyle = p.kind === "ball" ? ink : "#fff"; g.fill(); g.strokeStyle = ink; g.stroke();
      }
    }
  }
  g.fillStyle = "#000"; g.font = "16px system-ui, sans-serif";
  g.fillText(`${d.name}: ${d.description}`, 12, 24);
  $("clock3d").textContent = `t = ${d.t[view.frame].toFixed(3)} s`;
  $("time3d").value = view.frame;
}

// -- playing ------------------------------------------------------------------------------------------------------
function tick(now) {
  const d = view.data;
  if (!d || !view.playing) return;
  const elapsed = (now - view.last) / 1000;
  const tNow = d.t[view.frame] + elapsed;
  if (elapsed > 0) {
    let k = view.frame;
    while (k + 1 < d.t.length && d.t[k + 1] <= tNow) k++;
    if (k !== view.frame) { view.frame = k; view.last = now; draw(); }
    if (k + 1 >= d.t.length) { view.frame = 0; view.last = now; }
  }
  requestAnimationFrame(tick);
}

function setPlaying(on) {
  view.playing = on;
  $("play3d").textContent = on ? "Pause" : "Play";
  if (on) { view.last = performance.now(); requestAnimationFrame(tick); }
}

// what is shown: a preset chosen ({name}) or a spatial scene's TOML opened ({toml}: a file, the planar page's
// Open TOML… of a dimension = 3 file, or `grubler app my_spatial.toml`)
async function run() {
  const name = $("preset3d").value;
  if (name) view.source = { name };
  if (!view.source) { notice("choose a spatial preset", true); return; }
  notice("running…");
  try {
    const d = await api("spatial", { ...view.source, t_end: Number($("t-end3d").value) });
    view.data = d; view.frame = 0; view.cam = { ...d.camera };
    for (const id of ["play3d", "time3d", "reset3d"]) $(id).disabled = false;
    $("time3d").max = d.t.length - 1;
    notice(`${d.t.length} frames, ${d.t[d.t.length - 1]} s`);
    draw(); setPlaying(true);
  } catch (e) {
    notice(`${e.field ? e.field + ": " : ""}${e.message}`, true);
  }
}

function openSource(source) {  // a TOML's scene, or a preset by name
  if (source.toml) { view.source = { toml: source.toml }; $("preset3d").value = ""; } else $("preset3d").value = source.name;
  return run();
}

// -- turning, moving and zooming the camera ----------------------------------------------------------------------
function pointer() {
  const canvas = $("view3d");
  let drag = null;
  canvas.addEventListener("pointerdown", (e) => {
    if (!view.cam) return;
    drag = { x: e.clientX, y: e.clientY, shift: e.shiftKey };
    canvas.setPointerCapture(e.pointerId); canvas.style.cursor = "grabbing";
  });
  canvas.addEventListener("pointermove", (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.shift) {  // move the target in the picture's plane, as far as the pointer went at its depth
      const b = basis(view.cam);
      const per = view.cam.distance * 2 * Math.tan(view.cam.fov / 2) / view.cam.zoom / canvas.clientHeight;
      view.cam.target = add(view.cam.target, add(mul(b.r, -dx * per), mul(b.u, dy * per)));
    } else {
      view.cam.azimuth -= dx * 0.01;
      view.cam.elevation = Math.max(-1.55, Math.min(1.55, view.cam.elevation + dy * 0.01));
    }
    draw();
  });
  const end = () => { drag = null; canvas.style.cursor = "grab"; };
  canvas.addEventListener("pointerup", end);
  canvas.addEventListener("pointercancel", end);
  canvas.addEventListener("wheel", (e) => {
    if (!view.cam) return;
    e.preventDefault();
    view.cam.distance *= Math.exp(0.0015 * e.deltaY);
    draw();
  }, { passive: false });
}

async function start() {
  pointer();
  $("run3d").addEventListener("click", run);
  $("preset3d").addEventListener("change", run);
  $("upload3d").addEventListener("change", async () => {
    const file = $("upload3d").files[0];
    if (file) await openSource({ toml: await file.text() });
    $("upload3d").value = "";
  });
  $("play3d").addEventListener("click", () => setPlaying(!view.playing));
  $("reset3d").addEventListener("click", () => { view.cam = { ...view.data.camera }; draw(); });
  $("time3d").addEventListener("input", () => { setPlaying(false); view.frame = Number($("time3d").value); draw(); });
  try {
    const cat = await api("spatial_catalog", {});
    for (const p of cat.presets) {
      const o = document.createElement("option");
      o.value = p.name; o.textContent = `${p.name}: ${p.description}`;
      $("preset3d").appendChild(o);
    }
    // what the app was started with, or what the planar page was given to open (its Open TOML…)
    let opened = null;
    try { opened = JSON.parse(sessionStorage.getItem("grubler.spatial") || "null"); } catch (e) { /* none */ }
    sessionStorage.removeItem("grubler.spatial");
    if (opened || cat.start) await openSource(opened || cat.start);
  } catch (e) { notice(e.message, true); }
}

start();
