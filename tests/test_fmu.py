"""The native mechanism FMU, driven through fmpy (and a second master) in child processes.

Each scenario (tests/fmu_scenarios.py) writes its measurements to JSON; the tests
judge that file, so a crash at interpreter exit (upstream PythonFMU issue 228)
can neither hide nor fake a result.
"""

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import grubler

HERE = Path(__file__).parent
ROOT = HERE.parent


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="session")
def fmu(tmp_path_factory):
    sys.path.insert(0, str(ROOT))
    import builds

    (path,) = builds.dist(tmp_path_factory.mktemp("dist"), ["Mechanism"])
    return path


def run_scenario(script: str, name: str, fmu: Path, tmp_path: Path) -> dict:
    out = tmp_path / f"{name}.json"
    args = [sys.executable, str(HERE / script)] + ([name] if script == "fmu_scenarios.py" else []) + [str(fmu), str(out)]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=600)
    assert out.exists(), f"scenario {name} wrote nothing (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    data = json.loads(out.read_text())
    assert data["done"]
    return data["result"]


# The library's run interpolates between the steps its controller chose; the FMU
# ends a step at every communication point.  Both are within the tolerance
# (rtol = atol = 1e-9) of the motion, so over a second or two they agree to a few
# 1e-9 rad, not to rounding.
AGREE = 1e-8


def library(t_end, torque=3.0, dt_out=0.01, scene="thesis-fourbar", **link2):
    sc = grubler.load_scene(scene)
    if link2:
        m = sc.mechanism
        sc = grubler.mechanism.scene.with_overrides(sc, mechanism=m.replace(links=(replace(m.links[0], **link2),) + m.links[1:]))
    return grubler.simulate(sc, t_end=t_end, dt_out=dt_out, torque=torque)


def test_fmpy_validate_passes(fmu):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu)) == []


def test_model_description_declares_the_interface(fmu):
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    for name in ("motor_torque", "load_torque"):
        assert by_name[name].causality == "input"
    outputs = ["B1", "theta2", "theta4_d", "theta3_dd", "drive_angle", "drive_speed", "tip_x", "tip_y",
               "closure_error", "Fx", "Fy", "Mz", "R1_Fx", "R3_Mz", "KE", "PE"]
    for name in outputs:
        assert by_name[name].causality == "output", name
        assert by_name[name].description
    for name in ("method", "rtol", "link3.m", "link2.damping", "closure.gain", "drive_joint", "link2.joint",
                 "load_joint", "initial.theta3", "gravity"):
        assert by_name[name].causality == "parameter", name
    assert by_name["method"].start == "exact" and by_name["drive_joint"].start == "theta2"
    assert float(by_name["link4.m"].start) == 3.0
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate


def test_simulate_fmu_with_a_torque_input_matches_the_library(fmu, tmp_path):
    res = run_scenario("fmu_scenarios.py", "simulate", fmu, tmp_path)
    lib = library(2.0)
    assert np.allclose(res["time"], lib.t)
    for name in ("theta2", "theta4", "Fx", "Fy", "KE"):
        assert np.max(np.abs(np.array(res[name]) - lib[name])) < AGREE, name
    assert np.allclose(res["drive_angle"], lib["theta2"], atol=1e-12)
    assert np.allclose(res["drive_speed"], lib["theta2_d"], atol=1e-12)


def test_an_effort_set_between_reads_changes_forces_not_the_state(fmu, tmp_path):
    # the FMU computes outputs when read and keeps what does not depend on the
    # efforts (angles, rates): a new torque at the same instant must reach the
    # accelerations and forces, and only them
    res = run_scenario("fmu_scenarios.py", "feedthrough", fmu, tmp_path)
    sim = grubler.Simulator(grubler.load_scene("thesis-fourbar").mechanism)
    for i in range(50):
        sim.set_inputs(3.0)
        sim.advance_to(i * 1e-2 + 1e-2)
    at3 = sim.outputs(["state", "dynamics"])
    z, zd = float(sim.z[0]), float(sim.zd[0])
    sim.set_inputs(5.0)
    at5 = sim.outputs(["state", "dynamics"])
    assert abs(at5["Fx"] - at3["Fx"]) > 1e-3  # the torque does move the force
    np.testing.assert_allclose(res["first"], [at3["theta2"], z, zd, at3["Fx"], at3["theta2_dd"]], rtol=0, atol=1e-10)
    np.testing.assert_allclose(res["second"], [at5["Fx"], at5["theta2_dd"], z], rtol=0, atol=1e-10)
    np.testing.assert_allclose(res["alone"], [zd], rtol=0, atol=1e-12)
    sim.advance_to(0.51)
    after = sim.outputs(["state", "dynamics"])
    np.testing.assert_allclose(res["after_step"], [float(sim.zd[0]), after["Fx"]], rtol=0, atol=1e-9)


