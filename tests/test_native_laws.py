"""The native control-law FMUs (PID, Encoder, Trajectory) held to the native contract.

As the mechanism and motor FMUs are (test_native_fmu.py, whose C host and
helpers these tests reuse): the binary needs no Python, ``fmpy validate``
passes, the C host with an empty environment gets the library's numbers bit
for bit (the same C: the library's Sampler and classes through ctypes), one
test per status class, serialised states replay and foreign or crafted ones
are refused naming the field, and random call sequences and crafted states run
under AddressSanitizer and UBSan.
"""

from __future__ import annotations

import math
import struct
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import grubler
from grubler.fmi.mechanism import mechanism_spec
from grubler.mechanism.scene import load_scene
from grubler.controllers import (PID, CascadeController, ComputedTorque, CurrentSensor, Encoder, LinearController,
                                 Sampler, Tachometer, Trajectory)
from test_native_fmu import (DISCARD, ERROR, OK, SANITIZER_ENV, WARNING, Host, Transcript, craft,  # noqa: F401
                             host, random_calls_hold, sanitize_all)

ROOT = Path(__file__).resolve().parent.parent
LAWS = ["PID", "CascadeController", "Encoder", "Tachometer", "CurrentSensor", "Trajectory", "ComputedTorque"]
# and build_fmu.py's LinearController, whose variables are its default controller's matrices
DIST_LAWS = [*LAWS, "LinearController"]
PID_PARAMS = {"K": 8.0, "Ti": 0.4, "Td": 0.05, "N": 10.0, "b": 0.7, "c": 0.5, "Ts": 1e-3, "u_min": -6.0,
              "u_max": 6.0}
ENC = {"counts_per_rev": 2000, "noise_std": 2e-3, "seed": 7, "delay": 2, "Ts": 1e-3}
CASCADE = {"K_position": 30.0, "Ti_position": 0.5, "K_speed": 0.8, "Ti_speed": 0.05, "speed_limit": 4.0,
           "u_min": -24.0, "u_max": 24.0, "Ts": 1e-3, "K_current": 2.0, "Ti_current": 0.05, "current_limit": 2.5}
SENSOR = {"gain_error": 0.03, "offset": 0.2, "noise_std": 0.05, "seed": 3, "bandwidth": 40.0, "Ts": 1e-3}
CT = {"gear_ratio": 10.0, "efficiency": 0.8, "R": 2.0, "k_t": 0.1, "k_e": 0.1, "Ts": 1e-3, "drive_inertia": 0.01}
TRAJ = {"kind": "scurve", "distance": 1.2, "v_max": 3.0, "a_max": 5.0, "j_max": 100.0, "delay": 0.02,
        "dwell": 0.1, "repeat": 3}
# each law's parameters and its inputs at step k
RUNS = {"PID": (PID_PARAMS, lambda k: {"setpoint": 1.0, "measurement": 0.6 * np.sin(0.03 * k), "feedforward": 0.1}),
        "CascadeController": (CASCADE, lambda k: {"position_setpoint": 1.0, "velocity_setpoint": 0.5,
                                                  "position": 0.8 * np.sin(0.01 * k), "speed": np.cos(0.01 * k),
                                                  "current": 1.5 * np.sin(0.05 * k)}),
        "Encoder": (ENC, lambda k: {"position": 0.3 * np.sin(3e-3 * k) + 1e-4 * k}),
        "Tachometer": (SENSOR, lambda k: {"speed": 30.0 * np.sin(0.02 * k)}),
        "CurrentSensor": (SENSOR, lambda k: {"current": 2.0 if k % 50 < 25 else -1.0}),
        "Trajectory": (TRAJ, lambda k: {}),
        # the thesis four-bar's crank swinging 2 rad either way of its sketch (theta2 = 0)
        "ComputedTorque": (CT, lambda k: {"position": 2.0 * np.sin(0.01 * k), "velocity": 20.0 * np.cos(0.01 * k),
                                          "acceleration": -200.0 * np.sin(0.01 * k)}),
        # the one-instance FMUs: a linear controller's, a CSV profile's
        "Lead": ({}, lambda k: {"setpoint": 1.0, "measurement": 0.2 * math.sin(0.1 * k), "feedforward": 0.0}),
        "Cam": ({"delay": 0.001}, lambda k: {})}
CLASSES = {"PID": PID, "CascadeController": CascadeController, "Encoder": Encoder, "Tachometer": Tachometer,
           "CurrentSensor": CurrentSensor, "Trajectory": Trajectory, "ComputedTorque": ComputedTorque,
           "Lead": LinearController, "Cam": Trajectory}


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The law FMUs as build_fmu.py makes them, unzipped too."""
    sys.path.insert(0, str(ROOT))
    import builds
    from fmpy import read_model_description

    out = {}
    for path in builds.dist(tmp_path_factory.mktemp("dist"), DIST_LAWS):
        d = tmp_path_factory.mktemp(path.stem)
        zipfile.ZipFile(path).extractall(d)
        out[path.stem] = (path, d, read_model_description(str(path)))
    return out


def law_host(host, built, name: str) -> Host:
    _, d, md = built[name]
    return Host(host, d / "binaries" / "linux64" / f"{name}.so", md.guid,
                {v.name: v.valueReference for v in md.modelVariables})


def stepped(h: Host, name: str, n: int, step: float, t0: float = 0.0) -> list[str]:
    """Script lines: n steps, each setting the inputs of RUNS[name] and reading every output."""
    inputs = RUNS[name][1]
    outs = [v for v, _ in _outputs(name)]
    lines = []
    for k in range(n):
        lines += [f"setr {h.vr[i]} {float(x)!r}" for i, x in inputs(k).items()]
        lines += [f"step {t0 + k * step!r} {step!r}", h.getr(*outs)]
    return lines


def _outputs(name):
    return list(CLASSES[name].outputs.items())


def library(name: str, n: int, step: float, params: dict | None = None) -> np.ndarray:
    """The library's law through its Sampler, stepped as the host steps the FMU."""
    s = Sampler(CLASSES[name](**(params or RUNS[name][0])), t0=0.0)
    rows = []
    for k in range(n):
        out = s.step(k * step, step, RUNS[name][1](k))
        rows.append([out[v] for v, _ in _outputs(name)])
    return np.array(rows)


