"""Cost per communication step of the native spatial FMU (the RSSR) against the planar Mechanism.fmu (the
thesis four-bar), each the mechanism of the same servo system, in the same master and process.

    python benchmarks/spatial_fmu_cost.py [--repeat 5] [--t-end 3]

The servo systems of examples/servo_fourbar.py and examples/servo_rssr.py (a DC motor through 50:1 under
PID position control, a half turn of the crank and back, 1 ms steps, Gauss-Seidel) run alternately with
``grubler.system.cosim.run(..., profile=True)``; per run, the mechanism's seconds in setReal, doStep and
getReal over the steps.  The RSSR runs at its FMU's default tolerance (1e-10, SpatialMechanism.simulate's)
and at the planar FMU's (1e-9).  The machine is shared: medians over the repeats.  Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent / "examples"))

import build_fmu  # noqa: E402
import servo_fourbar  # noqa: E402
import servo_rssr  # noqa: E402
from grubler.fmi.build import export_spatial, host_target  # noqa: E402
from grubler.fmi.spatial import spatial_preset  # noqa: E402
from grubler.system import cosim  # noqa: E402
from grubler.system.servo import servo_system  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--t-end", type=float, default=3.0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        platform = host_target().fmi2
        build_fmu.build(d, ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"], platforms=platform)
        export_spatial(spatial_preset("rssr"), d / "RSSR.fmu", platform)
        planar = servo_system(servo_fourbar.DESIGN, d, name="servo_fourbar")
        spatial = servo_system(servo_rssr.DESIGN, d, name="servo_rssr")
        loose = servo_system(servo_rssr.DESIGN, d, name="servo_rssr")
        loose.components["mechanism"].parameters.update(rtol=1e-9, atol=1e-9)
        cases = {"planar four-bar (Mechanism.fmu, rtol 1e-9)": planar, "RSSR (RSSR.fmu, rtol 1e-10)": spatial,
                 "RSSR (RSSR.fmu, rtol 1e-9)": loose}
        times = {k: [] for k in cases}
        steps = round(args.t_end / 1e-3)
        for _ in range(args.repeat):
            for label, system in cases.items():
                r = cosim.run(system, t_end=args.t_end, profile=True)
                times[label].append(sum(r.profile["mechanism"]) / steps)
        print("| mechanism | µs per communication step (setReal, doStep, getReal) |")
        print("|---|---|")
        for label, ts in times.items():
            print(f"| {label} | {1e6 * statistics.median(ts):.1f} (of {len(ts)} runs: "
                  f"{1e6 * min(ts):.1f} .. {1e6 * max(ts):.1f}) |")


if __name__ == "__main__":
    main()
