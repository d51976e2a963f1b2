"""The native Mechanism.fmu: C kernel + FMI 2.0 wrapper, run with no Python in the process.

Most checks drive the FMU's binary from a small C host (tests/fmi_host.c, built
here with ``cc``) started with an empty environment, so nothing of Python can
reach it.  The references are the library's own :class:`grubler.Simulator`
stepped to the same communication points (the same kernel through ctypes), the
model description's start values, and the FMI contract itself.
"""

from __future__ import annotations

import shutil
import struct
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import grubler
from grubler.fmi.build import FMI_HEADERS, fmi_headers_dir
from grubler.fmi.mechanism import fmu_parameters

import builds
from c_host import compile_host

HERE = Path(__file__).parent
ROOT = HERE.parent
OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
MATCH = 1e-12


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="session")
def built(tmp_path_factory):
    """dist/'s native FMUs as build_fmu.py makes them, unzipped too."""
    sys.path.insert(0, str(ROOT))
    import builds
    from fmpy import read_model_description

    out = {}
    for path in builds.dist(tmp_path_factory.mktemp("dist"), ["Mechanism", "DCMotor", "HydraulicCylinder",
                                                                          "PneumaticCylinder"]):
        d = tmp_path_factory.mktemp(path.stem)
        zipfile.ZipFile(path).extractall(d)
        out[path.stem] = (path, d, read_model_description(str(path)))
    return out


@pytest.fixture(scope="session")
def fmu(built):
    return built["Mechanism"][0]


@pytest.fixture(scope="session")
def unzipped(built):
    return built["Mechanism"][1]


@pytest.fixture(scope="session")
def md(built):
    return built["Mechanism"][2]


@pytest.fixture(scope="session")
def host():
    """tests/fmi_host.c, compiled against the FMI headers fmpy ships (once: builds.py)."""
    return builds.host()


class Host:
    """Runs scripts through the C host on one FMU binary, with an empty environment."""

    def __init__(self, host: Path, library: Path, guid: str, vr: dict[str, int], wrapper: list[str] | None = None):
        self.cmd = [*(wrapper or []), str(host), str(library), guid]
        self.vr = vr

    def run(self, script: list[str], env: dict | None = None, timeout: float = 600) -> "Transcript":
        proc = subprocess.run(self.cmd, input="\n".join(script) + "\n", capture_output=True, text=True,
                              env={} if env is None else env, timeout=timeout)
        assert proc.returncode == 0, f"host failed ({proc.returncode}):\n{proc.stderr[-2000:]}\n{proc.stdout[-2000:]}"
        return Transcript(proc.stdout)

    def start(self, params: dict | None = None, k: int = 0, name: str = "m", t0: float = 0.0,
              md=None) -> list[str]:
        """Lines that instantiate slot k, set parameters by their type, and initialise."""
        lines = [f"new {k} {name}", f"setup {t0!r}", "enter"]
        lines += self.set_lines(params or {}, md)
        return lines + ["exit"]

    def set_lines(self, params: dict, md) -> list[str]:
        types = {v.name: v.type for v in md.modelVariables}
        lines = []
        for name, value in params.items():
            t = types[name]
            if t == "String":
                lines.append(f"sets {self.vr[name]} {value if value != '' else '-'}")
            elif t in ("Integer", "Enumeration"):
                lines.append(f"seti {self.vr[name]} {int(value)}")
            else:
                lines.append(f"setr {self.vr[name]} {float(value)!r}")
        return lines

    def getr(self, *names: str) -> str:
        return "getr " + " ".join(str(self.vr[n]) for n in names)

    def run_steps(self, t0: float, h: float, n: int, *names: str) -> str:
        return f"run {t0!r} {h!r} {n} " + " ".join(str(self.vr[n]) for n in names)


class Transcript:
    def __init__(self, text: str):
        self.text = text
        self.lines = text.splitlines()
        self.logs = [ln for ln in self.lines if ln.startswith("log ")]
        self.results = [ln.split() for ln in self.lines if not ln.startswith(("log ", "row "))]

    def rows(self, width: int | None = None) -> np.ndarray:
        """The run commands' rows (those with ``width`` numbers, time included, if given)."""
        rows = [[float(x) for x in ln.split()[1:]] for ln in self.lines if ln.startswith("row ")]
        return np.array([r for r in rows if width is None or len(r) == width])

    def status(self, k: int) -> int:
        """Status of the k-th command (negative k from the end)."""
        return int(self.results[k][1])

    def statuses(self, cmd: str) -> list[int]:
        return [int(r[1]) for r in self.results if r[0] == cmd]

    def values(self, k: int) -> list[str]:
        return self.results[k][2:]

    def logged(self, text: str) -> bool:
        return any(text in ln for ln in self.logs)


def host_for(host, built, name: str) -> Host:
    _, d, desc = built[name]
    vr = {v.name: v.valueReference for v in desc.modelVariables}
    return Host(host, d / "binaries" / "linux64" / f"{name}.so", desc.guid, vr)


@pytest.fixture(scope="session")
def native(host, built):
    return host_for(host, built, "Mechanism")


@pytest.fixture(scope="session")
def motor(host, built):
    return host_for(host, built, "DCMotor")


BOTH = pytest.mark.parametrize("name", ["Mechanism", "DCMotor"])


def library_steps(scene, h: float, n: int, names, torque: float = 3.0, t0: float = 0.0) -> np.ndarray:
    """The library stepped like an FMU: the torque held, advance_to each communication point, outputs read."""
    if isinstance(scene, str):
        scene = grubler.load_scene(scene)
    sim = grubler.Simulator(scene.mechanism, method=scene.method, zd0=scene.initial_rates, t0=t0)
    rows = []
    for i in range(n):
        sim.set_inputs(torque, 0.0)
        sim.advance_to((t0 + i * h) + h)  # the host's arithmetic: doStep(t0 + i h, h)
        out = sim.outputs(["state", "dynamics", "energy", "reactions"])
        z, zd = sim.joint_state(sim.model.arrays.drive)
        out.update(drive_angle=z, drive_speed=zd)
        rows.append([t0 + (i + 1) * h] + [out[k] for k in names])  # what the host prints
    return np.array(rows)


NAMES = ("theta2", "theta3", "theta4_d", "theta2_dd", "tip_x", "closure_error", "Fx", "Fy", "Mz", "KE", "PE",
         "R2_Fx", "drive_angle", "drive_speed")
MOTOR_NAMES = ("shaft_torque", "current", "winding_temperature", "electrical_power", "motor_speed", "back_emf",
               "terminal_voltage", "reflected_inertia")
# a run of 100 steps of 10 ms per FMU: constant inputs, outputs read after every step
RUNS = {"Mechanism": ({"motor_torque": 3.0}, NAMES),
        "DCMotor": ({"voltage": 24.0, "shaft_speed": 5.0}, MOTOR_NAMES)}


def _script(name):
    inputs, names = RUNS[name]
    return lambda h: [f"setr {h.vr[k]} {v!r}" for k, v in inputs.items()] + [h.run_steps(0, 0.01, 100, *names)]


SCRIPTS = {name: _script(name) for name in RUNS}


# -- the binary -----------------------------------------------------------------

@pytest.mark.parametrize("name", ["Mechanism", "DCMotor", "HydraulicCylinder", "PneumaticCylinder"])
def test_the_binary_needs_no_python_and_exports_only_fmi2(built, name):
    so = built[name][1] / "binaries" / "linux64" / f"{name}.so"
    undefined = subprocess.run(["nm", "-D", "--undefined-only", str(so)], capture_output=True, text=True,
                               check=True).stdout
    assert undefined.strip()  # libc and libm functions at least
    assert not [ln for ln in undefined.splitlines() if "Py" in ln or "python" in ln.lower()]
    defined = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True,
                             check=True).stdout.split("\n")
    exported = [ln.split()[-1] for ln in defined if ln.strip() and ln.split()[1] in "TD"]
    assert exported and all(name.startswith("fmi2") for name in exported), exported
    deps = subprocess.run(["ldd", str(so)], capture_output=True, text=True).stdout
    assert "python" not in deps.lower()


@BOTH
def test_fmpy_validate_passes(built, name):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(built[name][0])) == []


def test_model_description_is_self_contained_with_units_and_structure(md):
    cs = md.coSimulation
    assert cs.needsExecutionTool is False or cs.needsExecutionTool == "false" or not cs.needsExecutionTool
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    by = {v.name: v for v in md.modelVariables}
    assert by["theta2"].unit == "rad" and by["B1_d"].unit == "m/s" and by["Fx"].unit == "N"
    assert by["Mz"].unit == "N.m" and by["link2.I"].unit == "kg.m2" and by["gravity"].unit == "m/s2"
    assert by["link3.m"].min == "0.0" or float(by["link3.m"].min) == 0.0
    assert by["link2.joint"].type == "Enumeration" and by["closure.type"].type == "Enumeration"
    units = {u.name for u in md.unitDefinitions}
    assert {v.unit for v in md.modelVariables if v.unit} <= units
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    assert len(md.outputs) == len(outputs) and len(md.initialUnknowns) == len(outputs)
    deps = {u.variable.name: [d.name for d in (u.dependencies or [])] for u in md.outputs}
    assert deps["theta2"] == [] and deps["drive_speed"] == [] and deps["KE"] == []
    assert sorted(deps["Fx"]) == ["load_torque", "motor_torque"] and deps["theta2_dd"]
    files = md.buildConfigurations[0].sourceFileSets[0].sourceFiles
    assert "fmi2_wrapper.c" in files and "mechanism_model.c" in files