def got(t: Transcript) -> np.ndarray:
    return np.array([[float(x) for x in r[2:]] for r in t.results if r[0] == "getr"])


# -- the binary ---------------------------------------------------------------------

@pytest.mark.parametrize("name", DIST_LAWS)
def test_the_binary_needs_no_python_and_exports_only_fmi2(built, name):
    so = built[name][1] / "binaries" / "linux64" / f"{name}.so"
    undefined = subprocess.run(["nm", "-D", "--undefined-only", str(so)], capture_output=True, text=True,
                               check=True).stdout
    assert not [ln for ln in undefined.splitlines() if "Py" in ln or "python" in ln.lower()]
    defined = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True,
                             check=True).stdout.splitlines()
    exported = [ln.split()[-1] for ln in defined if ln.strip() and ln.split()[1] in "TD"]
    assert exported and all(x.startswith("fmi2") for x in exported), exported


@pytest.mark.parametrize("name", LAWS)
def test_fmpy_validate_passes_and_the_variables_are_the_laws(built, name):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(built[name][0])) == []
    md = built[name][2]
    law = CLASSES[name]
    assert [v.name for v in md.modelVariables if v.causality == "input"] == list(law.inputs)
    assert [v.name for v in md.modelVariables if v.causality == "output"] == list(law.outputs)
    params = [v.name for v in md.modelVariables if v.causality == "parameter"]
    own = [p for p in law.parameters if p not in ("times", "positions", "mechanism")]
    assert params[:len(own)] == own
    # computed torque's mechanism is the scene as the Mechanism FMU shows it
    scene = [v.name for v in mechanism_spec(load_scene("thesis-fourbar")).variables if v.causality == "parameter"]
    assert set(params[len(own):]) <= set(scene) and ("link4.m" in params) == (name == "ComputedTorque")
    assert all(u.dependencies == [] for u in md.outputs)  # held outputs: no feed-through


@pytest.mark.parametrize("name", LAWS)
def test_a_sampled_laws_outputs_are_discrete_and_its_sample_time_the_default_step(built, name):
    # a sampled law's outputs hold between its samples: discrete (FMI 2.0 allows a discrete Real output,
    # initial calculated; fmpy validate above agrees); its sample time Ts (a fixed parameter, in s) is the
    # DefaultExperiment's stepSize, which fmpy's simulate_fmu and fmusim take as their communication step.
    # The trajectory, a law of time alone, is continuous and keeps the default step
    import xml.etree.ElementTree as ET

    root = ET.fromstring(zipfile.ZipFile(built[name][0]).read("modelDescription.xml"))
    by = {v.get("name"): v for v in root.iter("ScalarVariable")}
    sampled = not CLASSES[name].continuous
    for out in CLASSES[name].outputs:
        v = by[out]
        assert (v.get("causality"), v.get("variability"), v.get("initial")) == (
            "output", "discrete" if sampled else "continuous", "calculated"), out
    step = float(root.find("DefaultExperiment").get("stepSize"))
    if sampled:
        ts = by["Ts"]
        assert (ts.get("causality"), ts.get("variability"), ts.find("Real").get("unit")) == ("parameter", "fixed", "s")
        start = float(ts.find("Real").get("start"))
        # (Ts = 0: once per communication step, which the default step then is)
        assert step == (start if start > 0 else 0.001), (name, start)
    else:
        assert name == "Trajectory" and step == 0.001


def test_fmpy_simulates_a_sampled_law_at_its_sample_time(built):
    # what an importer does with the declaration: fmpy steps once per sample, the outputs change at each
    from fmpy import simulate_fmu

    res = simulate_fmu(str(built["PID"][0]), stop_time=0.02, start_values={"setpoint": 1.0, "Ti": 0.01,
                                                                           "u_max": 100.0})
    assert np.allclose(np.diff(res["time"]), 1e-3)
    assert np.all(np.diff(res["u"][1:]) > 0)  # the integral's ramp: a new value at every sample


def test_a_table_trajectory_that_drives_a_length_says_metres(tmp_path):
    # the trajectory of a cylinder's length (cylinder_check builds one) was declared in rad
    import xml.etree.ElementTree as ET

    from fmpy.validation import validate_fmu

    from grubler.controllers.native_fmu import export_table

    units = {}
    for quantity in ("length", "angle"):
        path = export_table([0.0, 0.5, 1.0], [0.1, 0.3, 0.2], tmp_path / f"{quantity}.fmu", quantity=quantity)
        assert validate_fmu(str(path)) == []
        root = ET.fromstring(zipfile.ZipFile(path).read("modelDescription.xml"))
        units[quantity] = {v.get("name"): (v.find("Real").get("unit"), v.get("description"))
                           for v in root.iter("ScalarVariable") if v.find("Real") is not None}
    length, angle = units["length"], units["angle"]
    assert length["position"] == ("m", "position setpoint [m]") and angle["position"][0] == "rad"
    assert length["velocity"][0] == "m/s" and length["acceleration"][0] == "m/s2"
    assert length["positions[2]"][0] == length["start"][0] == length["distance"][0] == "m"
    assert length["j_max"][1].endswith("[m/s3]") and length["delay"][0] == angle["delay"][0] == "s"
    with pytest.raises(grubler.SceneError, match=r"quantity: a trajectory drives an angle or a length, got 'volume'"):
        export_table([0.0, 1.0], [0.0, 1.0], tmp_path / "v.fmu", quantity="volume")


# -- the C host, empty environment, against the library ------------------------------

@pytest.mark.parametrize("name, step, n", [("PID", 2e-3, 150), ("PID", 0.25e-3, 600), ("Encoder", 1e-3, 400),
                                           ("CascadeController", 1e-3, 300), ("Tachometer", 2e-3, 300),
                                           ("CurrentSensor", 0.5e-3, 400), ("Trajectory", 1e-2, 150),
                                           ("ComputedTorque", 1e-3, 700), ("ComputedTorque", 2.5e-3, 200)])
def test_c_host_with_an_empty_environment_matches_the_library_bit_for_bit(host, built, name, step, n):
    h = law_host(host, built, name)
    t = h.run(h.start(RUNS[name][0], md=built[name][2]) + stepped(h, name, n, step))  # env={} by default
    assert set(t.statuses("step")) == {OK}
    assert np.array_equal(got(t), library(name, n, step))


