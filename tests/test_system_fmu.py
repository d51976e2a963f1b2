"""A system of native grubler FMUs as one native FMU (grubler.system.native, fmi/c/system_model.c).

The servo four-bar (examples/servo_fourbar.ssd) exported with ``grubler
export``: one binary holding its five models and master.c's loop.  It is held
to ``grubler cosim`` with the same step, run in fmpy (FMI 2 and 3), in the C
host under an empty environment, validated by fmpy, compiled as an importer
compiles it (strict C99, no complex); its FMU state replays bit for bit and a
crafted one is refused by the component it belongs to; a component's Discard
puts the whole system back; an SSD with a foreign FMU falls back to fmpy's
container with a one-line note.
"""

from __future__ import annotations

import math
import re
import shutil
import struct
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT))

import builds  # noqa: E402

SERVO = ["Trajectory", "Encoder", "PID", "DCMotor", "Mechanism"]
STEP = 1e-3
TOL_SETTINGS = {"master": "extrapolate", "tol": 1e-6}  # ServoFourbar3.fmu's start values


def grubler(*args, cwd=None) -> subprocess.CompletedProcess:
    exe = Path(sys.executable).parent / "grubler"
    return subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True, cwd=cwd)


@pytest.fixture(scope="module")
def servo(tmp_path_factory):
    """The servo four-bar's FMUs in a dist/ beside examples/servo_fourbar.ssd, and the system exported as
    FMI 2 (ServoFourbar.fmu, the default coupling: Gauss-Seidel, no tol) and FMI 3 (ServoFourbar3.fmu,
    exported with master extrapolate and tol 1e-6), each built once (tests/builds.py)."""
    root = tmp_path_factory.mktemp("servo")
    builds.dist(root / "dist", SERVO)
    (root / "examples").mkdir()
    ssd = root / "examples" / "servo_fourbar.ssd"
    shutil.copy(ROOT / "examples" / "servo_fourbar.ssd", ssd)
    return {"root": root, "ssd": ssd, 2: builds.system_fmu(ssd, SERVO, root / "ServoFourbar.fmu"),
            3: builds.system_fmu(ssd, SERVO, root / "ServoFourbar3.fmu", fmi=3, **TOL_SETTINGS)}


@pytest.fixture(scope="module")
def reference(servo):
    """grubler cosim of the system, 1 s at 1 ms."""
    from grubler.system import cosim

    return cosim.run(servo["ssd"], t_end=1.0, step=STEP)


