"""Bad input to the co-simulation runner, SSP reader, sweeps and sizing: each is refused
with a message that names what is wrong (no FMU is run)."""

import math
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from grubler import GrublerError, SceneError
from grubler import cosim, ssp
from grubler.studies.sizing import DutyCycle, size
from grubler.studies.sweep import run_sweep

from test_sizing import balanced_crank, toy_motor
from test_sweep import counted


def one_component(tmp_path):
    s = ssp.System("s")
    s.add("m", tmp_path / "Mechanism.fmu")
    return s


@pytest.mark.parametrize("kwargs, message", [
    ({"t_end": math.nan}, "t_end: must be finite, got nan"),
    ({"step": math.inf}, "step: must be finite, got inf"),
    ({"step": 0.0}, "step: must be positive, got 0.0"),
    ({"t_end": 1.0, "start_time": 2.0}, "t_end: 1.0 must be after the start time 2.0"),
    ({"master": "newtn"}, "master: must be one of gauss-seidel, jacobi, extrapolate, newton, got 'newtn'"),
    ({"record_every": 0}, "record_every: must be a whole number >= 1, got 0"),
])
def test_the_runner_names_a_bad_setting(tmp_path, kwargs, message):
    with pytest.raises(ssp.SystemDescriptionError, match=message):
        cosim.run(one_component(tmp_path), **kwargs)


def test_the_runner_refuses_an_empty_system():
    with pytest.raises(ssp.SystemDescriptionError, match="system 'empty': has no components"):
        cosim.run(ssp.System("empty"))


@pytest.mark.parametrize("text, message", [
    ("<not xml", "not valid XML"),
    ("<root/>", "the root element is root, not ssd:SystemStructureDescription"),
    ('<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
     'version="1.0" name="x"/>', "no ssd:System element"),
    ('<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
     'version="1.0" name="x"><ssd:System name="x"><ssd:Elements><ssd:System name="inner"/></ssd:Elements>'
     '</ssd:System></ssd:SystemStructureDescription>', "nested systems are not supported"),
    ('<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
     'version="1.0" name="x"><ssd:System name="x"><ssd:Elements><ssd:Component name="a"/></ssd:Elements>'
     '</ssd:System></ssd:SystemStructureDescription>', "a component needs a name and a source"),
])
def test_the_ssd_reader_names_what_is_wrong(text, message):
    with pytest.raises(ssp.SystemDescriptionError, match=message):
        ssp.from_xml(text)


def test_ssd_building_and_files_name_what_is_wrong(tmp_path):
    s = ssp.System("s")
    s.add("a", "A.fmu")
    with pytest.raises(ssp.SystemDescriptionError, match="component 'a': the name is used twice"):
        s.add("a", "B.fmu")
    with pytest.raises(ssp.SystemDescriptionError, match="a name is a letter then letters"):
        s.add("2a", "B.fmu")
    with pytest.raises(ssp.SystemDescriptionError, match="write it as 'component.variable'"):
        s.connect("a", "a.u")
    s.components["a"].parameters["bad"] = [1, 2]
    with pytest.raises(ssp.SystemDescriptionError, match="parameter 'bad': list is not a Real"):
        s.to_xml()
    with pytest.raises(ssp.SystemDescriptionError, match="write a .ssd file or a .ssp archive"):
        s.write(tmp_path / "s.xml")
    with pytest.raises(ssp.SystemDescriptionError, match="no such file"):
        ssp.read(tmp_path / "none.ssd")
    empty = tmp_path / "empty.ssp"
    with zipfile.ZipFile(empty, "w") as zf:
        zf.writestr("other.txt", "x")
    with pytest.raises(ssp.SystemDescriptionError, match="the archive has no SystemStructure.ssd"):
        ssp.read(empty)


def test_sweeps_and_sizing_name_what_is_wrong(tmp_path):
    with pytest.raises(GrublerError, match="sweep: no points"):
        run_sweep(counted, [], workers=1, progress=False)
    with pytest.raises(GrublerError, match="sweep: workers must be >= 1, got -1"):
        run_sweep(counted, [{"x": 1.0}, {"x": 2.0}], workers=-1, progress=False)
    with pytest.raises(SceneError, match="supply_voltage: toy has no nominal voltage"):
        size(balanced_crank(), DutyCycle.constant_speed(5.0, n=20), [toy_motor()], ratios=[10.0])
    with pytest.raises(SceneError, match="duty_cycle.period: must be positive and finite"):
        DutyCycle.from_trajectory(None, -1.0)
    with pytest.raises(SceneError, match="duty_cycle.t: needs at least 4 samples at increasing times"):
        DutyCycle.recorded([0.0, 1.0, 0.5, 2.0], np.zeros(4))