def test_communication_step_does_not_change_the_trajectory(fmu, tmp_path):
    res = run_scenario("fmu_scenarios.py", "steps", fmu, tmp_path)
    lib = library(1.0)
    for h, rows in res.items():
        a = np.array(rows)
        assert np.allclose(a[:, 0], lib.t[1:]), h
        assert np.max(np.abs(a[:, 1] - lib["theta2"][1:])) < AGREE, h
        assert np.max(np.abs(a[:, 3] - lib["Fx"][1:])) < 1e-7, h


def test_two_instances_with_different_parameters_side_by_side(fmu, tmp_path):
    res = run_scenario("fmu_scenarios.py", "two_instances", fmu, tmp_path)
    a, b = np.array(res["a"]), np.array(res["b"])
    assert np.max(np.abs(a[:, 1] - library(1.0)["theta2"][1:])) < AGREE
    assert np.max(np.abs(b[:, 1] - library(1.0, m=2.5)["theta2"][1:])) < AGREE
    assert np.max(np.abs(a[:, 1] - b[:, 1])) > 0.1  # they really differ


def test_saved_state_replays_the_same_trajectory(fmu, tmp_path):
    res = run_scenario("fmu_scenarios.py", "rollback", fmu, tmp_path)
    first = np.array(res["first"])
    assert first.shape == (100, 4)
    assert np.array_equal(first, np.array(res["replay"]))
    assert np.array_equal(first, np.array(res["replay_serialized"]))
    assert np.allclose(first, np.array(res["after_reset"]), rtol=0, atol=1e-10)


def test_bad_inputs_give_a_status_and_a_logged_message(fmu, tmp_path):
    res = run_scenario("fmu_scenarios.py", "bad_inputs", fmu, tmp_path)
    assert "status 2 (discard)" in res["nan_step"]
    assert any("motor_torque is nan" in m for m in res["messages_nan"])
    assert res["after_nan"] == "ok"
    assert "status 2 (discard)" in res["zero_step"]
    assert any("step size must be positive" in m for m in res["messages_zero_step"])
    # a bad parameter is an error at initialisation (the instance then refuses every call)
    assert "status 3 (error)" in res["bad_param"]
    assert any("link2.m: mass must be positive" in m for m in res["messages_param"])
    assert "status 3 (error)" in res["bad_scene"]
    assert any("method cannot be 'lagrange'" in m for m in res["messages_scene"])


def test_a_second_master_libcosim_agrees_with_fmpy(fmu, tmp_path):
    pytest.importorskip("libcosimpy")
    res = run_scenario("libcosim_scenario.py", "libcosim", fmu, tmp_path)
    rows = np.array(res["rows"])
    fmpy_run = run_scenario("fmu_scenarios.py", "simulate", fmu, tmp_path)
    assert rows.shape == (200, 3)
    assert np.allclose(rows[:, 0], fmpy_run["time"][1:], atol=1e-12)
    assert np.max(np.abs(rows[:, 1] - np.array(fmpy_run["theta2"][1:]))) < 1e-9
    assert np.max(np.abs(rows[:, 2] - np.array(fmpy_run["Fx"][1:]))) < 1e-7


def test_start_time_other_than_zero_and_a_step_limit(fmu, tmp_path):
    res = run_scenario("fmu_scenarios.py", "start_time", fmu, tmp_path)
    rows = np.array(res["rows"])
    assert np.allclose(rows[:, 0], 5.0 + library(1.0).t[1:])
    # a time-invariant scene: the motion from 5 s equals the motion from 0 s
    assert np.max(np.abs(rows[:, 1] - library(1.0)["theta2"][1:])) < AGREE
