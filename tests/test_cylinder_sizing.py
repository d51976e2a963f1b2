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

    builds.dist(tmp_path, ["HydraulicCylinder", "PID", "Trajectory"])
    study = size_cylinder(load_scene(TABLE).mechanism, "ram", _cycle(), [0.032, 0.04], [60e5, 100e5],
                          rod_ratio=0.5, constants=NO_FRICTION)
    check = cylinder_check(study, TABLE, "ram", tmp_path)
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
