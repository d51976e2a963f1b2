"""A run that goes wrong says so: the power at each mechanical connection, the energy the coupling makes,
and divergence (grubler.system.coupling_energy, hooked into cosim.run and `grubler cosim`).

- the cylinder slider-crank at a 3 ms step under Gauss-Seidel ends with cylinder forces of 50 kN where
  the settled run gives 150 N, and exited 0: it is now reported as diverged at the force's connection,
  and `grubler cosim` exits 2 with one line naming it;
- under Jacobi at 1 ms the same system's mechanism FMU fails at 1.77 s with a step-size message: the
  error now says first that the coupling at the force's connection made energy from nothing;
- the runs that hold (1 ms Gauss-Seidel on both cylinder systems, 5 ms on the boom) report nothing;
- on the servo four-bar the energy the coupling makes shrinks with the step, about tenfold per decade.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from grubler.system.coupling_energy import ENERGY_FRACTION, check, power_bonds, unit_kind
from grubler.system.result import CosimResult
from grubler.system.ssp import System

ROOT = Path(__file__).resolve().parent.parent


# -- the bookkeeping, on made-up records ------------------------------------------------------------------
def pair(master="jacobi", effort=None, flow=None, t=None):
    """A motor and a load coupled by a torque and a speed, their records given."""
    s = System("pair")
    s.add("motor", "m.fmu")
    s.add("load", "l.fmu")
    s.connect("motor.torque", "load.torque_in")
    s.connect("load.speed", "motor.speed_in")
    s.connect("load.angle", "motor.angle_in")  # rad: makes no power with the torque
    t = np.linspace(0.0, 1.0, 101) if t is None else t
    data = np.column_stack([effort, flow, np.zeros_like(t)])
    units = {"motor.torque": "N.m", "load.speed": "rad/s or m/s", "load.angle": "rad", "load.torque_in": "N m",
             "motor.speed_in": "rad/s", "motor.angle_in": "rad"}
    return CosimResult(t, ["load.torque_in", "motor.speed_in", "motor.angle_in"], data, s, ["motor", "load"],
                       master, t[1] - t[0], 0.0, units)


def test_a_power_bond_is_an_effort_and_its_flow_between_the_same_two_components_by_units():
    r = pair(effort=np.ones(101), flow=np.ones(101))
    (bond,) = power_bonds(r.system.connections, r.units)
    assert (bond.effort.start, bond.flow.start, bond.kind) == ("motor.torque", "load.speed", "rotational")
    assert (unit_kind("N", "m/s"), unit_kind("N m", "m/s"), unit_kind("V", "A")) == ("translational", None, None)


def test_steady_power_passes_without_coupling_energy_and_a_held_value_that_pumps_is_reported():
    t = np.linspace(0.0, 1.0, 101)
    steady = pair(effort=np.full(101, 2.0), flow=np.full(101, 3.0))
    (en,), findings = check(steady)
    assert en.given == pytest.approx(6.0) and en.received == pytest.approx(6.0) and en.coupling == pytest.approx(0)
    assert findings == []
    # a torque and a speed oscillating at 2 rad a step, a quarter period apart, growing: under Jacobi
    # each side holds the other's last value, and the load receives what the motor never gave
    k = np.arange(101)
    pumped = pair(effort=np.exp(5 * t) * np.cos(2 * k), flow=np.exp(5 * t) * np.sin(2 * k))
    (en,), findings = check(pumped)
    assert en.coupling > ENERGY_FRACTION * en.passed
    assert findings[0].diverged and findings[0].connection == "motor.torque -> load.torque_in"
    assert findings[0].message.startswith("diverged at motor.torque -> load.torque_in: the coupling made ")


def test_a_giver_that_took_in_what_its_taker_received_is_reported_however_little_passed():
    # a small torque and speed ringing at the step, a quarter period apart, under a large slow exchange
    # that nets nothing: the motor's net is negative, the load's positive, a few percent of what passed
    t = np.linspace(0.0, 1.0, 1001)
    k = np.arange(1001)
    slow = 30 * np.cos(2 * np.pi * 5 * t), 30 * np.sin(2 * np.pi * 5 * t)
    r = pair(effort=0.5 * np.cos(2 * k) + slow[0], flow=0.5 * np.sin(2 * k) + slow[1], t=t)
    (en,), findings = check(r)
    assert en.given < 0 < en.received and en.coupling < ENERGY_FRACTION * en.passed, en.line()
    assert findings[0].diverged and "motor took in " in findings[0].message, findings
    # a torque and speed in phase, ringing at the step too: both nets of one sign, nothing reported
    calm = pair(effort=0.5 * np.cos(2 * k) + slow[0] + 2, flow=0.5 * np.cos(2 * k) + slow[0] / 30 + 1, t=t)
    (en,), findings = check(calm)
    assert en.given > 0 and en.received > 0 and findings == [], en.line()


def test_a_value_that_is_not_finite_names_its_connection():
    effort = np.ones(101)
    effort[40:] = np.inf
    _, findings = check(pair(effort=effort, flow=np.ones(101)))
    assert findings[0].diverged
    assert findings[0].message == "diverged at motor.torque -> load.torque_in: it is inf at t = 0.4 s"


def test_rows_that_skip_communication_points_measure_no_energy():
    r = pair(effort=np.ones(101), flow=np.ones(101))
    assert check(r, consecutive=False) == ([], [])


# -- the systems ----------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    sys.path[:0] = [str(ROOT), str(ROOT / "examples")]
    import build_fmu

    d = tmp_path_factory.mktemp("dist")
    build_fmu.build(d, ["Mechanism", "DCMotor", "PID", "Encoder", "Trajectory", "HydraulicCylinder"])
    return d


@pytest.fixture(scope="module")
def cylinder_ssd(fmus):
    import cylinder_systems

    from grubler.system.cylinder_servo import cylinder_servo_system

    return {name: cylinder_servo_system(cylinder_systems.DESIGNS[name], fmus, name=name).write(fmus / f"{name}.ssd")
            for name in ("cylinder_slider_crank", "luffing_boom")}


@pytest.mark.parametrize("step, why", [("0.003", "12.52% of the 1.31e+03 J that passed"),
                                       ("0.002", "cylinder took in 25.7 J while mechanism received 61.4 J from it")])
def test_the_slider_crank_whose_forces_run_away_exits_2_naming_the_connection(cylinder_ssd, capsys, tmp_path,
                                                                               step, why):
    """At 3 ms the coupling made an eighth of the energy that passed; at 2 ms the forces ring at the step
    (46 kN), and the cylinder took in the energy the mechanism says it received from it."""
    from grubler.cli import run

    csv = tmp_path / "run.csv"
    assert run(["cosim", str(cylinder_ssd["cylinder_slider_crank"]), "--step", step, "--csv", str(csv)]) == 2
    out, err = capsys.readouterr()
    errors = [line for line in err.splitlines() if line.startswith("grubler: error: ")]
    assert errors == [line for line in err.splitlines() if "diverged" in line]
    assert len(errors) == 1 and errors[0].startswith(
        "grubler: error: diverged at cylinder.force -> mechanism.cylinder_force: the coupling made "), err
    assert why in errors[0]
    assert csv.exists()  # written, to look at
    assert "power at cylinder.force -> mechanism.cylinder_force with mechanism.cylinder_rate -> cylinder.rate" in out


def test_the_slider_crank_under_jacobi_fails_saying_the_coupling_made_energy_first(cylinder_ssd):
    from grubler.system.cosim import CosimError, run

    with pytest.raises(CosimError) as err:
        run(cylinder_ssd["cylinder_slider_crank"], step=1e-3, master="jacobi")
    msg = str(err.value)
    assert msg.startswith("diverged at cylinder.force -> mechanism.cylinder_force: the coupling made "), msg
    assert "or use Gauss-Seidel; then mechanism: doStep from t = " in msg


@pytest.mark.parametrize("name, step", [("cylinder_slider_crank", 1e-3), ("luffing_boom", 1e-3),
                                        ("luffing_boom", 5e-3)])
def test_a_run_that_holds_reports_no_false_alarm(cylinder_ssd, capsys, name, step):
    from grubler.cli import run
    from grubler.system.cosim import run as cosim_run

    res = cosim_run(cylinder_ssd[name], step=step, record=["cylinder.force"])
    assert res.findings == [] and res.diverged is None
    (en,) = res.power
    assert abs(en.coupling) < 1e-3 * en.passed, en.line()
    if step == 1e-3 and name == "cylinder_slider_crank":
        assert run(["cosim", str(cylinder_ssd[name])]) == 0
        assert "error" not in capsys.readouterr().err


def test_the_coupling_energy_of_the_servo_fourbar_shrinks_with_the_step(fmus):
    import servo_fourbar

    from grubler.system.cosim import run
    from grubler.system.servo import servo_system

    system = servo_system(servo_fourbar.DESIGN, fmus, name="servo_fourbar")
    made = []
    for h in (1e-2, 1e-3, 1e-4):
        res = run(system, t_end=2.0, step=h, record=["mechanism.drive_angle"])
        (en,) = res.power
        assert en.bond.effort.start == "motor.shaft_torque" and en.bond.flow.start == "mechanism.drive_speed"
        assert res.diverged is None
        made.append(abs(en.coupling))
    # measured 0.119, 0.0148, 0.00137 J (of some 40 J that passed): first order in the step
    assert made[0] > 4 * made[1] > 16 * made[2], made
