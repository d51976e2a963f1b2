"""The browser app's latencies, measured in a real browser (headless Chromium, Playwright).

    python benchmarks/app_latency.py [--moves 60] [--runs 5] [--out docs/app.md]

- drag: a pivot is dragged in ``--moves`` small mouse moves, one at a time;
  each is timed from the page's ``pointermove`` event to the redraw of its
  answer (mechanism, handles, class, branch and the coupler curve over a full
  sweep of the crank), as the page records it (``window.grublerStats.drag``).
  For a four-bar (fourbar-crank-rocker, its rocker-coupler pin) and a six-bar
  (stephenson-i, its rocker pivot).
- simulate: a click on Simulate for a 10 s run of fourbar-crank-rocker
  (1001 output rows, 400 frames) to its first frame and graphs on screen
  (``window.grublerStats.simulate``), ``--runs`` times.
- servo: the servo four-bar (thesis-fourbar, the default design, 10 s at 1 ms
  steps) re-run after a change of the PID gain K, from the change to its three
  graphs on screen (``window.grublerStats.servo``), ``--runs`` times after a
  first run.  The FMUs are built first (build_fmu.py) into the app's folder.

Prints p50 and p95 (ms) of each; ``--out`` replaces the results section of
docs/app.md.  Chromium is the system's (``/usr/bin/chromium``).
"""

from __future__ import annotations

import argparse
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


def drag_latencies(page, preset: str, handle: str, moves: int, radius: float) -> list[float]:
    page.select_option("#preset", preset)
    page.wait_for_selector(f'circle.handle[data-handle="{handle}"]')
    page.wait_for_timeout(300)
    hx, hy = page.evaluate(f"""() => state.analysis.handles.find((h) => h.id === "{handle}").xy""")
    page.evaluate("() => { window.grublerStats.drag = []; }")
    x0, y0 = screen_of(page, hx, hy)
    page.mouse.move(x0, y0)
    page.mouse.down()
    import math

    for k in range(moves):
        # a small circle about the start: every position closes, so each answer has its curve
        a = 2 * math.pi * k / moves
        x, y = screen_of(page, hx + radius * math.sin(a), hy + radius * (1 - math.cos(a)))
        page.mouse.move(x, y)
        page.wait_for_function(f"() => window.grublerStats.drag.length >= {k + 1}")
    page.mouse.up()
    return page.evaluate("() => window.grublerStats.drag")


def simulate_latencies(page, runs: int) -> list[float]:
    page.select_option("#preset", "fourbar-crank-rocker")
    page.wait_for_selector("circle.handle")
    page.fill("#t_end", "10")
    page.evaluate("() => { window.grublerStats.simulate = []; }")
    for k in range(runs):
        page.click("#simulate")
        page.wait_for_function(f"() => window.grublerStats.simulate.length >= {k + 1}")
    return page.evaluate("() => window.grublerStats.simulate")


def servo_latencies(page, runs: int) -> list[float]:
    page.select_option("#preset", "thesis-fourbar")
    page.wait_for_selector("circle.handle")
    page.click("#servo-run")
    page.wait_for_function("() => (window.grublerStats.servo || []).length >= 1", timeout=300_000)
    for k in range(runs):
        page.fill('#servo-form [data-key="K"]', str(300 - 20 * (k + 1)))
        page.press('#servo-form [data-key="K"]', "Enter")
        page.wait_for_function(f"() => window.grublerStats.servo.length >= {k + 2}", timeout=300_000)
    return page.evaluate("() => window.grublerStats.servo.slice(1)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", type=int, default=60)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--out", help="docs/app.md: replace its results section")
    args = ap.parse_args()
    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    root = Path(tempfile.mkdtemp(prefix="grubler-bench-"))
    sys.path.insert(0, str(ROOT))
    import build_fmu

    build_fmu.build(root / "dist", ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
    server = AppServer("127.0.0.1", 0, root)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    rows = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1400, "height": 1000})
        page.goto(server.url)
        page.wait_for_selector("circle.handle")
        for preset, handle, radius in (("fourbar-crank-rocker", "B", 0.02), ("stephenson-i", "rocker_pivot", 0.01)):
            ms = drag_latencies(page, preset, handle, args.moves, radius)
            rows.append((f"drag redrawn with its coupler curve, {preset} ({handle})", ms, 50))
        ms = simulate_latencies(page, args.runs)
        rows.append(("10 s simulation on screen after the click, fourbar-crank-rocker", ms, 300))
        ms = servo_latencies(page, args.runs)
        rows.append(("10 s servo co-simulation re-run after a gain change, on screen", ms, 1000))
        browser.close()
    server.shutdown()
    lines = ["| what | samples | p50 | p95 | target |", "|---|---|---|---|---|"]
    for what, ms, target in rows:
        lines.append(f"| {what} | {len(ms)} | {percentile(ms, 0.5):.1f} ms | {percentile(ms, 0.95):.1f} ms | "
                     f"{target} ms |")
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    machine = (f"Machine: {os.cpu_count()} cores ({platform.processor() or platform.machine()}, load average "
               f"{load} at the end: other jobs shared it), "
               f"Python {platform.python_version()}, Chromium from {chromium}, headless. Command: "
               f"`python benchmarks/app_latency.py --moves {args.moves} --runs {args.runs}`.")
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
