// grubler app: what a drawing tool gives a designer beside the mechanism: a grid that dragged joints snap
// to, each link's name and length written along it, and the units chosen once for the whole page (the
// table is units.js; this redraws every number the page shows when the choice changes).
"use strict";

const drawTools = { grid: false, dims: false };
try { Object.assign(drawTools, JSON.parse(localStorage.getItem("grubler.drawTools") || "{}")); } catch (e) { /* defaults */ }

// the grid's pitch, m: a round step (1, 2 or 5 times a power of ten, of a metre and so of a millimetre too)
// of about a twentieth of the view
function gridPitch() {
  if (!state.box) return 0;
  const step0 = state.box.span / 20, mag = Math.pow(10, Math.floor(Math.log10(step0)));
  return [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= step0 * (1 - 1e-9));
}

function gridMarkup() {
  const label = document.getElementById("grid-pitch");
  const p = drawTools.grid ? gridPitch() : 0;
  if (label) label.textContent = p ? "pitch " + say(p, "m") : "";
  if (!p) return "";
  const b = state.box;  // the view, and as much again round it: the page's aspect may show more than the box
  const x0 = Math.floor((b.x - b.w) / p), x1 = Math.ceil((b.x + 2 * b.w) / p);
  const y0 = Math.floor((b.y - b.h) / p), y1 = Math.ceil((b.y + 2 * b.h) / p);
  let html = `<g class="grid">`;
  for (let i = x0; i <= x1; i++) {
    html += `<line${i % 5 ? "" : ` class="major"`} x1="${i * p}" x2="${i * p}" y1="${y0 * p}" y2="${y1 * p}"/>`;
  }
  for (let j = y0; j <= y1; j++) {
    html += `<line${j % 5 ? "" : ` class="major"`} x1="${x0 * p}" x2="${x1 * p}" y1="${j * p}" y2="${j * p}"/>`;
  }
  return html + "</g>";
}

// a dragged point onto the nearest grid point, when the grid is on
function snapToGrid(xy) {
  const p = drawTools.grid ? gridPitch() : 0;
  if (!p) return xy;
  return xy.map((v) => tidy(Math.round(v / p) * p));
}

// each link's name and length along it, upright, a little off the bar on its left
function dimsMarkup(dims) {
  if (!drawTools.dims || !dims || !state.box) return "";
  const s = state.box.span, size = 0.022 * s;
  let html = "";
  for (const d of dims) {
    const dx = d.to[0] - d.from[0], dy = d.to[1] - d.from[1], L = Math.hypot(dx, dy);
    if (!(L > 0)) continue;
    let deg = (Math.atan2(dy, dx) * 180) / Math.PI;
    if (deg > 90.001 || deg < -89.999) deg += 180;  // upright: read left to right
    const a = (deg * Math.PI) / 180, nx = -Math.sin(a), ny = Math.cos(a), off = 0.018 * s;
    const mx = (d.from[0] + d.to[0]) / 2 + nx * off, my = (d.from[1] + d.to[1]) / 2 + ny * off;
    // the halo that keeps it readable over a bar: a stroke in the drawing's units, a sixth of the text's height
    html += `<text class="dim" data-link="${escapeXml(d.name)}" font-size="${size}" stroke-width="${size / 6}" text-anchor="middle" ` +
      `transform="translate(${mx},${my}) rotate(${deg}) scale(1,-1)">${escapeXml(d.name)} ` +
      `<tspan class="len">${escapeXml(say(d.length, "m"))}</tspan></text>`;
  }
  return html;
}

// the drawing again as it is (the scene's, a run's instant or the servo's), after a tool or a unit changed
function redrawDrawing() {
  if (typeof servoOnDrawing === "function" && servoOnDrawing()) drawServoFrame();
  else if (state.showingRun && state.run) drawRunFrame();
  else if (state.analysis && state.analysis.frame && state.box) drawScene(state.analysis);
}

// a new choice of units: every number the page shows, again (the servo form's typed values read in the old)
function unitsChanged(choose) {
  const servo = servoSettings();
  choose();
  fillServo(servo);
  if (state.analysis) {
    showFacts(state.analysis);
    renderFields(state.analysis.fields);
    const err = state.analysis.error;  // a field's refusal stays next to it
    const at = err && document.querySelector(`[data-err="${CSS.escape(err.field)}"]`);
    if (at) at.textContent = sayMessage(err.reason);
    const p = state.analysis.problem;
    document.getElementById("problem").textContent = p ? `${p.field}: ${sayMessage(p.reason)}` : "";
  }
  if (state.run) {
    state.run.columns.forEach((c) => columnShown(c));
    renderPanelControls();
    drawPanels();
  }
  if (state.servo) {
    state.servo.columns.forEach((c) => columnShown(c, true));
    drawServo();
  }
  redrawDrawing();
  showAnalysisFacts(state.showingRun && state.instant ? state.instant.analysis : state.analysis && state.analysis.analysis);
}

(function setupDrawTools() {
  for (const [id, key] of [["show-grid", "grid"], ["show-dims", "dims"]]) {
    const box = document.getElementById(id);
    box.checked = !!drawTools[key];
    box.addEventListener("change", () => {
      drawTools[key] = box.checked;
      try { localStorage.setItem("grubler.drawTools", JSON.stringify(drawTools)); } catch (e) { /* this page only */ }
      redrawDrawing();
    });
  }
  setupUnits(unitsChanged);
  setupHistory();
})();
