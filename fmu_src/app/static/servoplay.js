// grubler app: the servo run played on the drawing as a simulation is (scrubbed, played, paused), its
// graphs' cursors following.  The server sends the run's frames (grubler.app.runs.drive_frames: the
// mechanism assembled at each recorded drive angle); this draws them.
"use strict";

const servoPlay = { playing: false, last: 0, drawn: null };

// app.js calls this with each servo run it shows
function servoRunShown(out) {
  const player = document.getElementById("servo-player");
  servoPause();
  state.servoT = 0;
  if (!out.frames || !out.frames.length) { player.hidden = true; return; }
  player.hidden = false;
  const scrub = document.getElementById("servo-scrub");
  scrub.max = String(out.t[out.t.length - 1]);
  scrub.value = "0";
  pause();  // the simulation's playing stops: the drawing is the servo's now
  fitView([...out.frames.filter((_, i) => i % 10 === 0), out.path]);
  drawServoFrame();
  servoStart();
}

function drawServoFrame() {
  const v = state.servo;
  if (!v || !v.frames || !v.frames.length) return;
  const i = search(v.frame_t, state.servoT);
  let html = `<g transform="scale(1,-1)">` + frameMarkup(v.frames[i]) + polyline(v.path, "path");
  const p = v.path[i];
  if (p) html += `<circle class="tracer" cx="${p[0]}" cy="${p[1]}" r="${0.01 * state.box.span}"/>`;
  const drawing = document.getElementById("drawing");
  drawing.innerHTML = html + "</g>";
  servoPlay.drawn = drawing.firstChild;  // anything else drawn since (an edit, a simulation) ends the playing
  document.getElementById("edit-mode").disabled = false;
  document.getElementById("servo-clock").textContent = `t = ${state.servoT.toFixed(3)} s`;
  document.getElementById("servo-scrub").value = String(state.servoT);
  document.querySelectorAll("#servo-plots svg").forEach((svg) => {
    const c = svg.querySelector(".cursor");
    if (!c) return;
    const L = +svg.dataset.l, R = +svg.dataset.r, t0 = +svg.dataset.x0, t1 = +svg.dataset.x1;
    const x = L + ((state.servoT - t0) / (t1 - t0 || 1)) * (R - L);
    c.setAttribute("x1", x); c.setAttribute("x2", x);
  });
}

function servoOnDrawing() { return servoPlay.drawn && document.getElementById("drawing").firstChild === servoPlay.drawn; }

function servoStart() {
  const v = state.servo;
  if (!v || !v.frames || !v.frames.length) return;
  if (state.servoT >= v.t[v.t.length - 1]) state.servoT = 0;
  if (!servoOnDrawing()) {  // back from the scene or a simulation: the servo's view again
    fitView([...v.frames.filter((_, i) => i % 10 === 0), v.path]);
    pause();
  }
  servoPlay.playing = true;
  servoPlay.last = performance.now();
  document.getElementById("servo-play").textContent = "Pause";
  drawServoFrame();
  requestAnimationFrame(servoTick);
}

function servoPause() {
  servoPlay.playing = false;
  const b = document.getElementById("servo-play");
  if (b) b.textContent = "Play";
}

function servoTick(now) {
  if (!servoPlay.playing) return;
  if (!servoOnDrawing() || !state.servo) { servoPause(); return; }
  const end = state.servo.t[state.servo.t.length - 1];
  // true speed, times the player's factor, as a simulation plays
  state.servoT = Math.min(end, state.servoT + ((now - servoPlay.last) / 1000) * Number(document.getElementById("speed").value));
  servoPlay.last = now;
  drawServoFrame();
  if (state.servoT >= end) { servoPause(); return; }
  requestAnimationFrame(servoTick);
}

(function setupServoPlay() {
  document.getElementById("servo-play").addEventListener("click", () => (servoPlay.playing ? servoPause() : servoStart()));
  document.getElementById("servo-scrub").addEventListener("input", () => {
    servoPause();
    state.servoT = Number(document.getElementById("servo-scrub").value);
    if (!servoOnDrawing()) { pause(); fitView([...state.servo.frames.filter((_, i) => i % 10 === 0), state.servo.path]); }
    drawServoFrame();
  });
})();
