// grubler app: the scene's force elements (springs, dampers, gas springs, joint springs and friction, loads).
// Their geometry is the server's (grubler.views.animation, as the GIFs draw them): a spring's zigzag points, a
// torsion spring's joint and its link's angle (the catalog's coil drawn there), a load's point and direction.
// This file draws them, offers adding and removing them, and starts the graphs of a run with their columns.
// app.js calls it from small hooks: frameMarkup, points, renderFields, defaultPanels, start.
"use strict";

const ELEMENT_KINDS = { spring: "spring", joint_spring: "joint spring", point_load: "load" };
const ELEMENT_GROUP = /^(spring|joint_spring|point_load)\[\d+\]$/;

// the elements of a frame, drawn under its joints: s is the view's span (m)
function forcesMarkup(f, s) {
  let out = "";
  for (const pts of f.springs || []) {
    out += `<polyline class="spring" points="${pts.map((p) => p[0] + "," + p[1]).join(" ")}"/>`;
  }
  const coil = (state.coil || []).map((p) => p[0] + "," + p[1]).join(" ");
  for (const c of f.coils || []) {  // the catalog's coil of radius 1, turned with its link, a joint's size
    const deg = (c[2] * 180) / Math.PI, R = 0.045 * s;
    const at = `translate(${c[0]},${c[1]}) rotate(${deg}) scale(${R})`;
    out += `<polyline class="coil" points="${coil}" transform="${at}"/>`;
  }
  for (const l of f.loads || []) {  // an arrow of a fixed size ending at its point, as the GIFs draw it
    const L = 0.1 * s, head = 0.025 * s, w = 0.45 * head;
    const [x, y, ux, uy] = l, bx = x - ux * head, by = y - uy * head;
    // its magnitude (the frame's fifth number, N) written at its tail
    const tail = [x - ux * L * 1.08 + 0.01 * s, y - uy * L * 1.08];
    const label = l.length > 4 ? labelMarkup(tail, say(l[4], "N"), "load") : "";
    out += `<g class="load"><line x1="${x - ux * L}" y1="${y - uy * L}" x2="${bx}" y2="${by}"/>` +
      `<polygon points="${x},${y} ${bx - uy * w},${by + ux * w} ${bx + uy * w},${by - ux * w}"/>${label}</g>`;
  }
  return out;
}

// the points a view fits: a spring's ends and a load's point
function forcePoints(f) {
  const out = [];
  for (const pts of f.springs || []) out.push(pts[0], pts[pts.length - 1]);
  for (const l of f.loads || []) out.push([l[0], l[1]]);
  return out;
}

// the form: each element's group gets its Remove button
function decorateElements(form) {
  form.querySelectorAll("h3").forEach((h) => {
    const key = h.textContent;
    if (!ELEMENT_GROUP.test(key)) return;
    const b = document.createElement("button");
    b.type = "button";
    b.className = "remove-element";
    b.dataset.element = key;
    b.textContent = "remove";
    b.title = `remove ${key} from the scene`;
    b.addEventListener("click", () => elementAction("remove_element", { element: key }));
    h.append(" ", b);
  });
}

async function elementAction(action, extra) {
  try {
    await analyse({ action, scene: state.scene, ...extra });
  } catch (e) { notice(`${e.field}: ${e.message}`, true); }
}

function setupElements() {
  document.querySelectorAll("#elements-bar button[data-kind]").forEach((b) => b.addEventListener("click", () =>
    elementAction("add_element", { kind: b.dataset.kind })));
}

// a run of a scene with elements: its graphs start with their forces (a joint spring's effort), their stored
// energies, and the energy balance that holds them all
function elementPanels(run) {
  const names = new Set(run.columns.map((c) => c.name));
  const has = (n) => names.has(n);
  const els = run.elements || [];
  if (!els.length) return [];
  const of = (kind, column) => els.filter((e) => e.kind === kind).map((e) => e.name + column).filter(has);
  const energy = els.map((e) => e.name + "_energy").filter(has);
  // the springs' forces (N) and the joint springs' efforts (N m or N) on axes of their own
  return [of("spring", "_force"), of("joint_spring", "_effort"), energy, ["energy_balance"].filter(has)]
    .filter((p) => p.length);
}

// the analysis layer's joint forces and the force elements' (a spring's at both its ends, a load's at its
// point), scaled together: the largest of them all is a fifth of the view
function forceArrows(a, s) {
  const all = a.forces.concat(a.element_forces || []);
  const k = (0.2 * s) / largest(all, "f");
  return all.map((f, i) => arrowMarkup(f.at, f.f, k, i < a.forces.length ? "force" : "force element",
    `${i < a.forces.length ? "" : f.label + " "}${say(Math.hypot(...f.f), "N")}`)).join("");
}

setupElements();
