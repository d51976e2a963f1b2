"""Sizing a hydraulic cylinder against a load balance worked by hand.

A 500 kg table on a vertical slide, lifted 0.2 m by a ram from a ground point
0.4 m below it (length 0.4 + B1, lever dL/dB1 = 1): the force is m (g + a) in
each phase of the trapezoid move, the capacity of a candidate at speed v is
(p_s - (A_A v / K)^2) A_A - (A_B v / K)^2 A_B with K = Q_N / sqrt(dp_N) (no
seal friction here), the flow margin the pump's over A_A v_max, the stroke's
over 0.2 m, the rod's Euler load pinned at 0.6 m over 3.5 times the push.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from grubler.controllers.trajectory import Trajectory
from grubler.errors import SceneError
from grubler.mechanism.scene import load_scene
from grubler.studies.cylinder_sizing import size_cylinder
from grubler.studies.sizing import DutyCycle

ROOT = Path(__file__).resolve().parent.parent
TABLE = """
name = "lift-table"
[link2]
joint = "P"
a = 0.0
m = 500.0
[drive]
joint = "B1"
[[actuator]]
name = "ram"
from_link = "ground"
from_point = [0.0, -0.4]
to_link = "link2"
to_point = [0.0, 0.0]
"""
M, G = 500.0, 9.81
V, A, D = 0.1, 0.5, 0.2  # the move: speed, acceleration, distance
NO_FRICTION = {"viscous_friction": 0.0, "coulomb_friction": 0.0, "stroke": 0.3}


def _cycle():
    move = Trajectory("trapezoid", distance=D, v_max=V, a_max=A)
    return DutyCycle.from_trajectory(move, move.move_time + 0.5, n=401, name="lift")


def _capacity(bore, rod, pressure, v):
    from grubler.motors.hydraulic import DEFAULT

    area_a, area_b = math.pi * bore ** 2 / 4, math.pi * (bore ** 2 - rod ** 2) / 4
    k = DEFAULT.nominal_flow / math.sqrt(DEFAULT.nominal_pressure_drop)
    return (pressure - (area_a * v / k) ** 2) * area_a - (area_b * v / k) ** 2 * area_b


def test_the_force_is_the_load_balance_of_each_phase():
    study = size_cylinder(load_scene(TABLE).mechanism, "ram", _cycle(), [0.04], [60e5], rod_ratio=0.5,
                          constants=NO_FRICTION)
    d = study.demand
    t_a = V / A
    accel, cruise = (d.t > 0.01) & (d.t < t_a - 0.01), (d.t > t_a + 0.01) & (d.t < D / V - 0.01)
    decel = (d.t > D / V + 0.01) & (d.t < D / V + t_a - 0.01)
    rest = d.t > D / V + t_a + 0.01
    for phase, accel_now in ((accel, A), (cruise, 0.0), (decel, -A), (rest, 0.0)):
        assert phase.sum() > 3
        assert d.force[phase] == pytest.approx(M * (G + accel_now), rel=1e-9)
    assert d.lever == pytest.approx(1.0)
    assert d.length.min() == pytest.approx(0.4) and d.length.max() == pytest.approx(0.4 + D)


def test_margins_and_ranking_against_the_hand_worked_balance():
    study = size_cylinder(load_scene(TABLE).mechanism, "ram", _cycle(), [0.025, 0.032, 0.04], [60e5, 100e5],
                          rod_ratio=0.5, constants=NO_FRICTION)
    by = {a.candidate.label: a for a in study.assessments}
    a = by["40 mm bore, 60 bar"]
    # the tightest force sample: the end of the acceleration, m (g + a) at nearly full speed
    hand_force = _capacity(0.04, 0.02, 60e5, V) / (M * (G + A))
    assert a.margins["force"] == pytest.approx(hand_force, rel=2e-3)
    assert a.margins["flow"] == pytest.approx((30.0 / 60000.0) / (math.pi * 0.04 ** 2 / 4 * V), rel=1e-9)
    assert a.margins["stroke"] == pytest.approx(0.3 / D, rel=1e-9)
    euler = math.pi ** 2 * 2.1e11 * math.pi * 0.02 ** 4 / 64 / (0.4 + D) ** 2
    assert a.margins["buckling"] == pytest.approx(euler / (3.5 * M * (G + A)), rel=1e-6)
    # 25 mm at 60 bar lifts 2.9 kN of the 5.2 kN: refused, its reason the force
    low = by["25 mm bore, 60 bar"]
    assert not low.feasible and any(f.startswith("force: needs 5.155 kN (push, driving)") for f in low.failures)
    assert low.margins["force"] == pytest.approx(_capacity(0.025, 0.0125, 60e5, V) / (M * (G + A)), rel=2e-3)
    # feasible: 32 mm at 100 bar (804 W) and 40 mm at 60 and 100 bar; the least power first
    assert [x.candidate.label for x in study.ranked] == ["40 mm bore, 60 bar", "32 mm bore, 100 bar",
                                                        "40 mm bore, 100 bar"]
    assert study.best.power == pytest.approx(60e5 * math.pi * 0.04 ** 2 / 4 * V, rel=1e-9)
    assert all(not x.feasible for x in study.rejected)


def test_bad_sizing_input_is_refused_by_name():
    model = load_scene(TABLE).mechanism
    for kwargs, field in (({"bores": [-0.04], "pressures": [60e5]}, "bores"),
                          ({"bores": [0.04], "pressures": []}, "pressures"),
                          ({"bores": [0.04], "pressures": [60e5], "rod_ratio": 1.0}, "rod_ratio")):
        with pytest.raises(SceneError) as exc:
            size_cylinder(model, "ram", _cycle(), **kwargs)
        assert exc.value.field == field
    with pytest.raises(SceneError) as exc:
        size_cylinder(model, "jack", _cycle(), [0.04], [60e5])
    assert exc.value.field == "actuator"


@pytest.mark.slow
def test_the_winner_is_checked_by_co_simulation(tmp_path):
    sys.path.insert(0, str(ROOT))
    import builds
    from grubler.studies.cylinder_sizing import cylinder_check

    builds.dist(tmp_path, ["HydraulicCylinder", "PID"])
    study = size_cylinder(load_scene(TABLE).mechanism, "ram", _cycle(), [0.032, 0.04], [60e5, 100e5],
                          rod_ratio=0.5, constants=NO_FRICTION)
    before = sorted(p.name for p in tmp_path.iterdir())
    check = cylinder_check(study, TABLE, "ram", tmp_path)
    # the FMU folder is an input: the setpoint's table and this scene's mechanism FMU were built elsewhere
    assert sorted(p.name for p in tmp_path.iterdir()) == before == ["HydraulicCylinder.fmu", "PID.fmu"]
    assert check.fits, check.lines()
    assert check.simulated_force == pytest.approx(M * (G + A), rel=0.2)
    assert check.peak_pressure <= 60e5


def test_cli_size_cylinder_ranks_and_rejects(tmp_path):
    scene = tmp_path / "table.toml"
    scene.write_text(TABLE)
    run = [sys.executable, "-m", "grubler.cli", "size", str(scene), "--cylinder", "ram", "--move", "trapezoid",
           "--distance", "0.2", "--v-max", "0.1", "--a-max", "0.5", "--bores", "25,32,40", "--pressures", "60,100"]
    r = subprocess.run(run, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "1. 40 mm bore, 60 bar" in r.stdout and "x  25 mm bore, 60 bar" in r.stdout
    bad = subprocess.run(run[:6] + ["--cylinder", "jack"], capture_output=True, text=True)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1


# -- the CLI's options, each told what it is for -------------------------------------------------
def _size(capsys, *args):
    from grubler.cli import run  # not main: a --check leaves main's process at once (os._exit, as cosim does)

    code = run(["size", *map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


BOOM = ["luffing-boom", "--cylinder", "lift", "--move", "trapezoid", "--distance", "0.1", "--v-max", "0.05",
        "--a-max", "0.2"]


def test_cli_size_cylinder_writes_its_table_and_its_plot(capsys, tmp_path):
    import csv

    import matplotlib.image

    out_csv, out_png = tmp_path / "cylinders.csv", tmp_path / "cylinders.png"
    code, out, err = _size(capsys, *BOOM, "--bores", "40,63", "--pressures", "100,160", "--out", out_csv,
                           "--plot", out_png)
    assert code == 0 and err == "", err
    assert f"wrote {out_csv}" in out and f"wrote {out_png}" in out
    rows = list(csv.DictReader(out_csv.open()))
    assert len(rows) == 4
    assert [r["rank"] for r in rows] == ["1", "2", "rejected", "rejected"]
    best = rows[0]  # the printed winner, in the units people size a cylinder in
    assert (float(best["bore [mm]"]), float(best["supply_pressure [bar]"])) == (63.0, 100.0)
    assert "1. 63 mm bore, 100 bar" in out
    assert rows[2]["why_not"].startswith("buckling: the 22.4 mm rod")
    assert float(rows[2]["margin_buckling"]) < 1.0 <= float(best["margin_buckling"])
    height, width = matplotlib.image.imread(out_png).shape[:2]
    assert width > 1200 and height > 400


@pytest.mark.parametrize("option, value, message", [
    ("--bores", "big", "--bores: 'big' is not a number: write V1,V2,... or START:STOP:N, in mm"),
    ("--bores", "", "--bores: needs at least one value (mm): V1,V2,... or START:STOP:N"),
    ("--bores", "30:100:1e8", "--bores: '30:100:1e8': N, the count of points, must be a whole number from 1 to 1e+06, "
                              "got '1e8'"),
    ("--bores", "1e300", "--bores: magnitude above 1e+12 mm is outside the supported range, got 1e+300 mm"),
    ("--bores", "0,40", "--bores: must be > 0 mm, got 0 mm"),
    ("--pressures", "100,nan", "--pressures: must be a finite number, got nan"),
])
def test_cli_size_cylinder_names_a_bad_candidate_list_as_typed(capsys, option, value, message):
    code, _, err = _size(capsys, *BOOM, option, value)
    (line,) = err.strip().splitlines()
    assert code == 2 and line == f"grubler: error: {message}", line


@pytest.mark.parametrize("extra", [["--motors", "all"], ["--ratios", "5,10"], ["--supply", "24"],
                                   ["--efficiency", "0.8"], ["--current-limit", "10"], ["--ambient", "30"]])
def test_a_motors_options_are_refused_with_cylinder(capsys, extra):
    code, _, err = _size(capsys, *BOOM, *extra)
    (line,) = err.strip().splitlines()
    assert code == 2 and line.startswith(f"grubler: error: {extra[0]}: is for motor sizing; --cylinder sizes a "
                                         "cylinder"), line
    if extra[0] == "--supply":
        assert "supply pressures are --pressures" in line


def test_a_cylinders_options_are_refused_without_it_and_a_cylinder_scene_is_not_given_a_motor(capsys):
    code, _, err = _size(capsys, "thesis-fourbar", "--bores", "40")
    assert code == 2 and err.strip() == ("grubler: error: --bores: is for cylinder sizing: add --cylinder ACTUATOR "
                                         "(or drop --bores)")
    code, out, err = _size(capsys, "luffing-boom")
    (line,) = err.strip().splitlines()
    assert code == 2 and out == ""
    assert line == ("grubler: error: size: luffing-boom is driven by a cylinder (actuator lift), not a motor on "
                    "theta2: size it with `grubler size luffing-boom --cylinder lift` (--bores, --pressures)"), line


def test_check_refuses_a_folder_without_the_fmus_before_any_work_and_writes_nothing_there(capsys, tmp_path):
    code, out, err = _size(capsys, *BOOM, "--check", tmp_path)
    (line,) = err.strip().splitlines()
    assert code == 2 and out == ""  # refused before the sizing printed anything
    assert line == (f"grubler: error: --check: no HydraulicCylinder.fmu, PID.fmu in '{tmp_path}': build the FMUs "
                    "there first (python3 build_fmu.py writes them to dist)"), line
    assert list(tmp_path.iterdir()) == []
    code, _, err = _size(capsys, *BOOM, "--check", tmp_path / "none")
    assert code == 2 and "--check: " in err and "no such folder" in err