def test_the_encoder_fmu_draws_the_librarys_noise(host, built):
    h = law_host(host, built, "Encoder")
    params = {**ENC, "counts_per_rev": 0, "delay": 0, "noise_std": 1.0}
    t = h.run(h.start(params, md=built["Encoder"][2]) + [h.run_steps(0.0, 1e-3, 50, "measured_position")])
    enc = Encoder(**params)
    assert np.array_equal(t.rows()[:, 1], [enc.measure(0.0) for _ in range(50)])


# -- one test per status class ----------------------------------------------------------

@pytest.mark.parametrize("name", LAWS)
def test_ok_a_run_and_a_reset_run_give_the_same_outputs(host, built, name):
    h = law_host(host, built, name)
    outs = [v for v, _ in _outputs(name)]
    t = h.run(h.start(RUNS[name][0], md=built[name][2]) + stepped(h, name, 20, 1e-3)
              + ["reset", "setup 0", "enter"] + h.set_lines(RUNS[name][0], built[name][2]) + ["exit"]
              + stepped(h, name, 20, 1e-3))
    assert set(t.statuses("step")) == {OK} and set(t.statuses("getr")) == {OK} and not t.logs
    rows = got(t)
    assert rows.shape == (40, len(outs)) and np.array_equal(rows[:20], rows[20:])


def test_warning_none_is_ever_answered_a_run_at_its_limits_is_ok_or_discarded(host, built):
    # the laws have no warning to give: the largest step they take is OK, the next one is refused
    h = law_host(host, built, "Encoder")
    t = h.run(h.start(ENC, md=built["Encoder"][2]) + ["step 0 99.9999", "step 99.9999 100.1"])
    assert t.statuses("step") == [OK, DISCARD] and not [ln for ln in t.logs if ln.startswith("log 1 ")]


@pytest.mark.parametrize("name, inputs, why", [
    ("PID", {"measurement": float("nan")}, "measurement is nan at t = 0.002 s: inputs must be finite"),
    ("Encoder", {"position": float("inf")}, "position is inf at t = 0.002 s: inputs must be finite")])
def test_discard_a_non_finite_input_and_the_run_goes_on(host, built, name, inputs, why):
    h = law_host(host, built, name)
    t = h.run(h.start(RUNS[name][0], md=built[name][2]) + stepped(h, name, 2, 1e-3)
              + [f"setr {h.vr[k]} {v}" for k, v in inputs.items()] + ["step 0.002 0.001"]
              + stepped(h, name, 3, 1e-3, t0=0.002))
    assert t.statuses("step") == [OK, OK, DISCARD, OK, OK, OK]
    assert t.logged(why), t.logs


@pytest.mark.parametrize("h_text, why", [("1e300", "at most 100000 per communication step"),
                                         ("0", "the step size must be positive and finite"),
                                         ("nan", "the step size must be positive and finite")])
def test_discard_a_step_the_clock_cannot_take(host, built, h_text, why):
    h = law_host(host, built, "PID")
    t = h.run(h.start(PID_PARAMS, md=built["PID"][2]) + [f"step 0 {h_text}", "step 0 0.001"])
    assert t.statuses("step") == [DISCARD, OK] and t.logged(why), t.logs


@pytest.mark.parametrize("name, params, why", [
    ("PID", {"u_min": 1.0, "u_max": 0.0}, "u_max: must exceed u_min (got 0)"),
    ("PID", {"Ts": 0.0}, "Ts: sample time must be finite and > 0 (got 0)"),
    ("PID", {"N": -1.0}, "N: must be > 0 (got -1)"),
    ("Encoder", {"noise_std": -0.1}, "noise_std: must be finite and >= 0 (got -0.10000000000000001)"),
    ("CascadeController", {"speed_limit": 0.0}, "speed_limit: must be finite and > 0 (got 0)"),
    ("Tachometer", {"gain_error": -1.0}, "gain_error: must be finite and > -1 (the gain stays positive) (got -1)"),
    ("CurrentSensor", {"bandwidth": -5.0}, "bandwidth: must be finite and >= 0 (0: instantaneous) (got -5)"),
    ("Trajectory", {"kind": "scurve", "j_max": 0.0}, "j_max: must be finite and > 0 (got 0)"),
    ("Trajectory", {"kind": "trapezoid", "distance": 0.0}, "distance: a move needs a non-zero distance (got 0)"),
    ("ComputedTorque", {"efficiency": 0.0}, "efficiency: must be in (0, 1] (got 0)"),
    # the mechanism's rules are the kernel's one check: the library's words (grb_scene_check)
    ("ComputedTorque", {"link3.m": -1.0}, "link3.m: mass must be positive, got -1.0"),
    ("ComputedTorque", {"gravity": -1.0}, "gravity: must be >= 0 (it acts along -y), got -1.0"),
    ("ComputedTorque", {"link2.a": 1e300}, "link2.a: magnitude above 1e+12 is outside the supported range"),
    ("ComputedTorque", {"drive_joint": ""}, "drive_joint: must name a real joint"),
    ("ComputedTorque", {"link2.a": 9.0}, "initial.theta2: the loop cannot be closed at the sketch with the drive "
                                         "held there")])
def test_error_a_bad_parameter_at_initialisation_names_it_and_the_instance_stays_refused(host, built, name, params,
                                                                                       why):
    h = law_host(host, built, name)
    t = h.run(h.start(params, md=built[name][2]) + ["step 0 0.001"])
    assert t.statuses("exit") == [ERROR] and t.statuses("step") == [ERROR]
    assert t.logged(why), t.logs


