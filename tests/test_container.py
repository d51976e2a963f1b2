"""A whole system exported as one FMU (fmpy's container FMU) runs as ``grubler cosim --master jacobi``.

The systems are native FMUs only (a DC motor through 50:1 driving the thesis
four-bar, once from rest and once already turning), so that every importer can
run them without Python: fmpy in this process, fmusim and the C host
(tests/fmi_host.c) with an empty environment.  The reference is our own master
run in a child process, which shares no code with the container's Rust engine.

What is compared: every output whose value is passed on or does not depend on
a connected input at the same instant.  An output that does (the mechanism's
accelerations depend on the motor torque now) is read by a host after the
container has set the inputs of the new instant, where ``grubler cosim``
records it as its FMU's step left it; docs/cosim.md says so.
"""

from __future__ import annotations

import csv
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from grubler import ssp
from grubler.system.container import BINARIES, ContainerError, export_system
from grubler.system.interface import FmuInterface
from test_native_fmu import Host, host  # noqa: F401 - the C host, compiled once per session

ROOT = Path(__file__).parent.parent
MATCH = 1e-9
T_END, STEP = 0.5, 1e-3


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def plant(tmp_path_factory):
    sys.path.insert(0, str(ROOT))
    import builds

    d = tmp_path_factory.mktemp("dist")
    builds.dist(d, ["Mechanism", "DCMotor"])
    return d


def motor_fourbar(plant: Path, folder: Path, crank_rate: float = 0.0) -> Path:
    """A DC motor on 12 V through 50:1 driving the thesis four-bar; the crank turns at ``crank_rate`` at t = 0."""
    s = ssp.System("motor_fourbar", stop_time=T_END, step=STEP)
    s.add("motor", plant / "DCMotor.fmu", gear_ratio=50.0, voltage=12.0)
    s.add("mechanism", plant / "Mechanism.fmu", **{"drive.inertia": 50.0 ** 2 * 1.34e-5,
                                                   "initial.theta2_d": crank_rate})
    s.connect("motor.shaft_torque", "mechanism.motor_torque")
    s.connect("mechanism.drive_speed", "motor.shaft_speed")
    return s.write(folder / f"motor_fourbar_{crank_rate:g}.ssd")


def grubler(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "grubler.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


def read_csv(path: Path) -> dict:
    """The columns by name (a heading is ``name [unit]``, and a unit may hold a comma)."""
    with open(path, newline="") as fh:
        heads = [h.split(" [")[0].strip('"') for h in next(csv.reader(fh))]
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2) if len(heads) == len(
        open(path).readlines()[1].split(",")) else None
    assert data is not None, f"{path}: the values do not line up with the headings"
    return {"t" if h == "time" else h: data[:, j] for j, h in enumerate(heads)}


def jacobi_run(ssd: Path, tmp_path: Path) -> dict:
    out = tmp_path / "jacobi.csv"
    proc = grubler("cosim", ssd, "--master", "jacobi", "--csv", out)
    assert proc.returncode == 0, proc.stderr
    return read_csv(out)


def compared(ssd: Path) -> list[str]:
    """The outputs a host reads as grubler cosim records them (see the module's docstring)."""
    system = ssp.read(ssd)
    connected = {c.end for c in system.connections}
    names = []
    for comp in system.components.values():
        itf = FmuInterface.of(system.source_path(comp))
        for port in itf.ports.values():
            deps = itf.feedthrough.get(port.name)
            if port.causality == "output" and port.type == "Real" and \
                    not {f"{comp.name}.{d}" for d in (deps or ())} & connected:
                names.append(f"{comp.name}.{port.name}")
    return names


def assert_matches(got: dict, ref: dict, names: list[str]):
    assert np.allclose(got["t"], ref["t"], rtol=0, atol=1e-12)
    worst = {n: float(np.max(np.abs(np.asarray(got[n]) - ref[n]))) for n in names}
    assert max(worst.values()) <= MATCH, {n: e for n, e in worst.items() if e > MATCH}
    assert np.ptp(ref["mechanism.drive_angle"]) > 0.01  # it moved


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("crank_rate", [0.0, 2.0])
def test_the_exported_system_runs_in_fmpy_as_grubler_cosim_jacobi(plant, tmp_path, fmi, crank_rate):
    from fmpy import simulate_fmu

    ssd = motor_fourbar(plant, tmp_path, crank_rate)
    fmu = tmp_path / "MotorFourbar.fmu"
    proc = grubler("export", ssd, "-o", fmu, "--container") if fmi == 2 else None
    if fmi == 2:
        assert proc.returncode == 0 and f"wrote {fmu}" in proc.stdout, proc.stderr
    else:
        export_system(ssd, fmu, fmi_version=3)
    names = compared(ssd)
    assert "mechanism.drive_angle" in names and "motor.current" in names and "mechanism.theta2_dd" not in names
    res = simulate_fmu(str(fmu), output=names)  # the FMU's own default experiment: 0.5 s at 1 ms
    got = {"t": res["time"], **{n: res[n] for n in names}}
    assert_matches(got, jacobi_run(ssd, tmp_path), names)


