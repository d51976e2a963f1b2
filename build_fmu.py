"""Build the project's FMUs into dist/ with pythonfmu.

    python build_fmu.py [--dest dist] [NAME ...]

Each FMU carries a copy of the grubler package in its resources/, so it runs the
same code the library runs; numpy and scipy must be installed in the Python that
runs it (see the README's FMU section).

Every slave declares which outputs depend on an input at the same instant
(grubler.fmi_slave), so a master can tell a state from an algebraic output.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

from pythonfmu.builder import FmuBuilder

HERE = Path(__file__).resolve().parent
SLAVES = {
    "Mechanism": HERE / "fmu_src" / "slaves" / "grubler_mechanism.py",
    "DCMotor": HERE / "motors" / "grubler_dc_motor.py",
    # grubler.controllers: each a thin LawSlave over its Python law
    "PID": HERE / "controllers" / "grubler_pid.py",
    "CascadeController": HERE / "controllers" / "grubler_cascade.py",
    "LinearController": HERE / "controllers" / "grubler_linear_controller.py",
    "ComputedTorque": HERE / "controllers" / "grubler_computed_torque.py",
    "Trajectory": HERE / "controllers" / "grubler_trajectory.py",
    "Encoder": HERE / "controllers" / "grubler_encoder.py",
}


def build(dest: Path = HERE / "dist", names: list[str] | None = None) -> list[Path]:
    """Build the named FMUs (default: all) and return their paths."""
    unknown = set(names or ()) - set(SLAVES)
    if unknown:
        raise SystemExit(f"build_fmu: no FMU named {', '.join(sorted(unknown))} (have: {', '.join(SLAVES)})")
    dest.mkdir(parents=True, exist_ok=True)
    built = []
    with tempfile.TemporaryDirectory(prefix="grubler_fmu_") as tmp:
        package = Path(tmp) / "grubler"
        skip = shutil.ignore_patterns("__pycache__", "*.pyc")
        shutil.copytree(HERE / "fmu_src", package, ignore=skip)
        # the same mapping as pyproject's package-dir: grubler.motors, grubler.controllers
        for sub in ("motors", "controllers"):
            shutil.copytree(HERE / sub, package / sub, ignore=skip)
        for name, script in SLAVES.items():
            if names and name not in names:
                continue
            path = FmuBuilder.build_FMU(script, dest=dest / f"{name}.fmu", project_files=[package],
                                        canGetAndSetFMUstate=True, canSerializeFMUstate=True)
            built.append(Path(path))
    return built


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dest", type=Path, default=HERE / "dist")
    ap.add_argument("names", nargs="*", help=f"FMUs to build (default all: {', '.join(SLAVES)})")
    args = ap.parse_args()
    for path in build(args.dest, args.names):
        print(f"built {path}")


if __name__ == "__main__":
    main()
