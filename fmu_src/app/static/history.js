// grubler app: undo and redo.  The page's scene after each edit (a drag, a form field, a preset or a type
// picked, a file opened) is kept, as its JSON, in a bounded history; Ctrl+Z steps back, Ctrl+Shift+Z (or
// Ctrl+Y) forward.  A step back is an edit like any other: the scene goes to the server and is drawn from
// its answer, so it gets the same checks, messages and drawing.
"use strict";

const HISTORY_LIMIT = 100;  // scenes kept to step back to: a scene is a few kB of JSON
const sceneHistory = { past: [], future: [], now: null, restoring: false, busy: Promise.resolve(), pending: 0 };

// app.js calls this whenever a scene is on the page for good (an edit's answer, a drag's end)
function noteScene(scene) {
  if (!scene) return;
  const s = JSON.stringify(scene);
  if (sceneHistory.restoring || sceneHistory.now === null) {  // a step's own answer, or the first scene
    sceneHistory.now = s;
  } else if (s !== sceneHistory.now) {
    sceneHistory.past.push(sceneHistory.now);
    if (sceneHistory.past.length > HISTORY_LIMIT) sceneHistory.past.shift();
    sceneHistory.future = [];
    sceneHistory.now = s;
  }
  showHistoryButtons();
}

function showHistoryButtons() {
  const undo = document.getElementById("undo"), redo = document.getElementById("redo");
  if (undo) undo.disabled = !sceneHistory.past.length;
  if (redo) redo.disabled = !sceneHistory.future.length;
}

// one step back (-1) or forward (+1); steps queue behind each other, never while a drag is under way
function stepHistory(direction) {
  sceneHistory.pending += 1;  // steps asked for and not yet on the page
  sceneHistory.busy = sceneHistory.busy.then(async () => {
    if (state.dragging || state.settling) return;
    const from = direction < 0 ? sceneHistory.past : sceneHistory.future;
    const to = direction < 0 ? sceneHistory.future : sceneHistory.past;
    if (!from.length) return;
    to.push(sceneHistory.now);
    sceneHistory.now = from.pop();
    showHistoryButtons();
    sceneHistory.restoring = true;
    try {
      await restoreScene(JSON.parse(sceneHistory.now));
    } catch (e) {
      notice(`${e.field}: ${e.message}`, true);
    } finally {
      sceneHistory.restoring = false;
    }
  }).finally(() => { sceneHistory.pending -= 1; });
  return sceneHistory.busy;
}

// a scene from the history on the page: another preset's, type's or drive's as a newly opened one (its
// drives, menus and run boxes), the same one's as an edit
async function restoreScene(data) {
  const now = state.scene || {};
  const same = (k) => JSON.stringify(data[k] === undefined ? null : data[k]) === JSON.stringify(now[k] === undefined ? null : now[k]);
  const kind = (d) => (d.mechanism && d.mechanism.type) || null;
  if (data.name !== now.name || kind(data) !== kind(now) || !same("actuator")) {
    await loadData(data);
  } else {
    showSource(data);
    await analyse({ scene: data });
  }
}

function setupHistory() {
  document.getElementById("undo").addEventListener("click", () => stepHistory(-1));
  document.getElementById("redo").addEventListener("click", () => stepHistory(1));
  document.addEventListener("keydown", (evt) => {
    if (!(evt.ctrlKey || evt.metaKey) || evt.altKey) return;
    const key = evt.key.toLowerCase();
    if (key !== "z" && key !== "y") return;
    // a text box keeps its own undo of what is being typed
    const a = document.activeElement;
    if (a && (a.tagName === "TEXTAREA" || (a.tagName === "INPUT" && !/^(checkbox|range|radio|button)$/.test(a.type)))) return;
    evt.preventDefault();
    stepHistory(key === "y" || evt.shiftKey ? 1 : -1);
  });
  showHistoryButtons();
}
