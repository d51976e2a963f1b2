"""A result that cannot be trusted says so; a bad scene tells every problem at once.

Warnings go to stderr, one line each, ``warning: ...``, and leave a successful
run's exit status at 0; the library carries them on its results.
"""

import pickle
import subprocess
import sys
from pathlib import Path

import pytest

import grubler
from grubler.cli import main
from grubler.errors import SceneError, SceneErrors
from grubler.mechanism.scene import load_scene, preset_names, preset_text

THREE_MISTAKES = """
[link2]
joint = "R"
a = -0.3
m = 1.0
[link3]
joint = "R"
a = 0.8
m = 0.0
[link4]
joint = "X"
a = 0.6
m = 1.0
[closure]
type = "revolute"
point = [1.0, 0.0]
[drive]
joint = "theta2"
"""


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


# -- every problem of a scene at once ---------------------------------------------------------
def test_a_scene_with_three_mistakes_lists_all_three_one_line_each(capsys, tmp_path):
    path = tmp_path / "three.toml"
    path.write_text(THREE_MISTAKES)
    code, out, err = run(capsys, "simulate", path, "--t-end", "0.1")
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 3, err
    assert all(line.startswith("grubler: error: ") for line in lines), err
    assert "link2.a: length must be >= 0, got -0.3" in lines[0]
    assert "link3.m: mass must be positive, got 0.0" in lines[1]
    assert "link4.joint: must be 'R' (revolute) or 'P' (prismatic), got 'X'" in lines[2]


def test_the_library_raises_one_exception_that_lists_every_problem():
    with pytest.raises(SceneError) as caught:
        load_scene(THREE_MISTAKES)
    exc = caught.value
    assert isinstance(exc, SceneErrors)
    assert [p.field for p in exc.problems] == ["link2.a", "link3.m", "link4.joint"]
    assert str(exc).splitlines() == [str(p) for p in exc.problems]
    assert exc.field == "link2.a"  # the first, for code that reads one field
    back = pickle.loads(pickle.dumps(exc))  # sweep workers send errors back pickled
    assert str(back) == str(exc) and [p.field for p in back.problems] == [p.field for p in exc.problems]


def test_a_mechanism_built_in_code_hears_of_every_bad_link_too():
    from grubler.mechanism.model import Link, Mechanism

    with pytest.raises(SceneErrors) as caught:
        Mechanism(links=(Link("R", -1.0), Link("R", 1.0, m=0.0, I=-1.0)))
    assert [p.field for p in caught.value.problems] == ["link2.a", "link3.m", "link3.I"]


def test_a_single_problem_is_still_a_plain_scene_error():
    with pytest.raises(SceneError) as caught:
        load_scene(preset_text("thesis-fourbar").replace("m = 2.0", "m = -2.0", 1))
    assert not isinstance(caught.value, SceneErrors)
    assert caught.value.field.endswith(".m")


def test_unknown_keys_of_several_tables_and_a_bad_builder_parameter_are_told_together():
    text = ('[mechanism]\ntype = "four-bar"\nground = 1.0\ncrank = 0.3\ncoupler = 0.8\nrocker = 0.6\n'
            'crank_angel = 0.1\n[drive]\ntorqe = 1.0\n[simulate]\nt_end = -1\ndt_ot = 0.1\n')
    with pytest.raises(SceneErrors) as caught:
        load_scene(text)
    fields = [p.field for p in caught.value.problems]
    assert fields == ["mechanism.crank_angel", "drive.torqe", "simulate.dt_ot", "simulate.t_end"], fields


def test_hundreds_of_problems_print_a_bounded_number_of_lines(capsys, tmp_path):
    path = tmp_path / "many.toml"
    path.write_text("".join(f'[link{k}]\njoint = "Q"\na = -1\nm = 0\n' for k in range(2, 40)))
    code, _, err = run(capsys, "info", path)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 51 and "more problems" in lines[-1], lines[-3:]