def test_cosim_cli_names_a_record_interval_off_the_step():
    # in a child process: `grubler cosim` leaves with os._exit (PythonFMU issue 228)
    root = Path(__file__).parent.parent
    proc = subprocess.run([sys.executable, "-m", "grubler.cli", "cosim", str(root / "examples" / "servo_fourbar.ssd"),
                           "--step", "0.001", "--dt-out", "0.0015"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "--dt-out: 0.0015 s must be a multiple of the step 0.001 s" in proc.stderr


# -- a length takes a length unit, never an angle's ----------------------------------------------
LENGTH_HINT = "a length was expected"


@pytest.mark.parametrize("old, new, field", [
    ("[link2]\n", '[link2]\na = "90 deg"\n', "link2.a"),
    ("from_point = [0.9, -0.3]", 'from_point = ["90 deg", -0.3]', "actuator[0].from_point"),
    ("[[actuator]]", '[closure]\npoint = [1.0, "pi/2"]\n\n[[actuator]]', "closure.point"),
])
def test_a_length_given_an_angle_is_refused_naming_the_field(old, new, field, capsys, tmp_path):
    from grubler.cli import main
    from grubler.mechanism.scene import load_scene, preset_text

    # the luffing boom has all three: a link, an actuator and a closure
    text = preset_text("luffing-boom")
    assert old in text
    text = text.replace(old, new, 1)
    with pytest.raises(SceneError, match=LENGTH_HINT) as exc:
        load_scene(text)
    assert exc.value.field == field and "is an angle" in exc.value.reason
    scene = tmp_path / "boom.toml"
    scene.write_text(text)
    assert main(["info", str(scene)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"grubler: error: {field}: ") and LENGTH_HINT in line, line


def test_a_length_unit_is_read_and_a_bare_number_is_metres():
    from grubler.mechanism.scene import load_scene, override, parameter, preset_text

    text = preset_text("luffing-boom")
    base = load_scene(text)
    # the same boom with every length of the three spelled in a length unit
    spelled = load_scene(text.replace("from_point = [0.9, -0.3]", 'from_point = ["900 mm", "-30 cm"]')
                         .replace("[link2]\n", '[link2]\na = "3 m"\n')
                         .replace("[[actuator]]", '[closure]\npoint = ["1000 mm", 0.0]\n\n[[actuator]]'))
    assert spelled.mechanism.actuators[0].from_point == pytest.approx(base.mechanism.actuators[0].from_point)
    assert spelled.mechanism.links[0].a == pytest.approx(3.0)
    assert spelled.mechanism.closures[0].to_point == pytest.approx(base.mechanism.closures[0].to_point)
    # --set and a sweep's axes go through override(): the same rule
    assert override(base, {"link2.a": "2.5 m"}).mechanism.links[0].a == pytest.approx(2.5)
    for value in ("90 deg", "pi/2", "3 kg"):
        with pytest.raises(SceneError, match=f"link2.a: .*{LENGTH_HINT}"):
            override(base, {"link2.a": value})
    with pytest.raises(SceneError, match=f"mechanism.crank: '3 rad' is an angle; {LENGTH_HINT}"):
        load_scene(text.replace("crank = 3.0", 'crank = "3 rad"'))
    # an angle field still takes its angle
    assert parameter(override(base, {"initial.theta2": "90 deg"}), "initial.theta2") == pytest.approx(math.pi / 2)


def test_the_sweep_cli_and_the_app_refuse_an_angle_for_a_length(capsys):
    from grubler.app import actions
    from grubler.cli import main

    assert main(["sweep", "thesis-fourbar", "--set", "link2.a=0.3,90 deg", "--t-end", "0.1", "--workers", "1"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == ("grubler: error: link2.a: '90 deg' is an angle; a length was expected: metres as a number (0.3) "
                    "or text with a length unit ('0.3 m', '300 mm')"), line
    data = actions.edit(actions.preset_data("thesis-fourbar"), "link2.a", "90 deg")
    with pytest.raises(SceneError, match=LENGTH_HINT) as exc:
        actions.analyse(data)
    assert exc.value.field == "link2.a"


@pytest.mark.parametrize("edit, field", [
    (("link2", "m", "1 deg"), "link2.m"),
    (("link3", "I", "pi/2"), "link3.I"),
    (("closure", "gain", "30 deg"), "closure.gain"),
    (("drive", "torque", "3 rad"), "drive.torque"),
    (("initial", "theta2_d", "30 deg"), "initial.theta2_d"),
])
def test_a_mass_torque_gain_or_rate_given_an_angle_is_refused_naming_the_field(edit, field):
    """Neither an angle nor a length: a plain number in its SI unit ('1 deg' was read as a 0.0175 kg link)."""
    from grubler.mechanism.scene import preset_text, scene_from_dict
    import tomllib

    data = tomllib.loads(preset_text("thesis-fourbar"))
    table, key, value = edit
    data.setdefault(table, {})[key] = value
    with pytest.raises(SceneError) as err:
        scene_from_dict(data)
    assert err.value.field == field and "is not a plain number" in err.value.reason, err.value


def test_a_builders_mass_given_an_angle_is_refused_and_its_angles_still_read_degrees():
    from grubler.mechanism.scene import scene_from_dict

    mech = {"type": "four-bar", "ground": 1.0, "crank": 0.2, "coupler": 0.8, "rocker": 0.6, "crank_angle": "30 deg"}
    assert scene_from_dict({"mechanism": mech}).mechanism.q_ref[1] == pytest.approx(math.radians(30))
    with pytest.raises(SceneError) as err:
        scene_from_dict({"mechanism": {**mech, "mass_per_length": "2 deg"}})
    assert err.value.field == "mechanism.mass_per_length" and "kg/m" in err.value.reason
