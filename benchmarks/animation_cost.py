"""What animating a co-simulation costs against the co-simulation itself.

    python benchmarks/animation_cost.py [--repeat 5] [--signals] [--old COMMIT]

The README's main job (examples/servo_fourbar.ssd: 10 s at 1 ms steps, five
FMUs) is co-simulated, and its record animated at 25 fps (251 frames) the way
``grubler animate co.csv --scene thesis-fourbar`` does after reading the CSV:
the record in simulate vocabulary (``runs.run_columns``), its joint coordinates
(``runs.coordinates``) and the GIF (``animation.animate``).  The two are timed
alternately in one process, ``--repeat`` rounds, and their medians compared
(the machine's speed drifts by tens of percent within a minute).  ``--signals``
adds two strips (crank angle and motor current) under the mechanism.  ``--old``
also times an older commit's animate on the same record, in the same rounds
(its package exported as ``grubler_old``, as benchmarks/compare_versions.py
does), for a before/after.  FMUs must be built (``python build_fmu.py``).
"""

from __future__ import annotations

import argparse
import importlib
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import grubler  # noqa: E402
from grubler import cosim  # noqa: E402

SYSTEM = ROOT / "examples" / "servo_fourbar.ssd"


def animate_record(pkg, res, out: str, signals: bool) -> int:
    """Animate a co-simulation's record with package ``pkg`` (this one or an old one)."""
    runs, animation = (importlib.import_module(f"{pkg.__name__}.{m}") for m in ("runs", "animation"))
    raw = {"t": res.t, **{c: res.data[:, i] for i, c in enumerate(res.columns)}}
    model = pkg.load_scene("thesis-fourbar").mechanism
    cols = runs.run_columns(raw, model)
    zs = runs.coordinates(cols, model)
    kw = {}
    if signals:
        kw["signals"] = [("crank angle [rad]", raw["mechanism.theta2"]), ("motor current [A]", raw["motor.current"])]
    return animation.animate(model, cols["t"], zs, out, fps=25, title="thesis-fourbar: four-bar", **kw)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--signals", action="store_true", help="two signal strips under the mechanism")
    p.add_argument("--old", metavar="COMMIT", help="also time this commit's animate (before/after)")
    args = p.parse_args(argv)
    old = None
    if args.old:
        from compare_versions import load_old

        old = load_old(args.old)
    times = {"co-simulation": [], "whole cosim.run": [], "animate": [], "animate (old)": []}
    frames = 0
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "a.gif")
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            res = cosim.run(SYSTEM)
            times["whole cosim.run"].append(time.perf_counter() - t0)
            times["co-simulation"].append(res.wall_time)  # its stepping, what `grubler cosim` prints as wall
            t0 = time.perf_counter()
            frames = animate_record(grubler, res, out, args.signals)
            times["animate"].append(time.perf_counter() - t0)
            size = os.path.getsize(out)
            if old is not None:
                t0 = time.perf_counter()
                animate_record(old, res, out, False)
                times["animate (old)"].append(time.perf_counter() - t0)
    print(f"servo four-bar, 10 s at 1 ms steps; {frames} frames at 25 fps"
          f"{', two signal strips' if args.signals else ''}; GIF {size / 1e6:.2f} MB; median of {args.repeat}, "
          f"alternated; {platform.processor() or platform.machine()}, {os.cpu_count()} cores")
    base = statistics.median(times["co-simulation"])
    for name, ts in times.items():
        if ts:
            med = statistics.median(ts)
            print(f"  {name:<16} {med:7.3f} s  ({med / base:5.2f} x the co-simulation; min {min(ts):.3f} s)")


if __name__ == "__main__":
    main()