def test_error_calls_against_the_contract_name_what_is_wrong(host, built):
    h = law_host(host, built, "Encoder")
    cases = [(["step 0 0.001"], "fmi2DoStep is not allowed in the state instantiated"),
             (["enter", "exit", f"setr {h.vr['measured_position']} 1"], "measured_position is an output"),
             (["enter", "exit", f"seti {h.vr['delay']} 3"], "delay is a fixed parameter"),
             (["enter", f"seti {h.vr['delay']} 10000"], "delay must be in 0 .. 9999"),
             (["enter", "getr 999"], "unknown value reference 999"),
             (["enter", f"setr {h.vr['delay']} 1"], "delay (value reference"),
             (["enter", f"sets {h.vr['Ts']} x"], "is a Real variable, not String")]
    for lines, why in cases:
        t = h.run(["new 0 e", "setup 0"] + lines + ["getr 1"])
        assert ERROR in [int(r[1]) for r in t.results if r[0] != "new"], (lines, t.text)
        assert t.logged(why), (why, t.logs)
    # a sample that overflows ends the run with an error, not a NaN passed on
    p = law_host(host, built, "PID")
    t = p.run(p.start({"K": 1e300, "Ti": 1e-300, "Ts": 1.0}, md=built["PID"][2])
              + [f"setr {p.vr['setpoint']} 1e300", f"setr {p.vr['measurement']} -1e300", "step 0 1", "step 1 1"])
    assert t.statuses("step") == [ERROR, ERROR] and t.logged("overflowed"), t.logs


# -- FMU states ----------------------------------------------------------------------

@pytest.mark.parametrize("name", LAWS)
def test_a_serialised_state_replays_and_is_honoured_before_initialisation(host, built, name, tmp_path):
    h = law_host(host, built, name)
    md = built[name][2]
    blob = tmp_path / "s.bin"
    t = h.run(h.start(RUNS[name][0], md=md) + stepped(h, name, 30, 1e-3) + ["save 0", f"ser 0 {blob}"]
              + stepped(h, name, 30, 1e-3, t0=0.03) + [f"deser 1 {blob}", "load 1"]
              + stepped(h, name, 30, 1e-3, t0=0.03))
    rows = got(t)
    assert t.statuses("load") == [OK] and np.array_equal(rows[30:60], rows[60:90])
    assert not np.all(rows[30:60] == rows[30])  # the replayed stretch moves
    # a fresh instance: parameters, the state, then initialisation
    t2 = h.run(["new 0 b", "setup 0"] + h.set_lines(RUNS[name][0], md) + [f"deser 0 {blob}", "load 0", "enter",
                                                                         "exit"]
               + stepped(h, name, 30, 1e-3, t0=0.03))
    assert t2.statuses("exit") == [OK] and np.array_equal(got(t2), rows[30:60])


@pytest.mark.parametrize("damage, why", [("corrupted", "checksum"), ("truncated", "truncated"),
                                         ("padded", "bytes"), ("version", "version"), ("foreign", "another model")])