@BOTH
def test_value_references_agree_between_binary_and_description(host, built, name):
    # what the binary reads at each value reference is what the description declares there
    native, md = host_for(host, built, name), built[name][2]
    stored = [v for v in md.modelVariables if v.causality in ("parameter", "input")]
    script = native.start(md=md)[:-1]  # in initialisation mode, every variable is readable
    for v in stored:
        kind = {"Real": "getr", "String": "gets"}.get(v.type, "geti")
        script.append(f"{kind} {v.valueReference}")
    t = native.run(script)
    got = t.results[-len(stored):]
    for v, r in zip(stored, got):
        assert r[1] == "0", (v.name, r)
        if v.type == "Real":
            assert float(r[2]) == float(v.start), v.name
        elif v.type == "String":
            assert r[2] == f"[{v.start}]", v.name
        else:
            assert int(r[2]) == int(v.start), v.name


def test_the_library_and_the_fmu_build_the_same_tables_as_the_model_locks_coordinates():
    # grb_scene_tables (C) builds the kernel's tables for the library and the FMU
    # alike; the locked coordinates must be the Python model's own (q_from_z uses them)
    from grubler.mechanism.model import L_APRED, L_PARENT, L_SLIDE0, L_THETA0

    for preset in grubler.mechanism.scene.preset_names():
        m = grubler.load_scene(preset).mechanism
        L = m.arrays.links
        assert np.array_equal(L[:, L_SLIDE0], m._q_locked[0::2]), preset
        assert np.array_equal(L[:, L_THETA0], m._q_locked[1::2]), preset
        # each link's predecessor: the previous link, or any earlier one in a tree (stephenson-iii)
        assert np.array_equal(L[:, L_APRED], [m.a1 if pk == 1 else m.links[pk - 2].a for pk in m.parents]), preset
        assert np.array_equal(L[:, L_PARENT], np.array(m.parents) - 2), preset


# -- physics: what the library computes ---------------------------------------------

def test_c_host_with_an_empty_environment_matches_the_library(native, md):
    t = native.run(native.start(md=md) + [f"setr {native.vr['motor_torque']} 3.0", native.run_steps(0.0, 0.01, 200, *NAMES)])
    assert t.statuses("run") == [OK]
    rows = t.rows()
    lib = library_steps("thesis-fourbar", 0.01, 200, NAMES)
    assert rows.shape == lib.shape == (200, 1 + len(NAMES))
    np.testing.assert_allclose(rows, lib, rtol=0, atol=MATCH)
    assert abs(rows[-1, 1] - rows[0, 1]) > 0.1  # it moved


@pytest.mark.parametrize("preset", ["thesis-slider-crank", "thesis-scotch-yoke", "thesis-oldham",
                                    "thesis-double-slider", "thesis-swinging-block", "thesis-quick-return",
                                    "thesis-conchoidal", "offset-slider-crank"])
def test_one_fmu_retuned_into_each_inversion_by_its_parameters(native, md, preset):
    scene = grubler.load_scene(preset)
    names = ("theta2", "B2", "theta3", "B3", "theta4", "Fx", "Fy", "KE", "drive_angle")
    torque = 0.5
    t = native.run(native.start(fmu_parameters(scene), md=md)
                   + [f"setr {native.vr['motor_torque']} {torque}", native.run_steps(0.0, 0.01, 50, *names)])
    assert t.statuses("exit") == [OK], t.logs
    lib = library_steps(scene, 0.01, 50, names, torque=torque)
    np.testing.assert_allclose(t.rows(), lib, rtol=0, atol=MATCH)


def test_the_penalty_closure_and_other_integrators_as_in_the_library(native, md):
    # the FMU has the kernel's explicit integrators only (its 'auto' is dop853 for
    # both closures; the library's scipy Radau and BDF are not in C)
    scene = grubler.load_scene("thesis-fourbar")
    names = ("theta2", "Fx", "closure_error")
    for params, integrator, step in (({"method": "penalty"}, "dop853", 1e-3), ({"integrator": "rk45"}, "rk45", 1e-3),
                                     ({"integrator": "rk4", "step": 2e-4}, "rk4", 2e-4)):
        t = native.run(native.start(params, md=md) + [f"setr {native.vr['motor_torque']} 3.0",
                                                      native.run_steps(0, 0.01, 30, *names)])
        sim = grubler.Simulator(scene.mechanism, method=params.get("method", "exact"), integrator=integrator, step=step)
        lib = []
        for i in range(30):
            sim.set_inputs(3.0, 0.0)
            sim.advance_to((i * 0.01) + 0.01)
            out = sim.outputs(["state", "dynamics"])
            lib.append([(i + 1) * 0.01] + [out[n] for n in names])
        np.testing.assert_allclose(t.rows(), np.array(lib), rtol=0, atol=MATCH, err_msg=str(params))


def test_a_penalty_closure_on_a_link_without_inertia_is_refused_at_initialisation(native, md):
    t = native.run(native.start({"method": "penalty", "link4.I": 0.0, "link4.p": 0.0}, md=md) + ["step 0 0.01"])
    assert t.statuses("exit") == [ERROR] and t.logged("method: the penalty closure cannot move the mechanism")


def test_the_loop_that_cannot_close_is_an_error_with_its_reason(native, md):
    t = native.run(native.start({"link2.a": 5.0}, md=md) + ["step 0 0.01"])
    assert t.statuses("exit") == [ERROR]
    assert t.logged("cannot be closed")
    assert t.statuses("step") == [ERROR]


# -- state ---------------------------------------------------------------------

def _reads_in_orders(fmu, md, start: list[str], h: float, steps: int, state: list[str]):
    """After each step, the outputs read in one of several orders and subsets, and, in a second run along the
    same steps, all of them at once: (subset read, what reading everything gave at that step) pairs."""
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    rest = [n for n in outputs if n not in state]
    reactions = [n for n in outputs if n.startswith("R") and n[1].isdigit()]
    orders = [[state], [state[::-1], rest], [reactions, state], [outputs[::-1]], [[n] for n in state[:4]],
              [[state[1]], rest[:3], state], [rest, state]]
    subset_script, whole_script, asked = list(start), list(start), []
    for i in range(steps):
        step = f"step {i * h!r} {h!r}"
        subset_script.append(step)
        whole_script += [step, fmu.getr(*outputs)]
        for names in orders[i % len(orders)]:
            subset_script.append(fmu.getr(*names))
            asked.append((i, names))
    subsets, whole = fmu.run(subset_script), fmu.run(whole_script)
    assert set(subsets.statuses("step")) == set(whole.statuses("step")) == {OK}
    assert set(subsets.statuses("getr")) == set(whole.statuses("getr")) == {OK}
    every = [dict(zip(outputs, r[2:])) for r in whole.results if r[0] == "getr"]
    read = [r[2:] for r in subsets.results if r[0] == "getr"]
    return [(got, [every[i][n] for n in names]) for (i, names), got in zip(asked, read)]


@pytest.mark.parametrize("preset", ["thesis-fourbar", "thesis-slider-crank"])
def test_outputs_read_in_any_order_or_subset_are_those_read_all_at_once(native, md, preset):
    """The coordinates and rates come from the state's kinematic pass, the rest from one evaluation: read alone,
    first, last or between the others, each output has the bits it has when everything is read at once."""
    scene = grubler.load_scene(preset)
    names = scene.mechanism.coordinate_names
    state = [*names, *(f"{x}_d" for x in names), "drive_angle", "drive_speed"]
    start = native.start(fmu_parameters(scene), md=md) + [f"setr {native.vr['motor_torque']} 0.5"]
    pairs = _reads_in_orders(native, md, start, 0.01, 21, state)
    assert len(pairs) > 21
    for got, expected in pairs:
        assert got == expected


def test_the_coordinates_and_rates_are_read_without_evaluating_the_dynamics(built, md):
    """Each coordinate and rate is at the kinematic pass's level, below the forward-dynamics evaluation's (the
    accelerations'), above the drive angle's (a copy of the state, what a coupling reads each step): an importer
    that reads the crank angle after each step does not pay for an evaluation."""
    from grubler.fmi.header import read_variables_source

    rows = {r.name: r for r in read_variables_source((built["Mechanism"][1] / "sources" / "model_variables.c")
                                                     .read_text())}
    names = [v.name for v in md.modelVariables if v.causality == "output" and v.name.startswith(("theta", "B"))]
    assert "theta2" in names and "theta2_d" in names and "theta2_dd" in names
    for n in names:
        expected = rows["theta2_dd"].level if n.endswith("_dd") else rows["theta2"].level
        assert rows[n].level == expected, n
    assert rows["drive_angle"].level < rows["theta2"].level < rows["theta2_dd"].level


