"""The native FMUs built as FMI 3.0 co-simulation: the same model files behind the FMI 3.0 adapter.

The references: the FMI 2.0 build of the same model (the same C on the same
code path, so the results agree to the bit), run by the same script through
the C host (tests/fmi_host.c) built for FMI 2.0 and for FMI 3.0 (-DHOST_FMI=3),
both with an empty environment; fmpy (validate, simulate) and fmusim, an
importer that shares no code with ours; and the FMI 3.0 contract itself.

fmusim is the FMI Reference FMUs' command-line importer: the tests find it by
the environment variable GRUBLER_FMUSIM or on PATH, and skip, saying so, where
it is absent (docs/fmi.md says how to build it).
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

from grubler.fmi.build import fmi_headers_dir

import builds
from test_native_fmu import (DISCARD, ERROR, OK, SANITIZE, SANITIZER_ENV, Host, Transcript, random_script,
                             sanitized_binary)

HERE = Path(__file__).parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
import build_fmu  # noqa: E402

# every native FMU build_fmu.py builds (a native model added there is checked here too)
NATIVE = list(build_fmu.NATIVE)
EVERY = pytest.mark.parametrize("name", NATIVE)
# inputs held through a run (the cylinders: the valve open half way, the rod moving);
# a model not named here runs on its inputs' start values
INPUTS = {"Mechanism": {"motor_torque": 3.0}, "DCMotor": {"voltage": 24.0, "shaft_speed": 5.0},
          "HydraulicCylinder": {"command": 0.5, "rate": 0.05}, "PneumaticCylinder": {"command": 0.5, "rate": 0.05},
          "RSSR": {"motor_torque": 0.5}}


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


def _build(tmp_path_factory, fmi: int) -> dict:
    from fmpy import read_model_description

    out = {}
    for path in builds.dist(tmp_path_factory.mktemp(f"fmi{fmi}"), NATIVE, fmi=fmi):
        d = tmp_path_factory.mktemp(f"{path.stem}{fmi}")
        zipfile.ZipFile(path).extractall(d)
        out[path.stem] = (path, d, read_model_description(str(path)))
    return out


@pytest.fixture(scope="session")
def built3(tmp_path_factory):
    """build_fmu.py --fmi 3's native FMUs, unzipped too."""
    return _build(tmp_path_factory, 3)


@pytest.fixture(scope="session")
def built2(tmp_path_factory):
    """The same FMUs as FMI 2.0 (build_fmu.py's default)."""
    return _build(tmp_path_factory, 2)


@pytest.fixture(scope="session")
def hosts():
    return {2: builds.host(), 3: builds.host(fmi=3)}


class Host3(Host):
    """The FMI 3.0 host: an enumeration is an Int64 there (setl), Int32 an Integer (seti)."""

    def set_lines(self, params: dict, md) -> list[str]:
        types = {v.name: v.type for v in md.modelVariables}
        lines = []
        for name, value in params.items():
            if types[name] in ("Int32", "Enumeration"):
                lines.append(f"{'setl' if types[name] == 'Enumeration' else 'seti'} {self.vr[name]} {int(value)}")
            else:
                lines += super().set_lines({name: value}, md)
        return lines


def host3(hosts, built3, name: str) -> Host3:
    _, d, md = built3[name]
    return Host3(hosts[3], d / "binaries" / "x86_64-linux" / f"{name}.so", md.guid,
                 {v.name: v.valueReference for v in md.modelVariables})


def host2(hosts, built2, name: str) -> Host:
    _, d, md = built2[name]
    return Host(hosts[2], d / "binaries" / "linux64" / f"{name}.so", md.guid,
                {v.name: v.valueReference for v in md.modelVariables})


def outputs(md) -> list[str]:
    return [v.name for v in md.modelVariables if v.causality == "output"]


def run_script(h: Host, md, name: str, n: int = 100, dt: float = 0.01) -> list[str]:
    return (h.start(md=md) + [f"setr {h.vr[k]} {v!r}" for k, v in INPUTS.get(name, {}).items()]
            + [h.run_steps(0.0, dt, n, *outputs(md))])


# -- the binary and the description ------------------------------------------------

def _fmi3_functions() -> set[str]:
    text = (fmi_headers_dir() / "fmi3Functions.h").read_text()
    return set(re.findall(r"FMI3_Export\s+(fmi3\w+)TYPE\s+\1\s*;", text))


@EVERY
def test_the_binary_exports_every_fmi3_function_and_nothing_else_and_needs_no_python(built3, name):
    so = built3[name][1] / "binaries" / "x86_64-linux" / f"{name}.so"
    defined = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True,
                             check=True).stdout.splitlines()
    exported = {ln.split()[-1] for ln in defined if ln.strip() and ln.split()[1] in "TD"}
    assert exported == _fmi3_functions() and len(exported) > 60
    undefined = subprocess.run(["nm", "-D", "--undefined-only", str(so)], capture_output=True, text=True,
                               check=True).stdout
    assert undefined.strip() and "Py" not in undefined and "python" not in undefined.lower()
    assert not (built3[name][1] / "binaries" / "linux64").exists()


@EVERY
def test_fmpy_validate_passes(built3, name):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(built3[name][0])) == []


