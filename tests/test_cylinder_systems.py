"""The cylinder-driven presets as co-simulated systems (examples/cylinder_systems.py).

Each system (a luffing boom and a slider-crank of the second type on a
hydraulic cylinder, a toggle clamp on a pneumatic one, a PID on the valve)
runs on FMUs built from this checkout and must settle on its setpoint; the
mechanism FMU's accelerations at every recorded state must be the library's
under the cylinder FMU's force (the force the mechanism sees is the
cylinder's); the chamber pressures stay between the tank (or a vacuum) and
the supply.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from grubler.errors import SceneError
from grubler.mechanism.dynamics import Inputs, forward_dynamics
from grubler.mechanism.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
SCENES = {"luffing_boom": "luffing-boom", "cylinder_slider_crank": "cylinder-slider-crank",
          "toggle_clamp": "toggle-clamp"}


# slow: FMU builds, C hosts and co-simulations (pytest -m 'not slow' leaves them out; CI runs them)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "examples"))
    import builds
    import cylinder_systems
    from grubler.system.cosim import run

    d = tmp_path_factory.mktemp("dist")
    builds.dist(d, ["HydraulicCylinder", "PneumaticCylinder", "PID", "Trajectory"])
    out = {}
    for path in cylinder_systems.main(d, d):
        out[path.stem] = (cylinder_systems.DESIGNS[path.stem], run(path))
    return out


@pytest.mark.parametrize("name", list(SCENES))
def test_the_system_settles_on_its_setpoint(runs, name):
    design, res = runs[name]
    act = load_scene(design.scene).mechanism.actuator_names[0]
    length, setpoint = res[f"mechanism.{act}_length"], res["trajectory.position"]
    assert abs(setpoint[-1] - setpoint[0]) == pytest.approx(abs(design.move))  # the setpoint moved
    assert abs(length[-1] - length[0]) > 0.9 * abs(design.move)  # and the mechanism with it
    last = res.t > res.t[-1] - 0.2
    assert np.max(np.abs(setpoint[last] - length[last])) < 2e-4
    assert np.max(np.abs(res[f"mechanism.{act}_rate"][last])) < 1e-3


@pytest.mark.parametrize("name", list(SCENES))
def test_the_mechanism_moves_under_the_cylinders_force(runs, name):
    """The mechanism FMU's recorded accelerations are the library's forward dynamics under the cylinder
    FMU's recorded force, at the recorded states: the force it took is the cylinder's."""
    design, res = runs[name]
    scene = load_scene(design.scene)
    m = scene.mechanism
    names = m.coordinate_names
    rows = np.linspace(0, len(res.t) - 1, 40).astype(int)
    force = res["cylinder.force"]
    assert np.ptp(force) > 1.0
    worst = 0.0
    for i in rows:
        q = np.array([res[f"mechanism.{x}"][i] for x in names])
        qd = np.array([res[f"mechanism.{x}_d"][i] for x in names])
        dyn = forward_dynamics(m, m.z_from_q(q), m.zd_from_qd(qd),
                               Inputs(load=design.load_torque, actuators=(float(force[i]),)))
        qdd_fmu = np.array([res[f"mechanism.{x}_dd"][i] for x in names])
        qdd = m.S @ dyn.zdd  # absolute accelerations (the locked coordinates' follow their links)
        scale = 1.0 + np.max(np.abs(qdd_fmu))
        worst = max(worst, float(np.max(np.abs(qdd - qdd_fmu)) / scale))
    assert worst < 1e-6


@pytest.mark.parametrize("name", list(SCENES))
def test_the_pressures_stay_between_tank_and_supply(runs, name):
    design, res = runs[name]
    pa, pb = res["cylinder.pressure_a"], res["cylinder.pressure_b"]
    if design.cylinder == "hydraulic":
        supply = res["cylinder.supply_pressure"]
        # a chamber may be drawn down towards a vacuum (gauge -1 bar), never above the supply node
        assert min(pa.min(), pb.min()) > -1.0e5
        assert max(pa.max(), pb.max()) <= supply.max() * (1 + 1e-6)
    else:
        from grubler.motors.pneumatic import DEFAULT

        assert min(pa.min(), pb.min()) > DEFAULT.exhaust_pressure - 1.0
        assert max(pa.max(), pb.max()) < DEFAULT.supply_pressure


def test_the_builder_refuses_a_scene_without_the_actuator_or_an_unknown_cylinder():
    from grubler.system.cylinder_servo import CylinderServoDesign, cylinder_servo_system

    for design, field in ((CylinderServoDesign("thesis-fourbar"), "actuator"),
                          (CylinderServoDesign("luffing-boom", actuator="jib"), "actuator"),
                          (CylinderServoDesign("luffing-boom", cylinder="electric"), "cylinder"),
                          (CylinderServoDesign("luffing-boom", load_torque=3.0), "load_torque")):
        with pytest.raises(SceneError) as exc:
            cylinder_servo_system(design, "nowhere")
        assert exc.value.field == field