def test_serialised_state_round_trips_bit_exactly(native, md, tmp_path):
    blob, again = tmp_path / "s.bin", tmp_path / "again.bin"
    names = ("theta2", "Fx", "KE")
    t = native.run(native.start(md=md) + [f"setr {native.vr['motor_torque']} 3.0", native.run_steps(0, 0.01, 100),
                                          "save 0", f"ser 0 {blob}", native.run_steps(1.0, 0.01, 50, *names),
                                          f"deser 1 {blob}", "load 1", f"ser 1 {again}",
                                          native.run_steps(1.0, 0.01, 50, *names)])
    assert set(t.statuses("ser")) == {OK} and t.statuses("deser") == [OK] and t.statuses("load") == [OK]
    assert blob.read_bytes() == again.read_bytes()
    rows = t.rows(width=4)
    first, replay = rows[:50], rows[50:]
    assert first.shape == (50, 4) and np.array_equal(first, replay)


@pytest.mark.parametrize("damage", ["corrupted", "truncated", "foreign", "padded", "version"])
def test_a_bad_state_blob_is_refused_with_an_error(native, md, tmp_path, damage):
    good = tmp_path / "good.bin"
    native.run(native.start(md=md) + [native.run_steps(0, 0.01, 10), "save 0", f"ser 0 {good}"])
    data = bytearray(good.read_bytes())
    if damage == "corrupted":
        data[len(data) // 2] ^= 0x10
        expect = "checksum"
    elif damage == "truncated":
        data = data[: len(data) - 8]
        expect = "truncated"
    elif damage == "padded":
        data += b"\0" * 8
        expect = "bytes"
    elif damage == "version":
        data[8] = 99
        expect = "version"
    else:  # a state of another model: same layout, another GUID
        data[24] ^= 0xFF
        expect = "another model"
    bad = tmp_path / "bad.bin"
    bad.write_bytes(bytes(data))
    t = native.run(native.start(md=md) + [f"deser 1 {bad}", "load 1", native.getr("theta2")])
    assert t.statuses("deser") == [ERROR]
    assert t.logged(expect), t.logs
    assert t.statuses("load") == [ERROR] and t.statuses("getr") == [ERROR]  # and the instance stays refused


def test_a_state_of_another_fmu_is_refused(native, motor, built, tmp_path):
    blob = tmp_path / "motor.bin"
    motor.run(motor.start(md=built["DCMotor"][2]) + [motor.run_steps(0, 1e-3, 5), "save 0", f"ser 0 {blob}"])
    assert blob.stat().st_size > 48
    t = native.run(native.start(md=built["Mechanism"][2]) + [f"deser 0 {blob}"])
    assert t.statuses("deser") == [ERROR] and t.logged("the state belongs to another model")


def test_a_state_set_before_initialisation_is_honoured(native, md, tmp_path):
    blob = tmp_path / "s.bin"
    names = ("theta2", "theta2_d", "Fx")
    t = native.run(native.start(md=md) + [f"setr {native.vr['motor_torque']} 2.0", native.run_steps(0, 0.01, 70),
                                          "save 0", f"ser 0 {blob}", native.run_steps(0.7, 0.01, 30, *names),
                                          # a new instance: the state restored before initialisation
                                          "new 1 later", f"deser 1 {blob}", "load 1", "setup 0", "enter", "exit",
                                          native.run_steps(0.7, 0.01, 30, *names)])
    assert t.statuses("exit") == [OK, OK]
    rows = t.rows(width=4)
    assert rows.shape == (60, 4) and np.array_equal(rows[:30], rows[30:])


def test_a_state_restored_while_stepping_brings_its_parameters(native, md, tmp_path):
    # instance a (a heavier crank) saves at 0.5 s; instance b, at 0.3 s with the
    # default crank, restores it and must go on exactly as a does
    blob = tmp_path / "a.bin"
    names = ("theta2", "Fx")
    torque = f"setr {native.vr['motor_torque']} 3.0"
    t = native.run(native.start({"link2.m": 2.0}, md=md) + [torque, native.run_steps(0, 0.01, 50), "save 0",
                                                            f"ser 0 {blob}", native.run_steps(0.5, 0.01, 20, *names)]
                   + native.start(k=1, name="b", md=md) + [torque, native.run_steps(0, 0.01, 30), f"deser 1 {blob}",
                                                           "load 1", native.run_steps(0.5, 0.01, 20, *names)])
    rows = t.rows(width=3)
    assert rows.shape == (40, 3) and np.array_equal(rows[:20], rows[20:])


def test_reset_runs_again_from_the_start(native, md):
    names = ("theta2", "Fx")
    t = native.run(native.start(md=md) + [f"setr {native.vr['motor_torque']} 3.0", native.run_steps(0, 0.01, 40, *names),
                                          "reset", "setup 0", "enter", "exit",
                                          f"setr {native.vr['motor_torque']} 3.0", native.run_steps(0, 0.01, 40, *names)])
    rows = t.rows()
    assert np.array_equal(rows[:40], rows[40:])


def test_many_instances_in_one_process(native, md):
    masses = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]
    script = []
    for k, m in enumerate(masses):
        script += native.start({"link2.m": m}, k=k, name=f"m{k}", md=md)
        script.append(f"setr {native.vr['motor_torque']} 3.0")
    for i in range(30):  # interleaved: each instance one step in turn
        for k in range(len(masses)):
            script += [f"use {k}", native.run_steps(i * 0.01, 0.01, 1, "theta2")]
    rows = native.run(script).rows()
    assert rows.shape == (30 * len(masses), 2)
    scene = grubler.load_scene("thesis-fourbar")
    for k, m in enumerate(masses):
        sc = grubler.mechanism.scene.override(scene, {"link2.m": m})
        lib = library_steps(sc, 0.01, 30, ("theta2",))
        np.testing.assert_allclose(rows[k:: len(masses)], lib, rtol=0, atol=MATCH)


# -- the error contract: one test per class ---------------------------------------------

def _contract(native, md, lines: list[str]):
    return native.run(native.start(md=md) + lines + [native.getr("theta2"), "reset", "setup 0", "enter", "exit",
                                                     native.run_steps(0, 0.01, 2, "theta2")])


def _refused_then_reset_works(t, cmd: str):
    assert t.statuses(cmd)[-1] == ERROR
    assert t.statuses("getr")[-1] == ERROR and t.logged("an earlier call failed")  # any call after an error
    assert t.statuses("reset") == [OK] and t.statuses("run") == [OK]  # fmi2Reset recovers


def test_unknown_value_reference(native, md):
    t = _contract(native, md, ["getr 99999"])
    assert t.logged("unknown value reference 99999")
    _refused_then_reset_works(t, "getr")


def test_wrong_type(native, md):
    t = _contract(native, md, [f"geti {native.vr['theta2']}"])
    assert t.logged("theta2") and t.logged("is a Real variable, not Integer")
    _refused_then_reset_works(t, "geti")


def test_set_an_output(native, md):
    t = _contract(native, md, [f"setr {native.vr['Fx']} 1.0"])
    assert t.logged("Fx is an output")
    _refused_then_reset_works(t, "setr")


def test_a_parameter_after_initialisation(native, md):
    t = _contract(native, md, [f"setr {native.vr['link2.m']} 2.0"])
    assert t.logged("link2.m is a fixed parameter; it cannot change after initialisation")
    _refused_then_reset_works(t, "setr")


def test_an_unknown_string_value(native, md):
    t = native.run([*native.start(md=md)[:-1], f"sets {native.vr['method']} lagrange"])
    assert t.statuses("sets") == [ERROR] and t.logged("method cannot be 'lagrange'; it accepts 'exact', 'penalty'")


def test_do_step_before_initialisation_and_after_terminate(native, md):
    t = native.run(["new 0 a", "setup 0", "step 0 0.01"])
    assert t.statuses("step") == [ERROR] and t.logged("fmi2DoStep is not allowed in the state instantiated")
    t = native.run(native.start(md=md) + ["step 0 0.01", "term", "step 0.01 0.01"])
    assert t.statuses("step") == [OK, ERROR] and t.logged("not allowed in the state terminated")


def test_a_bad_parameter_reads_back_and_is_refused_at_initialisation(native, md):
    t = native.run([*native.start({"link2.m": -1.0}, md=md)[:-1], native.getr("link2.m"), "exit"])
    assert t.statuses("getr") == [OK] and t.values(-2) == ["-1"]
    assert t.statuses("exit") == [ERROR]