def test_a_bad_state_blob_is_refused(host, built, tmp_path, damage, why):
    h = law_host(host, built, "Encoder")
    good = tmp_path / "good.bin"
    h.run(h.start(ENC, md=built["Encoder"][2]) + stepped(h, "Encoder", 5, 1e-3) + ["save 0", f"ser 0 {good}"])
    data = bytearray(good.read_bytes())
    if damage == "corrupted":
        data[len(data) // 2] ^= 0x10
    elif damage == "truncated":
        data = data[:-8]
    elif damage == "padded":
        data += b"\0" * 8
    elif damage == "version":
        data[8] = 99
    else:
        data[24] ^= 0xFF
    bad = tmp_path / "bad.bin"
    bad.write_bytes(bytes(data))
    t = h.run(h.start(ENC, md=built["Encoder"][2]) + [f"deser 1 {bad}", "load 1", "step 0 0.001"])
    assert t.statuses("deser") == [ERROR] and t.logged(why), t.logs
    assert t.statuses("load") == [ERROR] and t.statuses("step") == [ERROR]


def test_a_state_of_another_law_fmu_is_refused(host, built, tmp_path):
    blob = tmp_path / "pid.bin"
    p = law_host(host, built, "PID")
    p.run(p.start(PID_PARAMS, md=built["PID"][2]) + ["step 0 0.001", "save 0", f"ser 0 {blob}"])
    e = law_host(host, built, "Encoder")
    t = e.run(e.start(ENC, md=built["Encoder"][2]) + [f"deser 0 {blob}"])
    assert t.statuses("deser") == [ERROR] and t.logged("the state belongs to another model"), t.logs


def _block_index(built, name: str, field: str) -> int:
    """Index in the persistent block of a field of the law model's state (P_*), from config.h."""
    text = (built[name][1] / "sources" / "config.h").read_text()
    return int(next(ln.split()[2] for ln in text.splitlines() if ln.startswith(f"#define P_{field.upper()} ")))


def test_one_computed_torque_fmu_serves_another_mechanism_of_its_shape_and_refuses_where_it_cannot_close(host,
                                                                                                          built):
    from grubler.fmi.mechanism import fmu_parameters

    scene = load_scene("fourbar-double-rocker")  # theta2 = 1.047 at the sketch; it cannot pass 1.4
    h = law_host(host, built, "ComputedTorque")
    md = built["ComputedTorque"][2]
    params = {**CT, **{k: v for k, v in fmu_parameters(scene).items() if k in h.vr}}
    swing = lambda k: {"position": 1.047 + 0.3 * np.sin(0.02 * k), "velocity": 6.0 * np.cos(0.02 * k),  # noqa: E731
                       "acceleration": -120.0 * np.sin(0.02 * k)}
    lines = []
    for k in range(100):
        lines += [f"setr {h.vr[i]} {float(x)!r}" for i, x in swing(k).items()]
        lines += [f"step {k * 1e-3!r} 0.001", h.getr("torque", "motor_torque", "voltage")]
    t = h.run(h.start(params, md=md) + lines + [f"setr {h.vr['position']} 1.6", "step 0.1 0.001"])
    s = Sampler(ComputedTorque(scene, **CT), t0=0.0)
    ref = [list(s.step(k * 1e-3, 1e-3, swing(k)).values()) for k in range(100)]
    assert np.array_equal(got(t), np.array(ref))
    assert t.statuses("step") == [OK] * 100 + [ERROR]
    assert t.logged("sample at t = 0.1 s: the mechanism cannot take that drive position: its loop does not close"), \
        t.logs


@pytest.mark.parametrize("name, field, offset, value, why", [
    ("Encoder", "law", 4, 3.0, "state.head: must be a whole number in [0, delay]"),
    ("Encoder", "law", 2, 2.0**40, "state.rng: must be two whole numbers"),
    ("Encoder", "law", 5, float("nan"), "state.history: must hold finite readings"),
    ("Encoder", "law", 0, 0.5, "state.started: must be 0 or 1"),
    ("PID", "law", 0, float("inf"), "state.I: must be finite"),
    ("CascadeController", "law", 7, 0.5, "state.speed_loop: must be 0 or 1"),
    ("Tachometer", "law", 1, float("nan"), "state.filtered: must be finite"),
    ("CurrentSensor", "law", 3, -1.0, "state.rng: must be two whole numbers"),
    ("PID", "samples", 0, -1.0, "state.samples: must be a whole number >= 0"),
    ("PID", "t0", 0, 5.0, "state.t0: the start time must be finite and not after t"),
    ("PID", "out", 0, float("nan"), "state.outputs: the held outputs must be finite"),
    ("Trajectory", "started", 0, 2.0, "state.started: must be 0 or 1"),
    ("ComputedTorque", "law", 1, float("inf"), "state.z: must be finite")])
def test_a_crafted_state_is_refused_naming_the_field(host, built, tmp_path, name, field, offset, value, why):
    h = law_host(host, built, name)
    md = built[name][2]
    good = tmp_path / "good.bin"
    h.run(h.start(RUNS[name][0], md=md) + stepped(h, name, 5, 1e-3) + ["save 0", f"ser 0 {good}"])
    bad = tmp_path / "bad.bin"
    bad.write_bytes(craft(good.read_bytes(), {_block_index(built, name, field) + offset: value}))
    t = h.run(h.start(RUNS[name][0], md=md) + [f"deser 1 {bad}", "load 1", "reset", "setup 0", "enter", "exit",
                                                "step 0 0.001"])
    assert t.statuses("deser") == [ERROR] and t.logged(why), t.logs
    assert t.statuses("step") == [OK]  # reset brings the instance back


# -- sanitizers ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def sanitized(built, tmp_path_factory):
    return sanitize_all(built, tmp_path_factory.mktemp("asan"))


@pytest.mark.parametrize("name", LAWS)
@pytest.mark.parametrize("seed", [1, 2])
def test_random_call_sequences_never_crash_nor_corrupt_memory(built, sanitized, name, seed, tmp_path):
    random_calls_hold(sanitized, name, built[name][2], seed, tmp_path)


@pytest.mark.parametrize("name", LAWS)
def test_random_crafted_states_never_crash_nor_corrupt_memory(built, sanitized, name, tmp_path):
    crafted_states_hold(sanitized, name, built[name][2], tmp_path)


def crafted_states_hold(sanitized: dict, name: str, md, tmp_path: Path) -> None:
    """States with valid checksums and 1 to 3 doubles replaced by awkward numbers, restored, stepped and read
    in the sanitized host: no crash, no sanitizer report, some refused."""
    h = Host(sanitized["host"], sanitized[name], md.guid, {v.name: v.valueReference for v in md.modelVariables})
    good = tmp_path / "good.bin"
    h.run(h.start(RUNS[name][0], md=md) + stepped(h, name, 5, 1e-3) + ["save 0", f"ser 0 {good}"], env=SANITIZER_ENV)
    n = struct.unpack_from("<I", good.read_bytes(), 16)[0]
    rng = np.random.default_rng(7)
    awkward = [float("nan"), float("inf"), -float("inf"), 1e300, -1e300, 1e9, -3.0, -1.0, 0.0, 0.5, 2.5, 1000.0]
    script = h.start(RUNS[name][0], md=md)
    for k in range(120):
        blob = tmp_path / f"c{k}.bin"
        # the first doubles (parameters, the run's state) and the rest alike
        picks = rng.choice(min(n, 80), size=int(rng.integers(1, 4)), replace=False)
        blob.write_bytes(craft(good.read_bytes(), {int(i): float(rng.choice(awkward)) for i in picks}))
        script += [f"deser 1 {blob}", "load 1", "step 0.005 0.001", "getr 1", "reset", "setup 0", "enter", "exit"]
    proc = subprocess.run(h.cmd, input="\n".join(script) + "\n", capture_output=True, text=True, timeout=600,
                          env=SANITIZER_ENV)
    assert proc.returncode == 0 and "Sanitizer" not in proc.stderr and "runtime error" not in proc.stderr, \
        proc.stderr[-3000:]
    t = Transcript(proc.stdout)
    assert len(t.statuses("deser")) == 120 and ERROR in t.statuses("deser")
    assert set(t.statuses("step")) <= {OK, WARNING, DISCARD, ERROR}


# -- a user's law written in C (grubler export-law) ----------------------------------------

def pi_reference(params: dict, inputs: list[tuple[float, float]]) -> list[float]:
    """examples/pi_law.c's law, written again here from its comment: PI, clamped, conditional integration."""
    K, Ti, u_max, Ts = params["K"], params["Ti"], params["u_max"], params["Ts"]
    integral, out = 0.0, []
    for r, y in inputs:
        e = r - y
        v = K * e + integral
        u = min(max(v, -u_max), u_max)
        if u == v:
            integral += K * Ts / Ti * e
        out.append(u)
    return out


@pytest.fixture(scope="module")
def c_law(tmp_path_factory):
    from fmpy import read_model_description

    from grubler.controllers.native_fmu import export_law

    d = tmp_path_factory.mktemp("c_law")
    path = export_law(ROOT / "examples" / "pi_law.c", d / "PILaw.fmu")
    zipfile.ZipFile(path).extractall(d / "x")
    md = read_model_description(str(path))
    return path, d / "x", md


def test_a_law_written_in_c_runs_in_the_c_host_as_written(host, c_law, tmp_path):
    from fmpy.validation import validate_fmu

    path, d, md = c_law
    assert validate_fmu(str(path)) == []
    assert [v.name for v in md.modelVariables] == ["K", "Ti", "u_max", "Ts", "setpoint", "measurement", "u"]
    assert {v.name: v.unit for v in md.modelVariables}["Ts"] == "s"
    h = Host(host, d / "binaries" / "linux64" / "PILaw.so", md.guid,
             {v.name: v.valueReference for v in md.modelVariables})
    params = {"K": 3.0, "Ti": 0.02, "u_max": 2.0, "Ts": 1e-3}
    inputs = [(1.0 if k < 150 else -0.5, 0.4 * math.sin(0.02 * k)) for k in range(300)]
    script = h.start(params, md=md)
    for k, (r, y) in enumerate(inputs):
        script += [f"setr {h.vr['setpoint']} {r!r}", f"setr {h.vr['measurement']} {y!r}",
                   f"step {k * 1e-3!r} 0.001", h.getr("u")]
    blob = tmp_path / "s.bin"
    t = h.run(script[:-4 * 200] + ["save 0", f"ser 0 {blob}"] + script[-4 * 200:] + [f"deser 1 {blob}", "load 1"]
              + script[-4 * 200:])
    rows = got(t)[:, 0]
    assert set(t.statuses("step")) == {OK}
    ref = pi_reference(params, inputs)
    assert np.allclose(rows[:300], ref, rtol=0, atol=1e-12) and max(rows) == 2.0  # it clamps
    assert np.array_equal(rows[300:], rows[100:300])  # the saved state replays
    # the law refuses a sample: an error naming why, the run ended
    t = h.run(h.start({**params, "Ti": 0.0}, md=md) + ["step 0 0.001", "step 0.001 0.001"])
    assert t.statuses("step") == [ERROR, ERROR] and t.logged("law_step returned non-zero"), t.logs


def test_a_law_written_in_c_under_the_sanitizers(c_law, tmp_path):
    path, d, md = c_law
    (tmp_path / "asan").mkdir()
    sanitized = sanitize_all({"PILaw": (path, d, md)}, tmp_path / "asan")
    random_calls_hold(sanitized, "PILaw", md, 4, tmp_path)


@pytest.mark.parametrize("text, why", [
    ('GRUBLER_OUTPUT(u "x")\n', 'law.c:1: cannot read'),
    ('GRUBLER_PARAMETER(Ts, 1e-3, "sample time [s]")\nint law_step(void);\n', "declares no output"),
    ('GRUBLER_OUTPUT(u, "u [1]")\nint law_step(void);\n', "declares no sample time"),
    ('GRUBLER_OUTPUT(u, "u [1]")\nGRUBLER_PARAMETER(Ts, 1e-3, "sample time [s]")\n', "defines no law_step"),
    ('GRUBLER_OUTPUT(u, "u [1]")\nGRUBLER_OUTPUT(u, "again [1]")\n', "law.c:2: u is declared twice"),
    ('GRUBLER_PARAMETER(Ts, fast, "sample time [s]")\n', "law.c:1: the start of Ts must be a number"),
    ('GRUBLER_STATE(1000000000)\n', "GRUBLER_STATE(1000000000): at most 100000 doubles"),
    ('GRUBLER_WHATEVER(x)\n', "the declarations are GRUBLER_PARAMETER"),
    ('#include "grubler_law.h"\nGRUBLER_OUTPUT(u, "u [1]")\nGRUBLER_PARAMETER(Ts, 1e-3, "s [s]")\n'
     'int law_step(const double *param, double *state, double t, const double *in, double *out) '
     '{ return nothing; }\n', "law.c:4:")])
def test_export_law_refuses_a_bad_law_with_one_line(tmp_path, text, why):
    src = tmp_path / "law.c"
    src.write_text(text)
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export-law", str(src), "-o",
                           str(tmp_path / "L.fmu")], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert why in proc.stderr, proc.stderr
    assert not (tmp_path / "L.fmu").exists()