def test_the_fmi3_description_declares_fmi3_types_units_structure_and_capabilities(built3, built2):
    path, d, md = built3["Mechanism"]
    assert md.fmiVersion == "3.0" and md.guid == built2["Mechanism"][2].guid  # instantiationToken: the same model
    root = ET.fromstring(zipfile.ZipFile(path).read("modelDescription.xml"))
    cs = root.find("CoSimulation").attrib
    assert cs["canGetAndSetFMUState"] == cs["canSerializeFMUState"] == "true"
    assert cs["providesDirectionalDerivatives"] == "true"  # (fmpy 0.3.32 reads only FMI 2.0's singular name)
    assert cs["hasEventMode"] == cs["mightReturnEarlyFromDoStep"] == "false"
    motor = ET.fromstring(zipfile.ZipFile(built3["DCMotor"][0]).read("modelDescription.xml"))
    assert motor.find("CoSimulation").get("providesDirectionalDerivatives") == "false"
    by = {v.name: v for v in md.modelVariables}
    assert by["time"].causality == "independent" and by["time"].valueReference == 0 and by["time"].unit == "s"
    assert by["theta2"].type == "Float64" and by["theta2"].unit == "rad" and by["Fx"].unit == "N"
    assert by["link2.joint"].type == "Enumeration" and by["closure.link"].type == "Int32"
    assert by["method"].type == "String" and by["method"].start == "exact"
    assert {v.unit for v in md.modelVariables if v.unit} <= {u.name for u in md.unitDefinitions}
    two = {v.name: v for v in built2["Mechanism"][2].modelVariables}
    for v in md.modelVariables[1:]:  # the same variables at the same references, starts and causalities
        assert (v.valueReference, v.causality, v.start) == (two[v.name].valueReference, two[v.name].causality,
                                                            two[v.name].start), v.name
    deps = {u.variable.name: sorted(x.name for x in (u.dependencies or [])) for u in md.outputs}
    assert deps["theta2"] == [] and deps["Fx"] == ["load_torque", "motor_torque"]
    assert len(md.outputs) == len(md.initialUnknowns) == len(outputs(md))
    files = md.buildConfigurations[0].sourceFileSets[0].sourceFiles  # sources/buildDescription.xml
    assert "fmi3_wrapper.c" in files and "mechanism_model.c" in files and "fmi2_wrapper.c" not in files


@EVERY
def test_fmi3_variability_and_default_step_say_what_the_fmi2_build_says(built2, built3, name):
    # a sampled law's outputs are discrete Float64s (legal in FMI 3.0 co-simulation without event mode: they
    # change only inside fmi3DoStep, at its sample instants); its default step is its sample time Ts.  No
    # clock: a periodic clock would need event mode (or scheduled execution), which these FMUs do not have
    md3 = ET.fromstring(zipfile.ZipFile(built3[name][0]).read("modelDescription.xml"))
    md2 = ET.fromstring(zipfile.ZipFile(built2[name][0]).read("modelDescription.xml"))
    two = {v.get("name"): v.get("variability") for v in md2.iter("ScalarVariable")}
    three = {v.get("name"): v.get("variability") for v in md3.find("ModelVariables") if v.get("name") != "time"}
    assert three == two
    outs = [v.get("variability") for v in md3.find("ModelVariables") if v.get("causality") == "output"]
    sampled = name in ("PID", "CascadeController", "Encoder", "Tachometer", "CurrentSensor", "ComputedTorque",
                       "LinearController")
    assert set(outs) == {"discrete" if sampled else "continuous"}, (name, outs)
    assert md3.find("DefaultExperiment").get("stepSize") == md2.find("DefaultExperiment").get("stepSize")
    assert md3.find("ModelVariables/Clock") is None


@EVERY
def test_value_references_agree_between_binary_and_fmi3_description(hosts, built3, name):
    # what the binary reads at each value reference, through the getter of its FMI 3.0 type,
    # is the start the description declares there
    h, md = host3(hosts, built3, name), built3[name][2]
    getter = {"Float64": "getr", "String": "gets", "Int32": "geti", "Enumeration": "getl"}  # (the host's)
    stored = [v for v in md.modelVariables if v.causality in ("parameter", "input") and v.type in getter]
    t = h.run(h.start(md=md)[:-1] + [f"{getter[v.type]} {v.valueReference}" for v in stored] + ["getr 0"])
    assert t.values(-1) == ["0"]  # time, at the start time
    for v, r in zip(stored, t.results[-len(stored) - 1:-1]):
        assert r[1] == "0", (v.name, r)
        if v.type == "Float64":
            assert float(r[2]) == float(v.start), v.name
        elif v.type == "String":
            assert r[2] == f"[{v.start}]", v.name
        else:
            assert int(r[2]) == int(v.start), v.name


# -- the same numbers as the FMI 2.0 build ------------------------------------------------

@EVERY
def test_c_host_with_an_empty_environment_runs_fmi3_as_fmi2_to_the_bit(hosts, built2, built3, name):
    h2, h3, md = host2(hosts, built2, name), host3(hosts, built3, name), built3[name][2]
    t2, t3 = h2.run(run_script(h2, md, name)), h3.run(run_script(h3, md, name))
    assert t3.statuses("run") == t2.statuses("run") == [OK], t3.logs
    rows = t3.rows()
    assert rows.shape == (100, 1 + len(outputs(md)))
    assert name not in INPUTS or np.ptp(rows[:, 1:], axis=0).max() > 0  # it moved
    assert np.array_equal(rows, t2.rows(), equal_nan=True)