def test_a_bad_parameter_is_an_error_at_initialisation_naming_it(native, md):
    t = native.run(native.start({"link2.m": -1.0}, md=md) + ["step 0 0.01"])
    assert t.statuses("exit") == [ERROR] and t.logged("link2.m: mass must be positive, got -1")
    assert t.statuses("step") == [ERROR]
    t = native.run(native.start({"drive_joint": "B2"}, md=md))
    assert t.statuses("exit") == [ERROR] and t.logged("drive_joint: B2 is a locked (fictitious) coordinate")


def test_a_non_finite_input_is_discarded_with_its_reason(native, md):
    t = native.run(native.start(md=md) + [native.run_steps(0, 0.01, 3), f"setr {native.vr['motor_torque']} nan",
                                          "step 0.03 0.01", f"setr {native.vr['motor_torque']} 1.0", "step 0.03 0.01"])
    assert t.statuses("step") == [DISCARD, OK]
    assert t.logged("motor_torque is nan at t = 0.03 s: inputs must be finite")


def test_an_integration_failure_is_discarded_with_its_reason(native, md):
    t = native.run(native.start(md=md) + [f"setr {native.vr['motor_torque']} 1e300", "step 0 0.01",
                                          f"setr {native.vr['motor_torque']} 1.0", "step 0 0.01"])
    assert t.statuses("step") == [DISCARD, OK]
    assert t.logged("step from t = 0 s failed")


def test_a_null_instance_does_not_crash_the_host(native):
    t = native.run(["null"])
    assert t.statuses("null") == [ERROR]


SANITIZE = builds.SANITIZE
SANITIZER_ENV = {"ASAN_OPTIONS": "halt_on_error=1:detect_leaks=1", "UBSAN_OPTIONS": "halt_on_error=1"}


def sanitized_binary(unzipped_dir: Path, desc, out: Path) -> Path:
    """An FMU's binary rebuilt from its sources/ with AddressSanitizer and UBSan (once per sources: builds.py)."""
    return builds.sanitized_binary(unzipped_dir, desc, out)


@pytest.fixture(scope="session")
def sanitized(built, tmp_path_factory):
    return sanitize_all(built, tmp_path_factory.mktemp("asan"))


def sanitize_all(built: dict, d: Path) -> dict:
    """The FMUs' binaries and the host, rebuilt in d from sources/ with AddressSanitizer and UBSan."""
    if builds.sanitizer_problem():
        pytest.skip(f"cc cannot build with sanitizers here: {builds.sanitizer_problem()}")
    out = {"host": builds.host(flags=SANITIZE)}
    for name, (_, unzipped_dir, desc) in built.items():
        out[name] = sanitized_binary(unzipped_dir, desc, d / f"{name}.so")
    return out


def random_script(md, rng, tmp_path, n: int = 40) -> list[str]:
    """n random episodes of FMI calls: mostly a proper run (parameters, initialisation,
    steps with inputs, outputs read, states saved, serialised and restored), with a
    random call anywhere now and then: any state, any value reference, any value,
    good and bad state blobs."""
    variables = md.modelVariables
    n_vr = len(variables)
    params = [v for v in variables if v.causality == "parameter" and v.type == "Real"]
    inputs = [v.valueReference for v in variables if v.causality == "input"]
    outputs = [v.valueReference for v in variables if v.causality == "output"]
    strings = [c for v in variables if v.type == "String" for c in (v.start, "")] + ["garbage", "-"]
    numbers = ["0", "1", "-1", "0.5", "3", "1e300", "-1e300", "nan", "inf", "-inf", "1e-300", "2"]
    blobs = [tmp_path / f"s{k}.bin" for k in range(3)]
    (tmp_path / "junk.bin").write_bytes(bytes(rng.integers(0, 256, 200, dtype=np.uint8)))
    (tmp_path / "empty.bin").write_bytes(b"")
    files = [*blobs, tmp_path / "junk.bin", tmp_path / "empty.bin"]

    def fault() -> str:
        vr, k = int(rng.integers(0, n_vr + 4)), int(rng.integers(0, 3))
        return str(rng.choice([
            f"setr {vr} {rng.choice(numbers)}", f"seti {vr} {rng.choice(numbers)}",
            f"sets {vr} {rng.choice(strings) or '-'}", f"getr {vr}", f"geti {vr}", f"gets {vr}",
            f"step {rng.choice(['0', '0.3', 'nan'])} {rng.choice(['0', '-0.01', 'inf', 'nan', '0.01'])}",
            "enter", "exit", "term", "free", f"use {k}", f"new {k} i{k}", f"load {k}", f"drop {k}", f"save {k}",
            f"ser {k} {blobs[k]}", f"deser {k} {files[int(rng.integers(0, len(files)))]}", "null", "reset",
            "setup 0"]))

    out = []
    for _ in range(n):
        k = int(rng.integers(0, 3))
        out += [f"new {k} i{k}" if rng.random() < 0.5 else f"use {k}", "reset", "setup 0"]
        for v in rng.choice(params, size=min(3, len(params)), replace=False):
            x = float(v.start) * float(rng.choice([1.0] * 8 + [0.9, 1.1, -1.0])) if v.start else 0.0
            out.append(f"setr {v.valueReference} {x!r}")
        out += ["enter", "exit"]
        t = 0.0
        for _ in range(int(rng.integers(5, 25))):
            if rng.random() < 0.04:
                out.append(fault())
            h = float(rng.choice([1e-3, 1e-2, 5e-2]))
            out += [f"setr {vr} {float(rng.normal()) * 2:.6g}" for vr in inputs]
            out += [f"step {t!r} {h!r}", "getr " + " ".join(str(int(x)) for x in rng.choice(outputs, size=4))]
            t += h
            r = rng.random()
            if r < 0.1:
                out += [f"save {k}", f"ser {k} {blobs[k]}"]
            elif r < 0.15:
                out += [f"deser {k} {blobs[k]}", f"load {k}"]
        if rng.random() < 0.3:
            out.append("term")
    return out


@BOTH
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_random_call_sequences_never_crash_nor_corrupt_memory(built, sanitized, name, seed, tmp_path):
    random_calls_hold(sanitized, name, built[name][2], seed, tmp_path)


def random_calls_hold(sanitized: dict, name: str, md, seed: int, tmp_path: Path) -> None:
    """random_script's calls on the sanitized binary: no crash, no sanitizer report, never fmi2Fatal."""
    script = random_script(md, np.random.default_rng(seed), tmp_path)
    proc = subprocess.run([str(sanitized["host"]), str(sanitized[name]), md.guid], input="\n".join(script) + "\n",
                          capture_output=True, text=True, timeout=600, env=SANITIZER_ENV)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Sanitizer" not in proc.stderr and "runtime error" not in proc.stderr, proc.stderr[-3000:]
    t = Transcript(proc.stdout)
    statuses = [int(r[1]) for r in t.results if len(r) > 1 and r[1].lstrip("-").isdigit()]
    assert len(statuses) > 500 and set(statuses) <= {OK, WARNING, DISCARD, ERROR}  # never fmi2Fatal
    steps = t.statuses("step")
    assert steps.count(OK) > 100 and ERROR in statuses  # real runs, with faults among them


# -- other builds and masters ---------------------------------------------------------

def test_a_windows_build_without_gcc_or_fmpy_build_says_what_it_needs(tmp_path, monkeypatch):
    # Visual Studio builds go through fmpy.build, which fmpy before 0.3.26 lacks
    from grubler.fmi import build
    from grubler.fmi.mechanism import mechanism_spec

    import fmpy  # noqa: F401 - loaded here, on this platform (fmpy reads it at import)

    spec = mechanism_spec(grubler.load_scene("thesis-fourbar"), "M")
    monkeypatch.setattr(build.sys, "platform", "win32")
    monkeypatch.setattr(build.shutil, "which", lambda name: None)
    monkeypatch.setattr(build, "zig_compiler", lambda: None)  # nor the cross extra
    monkeypatch.setitem(sys.modules, "fmpy.build", None)  # import fails, as on fmpy 0.3.20
    with pytest.raises(build.BuildError, match="needs fmpy 0.3.26 or later"):
        build.build_fmu(spec, tmp_path / "M.fmu", "win64")
    assert list(tmp_path.iterdir()) == []