def run_fmu(path: Path, names: list[str], t_end: float, h: float, fmi: int = 2, parameters=None) -> np.ndarray:
    """The outputs ``names`` at every communication point, the FMU stepped at t = k h (as cosim steps)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    where = extract(str(path))
    try:
        if fmi == 2:
            f = FMU2Slave(guid=md.guid, unzipDirectory=where, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName="system")
            f.instantiate()
            f.setupExperiment(startTime=0.0)
            for k, v in (parameters or {}).items():
                (f.setString if isinstance(v, str) else f.setInteger if isinstance(v, int) else f.setReal)([vr[k]],
                                                                                                           [v])
            f.enterInitializationMode()
            f.exitInitializationMode()
            get = f.getReal
        else:
            f = FMU3Slave(guid=md.guid, unzipDirectory=where, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName="system")
            f.instantiate()
            for k, v in (parameters or {}).items():
                (f.setString if isinstance(v, str) else f.setInt32 if isinstance(v, int) else f.setFloat64)([vr[k]],
                                                                                                            [v])
            f.enterInitializationMode(startTime=0.0)
            f.exitInitializationMode()
            get = f.getFloat64
        refs = [vr[n] for n in names]
        rows = [get(refs)]
        for k in range(round(t_end / h)):
            f.doStep(k * h, h)
            rows.append(get(refs))
        f.terminate()
        f.freeInstance()
    finally:
        shutil.rmtree(where, ignore_errors=True)
    return np.array(rows)


def test_the_system_fmu_matches_grubler_cosim_with_the_same_step(servo, reference):
    from fmpy import read_model_description

    outputs = {v.name for v in read_model_description(str(servo[2])).modelVariables if v.causality == "output"}
    names = [c for c in reference.columns if c in outputs]  # (cosim also records connected inputs)
    got = run_fmu(servo[2], names, 1.0, STEP)
    want = np.column_stack([reference[c] for c in names])
    assert got.shape == want.shape and len(names) > 40
    worst = np.max(np.abs(got - want) / np.maximum(1.0, np.abs(want)))
    assert worst <= 1e-12, worst
    # the crank has moved: a comparison of something that runs
    assert np.ptp(reference["mechanism.theta2"]) > 1.0


def test_an_importers_long_step_is_made_of_communication_steps(servo, reference):
    # doStep of 10 ms on a communication_step of 1 ms: ten Gauss-Seidel steps, cosim's at 1 ms (the times
    # t + k h / 10 rather than k h: equal to rounding)
    got = run_fmu(servo[2], ["mechanism.theta2"], 1.0, 10 * STEP)[:, 0]
    want = np.asarray(reference["mechanism.theta2"])[::10]
    assert np.max(np.abs(got - want)) < 1e-9
    coarse = run_fmu(servo[2], ["mechanism.theta2"], 1.0, 10 * STEP, parameters={"communication_step": 10 * STEP})
    assert np.max(np.abs(coarse[:, 0] - want)) > 1e-6  # a coarser coupling is another run


def test_fmi3_build_of_the_same_models_gives_the_same_run(servo):
    # (the FMI 3 build's start values are the settings the FMI 2 run is given)
    names = ["mechanism.theta2", "motor.current", "controller.u", "encoder.measured_position"]
    two = run_fmu(servo[2], names, 0.5, STEP, parameters=TOL_SETTINGS)
    three = run_fmu(servo[3], names, 0.5, STEP, fmi=3)
    np.testing.assert_array_equal(two, three)


# -- the coupling: grubler cosim's --master and --tol as the FMU's parameters master and tol -----------

def _outputs(fmu: Path) -> set[str]:
    from fmpy import read_model_description

    return {v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "output"}


def test_master_and_tol_are_fixed_parameters_in_cosims_words_with_the_exports_start_values(servo):
    from fmpy import read_model_description

    two, three = ({v.name: v for v in read_model_description(str(servo[k])).modelVariables} for k in (2, 3))
    master, tol = two["master"], two["tol"]
    assert master.type == "String" and master.causality == "parameter" and master.variability == "fixed"
    assert all(m in master.description for m in ("gauss-seidel", "jacobi", "extrapolate"))
    assert tol.type == "Real" and tol.causality == "parameter" and tol.variability == "fixed" and tol.unit == "1"
    assert "grubler cosim --tol" in tol.description and two["communication_step"].unit == "s"
    # the default export: grubler cosim's default coupling; --master extrapolate --tol 1e-6: those starts
    assert (master.start, float(tol.start)) == ("gauss-seidel", 0.0)
    assert (three["master"].start, float(three["tol"].start)) == ("extrapolate", 1e-6)


@pytest.mark.parametrize("settings", [{"master": "jacobi"}, {"master": "extrapolate"},
                                      {"master": "extrapolate", "tol": 1e-8}, {"master": "newton"}],
                         ids=["jacobi", "extrapolate", "tol", "newton"])
def test_each_master_and_tol_set_on_the_fmu_match_grubler_cosim_with_the_same_settings(servo, settings):
    from grubler.system import cosim

    want = cosim.run(servo["ssd"], t_end=0.5, step=STEP, **settings)
    names = [c for c in want.columns if c in _outputs(servo[2])]
    got = run_fmu(servo[2], names, 0.5, STEP, parameters=settings)
    worst = np.max(np.abs(got - np.column_stack([want[c] for c in names])) / np.maximum(1.0, np.abs(got)))
    assert worst <= 1e-12, worst
    if "tol" in settings:
        assert want.coupling["substeps"] > 500  # sub-steps were made (and matched)
    if settings["master"] == "newton":
        assert want.coupling["evaluations"] > want.coupling["steps"] > 400  # steps were iterated (and matched)
    # an importer's doStep of 10 ms is ten communication steps that carry the history and the sub-step clock
    coarse = run_fmu(servo[2], ["mechanism.theta2"], 0.5, 10 * STEP, parameters=settings)[:, 0]
    assert np.max(np.abs(coarse - np.asarray(want["mechanism.theta2"])[::10])) < 1e-9


def test_with_tol_1e_6_it_matches_cosim_tol_1e_6_and_is_closer_to_one_monolithic_simulation(servo):
    # ServoFourbar3.fmu, exported with --master extrapolate --tol 1e-6, runs as grubler cosim --tol 1e-6
    import dataclasses

    from grubler.system import cosim
    from servo_reference import monolithic

    sys.path.insert(0, str(ROOT / "examples"))
    import servo_fourbar

    want = cosim.run(servo["ssd"], t_end=0.5, step=STEP, tol=1e-6)
    names = [c for c in want.columns if c in _outputs(servo[3])]
    got = run_fmu(servo[3], names, 0.5, STEP, fmi=3)
    worst = np.max(np.abs(got - np.column_stack([want[c] for c in names])) / np.maximum(1.0, np.abs(got)))
    assert worst <= 1e-12, worst
    # with the encoder's quantisation off, against the servo as one ODE (tests/servo_reference.py): the crank
    # at every sample instant, the FMU with its tol and with tol 0 (its Gauss-Seidel default)
    quiet = {"encoder.counts_per_rev": 0}
    ref = monolithic(dataclasses.replace(servo_fourbar.DESIGN, encoder={"counts_per_rev": 0, "Ts": STEP}), 0.2)
    tight = run_fmu(servo[3], ["mechanism.drive_angle"], 0.2, STEP, fmi=3, parameters=quiet)[:, 0]
    plain = run_fmu(servo[2], ["mechanism.drive_angle"], 0.2, STEP, parameters=quiet)[:, 0]
    err_tight, err_plain = (np.max(np.abs(x - ref["drive_angle"])) for x in (tight, plain))
    assert err_tight < 1e-6 and err_tight < err_plain / 100, (err_tight, err_plain)


@pytest.mark.parametrize("script, named", [
    ("setr {tol} -1", "tol: must be 0 (no error control) or a number from 1e-14 to 0.5, got -1"),
    ("setr {tol} nan", "tol: must be 0 (no error control) or a number from 1e-14 to 0.5, got nan"),
    ("setr {tol} 1e-6", 'tol: error control is the extrapolating master\'s (master = "extrapolate"), but master is '
                        '"gauss-seidel"'),
    ("sets {master} jacobi\nsetr {tol} 1e-6", 'but master is "jacobi"'),
], ids=["negative", "nan", "gauss-seidel", "jacobi"])
def test_a_bad_tol_is_an_error_naming_it(host, servo, tmp_path, script, named):
    from fmpy import read_model_description

    vr = {v.name: v.valueReference for v in read_model_description(str(servo[2])).modelVariables}
    out = host_run(host, servo, "new 0 s\nsetup 0\n" + script.format(**vr) + "\nenter\nexit\nstep 0 0.001\nfree\n",
                   tmp_path)
    assert next(line for line in out if line.startswith("exit")).split()[1] == "3", out  # Error
    assert any(line.startswith("log") and named in line for line in out), out


def test_a_master_it_does_not_run_is_refused_naming_it_and_its_choices(host, servo, tmp_path):
    from fmpy import read_model_description

    vr = {v.name: v.valueReference for v in read_model_description(str(servo[2])).modelVariables}
    out = host_run(host, servo, f"new 0 s\nsetup 0\nsets {vr['master']} newtn\nfree\n", tmp_path)
    assert next(line for line in out if line.startswith("sets")).split()[1] == "3", out
    assert any("master cannot be 'newtn'" in line and "gauss-seidel" in line and "'newton'" in line
               for line in out), out


def test_an_adaptive_run_replays_bit_for_bit_from_a_saved_state(host, servo, tmp_path):
    # the extrapolating master's history and the sub-step clock are in the state: a run restored mid-way
    # goes on as the run that was never interrupted (memory and bytes alike)
    from fmpy import read_model_description

    vr = {v.name: v.valueReference for v in read_model_description(str(servo[2])).modelVariables}
    theta = vr["mechanism.theta2"]
    script = (f"new 0 s\nsetup 0\nsets {vr['master']} extrapolate\nsetr {vr['tol']} 1e-7\nenter\nexit\n"
              f"run 0 0.001 150\nsave 0\nser 0 state.bin\nrun 0.15 0.001 100 {theta}\nload 0\n"
              f"run 0.15 0.001 100 {theta}\ndeser 1 state.bin\nload 1\nrun 0.15 0.001 100 {theta}\nfree\n")
    out = rows(host_run(host, servo, script, tmp_path))
    first, again, from_bytes = out[150:250], out[250:350], out[350:450]
    assert len(from_bytes) == 100 and first == again == from_bytes
    # the extrapolated run is another run than Gauss-Seidel's
    plain = run_fmu(servo[2], ["mechanism.theta2"], 0.25, STEP)[151:, 0]
    assert np.max(np.abs(np.array([r[1] for r in first]) - plain)) > 1e-6


def test_the_export_takes_cosims_master_and_tol_and_refuses_what_cosim_refuses(servo, tmp_path, monkeypatch,
                                                                             capsys):
    from grubler import cli
    from grubler.system import native

    asked = {}

    def export(system, dest, platforms, fmi=2, field="output", master=None, tol=None, sources=True):
        asked.update(master=master, tol=tol, sources=sources)
        return Path(dest)

    monkeypatch.setattr(native, "export_native_system", export)
    assert cli.main(["export", str(servo["ssd"]), "-o", str(tmp_path / "S.fmu"), "--tol", "1e-7",
                     "--platforms", "linux64"]) == 0
    assert asked == {"master": "extrapolate", "tol": 1e-7, "sources": True}
    assert "master extrapolate, tol 1e-07" in capsys.readouterr().out
    for args, words in ((["--master", "jacobi", "--tol", "1e-7"], "tol: the adaptive step is the extrapolating "
                                                                   "master's (master 'extrapolate'), got master "
                                                                   "'jacobi'"),
                        (["--tol", "0"], "--tol"), (["--tol", "1"], "--tol"), (["--master", "newtn"], "--master")):
        r = grubler("export", servo["ssd"], "-o", tmp_path / "S.fmu", *args)
        assert r.returncode == 2 and words in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (tmp_path / "S.fmu").exists()


def test_a_parameter_of_a_component_is_the_systems_and_reaches_it(servo):
    from grubler.system import cosim
    from grubler.system.ssp import read

    system = read(servo["ssd"])
    system.components["controller"].parameters["K"] = 0.5 * float(system.components["controller"].parameters["K"])
    want = cosim.run(system, t_end=0.5, step=STEP)["mechanism.theta2"]
    got = run_fmu(servo[2], ["mechanism.theta2"], 0.5, STEP, parameters={"controller.K": system.components[
        "controller"].parameters["K"]})[:, 0]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert np.max(np.abs(got - run_fmu(servo[2], ["mechanism.theta2"], 0.5, STEP)[:, 0])) > 1e-6


def test_one_binary_no_nested_fmu_units_and_its_own_identifier(servo):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    names = zipfile.ZipFile(servo[2]).namelist()
    binaries = [n for n in names if n.startswith("binaries/")]
    assert binaries == ["binaries/linux64/ServoFourbar.so"]
    assert not [n for n in names if n.endswith((".fmu", "container.json")) or n.startswith("resources/")]
    md = read_model_description(str(servo[2]))
    assert md.coSimulation.modelIdentifier == "ServoFourbar"
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    v = {x.name: x for x in md.modelVariables}
    assert v["mechanism.theta2"].unit == "rad" and v["motor.current"].unit == "A"
    assert v["controller.K"].causality == "parameter" and v["mechanism.load_torque"].causality == "input"
    assert v["mechanism.link2.joint"].type == "Enumeration"
    assert "mechanism.motor_torque" not in v  # a connected input is the system's inside
    assert validate_fmu(str(servo[2])) == [] and validate_fmu(str(servo[3])) == []
    so = servo["root"] / "so"
    zipfile.ZipFile(servo[2]).extract(binaries[0], so)
    exported = subprocess.run(["nm", "-D", "--defined-only", str(so / binaries[0])], capture_output=True,
                              text=True, check=True).stdout.split()
    symbols = [s for s in exported if s.isidentifier() and len(s) > 1]
    assert symbols and all(s.startswith("fmi2") for s in symbols), symbols


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_binary_only_export_leaves_sources_out_and_runs_the_same_bits(servo, fmi, tmp_path):
    # For deployment: no sources/ (FMI allows it; a FMI 2 description then lists no SourceFiles), so nothing to
    # unpack but the binary and the description, and the same run
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    out = servo["root"] / f"Deployed{fmi}.fmu"
    r = grubler("export", servo["ssd"], "-o", out, "--fmi", fmi, "--platforms", "linux64", "--binary-only",
                *(("--master", "extrapolate", "--tol", "1e-6") if fmi == 3 else ()))
    assert r.returncode == 0, r.stderr
    names = zipfile.ZipFile(out).namelist()
    assert sorted(names) == sorted(["modelDescription.xml", f"binaries/{'linux64' if fmi == 2 else 'x86_64-linux'}/"
                                                            f"Deployed{fmi}.so"])
    assert b"SourceFiles" not in zipfile.ZipFile(out).read("modelDescription.xml")
    assert validate_fmu(str(out)) == []
    assert read_model_description(str(out)).coSimulation.modelIdentifier == f"Deployed{fmi}"
    probe = ["mechanism.theta2", "motor.current", "mechanism.Fx"]
    np.testing.assert_array_equal(run_fmu(out, probe, 0.05, STEP, fmi=fmi), run_fmu(servo[fmi], probe, 0.05, STEP,
                                                                                      fmi=fmi))


def test_binary_only_is_refused_for_what_is_not_a_systems_native_fmu(tmp_path):
    r = grubler("export", "thesis-fourbar", "-o", tmp_path / "M.fmu", "--binary-only")
    assert r.returncode == 2 and r.stderr.strip().count("\n") == 0, r.stderr
    assert r.stderr.startswith("grubler: error: --binary-only:") and not (tmp_path / "M.fmu").exists()


@pytest.fixture(scope="module")
def host(servo):
    return builds.host()


def host_run(host, servo, script: str, cwd: Path) -> list[str]:
    from fmpy import read_model_description

    root = cwd / "unzipped"
    if not root.exists():
        zipfile.ZipFile(servo[2]).extractall(root)
    guid = read_model_description(str(servo[2])).guid
    r = subprocess.run(["env", "-i", str(host), str(root / "binaries" / "linux64" / "ServoFourbar.so"), guid],
                       input=script, capture_output=True, text=True, cwd=cwd, timeout=120)
    assert r.returncode == 0, r.stderr
    return r.stdout.splitlines()


def rows(lines: list[str]) -> list[list[float]]:
    return [[float(x) for x in line.split()[1:]] for line in lines if line.startswith("row ")]


def test_it_runs_in_the_c_host_in_an_empty_environment_as_in_fmpy(host, servo, tmp_path):
    from fmpy import read_model_description

    vr = {v.name: v.valueReference for v in read_model_description(str(servo[2])).modelVariables}
    out = host_run(host, servo, f"new 0 s\nsetup 0\nenter\nexit\nrun 0 0.001 500 {vr['mechanism.theta2']}\nfree\n",
                   tmp_path)
    got = np.array(rows(out))[:, 1]
    want = run_fmu(servo[2], ["mechanism.theta2"], 0.5, STEP)[1:, 0]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_a_saved_state_replays_bit_for_bit_in_memory_and_serialised(host, servo, tmp_path):
    from fmpy import read_model_description

    vr = read_model_description(str(servo[2])).modelVariables
    theta, current = (next(v.valueReference for v in vr if v.name == n) for n in ("mechanism.theta2", "motor.current"))
    script = (f"new 0 s\nsetup 0\nenter\nexit\nrun 0 0.001 300\nsave 0\nser 0 state.bin\n"
              f"run 0.3 0.001 200 {theta} {current}\nload 0\nrun 0.3 0.001 200 {theta} {current}\n"
              f"deser 1 state.bin\nload 1\nrun 0.3 0.001 200 {theta} {current}\nfree\n")
    out = rows(host_run(host, servo, script, tmp_path))
    first, again, from_bytes = out[300:500], out[500:700], out[700:900]
    assert len(from_bytes) == 200 and first == again == from_bytes
    # the state is every component's block after the system's own: more than any one component holds
    assert (tmp_path / "state.bin").stat().st_size > 48 + 8 * 300


def test_outputs_read_in_any_order_or_subset_are_those_read_all_at_once(host, servo, tmp_path):
    # The mechanism's coordinates and rates come from the state alone, its accelerations and forces from one
    # evaluation: whichever is read first, alone or with others, each output has the bits reading all gives.
    from fmpy import read_model_description

    real = [v for v in read_model_description(str(servo[2])).modelVariables
            if v.causality == "output" and v.type == "Real"]
    vr = {v.name: v.valueReference for v in real}
    names = list(vr)
    state = [n for n in names if n.startswith("mechanism.") and n.split(".")[1].rstrip("_d")[-1].isdigit()
             and not n.endswith("_dd")]
    rest = [n for n in names if n not in state]
    assert "mechanism.theta2" in state and "mechanism.theta2_d" in state and "mechanism.theta2_dd" in rest
    orders = [[state], [state[::-1], rest], [rest[::-1], state], [["mechanism.theta2"], names[::-1]],
              [[n] for n in state]]
    start = "new 0 s\nsetup 0\nenter\nexit\n"
    subsets, whole, asked = start, start, []
    for i in range(15):
        step = f"step {i * STEP!r} {STEP!r}\n"
        whole += step + "getr " + " ".join(str(vr[n]) for n in names) + "\n"
        subsets += step
        for group in orders[i % len(orders)]:
            subsets += "getr " + " ".join(str(vr[n]) for n in group) + "\n"
            asked.append((i, group))
    got = [line.split() for line in host_run(host, servo, subsets + "free\n", tmp_path) if line.startswith("getr")]
    every = [dict(zip(names, line.split()[2:]))
             for line in host_run(host, servo, whole + "free\n", tmp_path) if line.startswith("getr")]
    assert len(got) == len(asked) and len(every) == 15 and {g[1] for g in got} == {"0"}
    for (i, group), line in zip(asked, got):
        assert line[2:] == [every[i][n] for n in group], (i, group)


def test_the_mechanisms_coordinates_are_read_at_the_level_that_needs_no_evaluation(servo, tmp_path):
    # A system output's level is 1 + its component's: the crank angle and rate are at the mechanism's kinematic
    # pass's, below the accelerations' (one forward-dynamics evaluation of the mechanism)
    from grubler.fmi.header import read_variables_source

    with zipfile.ZipFile(servo[2]) as z:
        rows = {r.name: r for r in read_variables_source(z.read("sources/model_variables.c").decode())}
    assert rows["mechanism.theta2"].level == rows["mechanism.theta2_d"].level < rows["mechanism.theta2_dd"].level


def _fnv(data: bytes) -> int:
    h = 14695981039346656037
    for b in data:
        h = ((h ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return h


def _define(header: Path, name: str) -> int:
    return int(re.search(rf"^#define {name} (\d+)$", header.read_text(), re.M).group(1))


def test_a_crafted_state_is_refused_by_the_component_it_belongs_to(host, servo, tmp_path):
    host_run(host, servo, "new 0 s\nsetup 0\nenter\nexit\nrun 0 0.001 100\nsave 0\nser 0 good.bin\nfree\n", tmp_path)
    blob = bytearray((tmp_path / "good.bin").read_bytes())
    n_stored, n = struct.unpack_from("<II", blob, 12)
    block = list(struct.unpack_from(f"<{n}d", blob, 48))
    # the first component in stepping order owns the block's first part after the system's own: its time
    # made NaN, a value the system's checks do not read and the component's own refuses
    src = tmp_path / "unzipped" / "sources"
    name, first = re.search(r'\{"(\w+)", &grb_m(\d+)_calls', (src / "system_components.c").read_text()).groups()
    folder = next(src.glob(f"m{first}_*"))
    block[_define(src / "config.h", "P_COMPONENTS") + _define(folder / "config.h", "P_T")] = math.nan
    struct.pack_into(f"<{n}d", blob, 48, *block)
    struct.pack_into("<Q", blob, 32, _fnv(bytes(blob[48:48 + 8 * n_stored])))
    struct.pack_into("<Q", blob, 40, _fnv(bytes(blob[48:])))
    (tmp_path / "bad.bin").write_bytes(blob)
    out = host_run(host, servo, "new 0 s\nsetup 0\nenter\nexit\ndeser 0 bad.bin\nfree\n", tmp_path)
    deser = next(line for line in out if line.startswith("deser"))
    assert deser.split()[1] == "3", out  # Error
    assert any(f"{name}: state.t: the time must be finite" in line for line in out), out
    assert any(f"{name}: its part of the state is refused" in line for line in out), out
    # a state of another model: PID.fmu's own, not the system's
    from fmpy import read_model_description

    pid = servo["root"] / "dist" / "PID.fmu"
    zipfile.ZipFile(pid).extractall(tmp_path / "pid")
    r = subprocess.run(["env", "-i", str(host), str(tmp_path / "pid" / "binaries" / "linux64" / "PID.so"),
                        read_model_description(str(pid)).guid],
                       input="new 0 s\nsetup 0\nenter\nexit\nsave 0\nser 0 pid.bin\nfree\n", capture_output=True,
                       text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = host_run(host, servo, "new 0 s\nsetup 0\nenter\nexit\ndeser 0 pid.bin\nfree\n", tmp_path)
    assert next(line for line in out if line.startswith("deser")).split()[1] == "3"
    assert any("belongs to another model" in line for line in out), out


def test_a_components_discard_puts_the_whole_system_back(host, servo, tmp_path):
    from fmpy import read_model_description

    vr = {v.name: v.valueReference for v in read_model_description(str(servo[2])).modelVariables}
    load, theta = vr["mechanism.load_torque"], vr["mechanism.theta2"]
    script = (f"new 0 s\nsetup 0\nenter\nexit\nrun 0 0.001 100\nsetr {load} nan\nstep 0.1 0.001\ngetr {theta}\n"
              f"setr {load} 0\nrun 0.1 0.001 100 {theta}\nfree\n")
    out = host_run(host, servo, script, tmp_path)
    step = next(line for line in out if line.startswith("step"))
    assert step.split()[1] == "2", out  # Discard
    assert any("the system is back at t = 0.10000000000000001 s" in line for line in out), out
    after = rows(out)[-100:]
    plain = run_fmu(servo[2], ["mechanism.theta2"], 0.2, STEP)[101:, 0]
    np.testing.assert_allclose([r[1] for r in after], plain, rtol=0, atol=1e-12)


def test_a_discard_puts_back_every_bit_of_the_state_the_encoders_delay_line_too(host, servo, tmp_path):
    # Before each step the system copies only each component's live part: of the encoder's delay line (10 000
    # readings) the delay + 1 a run uses (law_state_used).  With a delay of 3 the ring's four slots take the
    # discarded steps' readings in turn; each Discard must leave the whole state as it was, byte for byte.
    from fmpy import read_model_description

    vr = {v.name: v.valueReference for v in read_model_description(str(servo[2])).modelVariables}
    load, delay = vr["mechanism.load_torque"], vr["encoder.delay"]
    script = f"new 0 s\nsetup 0\nseti {delay} 3\nenter\nexit\nsetr {load} 0\nrun 0 0.001 100\n"  # (load set: its flag too)
    for k in range(4):
        t = 0.1 + 0.001 * k
        script += (f"save 0\nser 0 before{k}.bin\nsetr {load} nan\nstep {t!r} 0.001\nsetr {load} 0\nsave 1\n"
                   f"ser 1 after{k}.bin\nstep {t!r} 0.001\n")
    out = host_run(host, servo, script + "free\n", tmp_path)
    assert [line.split()[1] for line in out if line.startswith("step")] == ["2", "0"] * 4, out
    for k in range(4):
        before, after = (tmp_path / f"before{k}.bin").read_bytes(), (tmp_path / f"after{k}.bin").read_bytes()
        assert len(before) > 8 * 10_000 and before == after, k
    # the delay line moved between the rounds (each round's state is another)
    assert len({(tmp_path / f"before{k}.bin").read_bytes() for k in range(4)}) == 4


def test_a_bad_component_parameter_is_refused_with_the_components_name(host, servo, tmp_path):
    from fmpy import read_model_description

    vr = {v.name: v.valueReference for v in read_model_description(str(servo[2])).modelVariables}
    out = host_run(host, servo, f"new 0 s\nsetup 0\nsetr {vr['motor.rotor_inertia']} -1\nenter\nexit\nfree\n",
                   tmp_path)
    assert next(line for line in out if line.startswith("exit")).split()[1] == "3", out  # Error
    assert any(line.startswith("log") and "motor: rotor_inertia" in line for line in out), out


def test_an_ssd_with_a_foreign_fmu_falls_back_to_the_container_with_a_note(servo, tmp_path):
    from grubler.system.native import why_not_native
    from grubler.system.ssp import read

    foreign = tmp_path / "dist"
    shutil.copytree(servo["root"] / "dist", foreign)
    pid = foreign / "PID.fmu"
    parts = {n: zipfile.ZipFile(pid).read(n) for n in zipfile.ZipFile(pid).namelist()}
    parts["modelDescription.xml"] = parts["modelDescription.xml"].replace(b'generationTool="grubler',
                                                                          b'generationTool="another tool, not grubler')
    with zipfile.ZipFile(pid, "w") as z:
        for n, data in parts.items():
            z.writestr(n, data)
    (tmp_path / "examples").mkdir()
    ssd = tmp_path / "examples" / "servo_fourbar.ssd"
    shutil.copy(servo["ssd"], ssd)
    assert why_not_native(read(ssd)).startswith("component controller: PID.fmu is not a native grubler FMU")
    r = grubler("export", ssd, "-o", tmp_path / "S.fmu")
    assert r.returncode == 0, r.stderr
    note = [line for line in r.stderr.splitlines() if line.startswith("note:")]
    assert len(note) == 1 and "fmpy's container" in note[0] and "controller" in note[0], r.stderr
    assert "resources/container.json" in zipfile.ZipFile(tmp_path / "S.fmu").namelist()


def test_a_grubler_fmu_of_another_version_is_not_compiled_in(servo, tmp_path):
    from grubler.system.native import component_model

    zipfile.ZipFile(servo["root"] / "dist" / "DCMotor.fmu").extractall(tmp_path)
    common = tmp_path / "sources" / "fmi_common.c"
    common.write_text(common.read_text() + "\n/* another version */\n")
    why = component_model(Path("DCMotor.fmu"), tmp_path)
    assert why == "DCMotor.fmu was built by another grubler version (fmi_common.c differs: build it again)"


def test_its_sources_compile_as_strict_c99_without_complex(servo, tmp_path):
    from test_platforms import STRICT, importer_build

    zipfile.ZipFile(servo[2]).extractall(tmp_path / "u")
    (tmp_path / "u" / "binaries" / "linux64" / "ServoFourbar.so").unlink()
    try:
        built = importer_build(tmp_path / "u", *STRICT, "-D__STDC_NO_COMPLEX__")
    except subprocess.CalledProcessError as exc:
        pytest.fail(f"the system's sources do not compile as strict C99 without complex:\n{exc.stderr}")
    assert built.is_file()


def test_two_fmus_that_carry_different_kernels_are_not_compiled_together(servo, tmp_path):
    from grubler.system.native import why_not_native
    from grubler.system.ssp import read

    dist = tmp_path / "dist"
    shutil.copytree(servo["root"] / "dist", dist)
    pid = dist / "PID.fmu"
    parts = {n: zipfile.ZipFile(pid).read(n) for n in zipfile.ZipFile(pid).namelist()}
    parts["sources/ctl_pid.c"] += b"\n/* another kernel */\n"
    with zipfile.ZipFile(pid, "w") as z:
        for n, data in parts.items():
            z.writestr(n, data)
    (tmp_path / "examples").mkdir()
    shutil.copy(servo["ssd"], tmp_path / "examples" / "servo_fourbar.ssd")
    why = why_not_native(read(tmp_path / "examples" / "servo_fourbar.ssd"))
    assert why is not None and "carry different ctl_pid.c" in why and "PID.fmu" in why, why


def test_two_instances_of_one_fmu_share_its_model_and_keep_their_own_state(servo, tmp_path):
    from grubler.system import cosim
    from grubler.system.native import export_native_system
    from grubler.system.ssp import System

    s = System("two_moves", base=servo["root"] / "dist", step=STEP)
    s.add("slow", "Trajectory.fmu", kind="sine", amplitude=0.5, frequency=1.0)
    s.add("fast", "Trajectory.fmu", kind="sine", amplitude=0.25, frequency=3.0)
    s.add("pid", "PID.fmu", K=2.0, Ts=0.001)
    s.connect("slow.position", "pid.setpoint")
    s.connect("fast.position", "pid.measurement")
    fmu = export_native_system(s, tmp_path / "TwoMoves.fmu", "linux64")
    src = [n for n in zipfile.ZipFile(fmu).namelist() if n.endswith("/symbols.h")]
    assert len(src) == 2  # Trajectory's model once, PID's once
    want = cosim.run(s, t_end=0.5, step=STEP)
    names = ["slow.position", "fast.position", "pid.u"]
    got = run_fmu(fmu, names, 0.5, STEP)
    np.testing.assert_allclose(got, np.column_stack([want[n] for n in names]), rtol=0, atol=1e-12)
    assert np.max(np.abs(got[:, 0] - got[:, 1])) > 0.1


def test_random_call_sequences_under_asan_and_ubsan(servo, tmp_path):
    # test_native_fmu's random episodes (parameters scaled or negated, steps of 1 to 50 ms, states saved,
    # serialised, restored, mutated blobs, calls in any state) on the system rebuilt from its sources with
    # AddressSanitizer and UBSan: no report, no crash, never Fatal
    from fmpy import read_model_description
    from test_native_fmu import SANITIZE, SANITIZER_ENV, random_calls_hold, sanitized_binary

    if builds.sanitizer_problem():
        pytest.skip(f"cc cannot build with sanitizers here: {builds.sanitizer_problem()}")
    zipfile.ZipFile(servo[2]).extractall(tmp_path / "u")
    md = read_model_description(str(servo[2]))
    sanitized = {"host": builds.host(flags=tuple(SANITIZE)),
                 "ServoFourbar": sanitized_binary(tmp_path / "u", md, tmp_path / "ServoFourbar.so")}
    for seed in (1, 2):
        random_calls_hold(sanitized, "ServoFourbar", md, seed, tmp_path)
    # the extrapolating master with error control (sub-steps rolled back through the components' blocks), and
    # the Newton master (iterations rolled back, its Jacobian kept in the block), with steps of 1 to 7 ms, a
    # state saved, restored and serialised in between
    vr = {v.name: v.valueReference for v in md.modelVariables}
    for settings in (f"sets {vr['master']} extrapolate\nsetr {vr['tol']} 1e-7", f"sets {vr['master']} newton"):
        script = (f"new 0 s\nsetup 0\n{settings}\nenter\nexit\n"
                  f"run 0 0.001 20\nsave 0\nrun 0.02 0.007 10\nload 0\nser 0 s.bin\ndeser 1 s.bin\nload 1\n"
                  f"run 0.02 0.003 10 {vr['mechanism.theta2']}\nfree\n")
        proc = subprocess.run([str(sanitized["host"]), str(sanitized["ServoFourbar"]), md.guid], input=script,
                              capture_output=True, text=True, timeout=600, env=SANITIZER_ENV, cwd=tmp_path)
        assert proc.returncode == 0 and "Sanitizer" not in proc.stderr and "runtime error" not in proc.stderr, \
            proc.stderr[-3000:]
        assert [line.split()[1] for line in proc.stdout.splitlines()
                if line.split()[0] in ("run", "load", "deser")] == ["0"] * 6, proc.stdout[-2000:]


# -- every platform: the system FMU's binaries with the cross extra (zig), run under wine and qemu -----------
CROSS = "linux64,win64,darwin64,aarch64-linux"


@pytest.fixture(scope="module")
def cross(servo):
    """The servo system as one FMU with a binary for every platform, unzipped, and its description."""
    from fmpy import read_model_description

    from grubler.fmi.build import zig_compiler

    if zig_compiler() is None:
        pytest.skip("cross-building needs the cross extra: pip install 'grubler[cross]' (zig)")
    fmu = builds.system_fmu(servo["ssd"], SERVO, servo["root"] / "ServoFourbarX.fmu", platforms=CROSS)
    zipfile.ZipFile(fmu).extractall(servo["root"] / "cross")
    return servo["root"] / "cross", read_model_description(str(fmu))


def _binary(cross, folder: str) -> Path:
    from grubler.fmi.build import TARGETS

    return cross[0] / "binaries" / folder / f"ServoFourbarX{next(t.suffix for t in TARGETS if t.fmi2 == folder)}"


@pytest.mark.parametrize("folder", CROSS.split(","))
def test_every_platforms_binary_needs_only_the_c_library_and_exports_only_fmi2(cross, folder):
    from test_platforms import needs_only_the_c_library

    needs_only_the_c_library(_binary(cross, folder), folder)  # (linux64 and aarch64: glibc 2.17's symbols)


def _agrees_with_linux64(cross, folder: str, wrapper: list[str], exe: Path, env: dict) -> None:
    """300 steps of Gauss-Seidel and 300 of the extrapolating master with tol 1e-6, every output read after
    each, in the C host on ``folder``'s binary and on linux64's: the same to rounding (the encoder's
    quantisation off, so that a last bit cannot flip a count), relative to max(1, |value|): Gauss-Seidel's
    to 1e-12 (measured: 3.7e-13 win64, 5.2e-13 aarch64); the adaptive run's sub-steps follow its error
    estimate, a difference of two runs that agree to 1e-6, so the maths library's last bit moves a sub-step
    by 1e-10 of itself and the outputs by less (measured: 7.3e-12, 6.0e-12), hence 1e-10 there."""
    from test_native_fmu import Host
    from test_platforms import RELATIVE

    d, md = cross
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outs = [v.name for v in md.modelVariables if v.causality == "output"]
    quiet = {"encoder.counts_per_rev": 0}
    native = Host(builds.host(), _binary(cross, "linux64"), md.guid, vr)
    script = (native.start(quiet, md=md) + [native.run_steps(0.0, STEP, 300, *outs), "free"]
              + native.start({**quiet, **TOL_SETTINGS}, md=md) + [native.run_steps(0.0, STEP, 300, *outs), "free"])
    ours = native.run(script)
    theirs = Host(exe, _binary(cross, folder), md.guid, vr, wrapper=wrapper).run(script, env=env)
    assert ours.rows().shape == (600, 1 + len(outs)) and ours.statuses("run") == [0, 0]
    off = np.abs(theirs.rows() - ours.rows()) / np.maximum(np.abs(ours.rows()), 1.0)
    assert off[:300].max() <= RELATIVE and off[300:].max() <= 1e-10, (off[:300].max(), off[300:].max())
    assert np.ptp(ours.rows()[:, 1 + outs.index("mechanism.theta2")]) > 0.1  # (a run that moves)


def test_the_win64_binary_under_wine_runs_as_linux64s(cross, tmp_path_factory):
    from test_platforms import host_build, wine_program

    wine = wine_program()
    if wine is None:
        pytest.skip("running win64 binaries here needs wine (Debian: apt-get install wine64)")
    d = tmp_path_factory.mktemp("wine")
    env = {"WINEDEBUG": "-all", "WINEPREFIX": str(d / "prefix"), "HOME": str(d), "PATH": "/usr/bin:/bin"}
    _agrees_with_linux64(cross, "win64", [wine], host_build(d, "x86_64-windows-gnu"), env)


def test_the_aarch64_linux_binary_under_qemu_runs_as_linux64s(cross, tmp_path):
    from test_platforms import host_build, qemu_wrapper

    _agrees_with_linux64(cross, "aarch64-linux", qemu_wrapper(), host_build(tmp_path, "aarch64-linux-gnu.2.17"), {})


# -- fmusim, the FMI Reference FMUs' importer (GRUBLER_FMUSIM or PATH, as tests/test_container.py finds it) ---

def run_fmusim(fmu: Path, out: Path, names: list[str], t_end: float, *extra: str) -> np.ndarray:
    """fmusim's run of ``fmu`` at 1 ms in an empty environment: the outputs ``names``, a row a step."""
    from test_container import fmusim

    if fmusim() is None:
        pytest.skip("no fmusim (the FMI reference importer): set GRUBLER_FMUSIM to one, or put it on PATH "
                    "(docs/fmi.md says how to build it)")
    picks = [a for n in names for a in ("--output-variable", n)]
    proc = subprocess.run([fmusim(), "--interface-type", "cs", "--stop-time", str(t_end), "--output-interval",
                           str(STEP), *extra, *picks, "--output-file", str(out), str(fmu)], env={},
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    data = np.genfromtxt(out, delimiter=",", names=True)
    return np.column_stack([data[n.replace(".", "")] for n in names])  # (genfromtxt drops the dots)


def test_it_runs_in_fmusim_in_an_empty_environment_as_in_the_c_host_fmi_2_and_3(host, servo, tmp_path):
    # FMI 2 with its defaults; FMI 2 given FMI 3's start values with --start-value, and the FMI 3 build
    # (exported with them): each as the C host runs it (fmpy here: the C host's test holds fmpy's to 1e-12)
    # (to 1e-12 of max(1, |value|): fmusim adds up its own time, one rounding from t = k h)
    def close(a, b):
        return np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b))) <= 1e-12

    names = ["mechanism.theta2", "motor.current", "controller.u"]
    plain = run_fmusim(servo[2], tmp_path / "2.csv", names, 0.5)
    assert close(plain, run_fmu(servo[2], names, 0.5, STEP))
    starts = [a for k, v in TOL_SETTINGS.items() for a in ("--start-value", k, str(v))]
    two = run_fmusim(servo[2], tmp_path / "2tol.csv", names, 0.5, *starts)
    three = run_fmusim(servo[3], tmp_path / "3.csv", names, 0.5)
    np.testing.assert_array_equal(two, three)
    assert close(three, run_fmu(servo[3], names, 0.5, STEP, fmi=3))
    assert np.max(np.abs(three - plain)) > 1e-6  # another coupling: another run