def test_fmi3_host_runs_a_model_retuned_by_enumerations_and_strings_as_fmi2(hosts, built2, built3):
    # every parameter type on its FMI 3.0 path: a slider-crank by Int64 enumerations, Int32s, strings, Float64s
    import grubler
    from grubler.fmi.mechanism import fmu_parameters

    params = fmu_parameters(grubler.load_scene("thesis-slider-crank"))
    params["integrator"] = "rk45"
    h2, h3 = host2(hosts, built2, "Mechanism"), host3(hosts, built3, "Mechanism")
    names = ("theta2", "B3", "Fx", "KE", "drive_angle")
    rows = []
    for h, md in ((h2, built2["Mechanism"][2]), (h3, built3["Mechanism"][2])):
        t = h.run(h.start(params, md=md) + [f"setr {h.vr['motor_torque']} 0.5", h.run_steps(0.0, 0.01, 50, *names)])
        assert t.statuses("exit") == [OK] and t.statuses("run") == [OK], t.logs
        rows.append(t.rows())
    assert any(ln.startswith("setl ") for ln in h3.set_lines(params, built3["Mechanism"][2]))
    assert np.array_equal(rows[0], rows[1])


@EVERY
def test_fmpy_simulates_fmi3_as_fmi2(built2, built3, name):
    import fmpy

    md = built3[name][2]
    inputs = INPUTS.get(name, {})
    sig = np.array([(0.0, *inputs.values()), (1.0, *inputs.values())],
                   dtype=[("time", float), *((k, float) for k in inputs)]) if inputs else None
    res = {fmi: fmpy.simulate_fmu(str(b[name][0]), stop_time=0.5, output_interval=1e-2, step_size=1e-2,
                                  input=sig, output=outputs(md))
           for fmi, b in ((2, built2), (3, built3))}
    assert len(res[3]) == len(res[2]) == 51
    for k in outputs(md):
        np.testing.assert_allclose(res[3][k], res[2][k], rtol=0, atol=1e-12, err_msg=k)
        assert np.array_equal(res[3][k], res[2][k], equal_nan=True), k  # the same code path: to the bit


def test_directional_derivatives_are_the_fmi2_builds(built2, built3):
    unknowns = ("theta2_dd", "Fx", "Fy", "Mz", "R2_Fx", "closure_error")
    got = {}
    for fmi, b in ((2, built2), (3, built3)):
        s, vr = _slave(fmi, b, {})
        (s.setReal if fmi == 2 else s.setFloat64)([vr["motor_torque"]], [3.0])
        for i in range(20):
            s.doStep(i * 0.01, 0.01)
        got[fmi] = [s.getDirectionalDerivative([vr[n] for n in unknowns], [vr["motor_torque"], vr["load_torque"]],
                                               seed) for seed in ([1.0, 0.0], [0.0, 1.0])]
        s.terminate()
        s.freeInstance()
    assert np.array_equal(np.array(got[3]), np.array(got[2]))
    assert np.abs(np.array(got[3])).max() > 0.1  # the outputs do depend on the torques


def _slave(fmi: int, b: dict, params: dict, **instantiate):
    """An fmpy slave of the Mechanism build, its parameters set by type, initialised."""
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    path, _, md = b["Mechanism"]
    s = (FMU2Slave if fmi == 2 else FMU3Slave)(guid=md.guid, unzipDirectory=extract(str(path)),
                                               modelIdentifier="Mechanism", instanceName="m")
    s.instantiate(**instantiate)
    if fmi == 2:
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
    else:
        s.enterInitializationMode(startTime=0.0)
    by = {v.name: v for v in md.modelVariables}
    setter = {"Real": "setReal", "Integer": "setInteger", "Enumeration": "setInteger" if fmi == 2 else "setInt64",
              "String": "setString", "Float64": "setFloat64", "Int32": "setInt32"}
    for name, value in params.items():
        v = by[name]
        getattr(s, setter[v.type])([v.valueReference], [value])
    s.exitInitializationMode()
    return s, {n: v.valueReference for n, v in by.items()}


def test_a_step_over_change_points_reports_no_event_and_returns_as_fmi2(built2, built3):
    # the change-point four-bar turns six times in 3 s, every link aligned twice a turn; an importer
    # that allows early return gets none, and the numbers are the FMI 2.0 build's (docs/fmi.md)
    import grubler
    from grubler.fmi.mechanism import fmu_parameters

    params = fmu_parameters(grubler.load_scene("fourbar-change-point"))
    names = ("theta2", "theta2_d", "theta3", "Fx", "KE", "PE")
    rows, flags = {}, []
    for fmi, b in ((2, built2), (3, built3)):
        s, vr = _slave(fmi, b, params, **({"earlyReturnAllowed": True} if fmi == 3 else {}))
        refs = [vr[n] for n in names]
        (s.setReal if fmi == 2 else s.setFloat64)([vr["motor_torque"]], [0.5])
        out = []
        for i in range(300):
            r = s.doStep(i * 0.01, 0.01)
            if fmi == 3:
                flags.append((r[0], r[1], r[2], r[3] == (i + 1) * 0.01 or abs(r[3] - (i + 1) * 0.01) < 1e-15))
            out.append((s.getReal if fmi == 2 else s.getFloat64)(refs))
        s.terminate()
        s.freeInstance()
        rows[fmi] = np.array(out)
    assert set(flags) == {(False, False, False, True)}
    assert rows[3][-1, 0] > 2 * np.pi * 5  # past ten change points
    assert np.array_equal(rows[3], rows[2])