@BOTH
def test_fmpy_builds_a_working_binary_from_the_shipped_sources(host, built, name, tmp_path):
    """fmpy.build compiles sources/ with its own CMakeLists (fmpy/c-code); fmpy runs the result.

    fmpy's CMakeLists links no libm: a Python host has it loaded already, a C
    host that has not needs ``cmake_options={"CMAKE_SHARED_LINKER_FLAGS": "-lm"}``.
    """
    from fmpy.fmi2 import FMU2Slave

    build_platform_binary = pytest.importorskip("fmpy.build", reason="fmpy.build came with fmpy 0.3.26"
                                                ).build_platform_binary
    if shutil.which("cmake") is None:
        pytest.skip("fmpy.build needs cmake")
    native, unzipped, md = host_for(host, built, name), built[name][1], built[name][2]
    d = tmp_path / "src"
    shutil.copytree(unzipped, d)
    shutil.rmtree(d / "binaries")
    (tmp_path / "build").mkdir()
    build_platform_binary(d, build_dir=tmp_path / "build")
    assert (d / "binaries" / "linux64" / f"{name}.so").is_file()
    s = FMU2Slave(guid=md.guid, unzipDirectory=str(d), modelIdentifier=name, instanceName="built")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    inputs, names = RUNS[name]
    s.setReal([native.vr[k] for k in inputs], list(inputs.values()))
    rows = []
    for i in range(100):
        s.doStep(i * 0.01, 0.01)
        rows.append([(i + 1) * 0.01] + s.getReal([native.vr[n] for n in names]))
    s.terminate()
    s.freeInstance()
    script = native.start(md=md) + SCRIPTS[name](native)
    np.testing.assert_allclose(np.array(rows), native.run(script).rows(), rtol=0, atol=MATCH)


def test_fmpy_runs_it_like_the_c_host(native, md, fmu):
    import fmpy

    names = ["theta2", "Fx", "drive_speed"]
    sig = np.array([(0.0, 3.0, 0.0), (10.0, 3.0, 0.0)],
                   dtype=[("time", float), ("motor_torque", float), ("load_torque", float)])
    res = fmpy.simulate_fmu(str(fmu), stop_time=1.0, output_interval=1e-2, step_size=1e-2, input=sig, output=names)
    t = native.run(native.start(md=md) + [f"setr {native.vr['motor_torque']} 3.0", native.run_steps(0, 0.01, 100, *names)])
    rows = t.rows()
    for k, n in enumerate(names):
        np.testing.assert_allclose(res[n][1:], rows[:, k + 1], rtol=0, atol=MATCH)


def test_instantiated_again_after_its_first_extraction_folder_is_gone(fmu, md, native):
    # (the pythonfmu FMU could not: a stale module stayed in sys.modules)
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave

    rows = []
    for k in range(2):
        d = extract(str(fmu))
        s = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier="Mechanism", instanceName=f"m{k}")
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        s.setReal([native.vr["motor_torque"]], [3.0])
        s.doStep(0.0, 0.1)
        rows.append(s.getReal([native.vr["theta2"], native.vr["Fx"]]))
        s.terminate()
        s.freeInstance()
        shutil.rmtree(d, ignore_errors=True)
    assert rows[0] == rows[1]


def test_libcosim_runs_it_like_fmpy(fmu, tmp_path):
    pytest.importorskip("libcosimpy")
    import json

    out = tmp_path / "libcosim.json"
    subprocess.run([sys.executable, str(HERE / "libcosim_scenario.py"), str(fmu), str(out)], timeout=600)
    rows = np.array(json.loads(out.read_text())["result"]["rows"])
    lib = library_steps("thesis-fourbar", 0.01, 200, ("theta2", "Fx"))
    assert rows.shape == (200, 3)
    np.testing.assert_allclose(rows, lib, rtol=0, atol=MATCH)


@BOTH
def test_win64_binary_under_wine_agrees(host, built, name, tmp_path):
    gcc, wine = shutil.which("x86_64-w64-mingw32-gcc"), shutil.which("wine") or shutil.which("wine64")
    native, md = host_for(host, built, name), built[name][2]
    dll = built[name][1] / "binaries" / "win64" / f"{name}.dll"
    if gcc is None or wine is None:
        pytest.skip("needs the MinGW-w64 cross compiler and wine (Debian: gcc-mingw-w64-x86-64, wine64)")
    assert dll.is_file(), "MinGW-w64 is installed, so build_fmu.py must ship binaries/win64"
    exe = compile_host(tmp_path / "fmi_host.exe", compiler=(gcc,))
    env = {"WINEDEBUG": "-all", "WINEPREFIX": str(tmp_path / "wine"), "HOME": str(tmp_path),
           "PATH": "/usr/bin:/bin"}
    win = Host(exe, dll, md.guid, native.vr, wrapper=[wine])
    script = native.start(md=md) + SCRIPTS[name](native)
    np.testing.assert_allclose(win.run(script, env=env).rows(), native.run(script).rows(), rtol=0, atol=MATCH)


# -- the DC motor ------------------------------------------------------------------------

MOTOR_PARAMS = {"gear_ratio": 5.0, "gear_efficiency": 0.8, "current_limit": 4.0, "supply_voltage": 36.0,
                "ambient_temperature": 30.0, "viscous_friction": 2e-5}


def motor_library(h: float, voltages, speed: float, **changes):
    """grubler.motors' MotorSimulator with MOTOR_PARAMS: the library's motor, step by step."""
    from grubler.motors import DCMotor, Drive, Gearbox, load_motor
    from grubler.motors.dc_motor import MotorSimulator

    p = {**MOTOR_PARAMS, **changes}
    data = load_motor("maxon-re40-148877").replace(viscous_friction=p["viscous_friction"])
    m = DCMotor(data, Gearbox(p["gear_ratio"], p["gear_efficiency"]), Drive(p["supply_voltage"], p["current_limit"]),
                ambient_temperature=p["ambient_temperature"])
    sim, rows = MotorSimulator(m), []
    for k, v in enumerate(voltages):
        out = sim.step(v, speed, h)
        rows.append([(k + 1) * h] + [getattr(out, n) for n in MOTOR_NAMES[:-1]] + [m.reflected_inertia])
    return np.array(rows)


def test_motor_in_the_c_host_matches_the_library(motor, built):
    md = built["DCMotor"][2]
    volts = [0.0] * 10 + [30.0] * 60 + [-12.0] * 30  # a step that hits the current limit, then a reversal
    script = motor.start(MOTOR_PARAMS, md=md) + [f"setr {motor.vr['shaft_speed']} 20.0"]
    for k, v in enumerate(volts):
        script += [f"setr {motor.vr['voltage']} {v!r}", motor.run_steps(k * 1e-3, 1e-3, 1, *MOTOR_NAMES)]
    rows = motor.run(script).rows()
    lib = motor_library(1e-3, volts, 20.0)
    np.testing.assert_allclose(rows, lib, rtol=0, atol=MATCH)
    assert np.max(np.abs(rows[:, 2])) == pytest.approx(4.0)  # the limiter acted


def test_motor_winding_starts_at_ambient_unless_set(motor, built):
    md = built["DCMotor"][2]
    t = motor.run(motor.start({"ambient_temperature": 40.0}, md=md) + [motor.getr("winding_temperature")]
                  + motor.start({"ambient_temperature": 40.0, "initial_temperature": 60.0}, k=1, md=md)
                  + [motor.getr("winding_temperature")])
    assert [float(v[2]) for v in t.results if v[0] == "getr"] == [40.0, 60.0]


def test_motor_state_round_trips_and_is_honoured_before_initialisation(motor, built, tmp_path):
    md, blob = built["DCMotor"][2], tmp_path / "m.bin"
    names = ("current", "winding_temperature", "shaft_torque")
    t = motor.run(motor.start(MOTOR_PARAMS, md=md) + [f"setr {motor.vr['voltage']} 24.0",
                                                      motor.run_steps(0, 1e-3, 30), "save 0", f"ser 0 {blob}",
                                                      motor.run_steps(0.03, 1e-3, 20, *names),
                                                      "new 1 later", f"deser 1 {blob}", "load 1", "setup 0",
                                                      "enter", "exit", motor.run_steps(0.03, 1e-3, 20, *names)])
    rows = t.rows(width=4)
    assert rows.shape == (40, 4) and np.array_equal(rows[:20], rows[20:])


def test_motor_refuses_a_bad_parameter_naming_it(motor, built):
    t = motor.run(motor.start({"gear_efficiency": 1.5}, md=built["DCMotor"][2]) + ["step 0 0.001"])
    assert t.statuses("exit") == [ERROR] and t.logged("gear_efficiency:") and t.statuses("step") == [ERROR]


def test_a_system_written_for_the_pythonfmu_plant_is_told_what_to_set(built):
    from grubler import cosim, ssp

    s = ssp.System("old")
    s.add("m", built["Mechanism"][0], mechanism="thesis-fourbar")
    s.add("d", built["DCMotor"][0], motor="maxon-re40-148877")
    with pytest.raises(ssp.SystemDescriptionError) as err:
        cosim.run(s, t_end=0.01)
    assert "has no variable 'mechanism' (the native Mechanism.fmu takes the scene's quantities" in str(err.value)
    assert "grubler.fmi.motor.motor_parameters(name)" in str(err.value)


# -- grubler export --------------------------------------------------------------------

