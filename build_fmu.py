"""Build the project's FMUs into dist/ with pythonfmu.

    python build_fmu.py [--dest dist] [NAME ...]

Each FMU carries a copy of the grubler package in its resources/, so it runs the
same code the library runs; numpy and scipy must be installed in the Python that
runs it (see the README's FMU section).

Every slave declares which outputs depend on an input at the same instant
(grubler.fmi_slave), so a master can tell a state from an algebraic output.
The controller FMUs carry a C wrapper in front of pythonfmu's linux64 binary
that reports the status each call deserves (controllers/status_wrapper.c):
building them needs a C compiler.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from pythonfmu.builder import FmuBuilder

from grubler.controllers import PID, CascadeController, ComputedTorque, Encoder, LinearController, Trajectory
from grubler.controllers.fmu import build_controller_fmu, stage_package

HERE = Path(__file__).resolve().parent
# FMUs with a slave script of their own
SLAVES = {
    "Mechanism": HERE / "fmu_src" / "slaves" / "grubler_mechanism.py",
    "DCMotor": HERE / "motors" / "grubler_dc_motor.py",
}
# grubler.controllers: each law becomes an FMU the way a user's own law does
LAWS = {law.__name__: law for law in (PID, CascadeController, LinearController, ComputedTorque, Trajectory, Encoder)}
FMUS = [*SLAVES, *LAWS]


def build(dest: Path = HERE / "dist", names: list[str] | None = None) -> list[Path]:
    """Build the named FMUs (default: all) and return their paths."""
    unknown = set(names or ()) - set(FMUS)
    if unknown:
        raise SystemExit(f"build_fmu: no FMU named {', '.join(sorted(unknown))} (have: {', '.join(FMUS)})")
    dest.mkdir(parents=True, exist_ok=True)
    built = []
    with tempfile.TemporaryDirectory(prefix="grubler_fmu_") as tmp:
        package = stage_package(Path(tmp))
        for name, script in SLAVES.items():
            if names and name not in names:
                continue
            path = FmuBuilder.build_FMU(script, dest=dest / f"{name}.fmu", project_files=[package],
                                        canGetAndSetFMUstate=True, canSerializeFMUstate=True)
            built.append(Path(path))
    for name, law in LAWS.items():
        if not names or name in names:
            built.append(build_controller_fmu(law, dest / f"{name}.fmu"))
    return built


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dest", type=Path, default=HERE / "dist")
    ap.add_argument("names", nargs="*", help=f"FMUs to build (default all: {', '.join(FMUS)})")
    args = ap.parse_args()
    for path in build(args.dest, args.names):
        print(f"built {path}")


if __name__ == "__main__":
    main()