# -- FMU state ------------------------------------------------------------------------

def test_serialised_state_round_trips_and_an_fmi2_state_restores_in_the_fmi3_build(hosts, built2, built3, tmp_path):
    md = built3["Mechanism"][2]
    h2, h3 = host2(hosts, built2, "Mechanism"), host3(hosts, built3, "Mechanism")
    names = ("theta2", "Fx", "KE")

    def script(h, first: str, blob: Path) -> list[str]:
        return h.start(md=md) + [f"setr {h.vr['motor_torque']} 3.0", h.run_steps(0.0, 0.01, 10, "theta2"),
                                 "save 0", f"ser 0 {blob}", h.run_steps(0.1, 0.01, 10, *names),
                                 f"deser 1 {first}", "load 1", h.run_steps(0.1, 0.01, 10, *names)]

    blob2, blob3 = tmp_path / "two.bin", tmp_path / "three.bin"
    t2 = h2.run(script(h2, str(blob2), blob2))
    t3 = h3.run(script(h3, str(blob2), blob3))  # the FMI 2.0 build's blob, restored by the FMI 3.0 build
    assert t3.statuses("deser") == t3.statuses("load") == [OK], t3.logs
    assert blob3.read_bytes() == blob2.read_bytes()
    rows = t3.rows(1 + len(names))
    assert len(rows) == 20 and np.array_equal(rows[:10], rows[10:]) and np.array_equal(rows, t2.rows(1 + len(names)))


def test_a_state_saved_while_stepping_and_restored_before_initialisation_resumes_stepping(mech3, tmp_path):
    # as an importer that restores the mode with the state does (fmusim's --initial-fmu-state-file);
    # one that initialises after restoring goes on from the state too (test_native_fmu)
    h, md = mech3
    blob, names = tmp_path / "s.bin", ("theta2", "theta2_d", "Fx")
    t = h.run(h.start(md=md) + [f"setr {h.vr['motor_torque']} 2.0", h.run_steps(0, 0.01, 70, "theta2"), "save 0",
                                f"ser 0 {blob}", h.run_steps(0.7, 0.01, 30, *names),
                                "new 1 later", f"deser 1 {blob}", "load 1", h.run_steps(0.7, 0.01, 30, *names)])
    assert t.statuses("run")[-1] == OK, t.logs
    rows = t.rows(width=4)
    assert rows.shape == (60, 4) and np.array_equal(rows[:30], rows[30:])


@pytest.mark.parametrize("damage", ["flip", "truncate", "magic", "version", "mode", "foreign"])
def test_a_corrupt_or_foreign_state_blob_is_refused_with_its_reason(hosts, built3, tmp_path, damage):
    md = built3["Mechanism"][2]
    h, motor = host3(hosts, built3, "Mechanism"), host3(hosts, built3, "DCMotor")
    blob = tmp_path / "s.bin"
    if damage == "foreign":
        t = motor.run(motor.start(md=built3["DCMotor"][2]) + ["save 0", f"ser 0 {blob}"])
        assert t.statuses("ser") == [OK]
    else:
        h.run(h.start(md=md) + [h.run_steps(0.0, 0.01, 3), "save 0", f"ser 0 {blob}"])
        b = bytearray(blob.read_bytes())
        if damage == "flip":
            b[-3] ^= 0x10
        elif damage == "truncate":
            b = b[:-8]
        elif damage == "magic":
            b[0:8] = b"NOTGRUBL"
        elif damage == "mode":
            b[20] = 99
        else:
            b[8] = 7
        blob.write_bytes(bytes(b))
    t = h.run(h.start(md=md) + [f"deser 0 {blob}", "step 0 0.01", "reset", "setup 0", "enter", "exit",
                                "step 0 0.01"])
    reason = {"flip": "checksum does not match", "truncate": "truncated or padded", "magic": "bad magic",
              "version": "state layout version 7",
              "mode": "the state machine's state 99 is none of this FMU's", "foreign": "belongs to another model"}[damage]
    assert t.statuses("deser") == [ERROR] and t.logged(f"fmi3DeserializeFMUState: ") and t.logged(reason)
    assert t.statuses("step") == [ERROR, OK]  # refused until fmi3Reset


# -- the error contract, one test per class ---------------------------------------------

@pytest.fixture(scope="session")
def mech3(hosts, built3):
    return host3(hosts, built3, "Mechanism"), built3["Mechanism"][2]


def _refused_then_reset_works(h, md, lines: list[str], cmd: str, *reasons: str) -> Transcript:
    t = h.run(h.start(md=md) + lines + [h.getr("theta2"), "reset", "setup 0", "enter", "exit",
                                        h.run_steps(0, 0.01, 2, "theta2")])
    assert t.statuses(cmd)[-1] == ERROR
    for r in reasons:
        assert t.logged(r), (r, t.logs)
    assert t.statuses("getr")[-1] == ERROR
    assert t.logged("only fmi3Reset, fmi3FreeInstance and fmi3SetFMUState (a state saved before the error) are allowed")
    assert t.statuses("reset") == [OK] and t.statuses("run") == [OK]
    return t