@pytest.mark.parametrize("make, why", [(None, "law.c': no such file"),
                                       (b"\x89PNG\r\n\x1a\n\xff", "not UTF-8 text (byte 0x89 at offset 0)"),
                                       ("/dev/zero", "'/dev/zero': not a regular file"),
                                       ("/proc/self/mem", "cannot be read (Input/output error)")])
def test_export_law_says_why_a_file_cannot_be_its_source(tmp_path, make, why):
    # /dev/zero once read until memory ran out: the law is read as every input file is (regular, capped)
    src = tmp_path / "law.c"
    if isinstance(make, str):
        if not Path(make).exists():
            pytest.skip(f"no {make} here")
        src = Path(make)
    elif make is not None:
        src.write_bytes(make)
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export-law", str(src), "-o",
                           str(tmp_path / "L.fmu")], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert why in proc.stderr and "law: " in proc.stderr, proc.stderr


def _law_with(tmp_path, old: str, new: str) -> Path:
    """examples/pi_law.c with one piece of text replaced, as law.c in tmp_path."""
    text = (ROOT / "examples" / "pi_law.c").read_text()
    assert old in text
    src = tmp_path / "law.c"
    src.write_text(text.replace(old, new, 1))
    return src


GAIN = '"proportional gain [V/rad]"'
RETURN = "int law_step("


@pytest.mark.parametrize("old, new, why", [
    (GAIN, r'"gain \x [V/rad]"', r"law.c:9: the description of K: \x is no C escape"),
    (GAIN, r'"gain \u0000 [V/rad]"', "law.c:9: the description of K holds U+0000, a character an FMU's "
                                      "modelDescription.xml cannot carry"),
    (GAIN, r'"gain \x01 [V/rad]"', "law.c:9: the description of K holds U+0001"),
    (GAIN, r'"gain \xff [V/rad]"', "which is not UTF-8 text"),
    ("GRUBLER_STATE(1)", "GRUBLER_STATE(" + "1" * 5000 + ")", "law.c:16: GRUBLER_STATE(1111"),
    ("GRUBLER_STATE(1)", "GRUBLER_STATE(1)\nGRUBLER_STATE(2)", "law.c:17: GRUBLER_STATE declared again "
                                                                "(first at line 16)"),
    (RETURN, "int law_check(void) { return 0; }\n" + RETURN, "law.c:18: defines law_check, a name the FMU's own"),
    (RETURN, "int fmi2DoStep(void)\n{ return 0; }\n" + RETURN, "law.c:18: defines fmi2DoStep"),
    # the linker's answer, mapped to the line: a name of the FMU's C that no rule up front knows
    (RETURN, "double model_time(void) { return 0.0; }\n" + RETURN, "law.c:18: defines model_time"),
    # a compiler error in a file the law includes: that file's line, and where the law includes it
    ('#include "grubler_law.h"', '#include "grubler_law.h"\n#include "JUNK"', "junk.txt:1:5: expected"),
])
def test_export_law_names_the_line_and_the_reason(tmp_path, old, new, why):
    (tmp_path / "junk.txt").write_text("root:x:0:0:root:/root:/bin/bash\n")
    src = _law_with(tmp_path, old, new.replace("JUNK", str(tmp_path / "junk.txt")))
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export-law", str(src), "-o",
                           str(tmp_path / "L.fmu")], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert why in proc.stderr and str(tmp_path) in proc.stderr, proc.stderr
    if "JUNK" in new:
        assert "(included at " + str(src) + ":8)" in proc.stderr, proc.stderr
    assert not (tmp_path / "L.fmu").exists()


