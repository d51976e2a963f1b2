// grubler app: the units the page shows its numbers in, chosen once and used everywhere on the page (the
// scene's form, the servo's form, the graphs and their axes, the facts, the drawing's labels and arrows).
// The server speaks SI, as the scene's TOML and the CSV do; this is the page's one table of conversions.
// A length and its rates are shown in m or mm, an angle and its rates in deg or rad; every other unit
// (N, N m, kg m^2, ...) is shown as the server writes it.
"use strict";

// per kind: the SI unit, and each unit it may be shown in with how many of that unit make the SI one
const UNIT_TABLE = {
  length: { si: "m", shown: { m: 1, mm: 1000 } },
  angle: { si: "rad", shown: { deg: 180 / Math.PI, rad: 1 } },
};
const UNIT_RATES = ["", "/s", "/s^2"];  // a kind's unit, per second and per second squared convert alike
const UNIT_DEFAULTS = { length: "m", angle: "deg" };
const units = { ...UNIT_DEFAULTS };
try {  // the choice outlives the page
  const kept = JSON.parse(localStorage.getItem("grubler.units") || "{}");
  for (const kind of Object.keys(UNIT_TABLE)) if (kept[kind] in UNIT_TABLE[kind].shown) units[kind] = kept[kind];
} catch (e) { /* no storage: the defaults */ }

// an SI unit as the page shows it now: {unit, factor} (a value shown = factor x the SI value).  A scene
// field's angle unit reads "rad, or '30 deg'": its first word is its SI unit
function shownUnit(si) {
  const base = String(si || "").split(",")[0].trim();
  for (const [kind, t] of Object.entries(UNIT_TABLE)) {
    for (const rate of UNIT_RATES) {
      if (base === t.si + rate) return { unit: units[kind] + rate, factor: t.shown[units[kind]], kind };
    }
    // per one of them (a mechanical advantage's 1/m: newtons per newton metre): the factor inverted
    if (base === "1/" + t.si) return { unit: "1/" + units[kind], factor: 1 / t.shown[units[kind]], kind };
  }
  return { unit: si || "", factor: 1, kind: null };
}

// a form's number is shown to six significant digits (0.785398 rad, not 0.785398163397); what the scene holds
// is what is sent back unless that number is edited (a list's each part): see fieldText and fieldSent
const SHOWN_DIGITS = 6;
function shortText(v) {
  return typeof v === "number" && Number.isFinite(v) ? String(Number(v.toPrecision(SHOWN_DIGITS))) : String(v);
}
// a field's value (as fieldShown gives it) as its input shows it
function fieldText(shown) { return Array.isArray(shown) ? "[" + shown.map(shortText).join(", ") + "]" : shortText(shown); }
// the text an edited field sends, in SI (fieldSI): ``value`` is what the scene holds, ``shown`` the text the field
// was given; a part typed as it was shown is sent as the scene holds it, not as its six digits
function fieldSent(typed, shown, value, si) {
  const t = String(typed).trim();
  if (t === shown) return Array.isArray(value) ? "[" + value.join(", ") + "]" : String(value);
  const parts = (x) => x.slice(1, -1).split(",").map((p) => p.trim());
  if (!Array.isArray(value) || !(t.startsWith("[") && t.endsWith("]"))) return fieldSI(t, si);
  const typedParts = parts(t), shownParts = parts(shown);
  if (typedParts.length !== value.length || shownParts.length !== value.length) return fieldSI(t, si);
  return "[" + typedParts.map((p, i) => (p === shownParts[i] ? String(value[i]) : fieldSI(p, si))).join(", ") + "]";
}

// twelve significant digits: 0.3 m reads 300 mm, not 299.99999999999994
function tidy(v) { return Number(Number(v).toPrecision(12)); }
function toShown(v, si) { return tidy(v * shownUnit(si).factor); }
function toSI(v, si) { return tidy(v / shownUnit(si).factor); }

// a value and its unit in words, as the page's labels write them ("300 mm", "12.5 deg/s²")
function say(v, si) {
  const u = prettyUnit(shownUnit(si).unit);
  return fmt(v * shownUnit(si).factor) + (u === "°" ? u : u ? " " + u : "");
}
function prettyUnit(u) { return String(u).replace(/\^2/g, "²").replace(/^deg$/, "°"); }