@pytest.mark.parametrize("line, cmd, reasons", [
    ("getr 99999", "getr", ["fmi3GetFloat64: unknown value reference 99999"]),
    ("geti {theta2}", "geti", ["fmi3GetInt32: theta2", "is a Real variable, not Integer"]),
    ("geti {link2.joint}", "geti", ["link2.joint", "is an Enumeration, which fmi3GetInt64 and fmi3SetInt64"]),
    ("getl {closure.link}", "getl", ["closure.link", "is an Int32, which fmi3GetInt32 and fmi3SetInt32"]),
    ("setr {Fx} 1.0", "setr", ["fmi3SetFloat64: Fx is an output"]),
    ("setr 0 1.0", "setr", ["time is the independent variable"]),
    ("setr {link2.m} 2.0", "setr", ["link2.m is a fixed parameter", "(fmi3Reset, then set it)"]),
    ("step 0 0.01", "step", []),  # (after a step the model is at 0.01: a wrong time is a Discard, see below)
])
def test_a_bad_call_is_an_error_naming_why_and_only_reset_recovers(mech3, line, cmd, reasons):
    h, md = mech3
    by = {v.name: v.valueReference for v in md.modelVariables}
    if cmd == "step":  # fmi3DoStep after fmi3Terminate
        t = h.run(h.start(md=md) + ["step 0 0.01", "term", "step 0.01 0.01"])
        assert t.statuses("step") == [OK, ERROR] and t.logged("fmi3DoStep is not allowed in the state terminated")
        return
    _refused_then_reset_works(h, md, [re.sub(r"\{([^}]+)\}", lambda m: str(by[m.group(1)]), line)], cmd, *reasons)


def test_calls_in_the_wrong_state_and_bad_values_are_refused(mech3):
    h, md = mech3
    t = h.run(["new 0 a", "step 0 0.01"])
    assert t.statuses("step") == [ERROR] and t.logged("fmi3DoStep is not allowed in the state instantiated")
    t = h.run([*h.start(md=md)[:-1], f"sets {h.vr['method']} lagrange"])
    assert t.statuses("sets") == [ERROR] and t.logged("method cannot be 'lagrange'; it accepts 'exact', 'penalty'")
    t = h.run([*h.start(md=md)[:-1], f"setl {h.vr['link2.joint']} 7"])
    assert t.statuses("setl") == [ERROR] and t.logged("link2.joint must be an item 1 .. 2 of its enumeration, got 7")
    t = h.run(h.start({"link2.m": -1.0}, md=md) + ["step 0 0.01"])
    assert t.statuses("exit") == [ERROR] and t.logged("link2.m: mass must be positive, got -1")
    t = h.run(["null"])
    assert t.statuses("null") == [ERROR]


def test_a_non_finite_input_or_a_wrong_time_is_discarded_and_the_run_goes_on(mech3):
    h, md = mech3
    t = h.run(h.start(md=md) + [h.run_steps(0, 0.01, 3), f"setr {h.vr['motor_torque']} nan", "step 0.03 0.01",
                                f"setr {h.vr['motor_torque']} 1.0", "step 0.5 0.01", "step 0.03 0.01", "getr 0"])
    assert t.statuses("step") == [DISCARD, DISCARD, OK]
    assert t.logged("motor_torque is nan at t = 0.03 s") and t.logged("fmi3DoStep at t = 0.5 s, but the model is")
    assert float(t.values(-1)[0]) == pytest.approx(0.04, abs=1e-15)  # time, value reference 0


def test_a_state_passed_where_its_address_belongs_is_freed_not_a_crash(mech3):
    # (fmusim 0.0.39 does this when it saves a final state)
    h, md = mech3
    t = h.run(h.start(md=md) + ["save 0", "dropstate 0", "save 1", "drop 1", h.run_steps(0, 0.01, 2, "theta2")])
    assert t.statuses("dropstate") == [OK] and t.logged("log 1 logStatusWarning fmi3FreeFMUState: given the FMU state")
    assert t.statuses("drop") == [OK] and t.statuses("run") == [OK]


def test_what_fmi3_adds_to_the_contract(built3):
    """Event mode asked of an FMU without it, array sizes, types the model has none of, event and
    configuration calls: each refused with a logged reason, through fmpy."""
    from fmpy import extract
    from fmpy.fmi3 import FMU3Slave

    path, _, md = built3["Mechanism"]
    vr = {v.name: v.valueReference for v in md.modelVariables}
    log = []

    def slave(**kw):
        s = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier="Mechanism",
                      instanceName="m")
        s.instantiate(logMessage=lambda env, status, category, message: log.append(message.decode()), **kw)
        return s

    with pytest.raises(Exception):
        slave(eventModeUsed=True)
    assert any("has no event mode (hasEventMode is false)" in m for m in log)

    def refused(call, *args, reason: str):
        s = slave()
        s.enterInitializationMode(startTime=0.0)
        s.exitInitializationMode()
        del log[:]
        with pytest.raises(Exception):
            getattr(s, call)(*args)
        assert any(reason in m for m in log), (call, log)
        s.freeInstance()

    refused("getFloat64", [vr["theta2"], vr["Fx"]], 1, reason="1 values for 2 value references")
    refused("getFloat32", [vr["theta2"]], reason="value reference %d is no Float32 variable" % vr["theta2"])
    refused("enterEventMode", reason="fmi3EnterEventMode: not supported (hasEventMode is false)")
    refused("enterStepMode", reason="step mode begins at fmi3ExitInitializationMode")
    refused("enterConfigurationMode", reason="no structural parameters")
    refused("getDirectionalDerivative", [vr["theta2"]], [vr["Fx"]], [1.0],
            reason="Fx is not an input; a co-simulation FMU's knowns are its inputs")