# -- a link's mass is never guessed -----------------------------------------------------------
def test_a_missing_mass_is_refused_by_name_not_taken_as_one_kilogram():
    with pytest.raises(SceneError, match=r"link3\.m: is required \(the link's mass, kg\)"):
        load_scene(preset_text("thesis-fourbar").replace("m = 2.0\n", "", 1))


def test_every_preset_still_loads_and_builders_give_their_masses():
    for name in preset_names():
        scene = load_scene(name)
        assert all(link.m > 0 for link in scene.mechanism.links), name


# -- ambient temperature ------------------------------------------------------------------------
@pytest.mark.parametrize("value, bound", [("1e6", "<= 200 degC"), ("-60", ">= -50 degC")])
def test_an_ambient_temperature_no_surroundings_have_is_refused_with_its_unit(value, bound):
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "size", "thesis-fourbar", "--ambient", value],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2
    (line,) = proc.stderr.strip().splitlines()
    assert "--ambient" in line and bound in line, line


def test_the_motor_model_refuses_it_too():
    from grubler.motors import DCMotor, load_motor

    with pytest.raises(SceneError, match=r"ambient_temperature: must be <= 200 degC, got 1e\+06 degC"):
        DCMotor(load_motor("maxon-re40-148877"), ambient_temperature=1e6)
    assert DCMotor(load_motor("maxon-re40-148877"), ambient_temperature=-40.0).ambient_temperature == -40.0


# -- a loop the penalty method left open ------------------------------------------------------
def _loop_gap(res):
    """How far a four-bar's tip is from its ground pivot, from the angles alone (plain trigonometry)."""
    import numpy as np

    m = res.model
    tip_x = sum(link.a * np.cos(res[f"theta{k + 2}"]) for k, link in enumerate(m.links))
    tip_y = sum(link.a * np.sin(res[f"theta{k + 2}"]) for k, link in enumerate(m.links))
    px, py = m.closures[0].to_point
    return np.hypot(tip_x - px, tip_y - py)


def test_a_loop_pulled_open_by_a_large_torque_is_warned_of_by_the_library_and_the_cli(capsys):
    import re

    res = grubler.simulate("fourbar-change-point", method="penalty", torque=1e4, t_end=0.2)
    (line,) = res.warnings
    assert line.startswith("closure: the loop opened by up to ") and "use the exact method" in line, line
    gap = float(_loop_gap(res).max())
    assert gap > 1.0  # open by more than its ground link: nothing of a four-bar is left
    stated = float(re.search(r"up to (\S+) m", line).group(1))
    assert abs(stated - gap) <= 0.005 * gap, (stated, gap)

    code, out, err = run(capsys, "simulate", "fourbar-change-point", "--method", "penalty", "--torque", "1e4",
                         "--t-end", "0.2")
    assert code == 0 and "fourbar-change-point" in out  # a warning, not a refusal
    assert err.strip().splitlines() == [f"warning: {line}"]


def test_the_penalty_methods_ordinary_compliance_is_not_warned_of():
    from grubler.mechanism.simulate import CLOSURE_WARNING, mechanism_size

    res = grubler.simulate("thesis-fourbar", method="penalty", torque=3.0, t_end=1.0)
    assert res.warnings == []
    assert 1e-4 < float(_loop_gap(res).max()) < CLOSURE_WARNING * mechanism_size(res.model)


def test_an_unassembled_penalty_start_is_told_apart_from_the_run():
    res = grubler.simulate("thesis-double-slider", method="penalty", t_end=0.3)
    assert res.warnings and res.warnings[0].startswith("closure: the start is open by 3.14 m or rad")


def test_the_readme_simulate_run_prints_no_warning(capsys, tmp_path):
    code, _, err = run(capsys, "simulate", "thesis-fourbar", "--t-end", "5", "--dt-out", "0.01", "--method", "exact",
                       "--rtol", "1e-9", "--torque", "3", "--csv", tmp_path / "run.csv")
    assert code == 0 and err == ""


