"""Build the project's FMUs into dist/.

    python build_fmu.py [--dest dist] [--fmi 2|3] [--platforms linux64,win64,...] [NAME ...]

The plant is native (grubler.fmi): Mechanism.fmu (the thesis four-bar's
defaults; every scene quantity a parameter), DCMotor.fmu (the maxon RE 40's
data; every datasheet number a parameter) and HydraulicCylinder.fmu and
PneumaticCylinder.fmu (a valve, a cylinder and its supply; every constant a
parameter) and RSSR.fmu (the spatial crank-rocker between skew shafts; every
number of the spatial model a parameter, docs/spatial.md) are the C models behind one FMI 2.0
wrapper (``--fmi 3``: its FMI 3.0 adapter, the same model files), with its C
sources inside.  It runs without Python.  With the ``cross`` extra (``pip
install 'grubler[cross]'``, the zig C compiler) each carries binaries for
linux64 (glibc 2.17 and later), win64, darwin64 (Intel and Apple silicon in one
file) and aarch64-linux; without it, for this machine with ``cc`` (and win64
when a MinGW-w64 cross compiler is installed), and one line says which
platforms were left out.  ``--platforms`` chooses.

PID.fmu, CascadeController.fmu, Encoder.fmu, Tachometer.fmu, CurrentSensor.fmu,
Trajectory.fmu, ComputedTorque.fmu (the thesis four-bar's scene as parameters,
its drive demand the kernel's) and LinearController.fmu (a discrete PI,
``LINEAR_DEFAULT`` in grubler.controllers.native_fmu, its matrices parameters;
``linear_spec`` builds any other python-control controller) are native too:
the laws' C (controllers/kernel and the mechanism kernel, the code the
library's classes run) behind one sampled-law model on the same wrapper.  Every
FMU here runs without Python, in FMI 2 and 3 alike; the pythonfmu route
(grubler.controllers.fmu) is for a user's own Python law.  Every FMU declares
which outputs depend on an input at the same instant, so a master can tell a
state from an algebraic output.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from grubler.controllers import CurrentSensor, Tachometer
from grubler.controllers.native_fmu import (cascade_spec, computed_torque_spec, encoder_spec, linear_default,
                                            linear_spec, pid_spec, sensor_spec, trajectory_spec)
from grubler.errors import InputError
from grubler.fmi.build import TARGETS, build_fmu, platforms_note, select_targets
from grubler.fmi.mechanism import mechanism_spec
from grubler.fmi.spatial import spatial_preset, spatial_spec
from grubler.fmi.cylinder import hydraulic_spec, pneumatic_spec
from grubler.fmi.motor import DEFAULT_MOTOR, motor_spec
from grubler.mechanism.scene import load_scene

HERE = Path(__file__).resolve().parent
# native FMUs: name -> the ModelSpec of the model they serve
NATIVE = {
    "Mechanism": lambda: mechanism_spec(load_scene("thesis-fourbar"), "Mechanism"),
    "DCMotor": lambda: motor_spec(DEFAULT_MOTOR, "DCMotor"),
    "HydraulicCylinder": lambda: hydraulic_spec(),
    "PneumaticCylinder": lambda: pneumatic_spec(),
    "PID": lambda: pid_spec("PID"),
    "CascadeController": lambda: cascade_spec("CascadeController"),
    "Encoder": lambda: encoder_spec("Encoder"),
    "Tachometer": lambda: sensor_spec(Tachometer),
    "CurrentSensor": lambda: sensor_spec(CurrentSensor),
    "Trajectory": lambda: trajectory_spec("Trajectory"),
    "ComputedTorque": lambda: computed_torque_spec(load_scene("thesis-fourbar"), "ComputedTorque"),
    "LinearController": lambda: linear_spec(linear_default(), "LinearController"),
    # the spatial kernel's (docs/spatial.md): the RSSR, every number of it a parameter
    "RSSR": lambda: spatial_spec(spatial_preset("rssr"), "RSSR", name="rssr"),
}
FMUS = list(NATIVE)


def build(dest: Path = HERE / "dist", names: list[str] | None = None, platforms=None, fmi: int = 2) -> list[Path]:
    """Build the named FMUs (default: all) and return their paths.

    With ``fmi=3`` they are FMI 3.0.  ``platforms`` (FMI 2.0 folders or FMI 3.0
    tuples, a list or comma-separated) chooses the native FMUs' binaries
    (default: every one this machine can build).
    """
    unknown = set(names or ()) - set(FMUS)
    if unknown:
        raise SystemExit(f"build_fmu: no FMU named {', '.join(sorted(unknown))} (have: {', '.join(FMUS)})")
    try:
        platforms = select_targets(platforms)
    except InputError as exc:
        raise SystemExit(f"build_fmu: --{exc}") from None
    platforms = [t.name for t in platforms]
    dest.mkdir(parents=True, exist_ok=True)
    built = []
    for name, spec in NATIVE.items():
        if not names or name in names:
            built.append(build_fmu(spec(), dest / f"{name}.fmu", platforms, fmi=fmi))
    return built


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dest", type=Path, default=HERE / "dist")
    ap.add_argument("--fmi", type=int, choices=[2, 3], default=2,
                    help="FMI version of the FMUs (default 2)")
    ap.add_argument("--platforms", help="the FMUs' binaries, comma-separated (default: every one this "
                                        f"machine can build; of {', '.join(dict.fromkeys(t.fmi2 for t in TARGETS))})")
    ap.add_argument("names", nargs="*", help=f"FMUs to build (default all: {', '.join(FMUS)})")
    args = ap.parse_args()
    for path in build(args.dest, args.names, args.platforms, args.fmi):
        print(f"built {path}")
    if args.platforms is None and platforms_note():
        print(f"build_fmu: {platforms_note()}")


if __name__ == "__main__":
    main()