# -- sanitizers over random call sequences -------------------------------------------------

@pytest.fixture(scope="session")
def sanitized3(built3, tmp_path_factory):
    """The FMI 3.0 binaries and host, rebuilt from sources/ with AddressSanitizer and UBSan."""
    d = tmp_path_factory.mktemp("asan3")
    if builds.sanitizer_problem():
        pytest.skip(f"cc cannot build with sanitizers here: {builds.sanitizer_problem()}")
    out = {"host": builds.host(fmi=3, flags=SANITIZE)}
    for name in ("Mechanism", "DCMotor"):
        _, unzipped_dir, desc = built3[name]
        out[name] = sanitized_binary(unzipped_dir, desc, d / f"{name}.so")
    return out


@pytest.mark.parametrize("name", ["Mechanism", "DCMotor"])
def test_random_fmi3_call_sequences_never_crash_nor_corrupt_memory(built3, sanitized3, name, tmp_path):
    md = built3[name][2]
    script = random_script(md, np.random.default_rng(5), tmp_path)
    proc = subprocess.run([str(sanitized3["host"]), str(sanitized3[name]), md.guid], input="\n".join(script) + "\n",
                          capture_output=True, text=True, timeout=600, env=SANITIZER_ENV)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Sanitizer" not in proc.stderr and "runtime error" not in proc.stderr, proc.stderr[-3000:]
    t = Transcript(proc.stdout)
    statuses = [int(r[1]) for r in t.results if len(r) > 1 and r[1].lstrip("-").isdigit()]
    assert len(statuses) > 500 and set(statuses) <= {OK, 1, DISCARD, ERROR}  # never fmi3Fatal
    assert t.statuses("step").count(OK) > 100 and ERROR in statuses


# -- fmusim, the FMI Reference FMUs' importer --------------------------------------------------

def fmusim() -> str:
    """fmusim's path (GRUBLER_FMUSIM, else PATH), or skip saying how to get it."""
    path = os.environ.get("GRUBLER_FMUSIM") or shutil.which("fmusim")
    if not path or not os.access(path, os.X_OK):
        pytest.skip("fmusim not found (set GRUBLER_FMUSIM or put it on PATH; docs/fmi.md says how to build it)")
    return path


def run_fmusim(fmu: Path, out: Path, name: str, *extra: str) -> np.ndarray:
    starts = [a for k, v in INPUTS.get(name, {}).items() for a in ("--start-value", k, repr(v))]
    proc = subprocess.run([fmusim(), "--interface-type", "cs", "--stop-time", "0.5", "--output-interval", "0.01",
                           *starts, *extra, "--output-file", str(out), str(fmu)],
                          capture_output=True, text=True, env={}, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    # (deletechars="": numpy would strip the dots of the spatial FMU's names, closure.Mx read as closureMx)
    return np.genfromtxt(out, delimiter=",", names=True, deletechars="")


@EVERY
def test_fmusim_runs_fmi3_as_fmi2_with_an_empty_environment(built2, built3, name, tmp_path):
    r3 = run_fmusim(built3[name][0], tmp_path / "3.csv", name)
    r2 = run_fmusim(built2[name][0], tmp_path / "2.csv", name)
    assert len(r3) == len(r2) == 51 and r3.dtype.names == r2.dtype.names
    assert set(outputs(built3[name][2])) <= set(r3.dtype.names)
    for k in r3.dtype.names:
        assert np.array_equal(r3[k], r2[k], equal_nan=True), k
    assert name not in INPUTS or max(np.ptp(r3[k]) for k in outputs(built3[name][2])) > 0  # it moved


@pytest.mark.parametrize("fmi", [2, 3])
def test_fmusim_saves_and_resumes_a_state(built2, built3, fmi, tmp_path):
    # fmusim serialises the final state and starts a run from it (deserialised and set before
    # initialisation, then stepped without initialising)
    fmu, state = {2: built2, 3: built3}[fmi]["Mechanism"][0], tmp_path / "state.bin"
    whole = run_fmusim(fmu, tmp_path / "whole.csv", "Mechanism")
    run_fmusim(fmu, tmp_path / "first.csv", "Mechanism", "--final-fmu-state-file", str(state))
    assert state.stat().st_size > 48 and state.read_bytes()[:8] == b"GRBFMI2S"
    again = run_fmusim(fmu, tmp_path / "again.csv", "Mechanism", "--initial-fmu-state-file", str(state),
                       "--start-time", "0.5", "--stop-time", "1.0")
    assert float(again["time"][0]) == 0.5 and float(again["theta2"][0]) == float(whole["theta2"][-1])


# -- the command line -------------------------------------------------------------------

def test_grubler_export_fmi3_and_a_bad_version(tmp_path):
    out = tmp_path / "Crank.fmu"
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export", "fourbar-crank-rocker", "-o", str(out),
                           "--fmi", "3"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    names = zipfile.ZipFile(out).namelist()
    assert "binaries/x86_64-linux/Crank.so" in names and "sources/fmi3_wrapper.c" in names
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(out)) == []
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export", "fourbar-crank-rocker", "-o", str(out),
                           "--fmi", "4"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "--fmi" in proc.stderr


