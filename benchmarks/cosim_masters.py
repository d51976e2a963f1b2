"""Co-simulation masters on the servo four-bar, against one monolithic simulation.

    python benchmarks/cosim_masters.py [--t-end 2] [--out docs/cosim.md]

The servo four-bar of examples/servo_fourbar.py (DC motor through 50:1, PID with
a 14-bit encoder, trapezoid moves of the crank) is run by:

- grubler's runner, Gauss-Seidel in the system's order (the default);
- grubler's runner, Jacobi (every FMU steps on the last communication point's values);
- ``fmpy.ssp.simulate_ssp``, fmpy's own SSP master (Jacobi, every connector starting at 0);
- the system exported as one FMU (``grubler export``: fmpy's container FMU, Jacobi), run by
  ``fmpy.simulate_fmu``;

at communication steps 1e-4, 1e-3 and 1e-2 s, and each is compared with the
monolithic reference (tests/servo_reference.py: mechanism, motor and gearbox in
one integrator, the encoder and PID sampled exactly) on the crank angle and the
motor current.  Wall times are of the run alone (FMUs already built), one run
each, in this process.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "examples")]

import build_fmu  # noqa: E402
import servo_fourbar  # noqa: E402
from servo_reference import monolithic  # noqa: E402

from grubler import cosim  # noqa: E402
from grubler.system.servo import servo_system  # noqa: E402

STEPS = (1e-4, 1e-3, 1e-2)


def on_reference_grid(t, values, ref, key, Ts=1e-3):
    k = np.round(t / Ts)
    on = np.abs(t / Ts - k) < 1e-6
    idx = k[on].astype(int)
    idx_ok = idx < len(ref[key])
    return float(np.max(np.abs(values[on][idx_ok] - ref[key][idx[idx_ok]])))


def fmpy_ssp(system, t_end, h, tmp: Path):
    """fmpy's master on the same system, given the same parameters (it ignores the SSD's own)."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet

    archive = system.write(tmp / "servo.ssp")
    pset = ParameterSet()
    pset.parameters = []
    for name, comp in system.components.items():
        for p, v in comp.parameters.items():
            if isinstance(v, str):
                continue  # fmpy's master sets no strings; the FMUs' defaults are the example's
            par = Parameter(name=f"{name}.{p}", type="Real", value=v)
            pset.parameters.append(par)
    t0 = time.perf_counter()
    res = simulate_ssp(str(archive), stop_time=t_end, step_size=h, parameter_set=pset)
    wall = time.perf_counter() - t0
    # fmpy records the outputs after each step at the step's start time
    t = res["time"] + h
    return t, res["mechanism.drive_angle"], res["motor.current"], wall


def container(system, t_end, h, tmp: Path):
    """The system as one FMU (fmpy's container, its fixed step h), run by fmpy.simulate_fmu."""
    from fmpy import simulate_fmu

    from grubler.system.container import export_system

    fmu = export_system(dataclasses.replace(system, step=h), tmp / "ServoFourbar.fmu")
    t0 = time.perf_counter()
    res = simulate_fmu(str(fmu), stop_time=t_end, step_size=h, output_interval=h,
                       output=["mechanism.drive_angle", "motor.current"])
    wall = time.perf_counter() - t0
    return res["time"], res["mechanism.drive_angle"], res["motor.current"], wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    design = servo_fourbar.DESIGN
    t0 = time.perf_counter()
    ref = monolithic(design, args.t_end)
    t_mono = time.perf_counter() - t0
    exact = monolithic(dataclasses.replace(design, encoder={"counts_per_rev": 0, "Ts": 1e-3}), args.t_end)
    encoder_cost = float(np.max(np.abs(ref["drive_angle"] - exact["drive_angle"])))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        build_fmu.build(tmp, ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
        system = servo_system(design, tmp, name="servo_fourbar")
        for h in STEPS:
            for label, master in (("grubler, Gauss-Seidel", cosim.GAUSS_SEIDEL), ("grubler, Jacobi", cosim.JACOBI)):
                r = cosim.run(system, t_end=args.t_end, step=h, master=master,
                              record=["mechanism.drive_angle", "motor.current"])
                rows.append((h, label, r.wall_time,
                             on_reference_grid(r.t, r["mechanism.drive_angle"], ref, "drive_angle"),
                             on_reference_grid(r.t, r["motor.current"], ref, "current")))
                print(rows[-1], flush=True)
            for label, master in (("fmpy.ssp.simulate_ssp", fmpy_ssp), ("one FMU (container) in fmpy", container)):
                try:
                    t, ang, cur, wall = master(system, args.t_end, h, tmp)
                    rows.append((h, label, wall, on_reference_grid(t, ang, ref, "drive_angle"),
                                 on_reference_grid(t, cur, ref, "current")))
                except Exception as exc:  # noqa: BLE001 - a master that cannot run it is a result too
                    rows.append((h, f"{label} (failed: {exc})", float("nan"), float("nan"), float("nan")))
                print(rows[-1], flush=True)
    lines = ["| step | master | wall time | max crank-angle error | max current error |", "|---|---|---|---|---|"]
    for h, label, wall, ea, ei in rows:
        lines.append(f"| {h:g} s | {label} | {wall:.2f} s | {ea:.2e} rad | {ei:.2e} A |")
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")), "?")
    text = "\n".join([
        f"{args.t_end:g} s of the servo four-bar (examples/servo_fourbar.py). The monolithic reference took "
        f"{t_mono:.1f} s. One encoder count is {2 * np.pi / design.encoder['counts_per_rev']:.2e} rad; "
        f"the encoder's quantisation alone moves the monolithic crank by up to {encoder_cost:.2e} rad.",
        "",
        *lines,
        "",
        f"Machine: {os.cpu_count()} cores ({cpu}), Python {platform.python_version()}. "
        f"Command: `python benchmarks/cosim_masters.py --t-end {args.t_end:g}`.",
    ])
    print(text)
    if args.out:
        head = args.out.read_text().split("<!-- results -->")[0] if args.out.exists() else ""
        args.out.write_text(head + "<!-- results -->\n\n" + text + "\n")
    sys.stdout.flush()
    os._exit(0)  # FMUs ran in this process: skip the teardown (PythonFMU issue 228)


if __name__ == "__main__":
    main()
