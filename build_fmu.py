"""Build the project's FMUs into dist/.

    python build_fmu.py [--dest dist] [--platforms linux64,win64,...] [NAME ...]

The plant is native (grubler.fmi): Mechanism.fmu (the thesis four-bar's
defaults; every scene quantity a parameter), DCMotor.fmu (the maxon RE 40's
data; every datasheet number a parameter) and HydraulicCylinder.fmu and
PneumaticCylinder.fmu (a valve, a cylinder and its supply; every constant a
parameter) are the C models behind one FMI 2.0
wrapper, with its C sources inside.  It runs without Python.  With the
``cross`` extra (``pip install 'grubler[cross]'``, the zig C compiler) each
carries binaries for linux64 (glibc 2.17 and later), win64, darwin64 (Intel and
Apple silicon in one file) and aarch64-linux; without it, for this machine
with ``cc`` (and win64 when a MinGW-w64 cross compiler is installed), and one
line says which platforms were left out.  ``--platforms`` chooses.

The controllers and the transducers stay pythonfmu FMUs, where Python is the
point: each carries a copy of the grubler package in its resources/ and runs
inside a Python interpreter with numpy and scipy installed (see the README's FMU
section).  Every FMU declares which outputs depend on an input at the same
instant, so a master can tell a state from an algebraic output.  A controller
FMU carries a C wrapper in front of pythonfmu's linux64 binary that reports the
status each call deserves (controllers/status_wrapper.c): building one needs a
C compiler too.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from grubler.controllers import PID, CascadeController, ComputedTorque, Encoder, LinearController, Trajectory
from grubler.controllers.fmu import build_controller_fmu
from grubler.errors import InputError
from grubler.fmi.build import TARGETS, build_fmu, platforms_note, select_targets
from grubler.fmi.mechanism import mechanism_spec
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
}

# grubler.controllers: each law becomes an FMU the way a user's own law does
LAWS = {law.__name__: law for law in (PID, CascadeController, LinearController, ComputedTorque, Trajectory, Encoder)}
FMUS = [*NATIVE, *LAWS]


def build(dest: Path = HERE / "dist", names: list[str] | None = None, platforms=None) -> list[Path]:
    """Build the named FMUs (default: all) and return their paths.

    ``platforms`` (FMI 2.0 folders or FMI 3.0 tuples, a list or comma-separated)
    chooses the native FMUs' binaries (default: every one this machine can build).
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
            built.append(build_fmu(spec(), dest / f"{name}.fmu", platforms))
    for name, law in LAWS.items():
        if not names or name in names:
            built.append(build_controller_fmu(law, dest / f"{name}.fmu"))
    return built


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dest", type=Path, default=HERE / "dist")
    ap.add_argument("--platforms", help="the native FMUs' binaries, comma-separated (default: every one this "
                                        f"machine can build; of {', '.join(dict.fromkeys(t.fmi2 for t in TARGETS))})")
    ap.add_argument("names", nargs="*", help=f"FMUs to build (default all: {', '.join(FMUS)})")
    args = ap.parse_args()
    for path in build(args.dest, args.names, args.platforms):
        print(f"built {path}")
    if args.platforms is None and platforms_note():
        print(f"build_fmu: {platforms_note()}")


if __name__ == "__main__":
    main()