def test_a_static_helper_may_share_a_reserved_name(tmp_path):
    from grubler.controllers.native_fmu import read_c_law

    src = _law_with(tmp_path, RETURN, "static int law_check(void) { return 0; }\n/* int fmi2DoStep(void) { } */\n"
                                      + RETURN)
    assert list(read_c_law(src).outputs) == ["u"]


def test_export_law_checks_where_it_writes_before_building(tmp_path):
    law = ROOT / "examples" / "pi_law.c"
    if Path("/proc").is_dir():  # a folder access() calls writable, where no file can be made
        proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export-law", str(law), "-o", "/proc/x.fmu"],
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        assert "--out: '/proc/x.fmu': cannot be written there" in proc.stderr, proc.stderr
    # the source as its own destination, named or by default: refused, the law intact
    src = tmp_path / "same.fmu"
    src.write_bytes(law.read_bytes())
    for out in (["-o", str(src)], []):
        proc = subprocess.run([sys.executable, "-m", "grubler.cli", "export-law", str(src), *out],
                              capture_output=True, text=True, timeout=300, cwd=tmp_path)
        assert proc.returncode == 2 and "is the law's source" in proc.stderr, proc.stderr
    assert src.read_bytes() == law.read_bytes()


# -- a python-control controller as a native FMU -------------------------------------------

def test_a_linear_controller_becomes_a_native_fmu_with_its_matrices_as_parameters(host, tmp_path):
    import control
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    from grubler.controllers import LinearController
    from grubler.controllers.native_fmu import linear_spec
    from grubler.fmi.build import build_fmu

    def make():
        return LinearController(control.tf([0.5, 3.0, 2.0], [1.0, 8.0, 0.0]), Ts=1e-2, method="tustin")

    path = build_fmu(linear_spec(make(), "Lead"), tmp_path / "Lead.fmu")
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    zipfile.ZipFile(path).extractall(tmp_path / "x")
    h = Host(host, tmp_path / "x" / "binaries" / "linux64" / "Lead.so", md.guid,
             {v.name: v.valueReference for v in md.modelVariables})
    start = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"}
    assert list(start) == ["Ts", "A[1,1]", "A[1,2]", "A[2,1]", "A[2,2]", "B[1]", "B[2]", "C[1]", "C[2]", "D"]
    assert np.array_equal(list(start.values())[1:], make().matrices)
    inputs = [{"setpoint": 1.0, "measurement": 0.3 * math.sin(0.1 * k), "feedforward": 0.05 * k} for k in range(200)]
    script = h.start(md=md)
    for k, i in enumerate(inputs):
        script += [f"setr {h.vr[n]} {x!r}" for n, x in i.items()] + [f"step {k * 1e-2!r} 0.01", h.getr("u")]
    t = h.run(script)
    s = Sampler(make())
    ref = [s.step(k * 1e-2, 1e-2, i)["u"] for k, i in enumerate(inputs)]
    assert np.array_equal(got(t)[:, 0], ref)  # the same C, bit for bit
    t = h.run(h.start({"A[2,1]": float("inf")}, md=md))
    assert t.statuses("exit") == [ERROR] and t.logged("A[2,1]: must be finite (got inf)"), t.logs


def test_build_fmu_makes_only_native_fmus_and_its_linear_controller_runs_without_python(host, built):
    """dist/LinearController.fmu was a pythonfmu build (fmusim under env -i: undefined _Py_NoneStruct)."""
    import build_fmu

    from grubler.controllers.native_fmu import LINEAR_DEFAULT, linear_default

    assert set(build_fmu.FMUS) == set(build_fmu.NATIVE)  # no pythonfmu route left in dist/
    path, d, md = built["LinearController"]
    assert not (d / "resources" / "grubler").exists()
    start = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"}
    assert start["Ts"] == LINEAR_DEFAULT["Ts"] and list(start.values())[1:] == list(linear_default().matrices)
    h = Host(host, d / "binaries" / "linux64" / "LinearController.so", md.guid,
             {v.name: v.valueReference for v in md.modelVariables})
    inputs = [{"setpoint": 1.0, "measurement": 0.5 * math.sin(0.01 * k), "feedforward": 0.0} for k in range(300)]
    script = h.start(md=md)
    for k, i in enumerate(inputs):
        script += [f"setr {h.vr[n]} {x!r}" for n, x in i.items()] + [f"step {k * 1e-3!r} 0.001", h.getr("u")]
    t = h.run(script)  # env={}: no PYTHONPATH, no Python at all
    assert set(t.statuses("step")) == {OK}
    s = Sampler(linear_default())
    ref = [s.step(k * 1e-3, 1e-3, i)["u"] for k, i in enumerate(inputs)]
    assert np.array_equal(got(t)[:, 0], ref)
    # the documented PI, K = 2, Ti = 0.1 s, Ts = 1 ms: u_k = K e_k + I_k, Tustin's integral of K e / Ti
    # I_k = I_k-1 + K Ts / (2 Ti) (e_k + e_k-1) from e_-1 = 0, i.e. K Ts / (2 Ti) (2 sum_j<=k e_j - e_k)
    e = np.array([i["setpoint"] - i["measurement"] for i in inputs])
    assert np.allclose(ref, 2.0 * e + 2.0 * 1e-3 / 0.2 * (2 * np.cumsum(e) - e), rtol=0, atol=1e-9)