# -- a small thread stack: every FMU stepped where an importer's secondary thread would -------------
# macOS gives a secondary thread 512 kB; the host's thread here has half that, a guard page below it
SMALL_STACK = 256 * 1024
# what a run may touch of it, the host's own frames included: a few kB of FMU, never an array of the state
STACK_BUDGET = 64 * 1024
# a law at export-law's limit of state (MAX_LAW_STATE doubles, 800 kB): each sample walks it all; a
# sample with an input below -1e6 is refused (law_step returns non-zero)
BIG_LAW = """#include "grubler_law.h"
GRUBLER_PARAMETER(Ts, 1e-3, "sample time [s]")
GRUBLER_INPUT(u, "input [1]")
GRUBLER_OUTPUT(y, "the mean of the inputs so far [1]")
GRUBLER_STATE({n})

int law_step(const double *param, double *state, double t, const double *in, double *out) {{
    int k;
    (void)param;
    (void)t;
    if (in[INPUT_u] < -1e6) return 1;
    state[0] += 1.0;
    state[1] += in[INPUT_u];
    for (k = {n} - 1; k > 1; k--) state[k] = state[k - 1];
    out[OUTPUT_y] = state[1] / state[0];
    return 0;
}}
"""


@pytest.fixture(scope="session")
def big_law(tmp_path_factory):
    """A user's law exported with GRUBLER_STATE at export-law's limit (FMI 2.0: export-law's only version)."""
    from fmpy import read_model_description

    from grubler.controllers.native_fmu import MAX_LAW_STATE, export_law

    d = tmp_path_factory.mktemp("big_law")
    (d / "big_law.c").write_text(BIG_LAW.format(n=MAX_LAW_STATE))
    path = export_law(d / "big_law.c", d / "BigLaw.fmu")
    zipfile.ZipFile(path).extractall(d / "x")
    return path, d / "x", read_model_description(str(path))


def _small_stack(h: Host) -> Host:
    h.cmd[1:1] = ["--stack", str(SMALL_STACK)]
    return h


def _every_native(hosts, built2, built3, big_law) -> list[tuple[str, Host, object]]:
    """(label, host, description) of every native FMU: build_fmu.py's in FMI 2.0 and 3.0, and the big law."""
    out = [(f"{name} FMI {fmi}", (host2 if fmi == 2 else host3)(hosts, built, name), built[name][2])
           for fmi, built in ((2, built2), (3, built3)) for name in NATIVE]
    path, d, md = big_law
    out.append(("BigLaw FMI 2", Host(hosts[2], d / "binaries" / "linux64" / "BigLaw.so", md.guid,
                                     {v.name: v.valueReference for v in md.modelVariables}), md))
    return out


def _inputs(label: str, h: Host) -> list[str]:
    name = label.split()[0]
    held = {**INPUTS, "BigLaw": {"u": 0.5}}.get(name, {})
    return [f"setr {h.vr[k]} {v!r}" for k, v in held.items()]


def test_every_native_fmu_runs_on_a_256_kb_thread_stack_as_on_the_main_thread(hosts, built2, built3, big_law,
                                                                               tmp_path):
    # instantiate, initialise, step with every output read, save, serialise, deserialise, restore and step
    # again, free: on a thread of 256 kB (env -i), the numbers those of the main thread's 8 MB
    used = {}
    for label, h, md in _every_native(hosts, built2, built3, big_law):
        blob = tmp_path / f"{label.replace(' ', '_')}.bin"
        script = (h.start(md=md) + _inputs(label, h) + [h.run_steps(0.0, 0.01, 20, *outputs(md)), "save 0",
                                                        f"ser 0 {blob}", h.run_steps(0.2, 0.01, 10, *outputs(md)),
                                                        f"deser 1 {blob}", "load 1",
                                                        h.run_steps(0.2, 0.01, 10, *outputs(md)), "free"])
        main = h.run(script)
        small = _small_stack(h).run(script)
        assert small.statuses("run") == [OK, OK, OK], (label, small.logs)
        assert small.statuses("ser") == small.statuses("deser") == small.statuses("load") == [OK], label
        assert np.array_equal(small.rows(), main.rows(), equal_nan=True), label
        assert small.lines[-1].startswith("stack "), label
        used[label] = int(small.lines[-1].split()[1])
    assert len(used) == 2 * len(NATIVE) + 1
    assert max(used.values()) < STACK_BUDGET, used


def test_a_law_whose_state_copy_sat_on_the_stack_needed_800_kb_of_it(hosts, big_law):
    # the check holds: the host's thread is what an FMU gets, so a law that copied its state onto the stack
    # (user_law.c before: double s[N_STATE]) would have died on it; its run touches a few kB
    path, d, md = big_law
    h = _small_stack(Host(hosts[2], d / "binaries" / "linux64" / "BigLaw.so", md.guid,
                          {v.name: v.valueReference for v in md.modelVariables}))
    t = h.run(h.start(md=md) + [f"setr {h.vr['u']} 2.0", h.run_steps(0.0, 1e-3, 5, "y")])
    assert t.statuses("run") == [OK] and t.rows()[-1, 1] == 2.0
    assert int(t.lines[-1].split()[1]) < STACK_BUDGET