// an angle of the scene's TOML: a number (rad) or a string with its unit ('30 deg', '1.2 rad', 'pi/3'); NaN
// for what the page cannot read (the server says why when it is sent)
function angleOf(v) {
  if (typeof v === "number") return v;
  const s = String(v).trim();
  let m = /^([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(deg|degree|degrees|°|rad)?$/.exec(s);
  if (m) return Number(m[1]) * (m[2] && m[2] !== "rad" ? Math.PI / 180 : 1);
  m = /^([-+]?)(?:(\d+\.?\d*)\s*\*\s*)?pi(?:\s*\/\s*(\d+\.?\d*))?$/.exec(s);
  if (m) return (m[1] === "-" ? -1 : 1) * Math.PI * Number(m[2] || 1) / Number(m[3] || 1);
  return NaN;
}

// a number of a form (scene or servo) as the field shows it, and the field's text as the scene takes it
function fieldShown(value, si) {
  const s = shownUnit(si);
  if (!s.kind || s.factor === 1 && s.kind !== "angle") return value;
  const one = (v) => {
    const x = s.kind === "angle" && !String(si).includes("/") ? angleOf(v)
      : typeof v === "number" ? v : /^\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\s*$/.test(v) ? Number(v) : NaN;
    return Number.isFinite(x) ? tidy(x * s.factor) : v;
  };
  return Array.isArray(value) ? value.map(one) : one(value);
}
function fieldSI(text, si) {
  const s = shownUnit(si);
  if (!s.kind) return text;
  const one = (t) => {
    const x = String(t).trim();
    if (!/^[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$/.test(x)) return x;  // words or a unit of its own: as typed
    // an angle of the scene in degrees is written as the TOML writes one, '30 deg'
    if (s.kind === "angle" && units.angle === "deg" && String(si).includes("30 deg")) return `${x} deg`;
    return String(tidy(Number(x) / s.factor));
  };
  const t = String(text).trim();
  if (t.startsWith("[") && t.endsWith("]")) {
    return "[" + t.slice(1, -1).split(",").filter((p) => p.trim()).map(one).join(", ") + "]";
  }
  return one(t);
}

// a run's column (SI values and unit, its words) as the graphs show it; its SI values kept for a new choice
function columnShown(c, paren) {
  if (c.si === undefined) { c.si = c.values; c.siUnit = c.unit; }
  const s = shownUnit(c.siUnit);
  c.unit = s.unit;
  c.values = s.factor === 1 ? c.si : Float32Array.from(c.si, (v) => v * s.factor);
  if (c.words !== undefined) c.label = c.words + (c.unit ? (paren ? ` (${c.unit})` : `, ${c.unit}`) : "");
  return c;
}

// the servo form's numbers carry their SI unit (data-unit): shown and read through the table, their unit's
// words (.unit-of[data-unit]) follow the choice
function showUnitWords(root) {
  (root || document).querySelectorAll("[data-unit-of]").forEach((e) => { e.textContent = shownUnit(e.dataset.unitOf).unit; });
}

// the menus #unit-length and #unit-angle; ``onChange(choose)`` is called with the switch to make, so that the
// page can read what it shows in the old units first
function setupUnits(onChange) {
  for (const kind of Object.keys(UNIT_TABLE)) {
    const sel = document.getElementById("unit-" + kind);
    if (!sel) continue;
    sel.value = units[kind];
    sel.addEventListener("change", () => onChange(() => {
      units[kind] = sel.value;
      try { localStorage.setItem("grubler.units", JSON.stringify(units)); } catch (e) { /* kept for this page only */ }
      showUnitWords();
    }));
  }
  showUnitWords();
}

// a message of the server's (a refusal, a loop that does not close) with its lengths in the page's unit: the
// server writes them in m ("the longest link (2.1 m)"); its angles it writes in deg and rad both
function sayMessage(text) {
  if (!text) return text;
  let out = String(text);
  const num = "([-+]?(?:\\d+\\.?\\d*|\\.\\d+)(?:e[-+]?\\d+)?)";
  if (units.length !== "m") {
    out = out.replace(new RegExp(`(^|[^\\w.])${num} m(/s\\^2|/s)?(?![\\w^²/])`, "g"),
      (all, before, v, rate) => before + say(Number(v), "m" + (rate || "")));
  }
  if (units.angle === "rad") {  // "30 deg (0.523599 rad)" says it already; "32.49 deg" alone is converted
    out = out.replace(new RegExp(`${num} deg \\(${num} rad\\)`, "g"), (all, d, r) => `${r} rad`)
      .replace(new RegExp(`(^|[^\\w.])${num} deg(/s\\^2|/s)?(?![\\w^²/])`, "g"),
        (all, before, v, rate) => before + say((Number(v) * Math.PI) / 180, "rad" + (rate || "")));
  }
  return out;
}
