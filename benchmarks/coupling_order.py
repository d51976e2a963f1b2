"""The coupling's order and cost: Gauss-Seidel, the extrapolating master and its tolerance, on the servo four-bar.

    python benchmarks/coupling_order.py [--t-end 2] [--out docs/cosim.md]

The servo four-bar of examples/servo_fourbar.py with the encoder's quantisation
off (``counts_per_rev = 0``), so that the error is the coupling's alone and its
order can be read, against the monolithic reference (tests/servo_reference.py):
the largest crank-angle error at the controller's sample instants, as
benchmarks/cosim_masters.py measures it (``on_reference_grid``).  Each master
runs at communication steps from 1 ms down; the extrapolating master with
``tol`` runs at the 1 ms step with its continuous components sub-stepped.  Wall
times are of the run alone (FMUs built, the first run discarded), the median of
three.  The observed order is log2 of the error's ratio between a step and its
half; "Gauss-Seidel's wall time at that error" reads Gauss-Seidel's measured
curve, log-log interpolated, or extrapolated at its last measured order beyond it
(said so).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import platform
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "examples"), str(ROOT / "benchmarks")]

import build_fmu  # noqa: E402
import servo_fourbar  # noqa: E402
from cosim_masters import on_reference_grid  # noqa: E402
from servo_reference import monolithic  # noqa: E402

from grubler import cosim  # noqa: E402
from grubler.system.servo import servo_system  # noqa: E402

GS_STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5, 1.5625e-5)
EXT_STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5)
TOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9)


def timed(system, ref, t_end, **kw):
    """(error, median wall time, the last result) of one setting."""
    walls, r = [], None
    for _ in range(3):
        r = cosim.run(system, t_end=t_end, record=["mechanism.drive_angle"], **kw)
        walls.append(r.wall_time)
        if r.wall_time > 5.0:
            break  # a long run once is enough
    return on_reference_grid(r.t, r["mechanism.drive_angle"], ref, "drive_angle"), statistics.median(walls), r


def gs_wall_at(curve: list[tuple[float, float, float]], err: float) -> tuple[float, str]:
    """Gauss-Seidel's wall time at an error, from its (step, error, wall) curve, and how it was read."""
    pts = sorted(curve, key=lambda p: -p[1])  # error falling
    for (h0, e0, w0), (h1, e1, w1) in zip(pts, pts[1:]):
        if e1 <= err <= e0:
            f = math.log(err / e0) / math.log(e1 / e0)
            return math.exp(math.log(w0) + f * math.log(w1 / w0)), "interpolated"
    (h0, e0, w0), (h1, e1, w1) = pts[-2], pts[-1]
    if err > e0:
        return w0, "at its largest step"
    p = math.log(e0 / e1) / math.log(h0 / h1)  # its order, measured at its smallest steps
    steps = (e1 / err) ** (1 / p)  # how much finer a step it needs
    return w1 * steps, f"extrapolated (order {p:.2f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    design = dataclasses.replace(servo_fourbar.DESIGN, encoder={"counts_per_rev": 0, "Ts": 1e-3})
    ref = monolithic(design, args.t_end)
    rows, gs_curve = [], []
    with tempfile.TemporaryDirectory() as tmp:
        build_fmu.build(Path(tmp), ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
        system = servo_system(design, tmp, name="servo_fourbar")
        cosim.run(system, t_end=0.01)  # warm
        for master, steps in (("gauss-seidel", GS_STEPS), ("extrapolate", EXT_STEPS)):
            last = None
            for h in steps:
                err, wall, _ = timed(system, ref, args.t_end, step=h, master=master)
                order = "" if last is None else f"{math.log2(last / err):.2f}"
                rows.append((master, f"{h:g} s", "", err, order, wall))
                if master == "gauss-seidel":
                    gs_curve.append((h, err, wall))
                last = err
                print(rows[-1], flush=True)
        for tol in TOLS:
            try:
                err, wall, r = timed(system, ref, args.t_end, step=1e-3, tol=tol)
            except cosim.CosimError as exc:  # an estimate that cannot be met is a result too
                print(f"tol {tol:g}: {exc}", flush=True)
                continue
            c = r.coupling
            rows.append(("extrapolate", "1 ms", f"{tol:g} ({c['substeps']} sub-steps, {c['rejected']} rejected)",
                         err, "", wall))
            print(rows[-1], flush=True)
    lines = ["| master | step | tol | max crank-angle error | order | wall time | Gauss-Seidel's wall time at that "
             "error | speed-up |", "|---|---|---|---|---|---|---|---|"]
    for master, h, tol, err, order, wall in rows:
        gs_wall, how = gs_wall_at(gs_curve, err)
        gs_text = f"{gs_wall:.3g} s ({how})" if master != "gauss-seidel" else ""
        speed = f"{gs_wall / wall:.3g}x" if master != "gauss-seidel" else ""
        lines.append(f"| {master} | {h} | {tol} | {err:.2e} rad | {order} | {wall:.3f} s | {gs_text} | {speed} |")
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")), "?")
    text = "\n".join([
        f"{args.t_end:g} s of the servo four-bar (examples/servo_fourbar.py), the encoder's quantisation off, "
        "against the monolithic reference (tests/servo_reference.py).",
        "",
        *lines,
        "",
        f"Machine: {os.cpu_count()} cores ({cpu}), load average {os.getloadavg()[0]:.1f}, Python "
        f"{platform.python_version()}. Command: `python benchmarks/coupling_order.py --t-end {args.t_end:g}`.",
    ])
    print(text)
    if args.out:
        doc = args.out.read_text()
        head, sep, tail = doc.partition("<!-- coupling order -->")
        if not sep:
            raise SystemExit(f"{args.out}: no '<!-- coupling order -->' marker to write under")
        rest = tail.partition("\n<!-- end coupling order -->")[2]
        args.out.write_text(head + sep + "\n\n" + text + "\n\n<!-- end coupling order -->" + rest)
    sys.stdout.flush()
    os._exit(0)


if __name__ == "__main__":
    main()