# -- a step that is not the one given -------------------------------------------------------------
def test_an_rk4_step_longer_than_the_output_interval_is_said_to_be_cut(capsys):
    res = grubler.simulate("thesis-fourbar", t_end=0.2, dt_out=0.01, integrator="rk4", step=0.05)
    (line,) = res.warnings
    assert line.startswith("step: 0.05 s is longer than the output interval 0.01 s") and "stepped 0.01 s" in line
    # what it says is what it did: 20 steps of 10 ms, not 4 of 50 ms
    assert res.stats["steps"] == 20, res.stats
    assert grubler.simulate("thesis-fourbar", t_end=0.2, dt_out=0.05, integrator="rk4", step=0.05).warnings == []
    code, _, err = run(capsys, "simulate", "thesis-fourbar", "--t-end", "0.2", "--integrator", "rk4", "--step", "0.05",
                       "--dt-out", "0.01")
    assert code == 0 and err.startswith("warning: step: 0.05 s is longer")


def test_a_step_given_to_an_adaptive_integrator_is_said_to_be_unused():
    (line,) = grubler.simulate("thesis-fourbar", t_end=0.1, step=0.05).warnings
    assert line.startswith("step: 0.05 s is rk4's fixed step; dop853 chooses its own steps")
    assert grubler.simulate("thesis-fourbar", t_end=0.1).warnings == []


# -- a communication step longer than what the components need ---------------------------------
ROOT = __import__("pathlib").Path(__file__).parent.parent


@pytest.fixture(scope="module")
def servo_ssd(tmp_path_factory):
    """The README's servo four-bar, on FMUs built from this checkout."""
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "examples"))
    import builds
    import servo_fourbar
    from grubler.system.servo import servo_system

    d = tmp_path_factory.mktemp("dist")
    builds.dist(d, ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory"])
    return servo_system(servo_fourbar.DESIGN, d, name="servo_fourbar").write(d / "servo_fourbar.ssd")


def cosim_cli(*args):
    return subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", *map(str, args)], capture_output=True,
                          text=True, timeout=600)


def _interfaces(system):
    from grubler.cosim import FmuInterface

    return {name: FmuInterface.of(system.source_path(comp)) for name, comp in system.components.items()}


@pytest.mark.slow
def test_the_servos_time_scales_are_its_sample_times_and_the_motors_mechanical_time_constant(servo_ssd):
    from grubler import cosim, ssp

    system = ssp.read(servo_ssd)
    scales = {(s.component, s.what.split(" ")[0]): s.seconds for s in cosim.time_scales(system, _interfaces(system))}
    p = system.components["motor"].parameters
    # J_rotor R / (k_t k_e), from the system file's own numbers
    tau_m = p["rotor_inertia"] * p["resistance"] / (p["torque_constant"] * p["back_emf_constant"])
    assert scales == {("encoder", "sample"): 1e-3, ("controller", "sample"): 1e-3,
                      ("motor", "mechanical"): pytest.approx(tau_m, rel=1e-12)}
    assert 1e-3 < tau_m < 0.05  # the README's step is inside it, the reporter's is not
    assert cosim.step_warnings(1e-3, cosim.time_scales(system, _interfaces(system))) == []


@pytest.mark.slow
def test_a_step_beyond_the_pids_sample_time_is_warned_of_and_the_run_still_succeeds(servo_ssd):
    proc = cosim_cli(servo_ssd, "--step", "0.05", "--t-end", "0.5")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 3 and all(line.startswith("warning: step: 0.05 s is longer than ") for line in lines), lines
    assert "controller's sample time Ts = 0.001 s" in lines[1]
    assert "motor's mechanical time constant" in lines[2]