def test_export_an_open_chain_and_run_it(host, tmp_path):
    from fmpy import read_model_description

    from grubler.cli import main

    path = tmp_path / "Pendulum.fmu"
    assert main(["export", "triple-pendulum", "-o", str(path)]) == 0
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(path)) == []
    md2 = read_model_description(str(path))
    assert md2.coSimulation.modelIdentifier == "Pendulum"
    assert not any(v.name.startswith(("closure.", "closure[")) for v in md2.modelVariables)
    d = tmp_path / "x"
    zipfile.ZipFile(path).extractall(d)
    vr = {v.name: v.valueReference for v in md2.modelVariables}
    h = Host(host, d / "binaries" / "linux64" / "Pendulum.so", md2.guid, vr)
    names = ("theta2", "theta3", "theta4", "KE", "PE")
    t = h.run(h.start(md=md2) + [f"setr {vr['motor_torque']} 0.0", h.run_steps(0, 0.01, 50, *names)])
    np.testing.assert_allclose(t.rows(), library_steps("triple-pendulum", 0.01, 50, names, torque=0.0),
                               rtol=0, atol=MATCH)


@pytest.mark.parametrize("args, field, reason", [
    (["no-such-scene"], "scene", ""), (["thesis-fourbar", "-o", "x.zip"], "--out", ""),
    (["bad.toml"], "link2.m", ""),
    # the output is checked before compiling: a name whose partial file (NAME.fmu.part) the file system refuses,
    (["thesis-fourbar", "-o", "a" * 250 + ".fmu"], "--out", "the file name is 254 characters"),
    (["thesis-fourbar", "-o", "a" * 300 + ".fmu"], "--out", "name"),
    # a folder that does not exist (not made: as every other command)
    (["thesis-fourbar", "-o", "missing/d/x.fmu"], "--out", "the folder 'missing/d' does not exist"),
])
def test_export_refuses_bad_input_with_one_line(tmp_path, args, field, reason):
    text = grubler.mechanism.scene.preset_text("thesis-fourbar").replace("m = 1.0", "m = -1.0", 1)
    (tmp_path / "bad.toml").write_text(text)
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export", *args], capture_output=True, text=True,
                          cwd=tmp_path)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{field}:" in lines[0] and reason in lines[0], lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]  # nothing written, no folder made


def test_export_refuses_a_scene_that_cannot_start_as_simulate_does(tmp_path):
    bad = tmp_path / "open.toml"
    bad.write_text('[mechanism]\ntype = "four-bar"\nground = 1\ncrank = 3\ncoupler = 0.8\nrocker = 0.6\n')
    said = {}
    for cmd in (["simulate", str(bad)], ["export", str(bad), "-o", str(tmp_path / "Open.fmu")]):
        proc = subprocess.run([sys.executable, "-m", "grubler.cli", *cmd], capture_output=True, text=True)
        assert proc.returncode == 2, proc.stderr
        said[cmd[0]] = proc.stderr.strip()
    assert said["export"] == said["simulate"] and "initial: the loop cannot be closed" in said["export"]
    assert not (tmp_path / "Open.fmu").exists()


def test_export_refuses_a_folder_it_may_not_write(tmp_path):
    import os

    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        if os.access(folder, os.W_OK):
            pytest.skip("this user writes into any folder (root): nothing to refuse")
        proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export", "thesis-fourbar", "-o",
                               str(folder / "x.fmu")], capture_output=True, text=True)
    finally:
        folder.chmod(0o755)
    assert proc.returncode == 2 and "output:" in proc.stderr and "is not writable" in proc.stderr, proc.stderr


def test_fmi_headers_come_from_fmpy(unzipped):
    for name in FMI_HEADERS:
        assert (unzipped / "sources" / name).read_bytes() == (fmi_headers_dir() / name).read_bytes()


# -- a branching chain: the predecessor of each link is a parameter -------------------

@pytest.fixture(scope="session")
def tree_fmu(host, tmp_path_factory):
    """The stephenson-iii scene exported (its links 4 and 5 hang from link 3), unzipped, in the host."""
    from fmpy import read_model_description


    d = tmp_path_factory.mktemp("tree")
    path = builds.export("stephenson-iii", d / "Stephenson3.fmu")
    zipfile.ZipFile(path).extractall(d / "unzipped")
    desc = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in desc.modelVariables}
    return Host(host, d / "unzipped" / "binaries" / "linux64" / "Stephenson3.so", desc.guid, vr), desc


def test_a_tree_scene_runs_in_the_c_host_like_the_library(tree_fmu):
    native, md = tree_fmu
    start = {v.name: v.start for v in md.modelVariables if v.name.endswith(".parent")}
    assert start == {"link2.parent": "1", "link3.parent": "2", "link4.parent": "3", "link5.parent": "3",
                     "link6.parent": "5"}
    names = ("theta2", "theta4", "theta5", "theta6_d", "theta5_dd", "closure_error", "Fx", "closure1_Fy",
             "R4_Fx", "R3_Mz", "KE", "PE")
    t = native.run(native.start(md=md) + [f"setr {native.vr['motor_torque']} 0.05",
                                          native.run_steps(0.0, 0.01, 100, *names)])
    assert t.statuses("run") == [OK], t.logs
    lib = library_steps("stephenson-iii", 0.01, 100, names, torque=0.05)
    np.testing.assert_allclose(t.rows(), lib, rtol=0, atol=MATCH)
    assert np.ptp(t.rows()[:, 3]) > 0.1  # the branch's loop moves


def test_a_parent_that_is_not_an_earlier_link_is_refused_with_its_name(tree_fmu):
    native, md = tree_fmu
    # the kernel walks each link's parents to the ground: link 5 hanging from itself would never get there
    t = native.run(native.start({"link5.parent": 5}, md=md))
    assert t.statuses("seti") == [ERROR] and t.statuses("exit") == [ERROR]
    assert t.logged("link5.parent must be in 1 .. 4, got 5"), t.logs
    t = native.run(native.start({"link5.parent": 1}, md=md) + [native.run_steps(0.0, 0.01, 2, "theta5")])
    assert t.statuses("exit") == [OK]  # a legal other tree: link 5 on the ground, its dyad then a four-bar


# -- crafted states: a blob with valid checksums and any content ----------------------
#
# The checksums are public (FNV-1a), so a blob can carry anything and pass them.
# Each crafted state below must be refused with fmi2Error and a log line naming
# the field, in a host process (a crash fails the test, not pytest) with a
# timeout (a hang fails it too), and the instance must reset, run and free.