def test_fmusim_reports_a_bad_tol_and_exits_with_an_error(servo, tmp_path):
    from test_container import fmusim

    if fmusim() is None:
        pytest.skip("no fmusim: set GRUBLER_FMUSIM to one, or put it on PATH")
    proc = subprocess.run([fmusim(), "--interface-type", "cs", "--stop-time", "0.01", "--start-value", "tol", "-1",
                           str(servo[2])], env={}, capture_output=True, text=True, timeout=600)
    assert proc.returncode != 0
    assert "tol: must be 0 (no error control) or a number from 1e-14 to 0.5, got -1" in proc.stdout + proc.stderr


# -- directional derivatives: the outputs along the system's inputs ----------------------------------------

@pytest.fixture(scope="module")
def pushed(servo):
    """A four-bar whose crank a PID drives by its torque (no motor), the trajectory's velocity its
    feedforward, so that the system's one input is the mechanism's load torque: every unconnected input is
    the mechanism's, which gives directional derivatives (the servo's controller.feedforward is a PID's,
    which gives none)."""
    from grubler.system.ssp import System

    s = System("pushed", base=servo["root"] / "dist", step=STEP)
    s.add("profile", "Trajectory.fmu", kind="sine", amplitude=0.5, frequency=1.0)
    s.add("controller", "PID.fmu", K=20.0, Ts=STEP)
    s.add("mechanism", "Mechanism.fmu", load_joint="theta4")  # (the rocker carries the load)
    s.connect("profile.position", "controller.setpoint")
    s.connect("mechanism.drive_angle", "controller.measurement")
    s.connect("profile.velocity", "controller.feedforward")
    s.connect("controller.u", "mechanism.motor_torque")
    ssd = s.write(servo["root"] / "examples" / "pushed.ssd")
    return builds.system_fmu(ssd, ["Trajectory", "PID", "Mechanism"], servo["root"] / "Pushed.fmu")


