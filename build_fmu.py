"""Build the project's FMUs into dist/ with pythonfmu.

    python build_fmu.py [--dest dist] [NAME ...]

Each FMU carries a copy of the grubler package in its resources/, so it runs the
same code the library runs; numpy and scipy must be installed in the Python that
runs it (see the README's FMU section).

pythonfmu leaves every output depending on every input, which would make any
feedback loop look algebraic to a master.  A slave that knows better says so in a
``feedthrough()`` method (output -> the inputs it depends on at the same instant;
an output it leaves out is a state), and the build writes that into the model
description's ModelStructure.
"""

from __future__ import annotations

import argparse
import importlib.util
import shutil
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

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


def _feedthrough(script: Path, name: str) -> dict[str, list[str]] | None:
    spec = importlib.util.spec_from_file_location(f"_grubler_build_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    slave = getattr(module, name)(instance_name="build", resources=str(script.parent))
    return slave.feedthrough() if hasattr(slave, "feedthrough") else None


def write_dependencies(fmu: Path, feedthrough: dict[str, list[str]]) -> None:
    """Declare in ``fmu``'s ModelStructure which inputs each output depends on."""
    with zipfile.ZipFile(fmu) as zf:
        entries = {i: zf.read(i) for i in zf.infolist()}
    md_info = next(i for i in entries if i.filename == "modelDescription.xml")
    root = ET.fromstring(entries[md_info])
    variables = root.findall("ModelVariables/ScalarVariable")
    index = {v.get("name"): str(k + 1) for k, v in enumerate(variables)}
    for unknown in root.findall("ModelStructure/Outputs/Unknown"):
        name = variables[int(unknown.get("index")) - 1].get("name")
        deps = [index[i] for i in feedthrough.get(name, [])]
        unknown.set("dependencies", " ".join(deps))
        if deps:
            unknown.set("dependenciesKind", " ".join(["dependent"] * len(deps)))
    entries[md_info] = ET.tostring(root, encoding="UTF-8", xml_declaration=True)
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as zf:
        for info, data in entries.items():
            zf.writestr(info, data)


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
            path = Path(FmuBuilder.build_FMU(script, dest=dest / f"{name}.fmu", project_files=[package],
                                             canGetAndSetFMUstate=True, canSerializeFMUstate=True))
            feedthrough = _feedthrough(script, name)
            if feedthrough is not None:
                write_dependencies(path, feedthrough)
            built.append(path)
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