def fnv1a(data: bytes) -> int:
    h = 14695981039346656037
    for b in data:
        h = ((h ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return h


def craft(blob: bytes, values: dict[int, float]) -> bytes:
    """A serialised state with some doubles of its block replaced and its checksums made to match."""
    b = bytearray(blob)
    n_stored, n = struct.unpack_from("<II", b, 12)
    assert len(b) == 48 + 8 * n
    for k, x in values.items():
        struct.pack_into("<d", b, 48 + 8 * k, x)
    struct.pack_into("<QQ", b, 32, fnv1a(bytes(b[48:48 + 8 * n_stored])), fnv1a(bytes(b[48:])))
    return bytes(b)


def refused_and_usable(h: Host, md, good: Path, bad: Path, values: dict[int, float], field: str,
                       output: str, env: dict | None = None) -> None:
    bad.write_bytes(craft(good.read_bytes(), values))
    t = h.run(h.start(md=md) + [f"deser 1 {bad}", "load 1", h.getr(output), "reset", "setup 0", "enter", "exit",
                                h.run_steps(0.0, 0.01, 3, output), "free"], env=env, timeout=120)
    assert t.statuses("deser") == [ERROR], t.logs
    assert t.logged(field) and t.logs[0].startswith("log 3 ") and t.logged("fmi2DeSerializeFMUstate: "), t.logs
    assert t.statuses("load") == [ERROR] and t.statuses("getr") == [ERROR]  # refused until reset
    assert t.statuses("exit") == [OK, OK] and t.statuses("run") == [OK] and len(t.rows()) == 3
    assert t.statuses("free") == [OK]


def saved_state(h: Host, md, path: Path, inputs: dict) -> Path:
    t = h.run(h.start(md=md) + [f"setr {h.vr[k]} {x!r}" for k, x in inputs.items()]
              + [h.run_steps(0.0, 0.01, 5), "save 0", f"ser 0 {path}"])
    assert t.statuses("ser") == [OK], t.logs
    return path


def _mechanism_cases(spec) -> list[tuple[str, dict, str]]:
    """(case, {block index: value}, the field the refusal names) for a mechanism FMU of spec's shape."""
    nc = spec.defines["N_CLOSURES"]
    last = "closure" if nc == 1 else f"closure[{nc - 1}]"
    y, f = spec.state_slot("y"), spec.state_slot("f")
    return [
        ("link beyond int", {spec.slot(f"{last}.link"): 1e9}, f"{last}.link must be in 2 .. "),
        ("link negative", {spec.slot(f"{last}.link"): -3.0}, f"{last}.link must be in 2 .. "),
        ("link not whole", {spec.slot(f"{last}.link"): 2.5}, f"{last}.link must be an integer"),
        ("to_link huge", {spec.slot(f"{last}.to_link"): 1e300}, f"{last}.to_link must be an integer"),
        ("parent", {spec.slot("link3.parent"): 3.0}, "link3.parent must be in 1 .. 2"),
        ("joint", {spec.slot("link2.joint"): 7.0}, "link2.joint must be an item 1 .. 2"),
        ("drive_joint", {spec.slot("drive_joint"): 1000.0}, "drive_joint must be the index of one of"),
        ("method", {spec.slot("method"): float("nan")}, "method must be the index of one of"),
        ("was-set flag", {spec.n_stored + spec.slot("link2.m"): 0.5}, "the flag saying whether link2.m was set"),
        ("mass", {spec.slot("link2.m"): -1.0}, "link2.m: mass must be positive"),
        ("started", {spec.state_slot("started"): 0.5}, "state.started: must be 0 or 1"),
        ("time", {spec.state_slot("t"): float("inf")}, "state.t: the time must be finite"),
        ("step", {spec.state_slot("h"): float("nan")}, "state.h:"),
        ("joint state", {y: float("nan")}, "state.theta2: the joint state must be finite"),
        ("joint rate", {y + spec.defines["N_LINKS"]: float("-inf")}, "state.theta2_d: the joint state must be"),
        ("derivative", {spec.state_slot("have_f"): 1.0, f + 1: float("nan")}, "state.f: the derivative of"),
        ("count", {spec.state_slot("steps"): -1.0}, "state.steps: a count must be >= 0"),
    ]


def _spec(scene: str, identifier: str):
    from grubler.fmi.mechanism import mechanism_spec

    return mechanism_spec(grubler.load_scene(scene), identifier)


MECHANISM_CASES = _mechanism_cases(_spec("thesis-fourbar", "Mechanism"))


@pytest.fixture(scope="session")
def watt_fmu(host, tmp_path_factory):
    """The watt-ii scene exported (two closures), unzipped, with its spec."""
    from fmpy import read_model_description


    d = tmp_path_factory.mktemp("watt")
    path = builds.export("watt-ii", d / "WattII.fmu")
    zipfile.ZipFile(path).extractall(d / "unzipped")
    desc = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in desc.modelVariables}
    return (Host(host, d / "unzipped" / "binaries" / "linux64" / "WattII.so", desc.guid, vr), desc,
            _spec("watt-ii", "WattII"), d / "unzipped")


@pytest.mark.parametrize("case, values, field", MECHANISM_CASES, ids=[c[0] for c in MECHANISM_CASES])
def test_a_crafted_mechanism_state_is_refused_naming_the_field(native, md, tmp_path, case, values, field):
    good = saved_state(native, md, tmp_path / "good.bin", {"motor_torque": 3.0})
    assert _spec("thesis-fourbar", "Mechanism").guid == md.guid  # the layout the cases address is the binary's
    refused_and_usable(native, md, good, tmp_path / "bad.bin", values, field, "theta2")


WATT_CASES = _mechanism_cases(_spec("watt-ii", "WattII"))


@pytest.mark.parametrize("case, values, field", WATT_CASES, ids=[c[0] for c in WATT_CASES])
def test_a_crafted_state_of_an_exported_two_loop_fmu_is_refused(watt_fmu, tmp_path, case, values, field):
    h, desc, spec, _ = watt_fmu
    assert spec.guid == desc.guid
    good = saved_state(h, desc, tmp_path / "good.bin", {"motor_torque": 0.5})
    refused_and_usable(h, desc, good, tmp_path / "bad.bin", values, field, "theta2")


def _motor_cases(spec) -> list[tuple[str, dict, str]]:
    return [
        ("current", {spec.state_slot("current"): float("nan")}, "state.current"),
        ("temperature", {spec.state_slot("temperature"): float("inf")}, "state.temperature"),
        ("resistance", {spec.slot("resistance"): -1.0}, "resistance"),
        ("current limit", {spec.slot("current_limit"): float("nan")}, "current_limit"),
        ("warned", {spec.state_slot("warned_hot"): 2.0}, "state.warned_hot"),
        ("started", {spec.state_slot("started"): -1.0}, "state.started"),
    ]


def _motor_spec():
    from grubler.fmi.motor import DEFAULT_MOTOR, motor_spec

    return motor_spec(DEFAULT_MOTOR, "DCMotor")


MOTOR_CASES = _motor_cases(_motor_spec())


@pytest.mark.parametrize("case, values, field", MOTOR_CASES, ids=[c[0] for c in MOTOR_CASES])
def test_a_crafted_motor_state_is_refused_naming_the_field(motor, built, tmp_path, case, values, field):
    desc = built["DCMotor"][2]
    assert _motor_spec().guid == desc.guid
    good = saved_state(motor, desc, tmp_path / "good.bin", {"voltage": 24.0, "shaft_speed": 5.0})
    refused_and_usable(motor, desc, good, tmp_path / "bad.bin", values, field, "current")


def test_crafted_states_under_the_sanitizers(built, sanitized, watt_fmu, tmp_path):
    """Every crafted case of the three FMUs, in one sanitized host run each: no invalid access, no UB, no leak."""
    h, desc, spec, unzipped = watt_fmu
    watt_so = sanitized_binary(unzipped, desc, tmp_path / "WattII.so")
    runs = [(Host(sanitized["host"], sanitized["Mechanism"], built["Mechanism"][2].guid,
                  {v.name: v.valueReference for v in built["Mechanism"][2].modelVariables}),
             built["Mechanism"][2], MECHANISM_CASES, {"motor_torque": 3.0}, "theta2"),
            (Host(sanitized["host"], watt_so, desc.guid, h.vr), desc, WATT_CASES, {"motor_torque": 0.5}, "theta2"),
            (Host(sanitized["host"], sanitized["DCMotor"], built["DCMotor"][2].guid,
                  {v.name: v.valueReference for v in built["DCMotor"][2].modelVariables}),
             built["DCMotor"][2], MOTOR_CASES, {"voltage": 24.0, "shaft_speed": 5.0}, "current")]
    for k, (host_, md_, cases, inputs, output) in enumerate(runs):
        good = tmp_path / f"good{k}.bin"
        t = host_.run(host_.start(md=md_) + [f"setr {host_.vr[n]} {x!r}" for n, x in inputs.items()]
                      + [host_.run_steps(0.0, 0.01, 5), "save 0", f"ser 0 {good}"], env=SANITIZER_ENV)
        for case, values, field in cases:
            refused_and_usable(host_, md_, good, tmp_path / f"bad{k}.bin", values, field, output, env=SANITIZER_ENV)


def test_a_rate_on_a_locked_coordinate_is_refused_with_the_librarys_reason(native, md, tmp_path):
    text = grubler.mechanism.scene.preset_text("thesis-fourbar").replace('theta3 = "pi/3"', 'theta3 = "pi/3"\nB1_d = 0.5')
    (tmp_path / "moving.toml").write_text(text)
    with pytest.raises(grubler.errors.SceneError) as err:
        grubler.load_scene(str(tmp_path / "moving.toml"))
    assert err.value.field == "initial.B1_d"
    t = native.run(native.start({"initial.B1_d": 0.5}, md=md))
    assert t.statuses("exit") == [ERROR]
    assert t.logged(f"initial.B1_d: {err.value.reason}"), t.logs
    # the rate the real joint implies is no error: a slide of a turning link stays 0
    assert native.run(native.start({"initial.B1_d": 0.0, "initial.theta2_d": 2.0}, md=md)).statuses("exit") == [OK]


def test_a_locked_angle_turns_with_its_predecessor(native, md):
    """On a prismatic pair the angle is locked: its absolute rate is the predecessor's, nothing else."""
    scene = grubler.load_scene("quick-return")  # link 4 slides on link 3: theta4 is locked
    m = scene.mechanism
    assert "theta4" not in m.free_names and m.parents[2] == 3
    params = fmu_parameters(scene)
    ok = native.run(native.start({**params, "initial.theta3_d": 1.5, "initial.theta4_d": 1.5}, md=md))
    assert ok.statuses("exit") == [OK], ok.logs
    t = native.run(native.start({**params, "initial.theta3_d": 1.5, "initial.theta4_d": 0.7}, md=md))
    assert t.statuses("exit") == [ERROR]
    assert t.logged("initial.theta4_d: theta4 is a locked (fictitious) coordinate; it cannot move (relative to "
                    "link3: its absolute rate is initial.theta3_d = 1.5, got 0.7)"), t.logs
    # the library's scene reader applies the same rule: the rate the predecessor gives is no error, another is
    import tomllib
    from grubler.mechanism.scene import preset_text, scene_from_dict

    data = tomllib.loads(preset_text("quick-return"))
    data.setdefault("initial", {}).update({"theta3_d": 1.5, "theta4_d": 1.5})
    assert scene_from_dict(data).initial_rates[m.free_names.index("theta3")] == 1.5
    data["initial"]["theta4_d"] = 0.7
    with pytest.raises(grubler.SceneError) as err:
        scene_from_dict(data)
    assert str(err.value) == ("initial.theta4_d: theta4 is a locked (fictitious) coordinate; it cannot move (relative "
                              "to link3: its absolute rate is initial.theta3_d = 1.5, got 0.7)")



def _library_refusal(params: dict) -> tuple[str, str] | None:
    """The library's refusal of a mechanism given as a mechanism FMU's parameters (field, reason), or None."""
    from grubler.mechanism.model import Closure, Link, Mechanism, coordinate_names

    n = sum(1 for k in params if k.startswith("link") and k.endswith(".joint"))
    links = [Link("P" if params[f"link{k}.joint"] == 2 else "R", *(params[f"link{k}.{f}"] for f in
                                                                   ("a", "p", "q", "m", "I", "damping")),
                  parent=int(params[f"link{k}.parent"])) for k in range(2, n + 2)]
    c = "closure"
    closures = [Closure("prismatic" if params[f"{c}.type"] == 2 else "revolute", int(params[f"{c}.link"]),
                        (params[f"{c}.at_x"], params[f"{c}.at_y"]), int(params[f"{c}.to_link"]),
                        (params[f"{c}.point_x"], params[f"{c}.point_y"]), params[f"{c}.angle"], params[f"{c}.psi"],
                        params[f"{c}.gain"], params[f"{c}.damping"])]
    names = coordinate_names(n)
    try:
        m = Mechanism(links, closures, [params[f"initial.{x}"] for x in names], params["ground.a1"],
                      params["ground.theta1"], params["gravity"], params["drive_joint"] or None,
                      params["load_joint"] or None, params["drive.inertia"])
    except grubler.SceneError as exc:
        return exc.field, exc.reason
    problems = m.problems(initial_rates=[params[f"initial.{x}_d"] for x in names])
    return (problems[0].field, problems[0].reason) if problems else None


# each of the mechanism's rules, broken on the four-bar (or the quick-return, whose link 4 slides on link 3)
# through the parameters a mechanism FMU has
ONE_RULE_EACH = [
    ("thesis-fourbar", {"gravity": -9.81}),
    ("thesis-fourbar", {"ground.a1": -0.5}),
    ("thesis-fourbar", {"link3.a": -0.8}),
    ("thesis-fourbar", {"link2.m": 0.0}),
    ("thesis-fourbar", {"link4.I": -0.1}),
    ("thesis-fourbar", {"link2.damping": -1e-05}),
    ("thesis-fourbar", {"closure.to_link": 4}),
    ("thesis-fourbar", {"closure.gain": 0.0}),
    ("thesis-fourbar", {"closure.damping": -100.0}),
    ("thesis-fourbar", {"link2.joint": 2, "link3.joint": 2, "link4.joint": 2}),  # one revolute in the loop
    ("quick-return", {"link3.joint": 2, "initial.theta3": 0.7, "initial.theta2": 0.7}),  # parallel slides
    ("thesis-fourbar", {"drive.inertia": -0.01}),
    ("thesis-fourbar", {"drive_joint": "", "drive.inertia": 0.01}),
    ("thesis-fourbar", {"drive_joint": "B2"}),
    ("thesis-fourbar", {"load_joint": "B3"}),
    ("thesis-fourbar", {"initial.B2_d": 0.5}),
    ("quick-return", {"initial.theta3_d": 1.5, "initial.theta4_d": 0.7}),
]
# the two interfaces spell these fields differently: the scene's [drive] joint is the FMU's drive_joint
FMU_SPELLING = {"drive.joint": "drive_joint", "load.joint": "load_joint"}


@pytest.mark.parametrize("scene, change", ONE_RULE_EACH, ids=lambda v: v if isinstance(v, str) else
                         ",".join(f"{k}={x}" for k, x in v.items()))
def test_the_library_and_the_fmu_refuse_a_mechanism_in_the_same_words(native, md, scene, change):
    """One check (the kernel's grb_scene_check) serves both: each rule's refusal reads the same, byte for byte."""
    params = {**fmu_parameters(grubler.load_scene(scene)), **change}
    refusal = _library_refusal(params)
    assert refusal is not None, change
    field, reason = refusal
    t = native.run(native.start(params, md=md))
    assert t.statuses("exit") == [ERROR], t.logs
    expected = f"{FMU_SPELLING.get(field, field)}: {reason}"
    assert any(line.endswith(expected) for line in t.logs), (expected, t.logs)

FOREIGN_STATE = """
import sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

slaves = []
for k, path in enumerate(sys.argv[1:3]):
    md = read_model_description(path)
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=f"i{k}")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    slaves.append(s)
own = slaves[1].getFMUstate()
slaves[1].setFMUstate(own)
print("own state restored", flush=True)
try:
    slaves[1].setFMUstate(slaves[0].getFMUstate())
    print("foreign state accepted")
except Exception as exc:
    print("foreign state refused:", exc)
slaves[1].reset()
slaves[1].freeInstance()
"""


def test_a_state_of_another_fmu_of_the_same_layout_is_refused_in_memory(fmu, tmp_path):
    """As serialised (by the GUID), so in memory: two FMUs of one layout, one's state set on the other."""
    from grubler.fmi.build import export

    other = export(grubler.load_scene("thesis-fourbar"), tmp_path / "Other.fmu")
    proc = subprocess.run([sys.executable, "-c", FOREIGN_STATE, str(fmu), str(other)], capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "own state restored" in proc.stdout
    assert "foreign state refused" in proc.stdout, proc.stdout
    assert "fmi2SetFMUstate: not a state of this model" in proc.stdout, proc.stdout


@BOTH
def test_random_crafted_states_never_crash_hang_nor_corrupt_memory(built, sanitized, name, tmp_path):
    """States with valid checksums and 1 to 3 random doubles of the block replaced by awkward numbers
    (a parameter, a was-set flag, the run's state, the integrator's workspace), each deserialised,
    restored, stepped and read, in the sanitized host."""
    md = built[name][2]
    h = Host(sanitized["host"], sanitized[name], md.guid, {v.name: v.valueReference for v in md.modelVariables})
    inputs = RUNS[name][0]
    good = saved_state(h, md, tmp_path / "good.bin", inputs)
    n = struct.unpack_from("<I", good.read_bytes(), 16)[0]
    rng = np.random.default_rng(7)
    awkward = [float("nan"), float("inf"), -float("inf"), 1e300, -1e300, 1e9, -3.0, -1.0, 0.0, 0.5, 2.5, 1000.0]
    output = RUNS[name][1][0]
    script = h.start(md=md)
    for k in range(150):
        blob = tmp_path / f"c{k}.bin"
        picks = rng.choice(n, size=int(rng.integers(1, 4)), replace=False)
        blob.write_bytes(craft(good.read_bytes(), {int(i): float(rng.choice(awkward)) for i in picks}))
        script += [f"deser 1 {blob}", "load 1", "step 0.05 0.01", h.getr(output), "reset", "setup 0", "enter",
                   "exit"]
    proc = subprocess.run(h.cmd, input="\n".join(script) + "\n", capture_output=True, text=True, timeout=600,
                          env=SANITIZER_ENV)
    assert proc.returncode == 0 and "Sanitizer" not in proc.stderr and "runtime error" not in proc.stderr, \
        proc.stderr[-3000:]
    t = Transcript(proc.stdout)
    deser = t.statuses("deser")
    assert len(deser) == 150 and set(deser) == {OK, ERROR}  # some slots take any value (an input, the workspace)
    assert set(t.statuses("step")) <= {OK, WARNING, DISCARD, ERROR}  # never fmi2Fatal


@pytest.mark.parametrize("name", ["HydraulicCylinder", "PneumaticCylinder"])
def test_a_cylinder_runs_in_the_c_host_with_an_empty_environment_as_the_library_steps_it(host, built, name):
    # no Python in the process: the C host loads the binary alone; the same C
    # behind the library gives the same numbers
    from grubler.motors.hydraulic import CylinderSimulator, DEFAULT as HYDRAULIC
    from grubler.motors.pneumatic import DEFAULT as PNEUMATIC, PneumaticSimulator

    h = host_for(host, built, name)
    cylinder, sim = (HYDRAULIC, CylinderSimulator(HYDRAULIC)) if name == "HydraulicCylinder" else \
        (PNEUMATIC, PneumaticSimulator(PNEUMATIC))
    length, rate = cylinder.retracted_length + 0.5 * cylinder.stroke, 0.01
    names = ("force", "pressure_a", "pressure_b", "spool")
    t = h.run(h.start(md=built[name][2]) + [f"setr {h.vr['command']} 0.6", f"setr {h.vr['length']} {length!r}",
                                            f"setr {h.vr['rate']} {rate!r}", h.run_steps(0.0, 1e-3, 200, *names)])
    want = []
    for k in range(200):
        out = sim.step(0.6, length, rate, 1e-3)
        want.append([(k + 1) * 1e-3] + [out[n] for n in names])
    np.testing.assert_allclose(t.rows(), want, rtol=MATCH, atol=0)