@pytest.mark.slow
def test_the_readme_cosim_run_prints_no_warning(servo_ssd, tmp_path):
    proc = cosim_cli(servo_ssd, "--csv", tmp_path / "servo.csv")  # the system's own 10 s at 1 ms
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    assert "order encoder -> controller" in proc.stdout


@pytest.mark.slow
def test_jacobi_says_what_it_costs_and_prints_no_stepping_order(servo_ssd):
    proc = cosim_cli(servo_ssd, "--master", "jacobi", "--t-end", "0.05")
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    assert "jacobi: all on the last step's values" in proc.stdout and "order" not in proc.stdout
    helptext = cosim_cli("--help").stdout
    assert "every connection adds a step of delay" in " ".join(helptext.split())


@pytest.mark.slow
def test_a_record_interval_shorter_than_the_step_is_refused_not_cut(servo_ssd):
    proc = cosim_cli(servo_ssd, "--step", "0.05", "--dt-out", "0.01", "--t-end", "0.2")
    assert proc.returncode == 2
    (line,) = proc.stderr.strip().splitlines()
    assert "--dt-out: 0.01 s is shorter than the communication step 0.05 s" in line, line


def test_an_animation_of_an_open_loop_says_so_too(capsys, tmp_path):
    scene = tmp_path / "penalty.toml"
    scene.write_text(preset_text("fourbar-change-point") + '\n[simulate]\nmethod = "penalty"\n')
    code, out, err = run(capsys, "animate", scene, "--torque", "1e4", "--t-end", "0.2", "--fps", "10",
                         "--out", tmp_path / "open.gif")
    assert code == 0 and "wrote" in out
    assert err.startswith("warning: closure: the loop opened by up to "), err


# -- a skipped test says why --------------------------------------------------------------------
def test_the_readme_test_command_lists_each_skip_with_its_reason(tmp_path):
    # the README's `python3 -m pytest` (and .ci/run) read pyproject's addopts; with -q alone a
    # skipped browser test is a bare `s` and the README's "skipped, saying why" would not hold
    root = Path(__file__).resolve().parents[1]
    (tmp_path / "test_skipping.py").write_text(
        "import pytest\n\n\n@pytest.mark.skip(reason='no Chromium found here')\ndef test_x():\n    pass\n")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-c", str(root / "pyproject.toml"), "--rootdir",
                           str(tmp_path), "-p", "no:cacheprovider", str(tmp_path / "test_skipping.py")],
                          capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "SKIPPED [1]" in proc.stdout and "no Chromium found here" in proc.stdout, proc.stdout


# -- an actuator given no force ------------------------------------------------------------------
def test_an_actuator_given_no_force_is_warned_of_by_the_run_and_by_its_report(capsys, tmp_path):
    csv_path = tmp_path / "boom.csv"
    code, _, err = run(capsys, "simulate", "luffing-boom", "--t-end", "0.5", "--csv", csv_path)
    (line,) = err.strip().splitlines()
    assert code == 0 and line.startswith("warning: actuator_forces: lift was given no force and pushed with 0 N "
                                         "throughout"), line
    assert "--actuator-force lift=N" in line
    assert grubler.simulate("luffing-boom", t_end=0.1).warnings[0].startswith("actuator_forces: lift was given")
    # given one, nothing is said
    code, _, err = run(capsys, "simulate", "luffing-boom", "--t-end", "0.5", "--actuator-force", "lift=1e4")
    assert code == 0 and err == ""
    for scene in ([], ["--scene", "luffing-boom"]):
        code, out, err = run(capsys, "report", csv_path, *scene, "--out", tmp_path / "boom.png")
        (line,) = err.strip().splitlines()
        assert code == 0 and line.startswith("warning: lift_force: lift was given no force"), line
    from grubler.views.report import key_numbers
    from grubler.views.runs import read_run

    model = load_scene("luffing-boom").mechanism
    _, columns = read_run(csv_path, model)
    assert ("actuator lift force", "0 N throughout: none was given") in key_numbers(columns, model.drive, model)