def test_its_outputs_derivatives_along_its_inputs_are_its_components_own(host, servo, pushed, tmp_path):
    from fmpy import read_model_description

    md = read_model_description(str(pushed))
    assert md.coSimulation.providesDirectionalDerivative
    assert not read_model_description(str(servo[2])).coSimulation.providesDirectionalDerivative
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outs = [v.name for v in md.modelVariables if v.causality == "output"]
    load, refs = vr["mechanism.load_torque"], " ".join(str(vr[n]) for n in outs)
    e = 1e-3
    zipfile.ZipFile(pushed).extractall(tmp_path / "u")
    script = (f"new 0 s\nsetup 0\nenter\nexit\nrun 0 0.001 200\nsetr {load} 0.5\nddr {load} {refs}\n"
              f"setr {load} {0.5 + e!r}\ngetr {refs}\nsetr {load} {0.5 - e!r}\ngetr {refs}\nfree\n")
    r = subprocess.run(["env", "-i", str(host), str(tmp_path / "u" / "binaries" / "linux64" / "Pushed.so"), md.guid],
                       input=script, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    lines = [line.split() for line in r.stdout.splitlines() if line.startswith(("ddr", "getr"))]
    assert [line[1] for line in lines] == ["0", "0", "0"], r.stdout[-2000:]
    dd, up, down = (np.array(line[2:], float) for line in lines)
    fd = (up - down) / (2 * e)  # the accelerations and forces are affine in the load: exact to rounding
    assert np.max(np.abs(dd - fd) / np.maximum(1.0, np.abs(fd))) < 1e-6, np.column_stack([dd, fd])
    moved = {n for n, d in zip(outs, dd) if d != 0.0}
    assert {"mechanism.theta2_dd", "mechanism.theta4_dd"} <= moved, moved
    assert not any(n.startswith(("profile.", "controller.")) for n in moved), moved


# -- the Newton master: the cylinder slider-crank, a hydraulic coupling stiff at a 10 ms step ----------------

CYLINDER = "cylinder_slider_crank"
COARSE = 1e-2  # the step at which Gauss-Seidel diverges on it (tests/test_cosim_newton.py)


@pytest.fixture(scope="module")
def cylinder(tmp_path_factory):
    """examples/cylinder_slider_crank.ssd beside a dist/ of its FMUs (its mechanism's built by
    examples/cylinder_systems.py's design), exported with --master newton (CylinderSliderCrank.fmu, cached)."""
    sys.path.insert(0, str(ROOT / "examples"))
    import cylinder_systems

    from grubler.system.cylinder_servo import cylinder_servo_system
    from grubler.system.native import export_native_system

    root = tmp_path_factory.mktemp("cylinder")
    builds.dist(root / "dist", ["HydraulicCylinder", "PID", "Trajectory"])
    cylinder_servo_system(cylinder_systems.DESIGNS[CYLINDER], root / "dist", name=CYLINDER)
    (root / "examples").mkdir()
    ssd = root / "examples" / f"{CYLINDER}.ssd"
    shutil.copy(ROOT / "examples" / ssd.name, ssd)

    def make(d: Path) -> Path:
        return export_native_system(ssd, d / "CylinderSliderCrank.fmu", "linux64", master="newton")

    fmu = builds.cached("system-CylinderSliderCrank-newton", builds.digest(builds.package_key(), ssd, "newton"), make)
    return {"root": root, "ssd": ssd, "fmu": builds.copy_to(fmu, root / "CylinderSliderCrank.fmu")}


def test_newton_holds_the_cylinder_slider_crank_at_10_ms_as_grubler_cosim_newton_where_gauss_seidel_diverges(
        cylinder):
    from fmpy import read_model_description
    from fmpy.fmi1 import FMICallException

    from grubler.system import cosim

    fmu = cylinder["fmu"]
    assert read_model_description(str(fmu)).modelVariables[1].start == "newton"  # the export's --master
    want = cosim.run(cylinder["ssd"], t_end=1.0, step=COARSE, master="newton")
    names = [c for c in want.columns if c in _outputs(fmu)]
    got = run_fmu(fmu, names, 1.0, COARSE, parameters={"communication_step": COARSE})
    expected = np.column_stack([want[c] for c in names])
    assert got.shape == expected.shape and len(names) > 20
    worst = np.max(np.abs(got - expected) / np.maximum(1.0, np.abs(expected)))
    assert worst <= 1e-12, worst  # (measured: 0, the same bits)
    assert want.coupling["jacobians"] < want.coupling["steps"]  # the Jacobian kept from step to step, as here
    force = got[:, names.index("cylinder.force")]
    assert 100.0 < np.max(np.abs(force)) < 200.0  # the 120 to 143 N Gauss-Seidel gives at 1 ms
    # the same FMU under Gauss-Seidel at 10 ms: the mechanism cannot take the step the coupling gives it
    with pytest.raises(FMICallException, match="discard"):
        run_fmu(fmu, ["cylinder.force"], 1.0, COARSE, parameters={"communication_step": COARSE,
                                                                   "master": "gauss-seidel"})


def cylinder_host_run(host, cylinder, script: str, cwd: Path) -> list[str]:
    from fmpy import read_model_description

    root = cwd / "unzipped"
    if not root.exists():
        zipfile.ZipFile(cylinder["fmu"]).extractall(root)
    guid = read_model_description(str(cylinder["fmu"])).guid
    r = subprocess.run(["env", "-i", str(host), str(root / "binaries" / "linux64" / "CylinderSliderCrank.so"), guid],
                       input=script, capture_output=True, text=True, cwd=cwd, timeout=120)
    assert r.returncode == 0, r.stderr
    return r.stdout.splitlines()


def test_a_newton_run_replays_bit_for_bit_from_a_saved_state_its_jacobian_in_it(host, cylinder, tmp_path):
    # the history the guess extrapolates from and the factored Jacobian, kept from step to step, are in the
    # state: a run restored mid-way goes on as the run never interrupted (memory and bytes alike)
    from fmpy import read_model_description

    vr = {v.name: v.valueReference for v in read_model_description(str(cylinder["fmu"])).modelVariables}
    seen = f"{vr['mechanism.cylinder_length']} {vr['cylinder.force']}"
    script = (f"new 0 s\nsetup 0\nsetr {vr['communication_step']} 0.01\nenter\nexit\nrun 0 0.01 30\nsave 0\n"
              f"ser 0 state.bin\nrun 0.3 0.01 30 {seen}\nload 0\nrun 0.3 0.01 30 {seen}\n"
              f"deser 1 state.bin\nload 1\nrun 0.3 0.01 30 {seen}\nfree\n")
    out = rows(cylinder_host_run(host, cylinder, script, tmp_path))
    first, again, from_bytes = out[30:60], out[60:90], out[90:120]
    assert len(from_bytes) == 30 and first == again == from_bytes
    # the state holds a usable Jacobian (made at a step before 0.3 s and kept)
    blob = (tmp_path / "state.bin").read_bytes()
    n = struct.unpack_from("<II", blob, 12)[1]
    block = struct.unpack_from(f"<{n}d", blob, 48)
    src = tmp_path / "unzipped" / "sources"
    assert block[_define(src / "config.h", "P_HAVE_JACOBIAN")] == 1.0
    assert _define(src / "config.h", "SYSTEM_N_UNKNOWN") == 3  # cylinder.force, the length and its rate


@pytest.mark.parametrize("where, value, named", [
    ("P_HAVE_JACOBIAN", 0.5, "state.have_jacobian: must be 0 or 1, got 0.5"),
    ("P_PIVOT", 7.0, "state.pivot: row 0's pivot must be a row from 0 to 2, got 7"),
    ("P_JACOBIAN", 0.0, "state.jacobian: its factored diagonal must be non-zero, got 0 at row 0"),
    ("P_JACOBIAN + 1", math.inf, "state.jacobian: must be finite, got inf"),
], ids=["flag", "pivot", "singular", "infinite"])
def test_a_crafted_newton_state_is_refused_naming_the_field(host, cylinder, tmp_path, where, value, named):
    # lu_solve indexes the unknowns by the pivots it reads: a crafted one never reaches it
    from fmpy import read_model_description

    vr = {v.name: v.valueReference for v in read_model_description(str(cylinder["fmu"])).modelVariables}
    cylinder_host_run(host, cylinder, f"new 0 s\nsetup 0\nsetr {vr['communication_step']} 0.01\nenter\nexit\n"
                                      "run 0 0.01 30\nsave 0\nser 0 good.bin\nfree\n", tmp_path)
    blob = bytearray((tmp_path / "good.bin").read_bytes())
    n_stored, n = struct.unpack_from("<II", blob, 12)
    block = list(struct.unpack_from(f"<{n}d", blob, 48))
    field, _, plus = where.partition(" + ")
    block[_define(tmp_path / "unzipped" / "sources" / "config.h", field) + int(plus or 0)] = value
    struct.pack_into(f"<{n}d", blob, 48, *block)
    struct.pack_into("<Q", blob, 32, _fnv(bytes(blob[48:48 + 8 * n_stored])))
    struct.pack_into("<Q", blob, 40, _fnv(bytes(blob[48:])))
    (tmp_path / "bad.bin").write_bytes(blob)
    out = cylinder_host_run(host, cylinder, "new 0 s\nsetup 0\nenter\nexit\ndeser 0 bad.bin\nfree\n", tmp_path)
    assert next(line for line in out if line.startswith("deser")).split()[1] == "3", out  # Error
    assert any(named in line for line in out), out


def test_a_newton_step_kept_unconverged_is_a_warning_naming_the_value_as_cosim_warns(host, cylinder, tmp_path):
    # at 50 ms one step of cosim's ends its 8 evaluations above the tolerance, and cosim says so; the FMU's
    # doStep that holds it returns Warning with the same words (the run before it: OK)
    from fmpy import read_model_description

    from grubler.system import cosim

    want = cosim.run(cylinder["ssd"], t_end=1.0, step=0.05, master="newton", record=["cylinder.force"])
    assert want.coupling["unconverged"] == 1, want.coupling
    said = next(w for w in want.warnings if w.startswith("master newton:"))
    vr = {v.name: v.valueReference for v in read_model_description(str(cylinder["fmu"])).modelVariables}
    out = cylinder_host_run(host, cylinder, f"new 0 s\nsetup 0\nsetr {vr['communication_step']} 0.05\nenter\nexit\n"
                                            f"run 0 0.05 20 {vr['cylinder.force']}\nfree\n", tmp_path)
    assert next(line for line in out if line.startswith("run")).split()[1] == "1", out  # Warning
    warned = [line for line in out if line.startswith("log 1") and "master newton: 1 of 1 steps from t = " in line]
    assert len(warned) == 1 and "kept after 8 evaluations with a coupling residual above 1e-05" in warned[0], out
    assert said.split("(largest ")[1].split(")")[0] in warned[0], (said, warned)  # its size and its value
    # the rows up to the step that warned are cosim's (the step that warned is not printed by the host)
    got = np.array(rows(out))[:, 1]
    np.testing.assert_array_equal(got, np.asarray(want["cylinder.force"])[1:len(got) + 1])


def test_the_fmi3_build_runs_newton_as_the_fmi2_build(cylinder):
    # (one model's files behind both wrappers: the same iteration, the same bits)
    from grubler.system.native import export_native_system

    def make(d: Path) -> Path:
        return export_native_system(cylinder["ssd"], d / "CylinderSliderCrank.fmu", "linux64", fmi=3, master="newton")

    three = builds.copy_to(builds.cached("system-CylinderSliderCrank-newton-fmi3",
                                         builds.digest(builds.package_key(), cylinder["ssd"], "newton", 3), make),
                           cylinder["root"] / "three" / "CylinderSliderCrank.fmu")
    names = ["mechanism.cylinder_length", "cylinder.force", "controller.u"]
    settings = {"communication_step": COARSE}
    np.testing.assert_array_equal(run_fmu(three, names, 0.5, COARSE, fmi=3, parameters=settings),
                                  run_fmu(cylinder["fmu"], names, 0.5, COARSE, parameters=settings))