def test_no_function_of_a_native_fmu_keeps_more_than_8_kb_on_its_stack(built2, big_law):
    # every C file an FMU ships in sources/, compiled as the FMU is, with the compiler's frame size check: a
    # regression names the function (gcc's -Wstack-usage also counts an alloca or a variable-length array)
    from grubler.fmi.build import CFLAGS

    cc = shutil.which("gcc") or shutil.which("cc")
    check = "-Wstack-usage=8192" if "gcc" in Path(cc).name else "-Wframe-larger-than=8192"
    folders = {name: d / "sources" for name, (_, d, _) in built2.items()} | {"BigLaw": big_law[1] / "sources"}
    for name, src in folders.items():  # (each FMU's sources checked once: builds.compile_check keeps a pass)
        builds.compile_check(name, src, [cc, *CFLAGS, check, "-Werror"])


# -- back from an Error: a state saved before it restores, and the run goes on -------------------------

def test_after_an_error_a_restored_state_runs_on_as_the_run_never_interrupted(hosts, built2, built3, big_law):
    # FMI 2.0 section 2.1.3, FMI 3.0 section 2.2.3: after fmiXError the importer may restore an FMU state
    # saved before it.  The error here: a value reference the model does not have (every FMU), and for the
    # law a sample law_step refuses, after which the law's state is half advanced
    for label, h, md in _every_native(hosts, built2, built3, big_law):
        fmi = label.split()[-1]
        outs = outputs(md)
        head = h.start(md=md) + _inputs(label, h) + [h.run_steps(0.0, 0.01, 10, *outs)]
        whole = h.run(head + [h.run_steps(0.1, 0.01, 10, *outs)])
        bad = ["getr 99999"] if not label.startswith("BigLaw") else [f"setr {h.vr['u']} -1e9", "step 0.13 0.01"]
        t = h.run(head + ["save 0", h.run_steps(0.1, 0.01, 3, *outs)] + _inputs(label, h) + bad
                  + [h.getr(outs[0]), "save 1", "load 1", "load 0", h.run_steps(0.1, 0.01, 10, *outs)])
        assert t.statuses(bad[-1].split()[0])[-1] == ERROR, (label, t.logs)
        assert t.statuses("getr")[-1] == ERROR and t.logged("fmi%sSetFMUstate" % fmi if fmi == "2" else
                                                            "fmi3SetFMUState (a state saved before the error)")
        # a state may be saved in the error state, but not restored: it holds what failed
        assert t.statuses("save") == [OK, OK] and t.statuses("load") == [ERROR, OK], (label, t.logs)
        assert t.logged("the state was saved in the error state"), label
        assert t.statuses("run") == [OK, OK, OK], (label, t.logs)
        assert np.array_equal(t.rows()[-10:], whole.rows()[-10:], equal_nan=True), label


# -- a scene number beyond the scene reader's bound ------------------------------------------------

@pytest.fixture(scope="session")
def boom(hosts, tmp_path_factory):
    """luffing-boom (a cylinder, the actuator 'lift') exported as FMI 2.0 and 3.0, and a host for each."""
    from fmpy import read_model_description

    from grubler.fmi.build import export
    from grubler.mechanism.scene import load_scene

    out = {}
    for fmi in (2, 3):
        d = tmp_path_factory.mktemp(f"boom{fmi}")
        path = export(load_scene("luffing-boom"), d / "Boom.fmu", fmi=fmi)
        zipfile.ZipFile(path).extractall(d / "x")
        md = read_model_description(str(path))
        lib = d / "x" / "binaries" / ("linux64" if fmi == 2 else "x86_64-linux") / "Boom.so"
        out[fmi] = ((Host if fmi == 2 else Host3)(hosts[fmi], lib, md.guid,
                                                  {v.name: v.valueReference for v in md.modelVariables}), md)
    return out


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("name, value", [("lift.from_point_x", 1e300), ("lift.to_point_y", -2e12),
                                         ("link2.a", 1e13)])
def test_a_scene_number_beyond_the_scene_readers_bound_is_an_error_naming_it(boom, fmi, name, value):
    # fmi2SetReal(lift.from_point_x, 1e300) was taken, and lift_length then read inf with fmi2OK
    h, md = boom[fmi]
    t = h.run(h.start({name: value}, md=md) + [h.getr("lift_length"), "reset", *h.start(md=md),
                                               h.run_steps(0.0, 0.01, 3, "lift_length")])
    assert t.statuses("exit")[0] == ERROR and t.statuses("getr") == [ERROR], t.logs
    assert t.logged(f"{name}: magnitude above 1e+12 is outside the supported range, got {value:g}"), t.logs
    assert t.statuses("exit")[1] == OK and t.statuses("run") == [OK]
    assert np.isfinite(t.rows()[:, 1]).all()
    # at the bound itself the number is taken (the scene reader's too), and refused for what it means
    t = h.run(h.start({name: math.copysign(1e12, value)}, md=md))
    assert not t.logged("outside the supported range"), t.logs
