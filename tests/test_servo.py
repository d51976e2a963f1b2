"""The co-simulated servo four-bar against one monolithic simulation of the same
equations (tests/servo_reference.py): the co-simulation's error shrinks with the
communication step, and at 1 ms it is below one encoder count."""

import dataclasses
import re
import json
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest

import builds
from servo_reference import monolithic

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE.parent / "examples"))
import servo_fourbar  # noqa: E402

T_END = 0.2


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("dist")
    builds.dist(d, ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
    return d


def cosimulate(fmu_dir, tmp_path, counts, steps):
    out = tmp_path / "servo.json"
    proc = subprocess.run([sys.executable, str(HERE / "servo_scenario.py"), str(fmu_dir), str(out), str(T_END),
                           str(counts), *map(str, steps)], capture_output=True, text=True, timeout=900)
    assert out.exists(), f"the scenario wrote nothing (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    return json.loads(out.read_text())["result"]


def error_against(ref, run, key="angle", ref_key="drive_angle"):
    t = np.array(run["t"])
    k = np.round(t / 1e-3)
    on = np.abs(t / 1e-3 - k) < 1e-6  # the reference's sample instants
    return float(np.max(np.abs(np.array(run[key])[on] - ref[ref_key][k[on].astype(int)])))


def test_cosimulation_converges_to_the_monolithic_run(fmu_dir, tmp_path):
    design = dataclasses.replace(servo_fourbar.DESIGN, encoder={"counts_per_rev": 0, "Ts": 1e-3})
    ref = monolithic(design, T_END)
    runs = cosimulate(fmu_dir, tmp_path, 0, ["0.01", "0.001", "0.00025"])
    assert runs["0.001"]["order"] == ["encoder", "controller", "motor", "mechanism", "trajectory"]
    err = {h: error_against(ref, r) for h, r in runs.items()}
    cur = {h: error_against(ref, r, "current", "current") for h, r in runs.items()}
    # first order in the coupling step: the motor holds the crank speed over a step
    assert err["0.001"] < err["0.01"] / 5 and err["0.00025"] < err["0.001"] / 2.5, err
    assert cur["0.001"] < cur["0.01"] / 5 and cur["0.00025"] < cur["0.001"] / 2.5, cur
    assert err["0.001"] < 2 * np.pi / 16384, err  # under one count of the example's encoder
    # and the motion is a real one: the crank has moved along the move's start
    assert np.ptp(ref["drive_angle"]) > 0.2


def test_cosimulation_error_is_below_what_the_encoder_costs(fmu_dir, tmp_path):
    design = servo_fourbar.DESIGN
    exact = monolithic(dataclasses.replace(design, encoder={"counts_per_rev": 0, "Ts": 1e-3}), T_END)
    with_encoder = monolithic(design, T_END)
    encoder_cost = float(np.max(np.abs(with_encoder["drive_angle"] - exact["drive_angle"])))
    run = cosimulate(fmu_dir, tmp_path, design.encoder["counts_per_rev"], ["0.001"])["0.001"]
    assert error_against(with_encoder, run) < encoder_cost, (error_against(with_encoder, run), encoder_cost)


SIZING_EXAMPLES = {  # docs/sizing.md's two examples
    "thesis-fourbar": ["thesis-fourbar", "--move", "trapezoid", "--distance", "3.1416", "--v-max", "6.2832",
                       "--a-max", "20", "--dwell", "0.5", "--reverse", "--ratios", "100",
                       "--motors", "maxon-re40-148866"],
    "slider-crank": ["slider-crank", "--speed", "12.566", "--load-torque", "-0.5", "--ratios", "20",
                     "--motors", "maxon-re40-148877"],
}


@pytest.mark.parametrize("example", list(SIZING_EXAMPLES))
def test_sizing_predicts_the_closed_loop_current_within_10_percent(fmu_dir, example):
    builds.dist(fmu_dir, ["ComputedTorque"])
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "size", *SIZING_EXAMPLES[example], "--supply", "48",
                           "--current-limit", "10", "--check", str(fmu_dir)],
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    rows = {}
    for line in out.splitlines():  # limit, predicted, co-simulated, difference, limit, margin, verdict
        cols = re.split(r"\s{2,}", line.strip())
        if len(cols) == 7 and cols[0] != "limit":
            rows[cols[0]] = (float(cols[1].split()[0]), float(cols[2].split()[0]), float(cols[3].split()[0]),
                             cols[6])
    assert set(rows) == {"peak current", "continuous torque", "speed", "voltage", "temperature rise"}, out
    for limit, (predicted, cosim, diff, verdict) in rows.items():
        assert abs(diff - 100 * (predicted - cosim) / cosim) < 0.2, (limit, out)
        assert verdict == "fits", (limit, out)
    peak, rms = rows["peak current"], rows["continuous torque"]
    assert abs(peak[2]) < 10 and abs(rms[2]) < 10, out
    # the agreement is the position loop's term: a perfect drive's peak is far off
    ideal = float(re.search(r"perfect drive \(no position loop\) would need ([\d.]+) A peak \(([+-][\d.]+) %\)",
                            out).group(2))
    assert ideal < -10, out
    assert float(re.search(r"within ([\d.e-]+) rad", out).group(1)) < 5e-3, out


