"""The browser app's latencies, measured in a real browser (headless Chromium, Playwright).

    python benchmarks/app_latency.py [--moves 60] [--runs 5] [--out docs/app.md]

Each latency runs to the frame that shows its answer (``record`` in app.js),
and is split into where the time went: the wait before its request leaves
(the page's event handling), the server's action (its ``Server-Timing``), the
transfer (the rest of the round trip, JSON parsing
included), the page's drawing and the wait for the frame that paints it.

- drag: a handle is dragged in ``--moves`` small mouse moves round a circle, one
  at a time; each is timed from the page's ``pointermove`` event to the frame
  that shows its answer (mechanism, handles, class, branch count with grubler
  info's 256 starts, and the coupler curve over a sweep of the crank).  For a
  four-bar (fourbar-crank-rocker, its rocker-coupler pin), the six-bars'
  pivots and moving joints (Stephenson I's rocker pivot and rocker joint E,
  Stephenson II's floating ternary joint P, Watt II's rocker joint C) and the
  four-link inversions' new handles (scotch yoke, double slider, conchoidal,
  Oldham).
- drag with the analysis layer on (``--analysis``: these rows alone, no FMUs
  built): the same moves with every arrow, instant centre, transmission angle
  and toggle drawn (velocities, accelerations, centres, joint forces), for the
  four-bar and Watt II (its rocker joint C), beside the same drags without the
  layer, measured in the same minute.
- simulate: a click on Simulate for a 10 s run of fourbar-crank-rocker
  (1001 output rows, 400 frames) to its first frame and graphs on screen,
  ``--runs`` times.
- servo: the servo four-bar (thesis-fourbar, the default design, 10 s at 1 ms
  steps) re-run after a change of the PID gain K, from the change to its three
  graphs on screen, ``--runs`` times after a first run.  The FMUs are built
  first (build_fmu.py) into the app's folder.

Prints p50 and p95 (ms) of each, the load average when it was measured and
the medians of its parts; ``--out`` replaces the results section of
docs/app.md.  Chromium is the system's (``/usr/bin/chromium``).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import re
import shutil
import statistics
import sys
import tempfile
import threading
from pathlib import Path

from playwright.sync_api import sync_playwright

from grubler.app.server import AppServer

ROOT = Path(__file__).resolve().parent.parent


def percentile(values, q: float) -> float:
    xs = sorted(values)
    k = (len(xs) - 1) * q
    lo = int(k)
    return xs[lo] + (xs[min(lo + 1, len(xs) - 1)] - xs[lo]) * (k - lo)


def screen_of(page, x: float, y: float):
    return page.evaluate("""([x, y]) => {
        const p = new DOMPoint(x, y).matrixTransform(document.querySelector('#drawing g').getScreenCTM());
        return [p.x, p.y];
    }""", [x, y])


def analysis_layer(page, on: bool) -> None:
    """Every kind of the analysis layer on (or off), and its answer on the page."""
    for box in page.query_selector_all("#analysis-layer input"):
        if box.is_checked() != on:
            box.click()
    page.wait_for_function("(on) => !!state.kinematics === on", arg=on)


def pick(page, preset: str) -> None:
    """Pick a preset and wait for its drawing: a new scene empties the run boxes, so they are filled after."""
    page.evaluate("() => { window.pickedFrom = state.analysis; }")
    page.select_option("#preset", preset)
    page.wait_for_function("""(name) => state.analysis !== window.pickedFrom && state.scene && state.scene.name === name
        && state.analysis.scene === state.scene""", arg=preset)


def drag_latencies(page, preset: str, handle: str, moves: int, layer: bool = False) -> tuple[list[float], list[dict]]:
    analysis_layer(page, layer)
    pick(page, preset)
    if layer:
        page.wait_for_function("() => !!state.analysis.analysis")
    page.wait_for_timeout(300)
    hx, hy = page.evaluate(f"""() => state.analysis.handles.find((h) => h.id === "{handle}").xy""")
    # a circle of 1.5 % of the drawing's size about the handle: every position closes, so each answer has its curve
    radius = 0.015 * page.evaluate("() => state.box.span")
    page.evaluate("() => { window.grublerStats.drag = []; window.grublerStats.parts.drag = []; }")
    x0, y0 = screen_of(page, hx, hy)
    page.mouse.move(x0, y0)
    page.mouse.down()
    for k in range(moves):
        a = 2 * math.pi * k / moves
        x, y = screen_of(page, hx + radius * math.sin(a), hy + radius * (1 - math.cos(a)))
        page.mouse.move(x, y)
        page.wait_for_function(f"() => window.grublerStats.drag.length >= {k + 1}")
    page.mouse.up()
    page.wait_for_function("() => !state.settling")
    return page.evaluate("() => [window.grublerStats.drag, window.grublerStats.parts.drag]")


def simulate_latencies(page, runs: int) -> list[float]:
    pick(page, "fourbar-crank-rocker")
    page.fill("#t_end", "10")
    page.evaluate("() => { window.grublerStats.simulate = []; window.grublerStats.parts.simulate = []; }")
    for k in range(runs):
        page.click("#simulate")
        page.wait_for_function(f"() => window.grublerStats.simulate.length >= {k + 1}")
    return page.evaluate("() => [window.grublerStats.simulate, window.grublerStats.parts.simulate]")


def servo_latencies(page, runs: int) -> list[float]:
    pick(page, "thesis-fourbar")
    page.click("#servo-run")
    page.wait_for_function("() => window.grublerStats.servo.length >= 1", timeout=300_000)
    for k in range(runs):
        page.fill('#servo-form [data-key="K"]', str(300 - 20 * (k + 1)))
        page.press('#servo-form [data-key="K"]', "Enter")
        page.wait_for_function(f"() => window.grublerStats.servo.length >= {k + 2}", timeout=300_000)
    return page.evaluate("() => [window.grublerStats.servo.slice(1), window.grublerStats.parts.servo.slice(1)]")


# (preset, handle) for the drag rows: a four-bar, the six-bars' pivots and moving joints, the new inversions'
DRAGS = [("fourbar-crank-rocker", "B"), ("stephenson-i", "rocker_pivot"), ("stephenson-i", "E"),
         ("stephenson-ii", "P"), ("watt-ii", "C"), ("scotch-yoke", "A"), ("double-slider", "block2"),
         ("conchoidal", "block"), ("oldham", "shaft2")]
ANALYSED_DRAGS = [("fourbar-crank-rocker", "B"), ("watt-ii", "C")]  # item 5 of issue 33: a four-bar and a six-bar


def row_text(row) -> str:
    what, ms, parts, target, load = row
    median = [statistics.median(p[k] for p in parts) for k in ("before", "server", "transfer", "draw", "paint")]
    return (f"| {what} | {len(ms)} | {percentile(ms, 0.5):.1f} ms | {percentile(ms, 0.95):.1f} ms | {target} ms | "
            f"{load:.1f} | {', '.join(f'{v:.1f}' for v in median)} ms |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", type=int, default=60)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--out", help="docs/app.md: replace its results section")
    ap.add_argument("--analysis", action="store_true",
                    help="only the drags with and without the analysis layer (no FMUs built, no runs)")
    args = ap.parse_args()
    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    root = Path(tempfile.mkdtemp(prefix="grubler-bench-"))
    sys.path.insert(0, str(ROOT))
    if not args.analysis:
        import build_fmu

        build_fmu.build(root / "dist", ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
    server = AppServer("127.0.0.1", 0, root)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    rows = []

    def add(what, measured, target):
        ms, parts = measured
        rows.append((what, ms, parts, target, os.getloadavg()[0]))
        print(row_text(rows[-1]), flush=True)

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1400, "height": 1000})
        page.goto(server.url)
        page.wait_for_selector("circle.handle")
        for preset, handle in [] if args.analysis else DRAGS:
            add(f"drag redrawn with its coupler curve, {preset} ({handle})", drag_latencies(page, preset, handle,
                                                                                           args.moves), 50)
        for preset, handle in ANALYSED_DRAGS:
            add(f"drag redrawn with its coupler curve and analysis arrows, {preset} ({handle})",
                drag_latencies(page, preset, handle, args.moves, layer=True), 50)
            if args.analysis:  # beside it, in the same minute: the same drag without the layer
                add(f"drag redrawn with its coupler curve, {preset} ({handle})",
                    drag_latencies(page, preset, handle, args.moves), 50)
        if not args.analysis:
            add("10 s simulation on screen after the click, fourbar-crank-rocker", simulate_latencies(page, args.runs),
                300)
            add("10 s servo co-simulation re-run after a gain change, on screen", servo_latencies(page, args.runs),
                1000)
        browser.close()
    server.shutdown()
    shutil.rmtree(root, ignore_errors=True)  # the FMUs built for the run, and what the app wrote
    lines = ["| what | samples | p50 | p95 | target | load | median parts: before, server, transfer, draw, frame |",
             "|---|---|---|---|---|---|---|"] + [row_text(r) for r in rows]
    machine = (f"Machine: {os.cpu_count()} cores ({platform.processor() or platform.machine()}), shared with other "
               f"jobs: *load* is the 1-minute load average (as `uptime` prints it) when the row was measured. "
               f"Python {platform.python_version()}, Chromium from {chromium}, headless. Command: "
               f"`python benchmarks/app_latency.py --moves {args.moves} --runs {args.runs}"
               f"{' --analysis' if args.analysis else ''}`.")
    text = "\n".join(lines) + "\n\n" + machine + "\n"
    print(text)
    if args.out:
        doc = Path(args.out).read_text()
        new = re.sub(r"(<!-- latency -->\n).*?(<!-- /latency -->)", lambda m: m.group(1) + "\n" + text + "\n" + m.group(2),
                     doc, flags=re.S)
        Path(args.out).write_text(new)
        print(f"wrote {args.out}", file=sys.stderr)
    sys.stdout.flush()
    # the servo's pythonfmu FMUs can corrupt the heap at interpreter exit (see grubler.cli): leave without it
    os._exit(0)


if __name__ == "__main__":
    main()