def fmusim() -> str | None:
    found = os.environ.get("GRUBLER_FMUSIM") or shutil.which("fmusim")
    return found if found and os.access(found, os.X_OK) else None


@pytest.mark.skipif(fmusim() is None, reason="no fmusim (the FMI reference importer): set GRUBLER_FMUSIM to one, "
                                              "or put it on PATH")
@pytest.mark.parametrize("fmi", [2, 3])
def test_the_exported_system_runs_in_fmusim_with_an_empty_environment(plant, tmp_path, fmi):
    ssd = motor_fourbar(plant, tmp_path, 2.0)
    fmu = export_system(ssd, tmp_path / "MotorFourbar.fmu", fmi_version=fmi)
    out = tmp_path / "fmusim.csv"
    proc = subprocess.run([fmusim(), "--interface-type", "cs", "--stop-time", str(T_END), "--output-interval",
                           str(STEP), "--output-file", str(out), str(fmu)], env={}, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert_matches(read_csv(out), jacobi_run(ssd, tmp_path), compared(ssd))


def test_the_exported_system_runs_in_the_c_host_with_an_empty_environment(plant, host, tmp_path):  # noqa: F811
    from fmpy import read_model_description

    ssd = motor_fourbar(plant, tmp_path, 2.0)
    fmu = export_system(ssd, tmp_path / "MotorFourbar.fmu")
    folder = tmp_path / "unzipped"
    zipfile.ZipFile(fmu).extractall(folder)
    md = read_model_description(str(fmu))
    names = ["mechanism.drive_angle", "mechanism.drive_speed", "motor.current"]
    c = Host(host, folder / "binaries" / "linux64" / "container_fmu.so", md.guid,
             {v.name: v.valueReference for v in md.modelVariables})
    c.cmd.append((folder / "resources").as_uri())
    t = c.run(c.start(md=md) + [c.run_steps(0.0, STEP, round(T_END / STEP), *names)])
    assert t.statuses("run") == [0]
    rows = t.rows()
    ref = jacobi_run(ssd, tmp_path)
    np.testing.assert_allclose(rows[:, 0], ref["t"][1:], rtol=0, atol=1e-12)
    for j, n in enumerate(names):
        np.testing.assert_allclose(rows[:, 1 + j], ref[n][1:], rtol=0, atol=MATCH, err_msg=n)


def test_what_the_exported_fmu_shows_and_how_its_engine_is_told(plant, tmp_path):
    import json

    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    ssd = motor_fourbar(plant, tmp_path, 2.0)
    fmu = export_system(ssd, tmp_path / "MotorFourbar.fmu")
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    assert md.coSimulation.modelIdentifier == "container_fmu"
    assert md.coSimulation.needsExecutionTool is False  # native FMUs only: no Python where it runs
    assert min(v.valueReference for v in md.modelVariables) == 1  # the engine keeps 0 for the time
    # the system's parameters are the FMU's defaults; the connected inputs are not shown
    assert float(by_name["motor.gear_ratio"].start) == 50.0 and by_name["motor.gear_ratio"].causality == "parameter"
    assert float(by_name["motor.voltage"].start) == 12.0 and by_name["motor.voltage"].causality == "input"
    assert "mechanism.motor_torque" not in by_name and "motor.shaft_speed" not in by_name
    # the engine's binary only where every nested FMU has one (here: the motor and the mechanism as built)
    # and fmpy ships the engine (not for aarch64-linux, which the cross extra builds the FMUs for)
    names = zipfile.ZipFile(fmu).namelist()
    nested = [{n.split("/")[3] for n in names if n.startswith(f"resources/{f}/binaries/")}
              for f in ("DCMotor", "Mechanism")]
    ours = {n.split("/")[1] for n in names if n.startswith("binaries/")}
    engine = {fmi2 for _, fmi2, _ in BINARIES if fmi2 is not None}
    assert "linux64" in ours and ours == set.intersection(*nested) & engine
    config = json.loads(zipfile.ZipFile(fmu).read("resources/container.json"))
    assert {c["variableType"] for c in config["connections"]} == {"Float64"}  # never FMI 2's "Real"
    # the torque (which depends on the motor's speed now) is read before the speed is set
    assert [(c["srcComponent"], c["dstComponent"]) for c in config["connections"]] == [(0, 1), (1, 0)]
    # the connected inputs start where a run's initialisation settles them: the crank's rate through 50:1
    speed_vr = FmuInterface.of(plant / "DCMotor.fmu").ports["shaft_speed"].vr
    starts = [v["start"] for v in config["variables"][len(md.modelVariables):] if v["mappings"] == [[0, speed_vr]]]
    assert starts == [["2.0"]]


def test_a_system_that_cannot_be_exported_is_named(plant, tmp_path):
    ssd = motor_fourbar(plant, tmp_path)
    text = ssd.read_text().replace("Mechanism.fmu", "Missing.fmu")
    bad = tmp_path / "bad.ssd"
    bad.write_text(text)
    proc = grubler("export", bad, "-o", tmp_path / "Bad.fmu")
    assert proc.returncode == 2 and "Missing.fmu not found" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) <= 3 and "Traceback" not in proc.stderr
    assert not (tmp_path / "Bad.fmu").exists()
    with pytest.raises(ContainerError, match="fmi_version: must be 2 or 3"):
        export_system(ssd, tmp_path / "X.fmu", fmi_version=4)