@pytest.mark.parametrize("example", ["servo_fourbar", "servo_slider_crank"])
def test_the_shipped_ssd_is_what_its_example_script_writes(example):
    import importlib

    from grubler import ssp
    from grubler.system.servo import servo_system

    module = importlib.import_module(example)
    shipped = ssp.read(HERE.parent / "examples" / f"{example}.ssd")
    built = servo_system(module.DESIGN, HERE.parent / "dist", name=example)
    assert shipped.components.keys() == built.components.keys()
    for name, comp in built.components.items():
        assert shipped.components[name].parameters == comp.parameters, name
        assert shipped.source_path(shipped.components[name]).resolve() == built.source_path(comp).resolve()
    assert shipped.connections == built.connections
    assert (shipped.order, shipped.plots, shipped.step, shipped.stop_time) == (
        built.order, built.plots, built.step, built.stop_time)


def test_libcosim_runs_the_servo_from_its_file_alone_as_the_jacobi_master_does(fmu_dir, tmp_path):
    """OSP's libcosim, given the .ssd and no step, takes the file's own step (the
    osp:FixedStepAlgorithm annotation), parameters and connections, and its fixed-step
    master (every FMU steps on the last communication point's values) is grubler's
    Jacobi: the same numbers to rounding over the example's whole 10 s."""
    pytest.importorskip("libcosimpy")
    from grubler import cosim, ssp
    from grubler.system.servo import servo_system

    # the shipped file carries the step where libcosim looks for it
    root = ET.parse(HERE.parent / "examples" / "servo_fourbar.ssd").getroot()
    fixed = root.find("ssd:DefaultExperiment/ssd:Annotations/ssc:Annotation[@type='com.opensimulationplatform']"
                      "/osp:Algorithm/osp:FixedStepAlgorithm", ssp.NS)
    assert float(fixed.get("baseStepSize")) == servo_fourbar.DESIGN.step

    path = servo_system(servo_fourbar.DESIGN, fmu_dir, name="servo_fourbar").write(tmp_path / "servo.ssd")
    # an OSP file with no grubler annotation: its step is read from OSP's
    only_osp = ET.parse(path)
    for ann in only_osp.getroot().findall("ssd:Annotations", ssp.NS):
        only_osp.getroot().remove(ann)
    assert ssp.from_xml(ET.tostring(only_osp.getroot())).step == servo_fourbar.DESIGN.step

    t_end = servo_fourbar.DESIGN.t_end
    out = tmp_path / "libcosim.json"
    proc = subprocess.run([sys.executable, str(HERE / "libcosim_ssp_scenario.py"), str(path), str(t_end), str(out),
                           "mechanism.drive_angle", "motor.current"], capture_output=True, text=True, timeout=600)
    assert out.exists(), f"libcosim wrote nothing (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    got = json.loads(out.read_text())["result"]
    rows = np.array(got["rows"])
    assert got["step"] == pytest.approx(servo_fourbar.DESIGN.step, abs=1e-12)

    ours = cosim.run(path, master="jacobi")
    assert ours.t[-1] == pytest.approx(t_end) and rows[-1, 0] == pytest.approx(t_end)
    at = np.searchsorted(ours.t, rows[:, 0] - 1e-9)
    assert np.max(np.abs(ours.t[at] - rows[:, 0])) < 1e-12
    # measured: 3.8e-12 rad and 2.9e-11 A (of 5 A peak) over 10 s
    assert np.max(np.abs(ours["mechanism.drive_angle"][at] - rows[:, 1])) < 1e-10
    assert np.max(np.abs(ours["motor.current"][at] - rows[:, 2])) < 1e-10


def test_the_servo_plot_shows_the_tracking_error_on_its_own_axis_in_words(fmu_dir, tmp_path):
    from grubler import cosim
    from grubler.system.servo import servo_system

    res = cosim.run(servo_system(servo_fourbar.DESIGN, fmu_dir, name="servo_fourbar"), t_end=T_END)
    panels = dict(res.panels())
    angle = {label: values for label, values, _ in panels["crank angle [rad]"]}
    assert set(angle) == {"crank angle, setpoint", "crank angle, response", "crank angle, encoder"}
    ((label, error, unit),) = panels["tracking error [rad]"]
    assert (label, unit) == ("setpoint - response", "rad")
    assert np.array_equal(error, res["trajectory.position"] - res["mechanism.drive_angle"])
    assert np.max(np.abs(error)) > 0
    for lines in panels.values():
        assert all("." not in label for label, _, _ in lines), lines   # words, not signal names
    res.plot(tmp_path / "servo.png")
    assert (tmp_path / "servo.png").stat().st_size > 10_000