def test_a_six_bar_gets_a_computed_torque_fmu_of_its_own_shape_that_runs_as_the_library(host, tmp_path):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    from grubler.controllers.native_fmu import export_computed_torque
    from grubler.system.servo import ServoDesign, servo_system

    scene = load_scene("watt-ii")  # five links, two closures: not ComputedTorque.fmu's shape
    with pytest.raises(grubler.SceneError, match="feedforward: ComputedTorque.fmu serves mechanisms of the thesis "
                                                 "four-bar's shape; this scene needs ComputedTorque_watt_ii.fmu"):
        servo_system(ServoDesign(scene="watt-ii", feedforward=True), tmp_path)
    path, params = export_computed_torque(scene, tmp_path)
    assert path.name == "ComputedTorque_watt_ii.fmu" and "closure[1].at_x" in params
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    zipfile.ZipFile(path).extractall(tmp_path / "x")
    h = Host(host, tmp_path / "x" / "binaries" / "linux64" / f"{path.stem}.so", md.guid,
             {v.name: v.valueReference for v in md.modelVariables})
    z0 = float(scene.mechanism.z_from_q(scene.mechanism.q_ref)[0])
    swing = [{"position": z0 + 0.3 * math.sin(0.02 * k), "velocity": 6.0 * math.cos(0.02 * k),
              "acceleration": -120.0 * math.sin(0.02 * k)} for k in range(150)]
    script = h.start(CT, md=md)
    for k, i in enumerate(swing):
        script += [f"setr {h.vr[n]} {x!r}" for n, x in i.items()] + [f"step {k * 1e-3!r} 0.001",
                                                                     h.getr("torque", "motor_torque", "voltage")]
    t = h.run(script)
    assert t.statuses("step") == [OK] * 150
    s = Sampler(ComputedTorque(scene, **CT))
    assert np.array_equal(got(t), [list(s.step(k * 1e-3, 1e-3, i).values()) for k, i in enumerate(swing)])
    assert servo_system(ServoDesign(scene="watt-ii", feedforward=True), tmp_path).components["feedforward"]


# -- a table or cam profile from CSV --------------------------------------------------------

@pytest.mark.parametrize("text, why", [
    ("time,position\n0,0\n0.5,abc\n", "row 3, column 2 (position): not a number, got 'abc'"),
    ("0,0\n0.5\n", "row 2: 1 columns; a profile has two"),
    ("0,0,1\n", "row 1: 3 columns"),
    ("0,0\n1,1\n1,2\n", "row 3, column 1 (time): times must increase, got 1 after 1"),
    ("0,0\n# a comment\n0.5,inf\n", "row 2, column 2 (position): must be finite"),
    ("time,position\n0,1\n", "1 points; a profile needs at least two"),
    ("", "0 points"),
    ("\xff\xfe", "cannot be read as a UTF-8 CSV file")])
def test_a_bad_profile_is_one_line_naming_the_row_and_column(tmp_path, text, why):
    from grubler.controllers.native_fmu import export_profile

    src = tmp_path / "cam.csv"
    src.write_bytes(text.encode("latin-1"))
    with pytest.raises(grubler.SceneError) as err:
        Trajectory(kind="table", profile=src)
    assert err.value.field == "profile" and why in err.value.reason and "\n" not in str(err.value)
    with pytest.raises(grubler.SceneError, match="profile"):
        export_profile(src, tmp_path / "Cam.fmu")
    assert not (tmp_path / "Cam.fmu").exists()


def test_a_cam_profile_fmu_runs_in_the_c_host_as_the_library_evaluates_it(host, tmp_path):
    from fmpy import read_model_description

    from grubler.controllers.native_fmu import export_profile

    src = tmp_path / "cam.csv"
    src.write_text("time,position\n# a cam: rise, dwell, return\n0,0\n0.1,0.02\n0.3,0.5\n0.5,0.52\n0.8,0.0\n")
    path = export_profile(src, tmp_path / "Cam.fmu")
    md = read_model_description(str(path))
    zipfile.ZipFile(path).extractall(tmp_path / "x")
    h = Host(host, tmp_path / "x" / "binaries" / "linux64" / "Cam.so", md.guid,
             {v.name: v.valueReference for v in md.modelVariables})
    t = h.run(h.start({"delay": 0.05}, md=md) + [h.run_steps(0.0, 1e-3, 1000, "position", "velocity",
                                                                "acceleration")])
    rows = t.rows()
    tr = Trajectory(kind="table", profile=src, delay=0.05)
    # the FMU evaluates at the step's start plus its size, as the host steps: (k h) + h
    assert np.array_equal(rows[:, 1:], [tr.evaluate(k * 1e-3 + 1e-3) for k in range(1000)])
    assert rows[-1, 1] == 0.0 and max(rows[:, 1]) > 0.5


def test_the_example_systems_use_native_fmus_only():
    import xml.etree.ElementTree as ET

    sys.path.insert(0, str(ROOT))
    import build_fmu

    for name in ("servo_fourbar.ssd", "servo_slider_crank.ssd"):
        root = ET.parse(ROOT / "examples" / name).getroot()
        used = [Path(c.get("source")).stem for c in root.iter("{http://ssp-standard.org/SSP1/SystemStructureDescription}"
                                                               "Component")]
        assert len(used) == 5 and set(used) <= set(build_fmu.NATIVE), (name, used)


# -- the one-instance FMUs (a linear controller, a profile) under the sanitizers ------------------


@pytest.fixture(scope="module")
def one_instance_fmus(tmp_path_factory):
    import control
    from fmpy import read_model_description

    from grubler.controllers import LinearController
    from grubler.controllers.native_fmu import export_profile, linear_spec
    from grubler.fmi.build import build_fmu

    d = tmp_path_factory.mktemp("one_instance")
    (d / "cam.csv").write_text("0,0\n0.002,0.1\n0.004,-0.1\n0.01,0\n")
    paths = [build_fmu(linear_spec(LinearController(control.tf([0.5, 3.0, 2.0], [1.0, 8.0, 0.0]), Ts=1e-3), "Lead"),
                       d / "Lead.fmu"), export_profile(d / "cam.csv", d / "Cam.fmu")]
    out = {}
    for path in paths:
        zipfile.ZipFile(path).extractall(d / path.stem)
        out[path.stem] = (path, d / path.stem, read_model_description(str(path)))
    (d / "asan").mkdir()
    return out, sanitize_all(out, d / "asan")


@pytest.mark.parametrize("name", ["Lead", "Cam"])
def test_one_instance_fmus_hold_the_contract_under_the_sanitizers(one_instance_fmus, name, tmp_path):
    from fmpy.validation import validate_fmu

    built_here, sanitized_here = one_instance_fmus
    assert validate_fmu(str(built_here[name][0])) == []
    random_calls_hold(sanitized_here, name, built_here[name][2], 5, tmp_path)
    crafted_states_hold(sanitized_here, name, built_here[name][2], tmp_path)