# FMI 2.0 (2.1.5, clarified in 2.0.5) makes the callback struct valid during fmi2Instantiate only: fmpy's
# container passes one on its stack, so a native FMU copies the logger it is given (fmi/c/fmi2_wrapper.c)
def test_a_nested_fmu_that_logs_reaches_the_host(plant, host, tmp_path):  # noqa: F811
    from fmpy import read_model_description

    s = ssp.System("hot", stop_time=0.01, step=STEP)  # the winding passes its maximum at once: a warning
    s.add("motor", plant / "DCMotor.fmu", voltage=12.0, max_winding_temperature=25.0)
    fmu = export_system(s, tmp_path / "Hot.fmu")
    folder = tmp_path / "unzipped"
    zipfile.ZipFile(fmu).extractall(folder)
    md = read_model_description(str(fmu))
    proc = subprocess.run([str(host), str(folder / "binaries" / "linux64" / "container_fmu.so"), md.guid,
                           (folder / "resources").as_uri()], input="new 0 s\nsetup 0.0\nenter\nexit\nstep 0.0 0.001\n",
                          capture_output=True, text=True, env={}, timeout=600)
    assert proc.returncode == 0, f"the host died (exit {proc.returncode})"
    assert "exceeds the datasheet's maximum" in proc.stdout


FMPY_CHILD = """
import os, sys
import numpy as np
from fmpy import simulate_fmu
fmu, out, t_end, step, names = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5].split(",")
res = simulate_fmu(fmu, stop_time=t_end, step_size=step, output_interval=step, output=names)
np.savez(out, t=res["time"], **{n: res[n] for n in names})
os._exit(0)  # a pythonfmu FMU may crash the interpreter's teardown (PythonFMU issue 228): the file is what counts
"""


def test_the_readmes_servo_exported_runs_in_fmpy_as_grubler_cosim_jacobi(tmp_path):
    # the README's system as it is built today, controllers and all (five FMUs, String,
    # Integer and Boolean parameters, a PID and an encoder sampling at 1 kHz)
    import dataclasses

    sys.path[:0] = [str(ROOT), str(ROOT / "examples")]
    import builds
    import servo_fourbar
    from grubler.system.servo import servo_system

    d = tmp_path / "dist"
    builds.dist(d, ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
    ssd = servo_system(dataclasses.replace(servo_fourbar.DESIGN, t_end=0.3), d, name="servo_fourbar").write(
        d / "servo_fourbar.ssd")
    fmu = tmp_path / "ServoFourbar.fmu"
    proc = grubler("export", ssd, "-o", fmu, "--container")
    assert proc.returncode == 0, proc.stderr
    # pythonfmu FMUs need a Python where they run: the exported FMU says so, and so does the command
    from fmpy import read_model_description

    from grubler.system.container import execution_tools

    tools = execution_tools(ssp.read(ssd))
    assert read_model_description(str(fmu)).coSimulation.needsExecutionTool == bool(tools)
    assert ("needs an execution tool where it runs, as " in proc.stderr) == bool(tools), proc.stderr
    names = compared(ssd)
    assert {"mechanism.drive_angle", "motor.current", "controller.u", "encoder.measured_position"} <= set(names)
    out = tmp_path / "container.npz"
    proc = subprocess.run([sys.executable, "-c", FMPY_CHILD, str(fmu), str(out), "0.3", str(STEP), ",".join(names)],
                          capture_output=True, text=True, timeout=600)
    assert out.exists(), proc.stderr[-3000:]
    got = dict(np.load(out))
    assert_matches(got, jacobi_run(ssd, tmp_path), names)
